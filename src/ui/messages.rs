//! The message history: every message the message line showed, kept whole
//! (the line cuts a long one to its width, and a newer one replaces it), so
//! the operator can read them again with scrollback (`M`, `docs/ui.md`,
//! "Message history"), and the helpers that make a message: [`Message`],
//! [`fault_text`]. Below the model, so that what the model holds can use them.

use std::collections::VecDeque;
use std::time::Instant;

use crate::device::api::ControllerFault;

use super::traffic_log::NoteLevel;

/// One line for the operator: a refusal and its reason, a fault, a notice.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    pub at: Instant,
    pub level: NoteLevel,
    pub text: String,
}

/// A controller's error for the operator: what it means and what to do
/// first (the message line may cut the rest), then the answer and command.
pub fn fault_text(f: &ControllerFault) -> String {
    // Meanings are sentences (isel chapter 5's end with a full stop); the
    // instruction follows a colon.
    let meaning = f.meaning.trim_end().trim_end_matches('.');
    format!(
        "{meaning}: {} (answer {} to {})",
        f.recovery.instruction(),
        f.code,
        f.command
    )
}

/// Messages kept; older ones are dropped (the traffic console and `--log`
/// keep the notes too).
pub const KEPT: usize = 500;

#[derive(Debug, Clone, Default, PartialEq)]
pub struct MessageHistory {
    messages: VecDeque<Message>,
    /// Messages dropped for room since the start.
    dropped: usize,
}

impl MessageHistory {
    pub fn push(&mut self, message: Message) {
        if self.messages.len() == KEPT {
            self.messages.pop_front();
            self.dropped += 1;
        }
        self.messages.push_back(message);
    }

    /// Oldest first.
    pub fn iter(&self) -> impl DoubleEndedIterator<Item = &Message> {
        self.messages.iter()
    }

    pub fn len(&self) -> usize {
        self.messages.len()
    }

    pub fn is_empty(&self) -> bool {
        self.messages.is_empty()
    }

    pub fn dropped(&self) -> usize {
        self.dropped
    }
}

/// `text` broken into lines of at most `width` characters, at blanks where
/// there are any: a long message is read whole, never cut.
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut out = Vec::new();
    for para in text.split('\n') {
        let mut line = String::new();
        for word in para.split(' ') {
            let mut word = word.to_string();
            loop {
                let used = line.chars().count();
                let need = word.chars().count() + usize::from(used > 0);
                if used + need <= width {
                    if used > 0 {
                        line.push(' ');
                    }
                    line.push_str(&word);
                    break;
                }
                if used > 0 {
                    out.push(std::mem::take(&mut line));
                    continue;
                }
                // A word longer than the line: cut it where the line ends.
                let head: String = word.chars().take(width).collect();
                word = word.chars().skip(width).collect();
                out.push(head);
                if word.is_empty() {
                    break;
                }
            }
        }
        out.push(line);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_keeps_every_character() {
        let text = "macro park, line 2 of 3: refused: emergency stop active: release it";
        let lines = wrap(text, 20);
        assert!(lines.iter().all(|l| l.chars().count() <= 20), "{lines:?}");
        assert_eq!(lines.join(" "), text);
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap("a\nb", 10), ["a", "b"]);
    }

    #[test]
    fn the_oldest_go_first_when_full() {
        let mut h = MessageHistory::default();
        let at = std::time::Instant::now();
        for i in 0..KEPT + 3 {
            h.push(Message {
                at,
                level: crate::ui::traffic_log::NoteLevel::Info,
                text: i.to_string(),
            });
        }
        assert_eq!(h.len(), KEPT);
        assert_eq!(h.dropped(), 3);
        assert_eq!(h.iter().next().map(|m| m.text.as_str()), Some("3"));
    }
}
