//! Terminal input on its own thread, forwarded as [`Msg`]s, and a watcher
//! that notices the terminal hanging up.
//!
//! No jog logic lives here: the device task enforces jog leases itself, so
//! a stuck input thread (crossterm spins and never returns when the terminal
//! vanishes without a SIGHUP, crossterm issue #793) cannot keep a machine
//! moving. The hang-up watcher is a separate thread for the same reason; on
//! a hang-up it writes the stop bytes itself (the emergency handle) before
//! it tells the loop.

use std::io::IsTerminal;
use std::os::fd::AsFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use ratatui::crossterm::event::{self, Event as TermEvent, KeyEvent};
use rustix::event::PollFlags;
use tokio::sync::mpsc::UnboundedSender;

use super::msg::Msg;
use super::terminal::run_emergency;
use crate::transport::fd::{poll_until, pollfd};

/// How often the threads look at their stop flag.
const POLL: Duration = Duration::from_millis(100);

/// The input thread and the hang-up watcher; they end when dropped (the
/// input thread at its next poll, unless crossterm is stuck, in which case
/// it is left behind: the process is leaving anyway).
#[derive(Debug)]
pub struct InputThreads {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl InputThreads {
    pub fn spawn(tx: UnboundedSender<Msg>) -> std::io::Result<InputThreads> {
        let stop = Arc::new(AtomicBool::new(false));
        let reader = {
            let stop = stop.clone();
            let tx = tx.clone();
            thread::Builder::new()
                .name("jogterm-input".into())
                .spawn(move || read_loop(&tx, &stop))?
        };
        let watcher = {
            let stop = stop.clone();
            thread::Builder::new()
                .name("jogterm-hangup".into())
                .spawn(move || watch_hangup(&tx, &stop))?
        };
        Ok(InputThreads {
            stop,
            threads: vec![reader, watcher],
        })
    }
}

impl Drop for InputThreads {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            // Joining a thread stuck in crossterm would hang the exit.
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

/// Most events taken in one batch; a paste without bracketed paste is
/// read in pieces of this many keys (each a burst of its own).
const MAX_BATCH: usize = 4096;

fn read_loop(tx: &UnboundedSender<Msg>, stop: &AtomicBool) {
    while !stop.load(Ordering::SeqCst) {
        let msgs = match event::poll(POLL) {
            Ok(false) => continue,
            Ok(true) => read_batch(),
            Err(e) => vec![terminate(format!("terminal input failed: {e}"))],
        };
        for msg in msgs {
            let ending = matches!(msg, Msg::Terminate { .. });
            if tx.send(msg).is_err() || ending {
                return;
            }
        }
    }
}

/// The event that is ready and every event already behind it: what one
/// read of the terminal delivered (crossterm parses a whole read into its
/// queue), or what arrived while it was parsed. Keys that come together
/// are handed on together, so `update` can tell a burst (a paste without
/// bracketed paste, keys a program typed) from keys a person types
/// (`ui::typing`, `docs/jogging.md`).
fn read_batch() -> Vec<Msg> {
    let mut events = Vec::new();
    let mut failed = None;
    loop {
        match event::read() {
            // The time it was read: what the jog keypad's dead-man
            // arithmetic and the burst rule count from.
            Ok(e) => events.push((e, Instant::now())),
            Err(e) => {
                failed = Some(e);
                break;
            }
        }
        if events.len() >= MAX_BATCH {
            break;
        }
        match event::poll(Duration::ZERO) {
            Ok(true) => continue,
            Ok(false) => break,
            Err(e) => {
                failed = Some(e);
                break;
            }
        }
    }
    let mut msgs = messages(events);
    if let Some(e) = failed {
        msgs.push(terminate(format!("terminal input failed: {e}")));
    }
    msgs
}

/// Terminal events as messages, in order: keys next to each other form one
/// batch (`KeyAt` for a lone key, `KeysAt` for several), a paste is
/// `Paste`, a resize `Resize`; other events (focus, mouse) are dropped.
pub fn messages(events: Vec<(TermEvent, Instant)>) -> Vec<Msg> {
    let mut out = Vec::new();
    let mut keys: Vec<(KeyEvent, Instant)> = Vec::new();
    let flush = |keys: &mut Vec<(KeyEvent, Instant)>, out: &mut Vec<Msg>| match keys.len() {
        0 => {}
        1 => {
            if let Some((key, at)) = keys.pop() {
                out.push(Msg::KeyAt(key, at));
            }
        }
        _ => out.push(Msg::KeysAt(std::mem::take(keys))),
    };
    for (event, at) in events {
        match event {
            TermEvent::Key(key) => keys.push((key, at)),
            TermEvent::Paste(text) => {
                flush(&mut keys, &mut out);
                out.push(Msg::Paste(text));
            }
            TermEvent::Resize(width, height) => {
                flush(&mut keys, &mut out);
                out.push(Msg::Resize { width, height });
            }
            _ => {}
        }
    }
    flush(&mut keys, &mut out);
    out
}

fn terminate(reason: String) -> Msg {
    Msg::Terminate { reason }
}

/// Report once when stdin (the terminal) hangs up: poll reports POLLHUP
/// whatever events are asked for.
fn watch_hangup(tx: &UnboundedSender<Msg>, stop: &AtomicBool) {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return;
    }
    while !stop.load(Ordering::SeqCst) {
        let mut fds = [pollfd(stdin.as_fd(), PollFlags::empty())];
        let n = poll_until(&mut fds, Some(Instant::now() + POLL));
        let gone = PollFlags::HUP | PollFlags::ERR | PollFlags::NVAL;
        if n.is_ok_and(|n| n > 0) && fds[0].revents().intersects(gone) {
            // The stop bytes first, from this thread: the loop may be stuck
            // on the dead terminal (crossterm issue #793).
            run_emergency();
            let _ = tx.send(terminate("the terminal hung up".into()));
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::crossterm::event::{KeyCode, KeyModifiers};

    fn key(c: char) -> TermEvent {
        TermEvent::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
    }

    #[test]
    fn keys_read_together_are_one_batch_and_a_lone_key_is_a_key() {
        let t = Instant::now();
        let later = t + Duration::from_micros(30);
        let events = vec![
            (key('6'), t),
            (key('6'), later),
            (TermEvent::Resize(100, 30), later),
            (key('q'), later),
            (TermEvent::Paste("666".into()), later),
            (TermEvent::FocusGained, later),
        ];
        let msgs = messages(events);
        let six = KeyEvent::new(KeyCode::Char('6'), KeyModifiers::NONE);
        let q = KeyEvent::new(KeyCode::Char('q'), KeyModifiers::NONE);
        assert_eq!(
            msgs,
            vec![
                Msg::KeysAt(vec![(six, t), (six, later)]),
                Msg::Resize {
                    width: 100,
                    height: 30
                },
                Msg::KeyAt(q, later),
                Msg::Paste("666".into()),
            ]
        );
        assert!(messages(Vec::new()).is_empty());
    }
}
