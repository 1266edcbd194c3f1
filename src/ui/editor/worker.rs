//! Two threads that carry out the editor's effects for the runtime, so that
//! neither a slow disk nor a long lint delays a frame or a stop:
//!
//! - the file thread takes requests in order (a recovery written, then the
//!   older one removed, must happen in that order);
//! - the lint thread takes only the newest job (an older snapshot is of a
//!   text that is gone).
//!
//! Results come back as [`Msg::Editor`] on the runtime's channel.

use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use tokio::sync::mpsc::UnboundedSender;

use super::checks::LintJob;
use super::io::{EditorIo, EditorMsg, perform};
use crate::ui::msg::Msg;

/// The newest lint job, and whether the thread should end.
#[derive(Default)]
struct LintSlot {
    job: Option<Box<LintJob>>,
    closed: bool,
}

pub struct EditorWorker {
    files: Option<Sender<EditorIo>>,
    lint: Arc<(Mutex<LintSlot>, Condvar)>,
    threads: Vec<JoinHandle<()>>,
}

impl EditorWorker {
    pub fn spawn(tx: UnboundedSender<Msg>) -> std::io::Result<EditorWorker> {
        let (files_tx, files_rx) = mpsc::channel::<EditorIo>();
        let file_thread = {
            let tx = tx.clone();
            thread::Builder::new()
                .name("jogterm-files".into())
                .spawn(move || file_loop(&files_rx, &tx))?
        };
        let lint = Arc::new((Mutex::new(LintSlot::default()), Condvar::new()));
        let lint_thread = {
            let lint = Arc::clone(&lint);
            thread::Builder::new()
                .name("jogterm-lint".into())
                .spawn(move || lint_loop(&lint, &tx))?
        };
        Ok(EditorWorker {
            files: Some(files_tx),
            lint,
            threads: vec![file_thread, lint_thread],
        })
    }

    /// Hand an effect over; never blocks.
    pub fn submit(&self, io: EditorIo) {
        match io {
            EditorIo::Lint(job) => {
                let (slot, wake) = &*self.lint;
                if let Ok(mut slot) = slot.lock() {
                    slot.job = Some(job);
                    wake.notify_one();
                }
            }
            other => {
                if let Some(files) = &self.files {
                    let _ = files.send(other);
                }
            }
        }
    }

    /// No more requests: the file thread ends after the ones handed over,
    /// the lint thread at once.
    fn close(&mut self) {
        self.files = None;
        if let Ok(mut slot) = self.lint.0.lock() {
            slot.closed = true;
            slot.job = None;
            self.lint.1.notify_one();
        }
    }

    /// Finish the file requests handed over (a last recovery, a save before
    /// quitting), waiting at most `bound`, and end the threads.
    pub fn finish(mut self, bound: Duration) {
        self.close();
        let until = Instant::now() + bound;
        while Instant::now() < until && self.threads.iter().any(|t| !t.is_finished()) {
            thread::sleep(Duration::from_millis(5));
        }
        for t in self.threads.drain(..) {
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

impl Drop for EditorWorker {
    fn drop(&mut self) {
        self.close();
    }
}

fn file_loop(requests: &Receiver<EditorIo>, tx: &UnboundedSender<Msg>) {
    let mut log = None;
    while let Ok(io) = requests.recv() {
        let msg = match io {
            EditorIo::JobLog(event) => EditorMsg::JobLogged(super::io::job_log(&mut log, event)),
            other => perform(other),
        };
        let _ = tx.send(Msg::Editor(msg));
    }
    // The console closed with a run under way (a quit refused nothing):
    // its end is what it is, a run without an end is a crash in the log.
    drop(log);
}

fn lint_loop(lint: &Arc<(Mutex<LintSlot>, Condvar)>, tx: &UnboundedSender<Msg>) {
    let (slot, wake) = &**lint;
    loop {
        let job = {
            let Ok(mut guard) = slot.lock() else { return };
            loop {
                if guard.closed {
                    return;
                }
                if let Some(job) = guard.job.take() {
                    break job;
                }
                guard = match wake.wait(guard) {
                    Ok(g) => g,
                    Err(_) => return,
                };
            }
        };
        let result = job.run();
        let _ = tx.send(Msg::Editor(EditorMsg::Linted(Box::new(result))));
    }
}
