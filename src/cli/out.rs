//! The commands' output, without the panics of `println!`/`eprintln!`.
//!
//! `println!` panics when stdout cannot be written (EPIPE: `jogterm poll |
//! head -1` after `head` has ended; EIO: the terminal hung up), and a panic
//! is status 101 with a Rust message instead of a clear error, and in a
//! command that holds a port it would skip the orderly close and its stop.
//! So stdout writes here return a [`StdoutError`] the command acts on (stop
//! polling or sending, close the session with its stop, exit as its help
//! says), and stderr writes ignore failure: when stderr is gone there is
//! nowhere left to report it (`docs/field-notes.md`, "Order on
//! hang-up").
//!
//! The crate denies `clippy::print_stdout` and `clippy::print_stderr`
//! outside tests (`src/lib.rs`, `src/main.rs`), so every command's output
//! goes through here or through a `Write` whose errors it handles.

use std::fmt::Display;
use std::io::{self, Write};

/// Why a line could not be written to stdout.
#[derive(Debug, thiserror::Error)]
pub enum StdoutError {
    /// EPIPE: whoever read stdout has gone (`| head -1`): as a rule on
    /// purpose, so the commands end normally.
    #[error("stdout was closed by its reader")]
    Closed,
    /// Anything else (EIO: the terminal hung up; ENOSPC: a full disk).
    #[error("cannot write to stdout: {0}")]
    Failed(#[source] io::Error),
}

impl From<io::Error> for StdoutError {
    fn from(e: io::Error) -> Self {
        if e.kind() == io::ErrorKind::BrokenPipe {
            StdoutError::Closed
        } else {
            StdoutError::Failed(e)
        }
    }
}

/// `text` and a newline on stdout, flushed at once: a sample or a reply
/// reaches a pipe's reader when it happens, and a reader that has gone is
/// noticed at the line it did not take.
pub fn line(text: impl Display) -> Result<(), StdoutError> {
    let mut out = io::stdout().lock();
    writeln!(out, "{text}")?;
    out.flush()?;
    Ok(())
}

/// The exit status of a command that reads until its reader goes away
/// (`poll`, `watch`) when stdout cannot take a line: 0 when the reader went
/// away (`| head -1` has what it wanted; as Ctrl-C, the session still stops
/// and closes), 1 and `jogterm <command>: …; <stopped>` for any other
/// failure.
pub fn stdout_failed(e: StdoutError, command: &str, stopped: &str) -> u8 {
    match e {
        StdoutError::Closed => 0,
        StdoutError::Failed(_) => {
            say(format_args!("jogterm {command}: {e}; {stopped}"));
            1
        }
    }
}

/// `text` and a newline on stderr; a failure is ignored.
pub fn say(text: impl Display) {
    let mut err = io::stderr().lock();
    let _ = writeln!(err, "{text}");
}

/// `text` on stderr as it is (a progress line rewritten in place), flushed;
/// a failure is ignored.
pub fn say_raw(text: impl Display) {
    let mut err = io::stderr().lock();
    let _ = write!(err, "{text}");
    let _ = err.flush();
}

/// `result` with a closed stdout (EPIPE) taken as success: for commands
/// whose output is a report (`check`, `arc`), a reader that took only part
/// of it changes nothing about the outcome.
pub fn closed_is_ok(result: io::Result<()>) -> io::Result<()> {
    match result {
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// Stdout as a [`Write`] that remembers whether its reader went away, for
/// code that takes a writer and reports failures as plain `io::Error`s
/// (`jogterm sim`'s control loop).
pub struct WatchedStdout {
    closed: bool,
}

impl WatchedStdout {
    pub fn new() -> WatchedStdout {
        WatchedStdout { closed: false }
    }

    /// Whether a write failed because the reader of stdout has gone.
    pub fn reader_gone(&self) -> bool {
        self.closed
    }

    fn note<T>(&mut self, result: io::Result<T>) -> io::Result<T> {
        if let Err(e) = &result
            && e.kind() == io::ErrorKind::BrokenPipe
        {
            self.closed = true;
        }
        result
    }
}

impl Default for WatchedStdout {
    fn default() -> Self {
        WatchedStdout::new()
    }
}

impl Write for WatchedStdout {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let result = io::stdout().lock().write(buf);
        self.note(result)
    }

    fn flush(&mut self) -> io::Result<()> {
        let result = io::stdout().lock().flush();
        self.note(result)
    }
}

/// Completes when the reader of stdout has gone, without a write to find
/// out: a pipe whose reader closed reports `POLLERR`, a socket's or a
/// terminal's far end that went away `POLLHUP` (poll(2); only errors are
/// asked for, so a writable stdout never wakes it). Never completes on a
/// file or `/dev/null`, nor when the watch cannot start. A thread of its own
/// looks every 100 ms and ends once the future is dropped.
///
/// For a command that may wait long between two lines (`poll` at a long
/// interval): it ends when `| head` has ended, not at its next sample.
pub fn stdout_gone() -> impl std::future::Future<Output = ()> {
    use std::os::fd::AsFd;
    use std::time::{Duration, Instant};

    use rustix::event::PollFlags;

    use crate::transport::fd::{poll_until, pollfd};

    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let watch = std::thread::Builder::new()
        .name("jogterm-stdout-watch".into())
        .spawn(move || {
            let stdout = io::stdout();
            while !tx.is_closed() {
                let mut fds = [pollfd(stdout.as_fd(), PollFlags::empty())];
                let deadline = Instant::now() + Duration::from_millis(100);
                if poll_until(&mut fds, Some(deadline)).is_err() {
                    return;
                }
                let revents = fds[0].revents();
                if revents.contains(PollFlags::NVAL) {
                    // No stdout at all: writes fail on their own.
                    return;
                }
                if revents.intersects(PollFlags::ERR | PollFlags::HUP) {
                    let _ = tx.send(());
                    return;
                }
            }
        });
    async move {
        // The watch that ended without seeing the reader go never completes.
        if watch.is_err() || rx.await.is_err() {
            std::future::pending::<()>().await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_broken_pipe_is_a_closed_stdout_and_nothing_else_is() {
        let closed = StdoutError::from(io::Error::from(io::ErrorKind::BrokenPipe));
        assert!(matches!(closed, StdoutError::Closed));
        let eio = StdoutError::from(io::Error::from(rustix::io::Errno::IO));
        assert!(matches!(eio, StdoutError::Failed(_)), "{eio}");
        assert!(
            eio.to_string().starts_with("cannot write to stdout: "),
            "{eio}"
        );
    }

    #[test]
    fn only_a_closed_stdout_counts_as_written() {
        assert!(closed_is_ok(Err(io::ErrorKind::BrokenPipe.into())).is_ok());
        assert!(closed_is_ok(Err(io::Error::from(rustix::io::Errno::IO))).is_err());
        assert!(closed_is_ok(Ok(())).is_ok());
    }

    #[test]
    fn the_watched_stdout_remembers_only_a_reader_that_went_away() {
        let mut w = WatchedStdout::new();
        assert!(
            w.note::<()>(Err(io::Error::from(rustix::io::Errno::IO)))
                .is_err()
        );
        assert!(!w.reader_gone());
        assert!(w.note::<()>(Err(io::ErrorKind::BrokenPipe.into())).is_err());
        assert!(w.reader_gone());
    }
}
