//! Terminal input on its own thread, forwarded as [`Msg`]s, and a watcher
//! that notices the terminal hanging up.
//!
//! No jog logic lives here: the device task enforces jog leases itself, so
//! a stuck input thread (crossterm spins and never returns when the terminal
//! vanishes without a SIGHUP, crossterm issue #793) cannot keep a machine
//! moving. The hang-up watcher is a separate thread for the same reason; on
//! a hang-up it writes the stop bytes itself (the emergency handle) before
//! it tells the loop.

use std::os::fd::{AsRawFd, BorrowedFd};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use ratatui::crossterm::event::{self, Event as TermEvent};
use tokio::sync::mpsc::UnboundedSender;

use super::msg::Msg;
use super::terminal::run_emergency;

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

fn read_loop(tx: &UnboundedSender<Msg>, stop: &AtomicBool) {
    while !stop.load(Ordering::SeqCst) {
        let msg = match event::poll(POLL) {
            Ok(false) => continue,
            Ok(true) => match event::read() {
                // The time it was read: what the jog keypad's dead-man
                // arithmetic counts from.
                Ok(TermEvent::Key(key)) => Msg::KeyAt(key, Instant::now()),
                Ok(TermEvent::Resize(width, height)) => Msg::Resize { width, height },
                Ok(_) => continue,
                Err(e) => terminate(format!("terminal input failed: {e}")),
            },
            Err(e) => terminate(format!("terminal input failed: {e}")),
        };
        let ending = matches!(msg, Msg::Terminate { .. });
        if tx.send(msg).is_err() || ending {
            return;
        }
    }
}

fn terminate(reason: String) -> Msg {
    Msg::Terminate { reason }
}

/// Report once when stdin (the terminal) hangs up: poll reports POLLHUP
/// whatever events are asked for.
fn watch_hangup(tx: &UnboundedSender<Msg>, stop: &AtomicBool) {
    // SAFETY: fd 0 stays open for the life of the process.
    let stdin = unsafe { BorrowedFd::borrow_raw(0) };
    if !is_tty(stdin) {
        return;
    }
    while !stop.load(Ordering::SeqCst) {
        let mut fds = libc::pollfd {
            fd: stdin.as_raw_fd(),
            events: 0,
            revents: 0,
        };
        // SAFETY: one valid pollfd, a bounded timeout.
        let n = unsafe { libc::poll(&mut fds, 1, POLL.as_millis() as libc::c_int) };
        if n > 0 && fds.revents & (libc::POLLHUP | libc::POLLERR | libc::POLLNVAL) != 0 {
            // The stop bytes first, from this thread: the loop may be stuck
            // on the dead terminal (crossterm issue #793).
            run_emergency();
            let _ = tx.send(terminate("the terminal hung up".into()));
            return;
        }
    }
}

fn is_tty(fd: BorrowedFd<'_>) -> bool {
    // SAFETY: isatty only inspects the descriptor.
    unsafe { libc::isatty(fd.as_raw_fd()) == 1 }
}
