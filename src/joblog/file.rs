//! The job log's file layer: where the log lives (`$JOGTERM_STATE_DIR`, as
//! recovery files and work offsets, `program::store::state_dir`), reading
//! it, and [`JobLog`], the handle a run writes through.
//!
//! A run must never wait on the disk: a stream sends its next command when
//! the one before has ended, and a sync that took 50 ms would leave the tool
//! standing in the material that long. So the handle hands each completed
//! line to a thread of its own, which appends it at once (one `write`: a
//! `kill -9` of the process loses only what the thread had not yet been
//! handed) and syncs it to the disk at most once a [`SYNC_EVERY`] (a power
//! cut loses at most that much), and the start and the end at once. Lines
//! completed while the thread writes are coalesced to the newest: the log
//! needs the last line, not every one.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use super::fold::{Ended, Folded, fold};
use super::record::{How, Record, Start, seconds};

/// The log's file in the state directory.
pub const FILE_NAME: &str = "jobs.jsonl";
/// The log before the last rotation, read before [`FILE_NAME`].
pub const OLD_NAME: &str = "jobs.1.jsonl";
/// A log this long is rotated when the next run starts: a 530 000-line
/// job streamed writes up to 530 000 line records (about 20 MB), and the
/// log stays readable at a glance. Two files: a run that started before
/// the rotation still appends to the file it opened, which is still read.
pub const ROTATE_AT: u64 = 8 << 20;
/// The longest a completed line waits for its sync to the disk.
pub const SYNC_EVERY: Duration = Duration::from_secs(1);
/// A log bigger than this is not read whole (a file that is no log).
const READ_CAP: u64 = 64 << 20;

/// The directory of the log: the state directory; `None` without a home.
pub fn dir() -> Option<PathBuf> {
    crate::program::store::state_dir()
}

/// The log of `dir`, folded: the rotated file, then the current one; a run
/// without an end whose process still lives is marked running. A file
/// that cannot be read is a note, never an error.
pub fn read(dir: &Path) -> Folded {
    let mut text = String::new();
    let mut notes = Vec::new();
    for name in [OLD_NAME, FILE_NAME] {
        let path = dir.join(name);
        match read_capped(&path) {
            Ok(Some(t)) => {
                text.push_str(&t);
                // A torn end of the old file is cut off from the new
                // file's first record.
                if !t.is_empty() && !t.ends_with('\n') && name == OLD_NAME {
                    text.push('\n');
                }
            }
            Ok(None) => {}
            Err(e) => notes.push(format!("{}: {e}", path.display())),
        }
    }
    let mut folded = fold(&dir.join(FILE_NAME).display().to_string(), &text);
    folded.notes.splice(0..0, notes);
    let boot = boot_id();
    for run in &mut folded.runs {
        if run.ended == Ended::NoEnd {
            run.running = alive(&run.start, boot.as_deref());
        }
    }
    folded
}

fn read_capped(path: &Path) -> io::Result<Option<String>> {
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let mut bytes = Vec::new();
    file.take(READ_CAP).read_to_end(&mut bytes)?;
    Ok(Some(String::from_utf8_lossy(&bytes).into_owned()))
}

/// This boot's id (Linux); a run of another boot no longer runs.
pub fn boot_id() -> Option<String> {
    std::fs::read_to_string("/proc/sys/kernel/random/boot_id")
        .ok()
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
}

/// The run's process still lives: the same boot, not this process, and
/// its pid is still a jogterm (a pid is reused once its process is gone).
fn alive(start: &Start, boot: Option<&str>) -> bool {
    if start.boot.as_deref() != boot || start.pid == std::process::id() {
        return false;
    }
    std::fs::read_to_string(format!("/proc/{}/comm", start.pid))
        .is_ok_and(|comm| comm.trim().starts_with("jogterm"))
}

/// Now as `2026-12-07T11:05:12Z`.
pub fn now_utc() -> String {
    let unix = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    jogterm_gcode::heightmap::rfc3339(i64::try_from(unix).unwrap_or(i64::MAX))
}

/// A run id: its start time and process (`20261207T110512Z-4711`).
pub fn run_id(at: &str) -> String {
    let compact: String = at.chars().filter(|c| *c != '-' && *c != ':').collect();
    format!("{compact}-{}", std::process::id())
}

enum Msg {
    Line(u32, f64),
    End(How, f64),
}

/// A run's handle on the log: [`JobLog::line`] as lines complete,
/// [`JobLog::end`] once. Dropped without an end (a panic), the run stays
/// without one: a crash, as it should read.
pub struct JobLog {
    tx: Option<mpsc::Sender<Msg>>,
    thread: Option<JoinHandle<()>>,
    started: Instant,
    failed: Arc<Mutex<Option<String>>>,
}

impl JobLog {
    /// Append `start` to the log in `dir` (rotated first when long) and
    /// sync it before returning: a run that crashes at once is in the log.
    pub fn start(dir: &Path, start: &Start) -> io::Result<JobLog> {
        std::fs::create_dir_all(dir)?;
        let path = dir.join(FILE_NAME);
        if std::fs::metadata(&path).is_ok_and(|m| m.len() >= ROTATE_AT) {
            std::fs::rename(&path, dir.join(OLD_NAME))?;
        }
        let mut file = OpenOptions::new()
            .create(true)
            .read(true)
            .append(true)
            .open(&path)?;
        let mut text = String::new();
        // A line torn by a crash is ended first, so that this record is a
        // line of its own and not the torn one's tail.
        if !ends_with_newline(&mut file)? {
            text.push('\n');
        }
        text.push_str(&Record::start(start.clone()).line_text());
        file.write_all(text.as_bytes())?;
        file.sync_data()?;
        let (tx, rx) = mpsc::channel();
        let failed = Arc::new(Mutex::new(None));
        let run = start.run.clone();
        let note = failed.clone();
        let thread = std::thread::Builder::new()
            .name("job-log".into())
            .spawn(move || writer(&mut file, &run, &rx, &note))?;
        Ok(JobLog {
            tx: Some(tx),
            thread: Some(thread),
            started: Instant::now(),
            failed,
        })
    }

    /// G-code line `line` ran to its end. Never waits.
    pub fn line(&self, line: u32) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(Msg::Line(line, self.elapsed()));
        }
    }

    /// The run ended `how`: the end written and synced, the thread done;
    /// a note when the log could not be written.
    pub fn end(mut self, how: How) -> Option<String> {
        if let Some(tx) = self.tx.take() {
            let _ = tx.send(Msg::End(how, self.elapsed()));
        }
        self.join();
        self.failed.lock().ok().and_then(|mut f| f.take())
    }

    fn elapsed(&self) -> f64 {
        seconds(self.started.elapsed().as_secs_f64())
    }

    fn join(&mut self) {
        self.tx = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for JobLog {
    fn drop(&mut self) {
        self.join();
    }
}

fn ends_with_newline(file: &mut File) -> io::Result<bool> {
    if file.metadata()?.len() == 0 {
        return Ok(true);
    }
    file.seek(SeekFrom::End(-1))?;
    let mut last = [0u8; 1];
    file.read_exact(&mut last)?;
    Ok(last[0] == b'\n')
}

/// The writer thread: appends what it is handed, the newest line of a
/// batch only, syncs the end at once and lines at most once a
/// [`SYNC_EVERY`]; ends with the end record or when the handle is gone.
fn writer(file: &mut File, run: &str, rx: &mpsc::Receiver<Msg>, failed: &Mutex<Option<String>>) {
    let mut last_line: Option<u32> = None;
    let mut written: Option<u32> = None;
    let mut synced = Instant::now();
    let mut unsynced = false;
    loop {
        let first = if unsynced {
            rx.recv_timeout(SYNC_EVERY.saturating_sub(synced.elapsed()))
        } else {
            rx.recv().map_err(|_| RecvTimeoutError::Disconnected)
        };
        let mut closing = matches!(first, Err(RecvTimeoutError::Disconnected));
        let mut end = None;
        let mut t_line = 0.0;
        for msg in first.ok().into_iter().chain(rx.try_iter()) {
            match msg {
                Msg::Line(line, t) => {
                    last_line = Some(line);
                    t_line = t;
                }
                Msg::End(how, t) => end = Some((how, t)),
            }
        }
        let mut text = String::new();
        if last_line != written
            && let Some(line) = last_line
        {
            text.push_str(
                &Record::Line {
                    run: run.to_owned(),
                    line,
                    t: t_line,
                }
                .line_text(),
            );
            written = last_line;
        }
        if let Some((how, t)) = end {
            text.push_str(
                &Record::End {
                    run: run.to_owned(),
                    at: now_utc(),
                    how,
                    line: last_line,
                    t,
                }
                .line_text(),
            );
            closing = true;
        }
        let mut result = Ok(());
        if !text.is_empty() {
            result = file.write_all(text.as_bytes());
            unsynced = true;
        }
        if unsynced && (closing || synced.elapsed() >= SYNC_EVERY) {
            result = result.and_then(|()| file.sync_data());
            synced = Instant::now();
            unsynced = false;
        }
        if let Err(e) = result
            && let Ok(mut f) = failed.lock()
        {
            f.get_or_insert_with(|| format!("the job log could not be written: {e}"));
        }
        if closing {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::record::test_start;
    use super::*;

    #[test]
    fn a_run_appends_its_start_lines_and_end_and_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let start = test_start("r1", "h");
        let log = JobLog::start(dir.path(), &start).unwrap();
        for line in 1..=50 {
            log.line(line);
        }
        assert_eq!(log.end(How::Done), None);
        let f = read(dir.path());
        assert!(f.notes.is_empty(), "{:?}", f.notes);
        assert_eq!(f.runs.len(), 1);
        assert_eq!(f.runs[0].last_line, Some(50));
        assert_eq!(f.runs[0].how(), "done");
        assert!(f.runs[0].end_at.is_some());
    }

    #[test]
    fn a_handle_dropped_without_an_end_leaves_a_crash_with_its_lines() {
        let dir = tempfile::tempdir().unwrap();
        let log = JobLog::start(dir.path(), &test_start("r1", "h")).unwrap();
        log.line(7);
        drop(log);
        let f = read(dir.path());
        assert_eq!(f.runs[0].how(), "crash");
        assert_eq!(f.runs[0].last_line, Some(7));
    }

    #[test]
    fn a_torn_line_is_ended_before_the_next_run_writes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(FILE_NAME);
        let mut text = Record::start(test_start("r1", "h")).line_text();
        text.push_str(r#"{"event":"line","run":"r1","li"#);
        std::fs::write(&path, text).unwrap();
        let torn = read(dir.path());
        assert_eq!(torn.notes.len(), 1, "{:?}", torn.notes);
        assert!(torn.notes[0].contains("its last line is cut off"));
        let log = JobLog::start(dir.path(), &test_start("r2", "h")).unwrap();
        assert_eq!(log.end(How::Stopped), None);
        let f = read(dir.path());
        assert_eq!(f.runs.len(), 2);
        assert_eq!(f.runs[1].how(), "stopped");
        // The torn line is now a line of its own in the middle: counted.
        assert_eq!(f.notes.len(), 1, "{:?}", f.notes);
    }

    #[test]
    fn a_long_log_is_rotated_and_both_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let log = JobLog::start(dir.path(), &test_start("r1", "h")).unwrap();
        log.line(3);
        drop(log);
        // Pad the first run's file past the rotation size.
        let path = dir.path().join(FILE_NAME);
        let mut file = OpenOptions::new().append(true).open(&path).unwrap();
        let pad = Record::Line {
            run: "r1".into(),
            line: 3,
            t: 0.0,
        }
        .line_text();
        let block = pad.repeat(usize::try_from(ROTATE_AT).unwrap() / pad.len() + 1);
        file.write_all(block.as_bytes()).unwrap();
        let log = JobLog::start(dir.path(), &test_start("r2", "h")).unwrap();
        log.end(How::Done);
        assert!(dir.path().join(OLD_NAME).exists());
        assert!(std::fs::metadata(&path).unwrap().len() < 4096);
        let f = read(dir.path());
        let runs: Vec<_> = f.runs.iter().map(|r| r.how()).collect();
        assert_eq!(runs, ["crash", "done"]);
    }

    #[test]
    fn a_run_of_this_process_or_another_boot_does_not_run() {
        let this = Start {
            pid: std::process::id(),
            boot: boot_id(),
            ..test_start("r", "h")
        };
        assert!(!alive(&this, boot_id().as_deref()));
        let other_boot = Start {
            boot: Some("another".into()),
            ..this
        };
        assert!(!alive(&other_boot, boot_id().as_deref()));
    }
}
