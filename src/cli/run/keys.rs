//! The operator's keys while `jogterm run` runs a job: read from a terminal
//! on stdin one by one (no Enter), never echoed. Ctrl-C stays a signal (the
//! session's interrupt, which stops the machine); the terminal's own line
//! handling comes back when the run ends, also on a panic's unwinding.
//!
//! Keys: Space, `s` or `q` stop; `p` pauses; `r` or Enter resumes; `+` and
//! `-` change the speed factor of the moves not yet sent by 10 %. Keys that
//! arrive together (a paste, a burst) only stop or pause ([`keys_of`]).

use std::io::{IsTerminal, Stdin};

use rustix::termios::{self, LocalModes, OptionalActions, SpecialCodeIndex, Termios};
use tokio::sync::mpsc;

/// What a key asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key {
    Stop,
    Pause,
    Resume,
    Faster,
    Slower,
    /// The terminal went away (EOF or a read error on stdin).
    Gone,
}

impl Key {
    pub fn of(byte: u8) -> Option<Key> {
        match byte {
            b' ' | b's' | b'S' | b'q' | b'Q' => Some(Key::Stop),
            b'p' | b'P' => Some(Key::Pause),
            b'r' | b'R' | b'\r' | b'\n' => Some(Key::Resume),
            b'+' | b'=' => Some(Key::Faster),
            b'-' | b'_' => Some(Key::Slower),
            _ => None,
        }
    }
}

/// The help line said before the start.
pub const HELP: &str =
    "keys: Space stops, p pauses, r resumes, + and - change the speed of the moves not yet sent";

/// Keys from the terminal; nothing when stdin is no terminal (a script, a
/// test without one: then only signals stop the run).
pub struct Keys {
    pub rx: mpsc::UnboundedReceiver<Key>,
    /// A stop key was read, or the terminal went away: the operator ended
    /// the run (the job log says `stopped`, not `error`).
    pub stopped: bool,
    _mode: Option<KeyMode>,
}

impl Keys {
    /// No keys: only signals stop (`jogterm upload --stream`).
    pub fn none() -> Keys {
        let (_, rx) = mpsc::unbounded_channel();
        Keys {
            rx,
            stopped: false,
            _mode: None,
        }
    }

    pub fn from_stdin() -> Keys {
        let (tx, rx) = mpsc::unbounded_channel();
        let stdin = std::io::stdin();
        if !stdin.is_terminal() {
            return Keys::none();
        }
        let mode = KeyMode::enter(&stdin);
        std::thread::Builder::new()
            .name("run-keys".into())
            .spawn(move || read_keys(&tx))
            .ok();
        Keys {
            rx,
            stopped: false,
            _mode: mode,
        }
    }

    /// Drop the keys typed before now: a wait for the operator is
    /// answered by a key pressed while it is shown, never by an Enter
    /// typed ahead while the piece before it ran. A stop among them still
    /// counts: `true`.
    pub fn forget_typed_ahead(&mut self) -> bool {
        let mut stop = false;
        while let Ok(key) = self.rx.try_recv() {
            if matches!(key, Key::Stop | Key::Gone) {
                self.stopped = true;
                stop = true;
            }
        }
        stop
    }

    /// The next key; pending forever when there are no keys, so that a
    /// `select!` on it waits for the other branches.
    pub async fn next(&mut self) -> Key {
        match self.rx.recv().await {
            Some(key) => {
                self.stopped |= matches!(key, Key::Stop | Key::Gone);
                key
            }
            None => std::future::pending().await,
        }
    }
}

fn read_keys(tx: &mpsc::UnboundedSender<Key>) {
    use std::io::Read;
    let mut bytes = [0u8; 64];
    let mut stdin = std::io::stdin().lock();
    loop {
        match stdin.read(&mut bytes) {
            Ok(n) if n > 0 => {
                for key in keys_of(bytes.get(..n).unwrap_or_default()) {
                    if tx.send(key).is_err() {
                        return;
                    }
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            _ => {
                let _ = tx.send(Key::Gone);
                return;
            }
        }
    }
}

/// The keys of one read. A read of several bytes is a paste or a burst, not
/// keys the operator pressed one by one: of it only what stops motion
/// counts (a stop, a pause), never a resume or a change of speed, as the
/// console answers nothing to a burst (`docs/gcode.md`, "`jogterm run`").
pub fn keys_of(bytes: &[u8]) -> Vec<Key> {
    let keys = bytes.iter().filter_map(|b| Key::of(*b));
    match bytes {
        [_] => keys.collect(),
        _ => {
            let burst: Vec<Key> = keys.collect();
            if burst.contains(&Key::Stop) {
                vec![Key::Stop]
            } else if burst.contains(&Key::Pause) {
                vec![Key::Pause]
            } else {
                Vec::new()
            }
        }
    }
}

/// The terminal (stdin) without line editing and echo, restored on drop.
struct KeyMode {
    saved: Termios,
}

impl KeyMode {
    fn enter(stdin: &Stdin) -> Option<KeyMode> {
        let saved = termios::tcgetattr(stdin).ok()?;
        let mut keys = saved.clone();
        keys.local_modes
            .remove(LocalModes::ICANON | LocalModes::ECHO);
        keys.special_codes[SpecialCodeIndex::VMIN] = 1;
        keys.special_codes[SpecialCodeIndex::VTIME] = 0;
        termios::tcsetattr(stdin, OptionalActions::Now, &keys).ok()?;
        Some(KeyMode { saved })
    }
}

impl Drop for KeyMode {
    fn drop(&mut self) {
        let _ = termios::tcsetattr(std::io::stdin(), OptionalActions::Now, &self.saved);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_typed_ahead_of_a_wait_answer_nothing_but_a_stop_counts() {
        let (tx, rx) = mpsc::unbounded_channel();
        let mut keys = Keys {
            rx,
            stopped: false,
            _mode: None,
        };
        for key in [Key::Resume, Key::Faster, Key::Resume] {
            tx.send(key).expect("send");
        }
        assert!(!keys.forget_typed_ahead());
        assert!(
            keys.rx.try_recv().is_err(),
            "nothing left to answer the wait"
        );
        assert!(!keys.stopped);
        for key in [Key::Resume, Key::Stop] {
            tx.send(key).expect("send");
        }
        assert!(keys.forget_typed_ahead());
        assert!(keys.stopped);
    }

    #[test]
    fn keys_map_as_the_help_says() {
        assert_eq!(Key::of(b' '), Some(Key::Stop));
        assert_eq!(Key::of(b'q'), Some(Key::Stop));
        assert_eq!(Key::of(b'p'), Some(Key::Pause));
        assert_eq!(Key::of(b'\r'), Some(Key::Resume));
        assert_eq!(Key::of(b'+'), Some(Key::Faster));
        assert_eq!(Key::of(b'-'), Some(Key::Slower));
        assert_eq!(Key::of(b'x'), None);
    }

    #[test]
    fn a_burst_stops_or_pauses_but_never_resumes_or_speeds_up() {
        assert_eq!(keys_of(b"+"), [Key::Faster]);
        assert_eq!(keys_of(b"r"), [Key::Resume]);
        assert!(keys_of(b"+++++").is_empty());
        assert!(keys_of(b"rr").is_empty());
        assert!(keys_of(b"r\r").is_empty());
        assert_eq!(keys_of(b"pr"), [Key::Pause]);
        assert_eq!(keys_of(b"r p +"), [Key::Stop]);
        assert!(keys_of(b"xyz").is_empty());
    }
}
