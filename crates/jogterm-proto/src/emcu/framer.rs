//! The interface's side of the line: cuts the received bytes into command
//! lines at CR or 0x01 (manual 1.4.2) and parses each one. Used by the
//! simulator, which acknowledges every line with CR and sets its error flag for
//! a refused one instead of executing it (decision 4).

use super::command::{Command, MAX_COMMAND_LINE, Terminator};
use super::parse::{ParseError, ParseErrorKind, parse_bytes};

/// One received command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// The line without its terminator (at most [`MAX_COMMAND_LINE`] + 1
    /// bytes are kept of an over-long line).
    pub raw: Vec<u8>,
    pub terminator: Terminator,
    /// The command, or why the interface would set its error flag.
    pub command: Result<Command, ParseError>,
}

/// Incremental framer of command lines.
#[derive(Debug, Clone, Default)]
pub struct CommandFramer {
    line: Vec<u8>,
    /// Bytes of the current line, also those no longer kept.
    len: usize,
}

impl CommandFramer {
    pub fn new() -> CommandFramer {
        CommandFramer::default()
    }

    /// One byte as it arrived; a line when it was a terminator.
    pub fn push(&mut self, byte: u8) -> Option<Received> {
        let Some(terminator) = Terminator::from_byte(byte) else {
            // Keep one byte past the limit so the line is known to be too long.
            if self.line.len() <= MAX_COMMAND_LINE {
                self.line.push(byte);
            }
            self.len = self.len.saturating_add(1);
            return None;
        };
        let raw = std::mem::take(&mut self.line);
        let len = std::mem::take(&mut self.len);
        let command = if len > MAX_COMMAND_LINE {
            Err(ParseError::new(
                MAX_COMMAND_LINE,
                ParseErrorKind::TooLong {
                    len,
                    max: MAX_COMMAND_LINE,
                },
            ))
        } else {
            parse_bytes(&raw).and_then(|command| {
                if terminator == Terminator::RunBuffer && command.is_master() {
                    Err(ParseError::new(
                        raw.len(),
                        ParseErrorKind::RunBufferOnMaster,
                    ))
                } else {
                    Ok(command)
                }
            })
        };
        Some(Received {
            raw,
            terminator,
            command,
        })
    }

    /// All lines the bytes complete, in order.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Received> {
        bytes.iter().filter_map(|b| self.push(*b)).collect()
    }

    /// Bytes of a line that has not ended yet.
    pub fn pending(&self) -> &[u8] {
        &self.line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_end_at_cr_or_run_buffer() {
        let mut f = CommandFramer::new();
        let lines = f.feed(b"@X\rW250\x01@J");
        assert_eq!(lines.len(), 2);
        assert_eq!(
            lines.first().map(|l| &l.command),
            Some(&Ok(Command::Status))
        );
        assert_eq!(
            lines.get(1).map(|l| (l.terminator, l.raw.as_slice())),
            Some((Terminator::RunBuffer, &b"W250"[..]))
        );
        assert_eq!(f.pending(), b"@J");
    }

    #[test]
    fn a_master_command_ended_by_run_buffer_is_refused() {
        let mut f = CommandFramer::new();
        let got = f.feed(b"@B\x01").pop();
        assert_eq!(
            got.map(|r| r.command),
            Some(Err(ParseError::new(2, ParseErrorKind::RunBufferOnMaster)))
        );
    }

    #[test]
    fn an_over_long_line_is_refused_with_bounded_memory() {
        let mut f = CommandFramer::new();
        let mut bytes = vec![b'1'; 10_000];
        bytes.push(b'\r');
        let lines = f.feed(&bytes);
        assert_eq!(lines.len(), 1);
        let line = lines.first().cloned();
        assert_eq!(
            line.as_ref().map(|l| l.raw.len()),
            Some(MAX_COMMAND_LINE + 1)
        );
        assert_eq!(
            line.map(|l| l.command),
            Some(Err(ParseError::new(
                MAX_COMMAND_LINE,
                ParseErrorKind::TooLong {
                    len: 10_000,
                    max: MAX_COMMAND_LINE
                }
            )))
        );
    }
}
