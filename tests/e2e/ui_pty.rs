//! Running a program in a pseudo-terminal (80x24 unless told) and reading
//! its screen back through a terminal parser (vt100), for the tests of the
//! terminal guard, of the real binary and of the fault-injection suite.

use std::fs::File;
use std::io::{Read, Write};
use std::num::NonZeroU16;
use std::os::fd::{AsRawFd, FromRawFd};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use portable_pty::{Child, CommandBuilder, MasterPty, PtySize, native_pty_system};

/// The pause between two keys a test types one by one.
pub const KEY_GAP: Duration = Duration::from_millis(40);

pub struct PtyRun {
    master: Option<Box<dyn MasterPty + Send>>,
    pub child: Box<dyn Child + Send + Sync>,
    writer: Option<Box<dyn Write + Send>>,
    output: Arc<Mutex<Vec<u8>>>,
    stop_reading: Arc<AtomicBool>,
    reader: Option<thread::JoinHandle<()>>,
    /// The terminal parser fed with the output up to the offset: each
    /// [`PtyRun::screen`] parses only what is new (a wait that reads the
    /// screen every 20 ms would otherwise parse the whole session again each
    /// time, a cost that grows with the session).
    parsed: Mutex<(vt100::Parser, usize)>,
    /// The child's state directory (recovery files, offsets) when the test
    /// gave none: a console under test never reads the user's own, where a
    /// recovery file from an earlier session would greet it with a popup.
    _state: Option<tempfile::TempDir>,
}

impl PtyRun {
    /// Start `program` with `args` and `env` in a new 80x24 pty.
    pub fn spawn(program: &Path, args: &[&str], env: &[(&str, &str)]) -> PtyRun {
        Self::spawn_sized(program, args, env, 24, 80)
    }

    /// Start `program` in a new pty of `rows` x `cols` (at least 1x1).
    pub fn spawn_sized(
        program: &Path,
        args: &[&str],
        env: &[(&str, &str)],
        rows: u16,
        cols: u16,
    ) -> PtyRun {
        let (rows, cols) = (rows.max(1), cols.max(1));
        let pty = native_pty_system()
            .openpty(PtySize {
                rows,
                cols,
                pixel_width: 0,
                pixel_height: 0,
            })
            .expect("open a pty");
        let mut cmd = CommandBuilder::new(program);
        cmd.args(args);
        cmd.env("TERM", "xterm-256color");
        for (k, v) in env {
            cmd.env(k, v);
        }
        let state = if env.iter().any(|(k, _)| *k == "JOGTERM_STATE_DIR") {
            None
        } else {
            let dir = tempfile::tempdir().expect("a state directory");
            cmd.env("JOGTERM_STATE_DIR", dir.path());
            Some(dir)
        };
        if let Ok(dir) = std::env::current_dir() {
            cmd.cwd(dir);
        }
        let child = pty.slave.spawn_command(cmd).expect("spawn in the pty");
        // Only the child may hold the slave, or the hang-up never comes.
        drop(pty.slave);
        // Our own dup of the master, read with a timeout, so that the reader
        // can let go of it when the test hangs up (every master fd must be
        // closed for the kernel to hang the terminal up).
        let fd = pty.master.as_raw_fd().expect("master fd");
        // Closed on exec: a process another test thread spawns (they share
        // this binary) must not inherit it, or it would hold the terminal
        // open after `close_master` and the hang-up would never come.
        // SAFETY: dup of an open fd; the File owns the copy.
        let copy = unsafe { libc::fcntl(fd, libc::F_DUPFD_CLOEXEC, 0) };
        assert!(
            copy >= 0,
            "dup the pty master: {}",
            std::io::Error::last_os_error()
        );
        // SAFETY: `copy` is a fresh descriptor nobody else owns.
        let mut file = unsafe { File::from_raw_fd(copy) };
        let writer = pty.master.take_writer().expect("writer");
        let output = Arc::new(Mutex::new(Vec::new()));
        let stop_reading = Arc::new(AtomicBool::new(false));
        let sink = output.clone();
        let stop = stop_reading.clone();
        let reader = thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while !stop.load(Ordering::SeqCst) {
                let mut pfd = libc::pollfd {
                    fd: file.as_raw_fd(),
                    events: libc::POLLIN,
                    revents: 0,
                };
                // SAFETY: one valid pollfd, bounded wait.
                let n = unsafe { libc::poll(&mut pfd, 1, 50) };
                if n <= 0 {
                    continue;
                }
                match file.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => sink
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .extend_from_slice(&buf[..n]),
                }
            }
        });
        PtyRun {
            master: Some(pty.master),
            child,
            writer: Some(writer),
            output,
            stop_reading,
            reader: Some(reader),
            parsed: Mutex::new((vt100::Parser::new(size(rows), size(cols), 0), 0)),
            _state: state,
        }
    }

    /// The terminal goes away: every master fd is closed.
    pub fn close_master(&mut self) {
        self.stop_reading.store(true, Ordering::SeqCst);
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
        self.writer = None;
        self.master = None;
    }

    pub fn send(&mut self, bytes: &[u8]) {
        let writer = self.writer.as_mut().expect("the pty is open");
        writer.write_all(bytes).expect("write to the pty");
        writer.flush().expect("flush the pty");
    }

    /// Type `keys` as a person does: one key per write, far enough apart
    /// that no two are read together or within the console's burst gap
    /// (5 ms, `ui::typing`), with room for a loaded machine. Keys written
    /// together are a burst: they type into a text field but never move,
    /// answer, send or switch anything.
    pub fn type_keys(&mut self, keys: &[&[u8]]) {
        for key in keys {
            thread::sleep(KEY_GAP);
            self.send(key);
        }
        thread::sleep(KEY_GAP);
    }

    /// `bytes` as the keys they encode, typed one by one (see
    /// [`PtyRun::type_keys`] and [`split_keys`]).
    pub fn type_bytes(&mut self, bytes: &[u8]) {
        self.type_keys(&split_keys(bytes));
    }

    /// `text` typed one character at a time (see [`PtyRun::type_keys`]).
    pub fn type_text(&mut self, text: &str) {
        let mut buf = [0u8; 4];
        for c in text.chars() {
            thread::sleep(KEY_GAP);
            self.send(c.encode_utf8(&mut buf).as_bytes());
        }
        thread::sleep(KEY_GAP);
    }

    /// Everything the program wrote so far.
    pub fn output(&self) -> Vec<u8> {
        self.output
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// What the program wrote from byte `offset` on (for a caller that keeps
    /// its own parser and feeds it only what is new).
    pub fn output_since(&self, offset: usize) -> Vec<u8> {
        let output = self.output.lock().unwrap_or_else(|p| p.into_inner());
        output.get(offset..).unwrap_or_default().to_vec()
    }

    /// The screen as the terminal shows it now: its last whole frame. A
    /// frame is a synchronized update (`ui::terminal::WholeFrames`), and a
    /// terminal that knows the mode shows none of it before its end; read
    /// in the middle, the screen was half the last frame and half the new
    /// one (a popup's title over the old lines, CI).
    pub fn screen(&self) -> Shown {
        let mut parsed = self.parsed.lock().unwrap_or_else(|p| p.into_inner());
        let (parser, seen) = &mut *parsed;
        let new = self.output_since(*seen);
        let whole = whole_frames(&new);
        *seen += whole;
        parser.process(&new[..whole]);
        Shown(parser.screen().clone())
    }

    /// Wait until the screen contains `needle`; the screen text on timeout.
    pub fn wait_for(&self, needle: &str, timeout: Duration) -> Result<String, String> {
        let end = Instant::now() + timeout;
        loop {
            let text = self.screen().screen().contents();
            if text.contains(needle) {
                return Ok(text);
            }
            if Instant::now() > end {
                return Err(text);
            }
            thread::sleep(Duration::from_millis(20));
        }
    }

    /// Wait for the program to end; its exit code, or `None` on timeout
    /// (the program is then killed).
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<u32> {
        let end = Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status.exit_code());
            }
            if Instant::now() > end {
                let _ = self.child.kill();
                return None;
            }
            thread::sleep(Duration::from_millis(20));
        }
    }

    /// After the program has ended: wait until its last output is read.
    pub fn drain(&mut self, timeout: Duration) {
        if let Some(reader) = self.reader.take() {
            let end = Instant::now() + timeout;
            while !reader.is_finished() && Instant::now() < end {
                thread::sleep(Duration::from_millis(10));
            }
            if reader.is_finished() {
                let _ = reader.join();
            }
        }
    }
}

/// A synchronized update's begin and end (DEC private mode 2026).
const FRAME_BEGIN: &[u8] = b"\x1b[?2026h";
const FRAME_END: &[u8] = b"\x1b[?2026l";

/// How much of `new` a terminal that knows synchronized updates shows: all
/// of it but a frame begun and not ended yet, and a begin marker cut off by
/// the read.
fn whole_frames(new: &[u8]) -> usize {
    if let Some(begin) = rfind(new, FRAME_BEGIN)
        && !contains(&new[begin..], FRAME_END)
    {
        return begin;
    }
    (1..FRAME_BEGIN.len())
        .rev()
        .find(|&n| new.ends_with(&FRAME_BEGIN[..n]))
        .map_or(new.len(), |n| new.len() - n)
}

/// What the terminal shows at one moment ([`PtyRun::screen`]).
pub struct Shown(vt100::Screen);

impl Shown {
    pub fn screen(&self) -> &vt100::Screen {
        &self.0
    }
}

/// A terminal dimension for vt100 (at least 1).
fn size(n: u16) -> NonZeroU16 {
    NonZeroU16::MIN.saturating_add(n.max(1) - 1)
}

impl Drop for PtyRun {
    fn drop(&mut self) {
        self.stop_reading.store(true, Ordering::SeqCst);
        let _ = self.child.kill();
    }
}

/// The keys a terminal's input bytes encode, each as its bytes: an escape
/// sequence (`ESC [ … final`, `ESC O x`), a UTF-8 character, or a byte.
pub fn split_keys(bytes: &[u8]) -> Vec<&[u8]> {
    let mut keys = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let rest = &bytes[i..];
        let len = match rest {
            [0x1b, b'[', tail @ ..] => {
                2 + tail
                    .iter()
                    .position(|b| (0x40..=0x7e).contains(b))
                    .map_or(tail.len(), |p| p + 1)
            }
            [0x1b, b'O', _, ..] => 3,
            [b, ..] if *b >= 0xc0 => {
                1 + rest[1..]
                    .iter()
                    .take_while(|b| (0x80..0xc0).contains(*b))
                    .count()
            }
            _ => 1,
        };
        keys.push(&rest[..len.min(rest.len())]);
        i += len.min(rest.len()).max(1);
    }
    keys
}

/// Whether `haystack` contains `needle`.
pub fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    haystack.windows(needle.len()).any(|w| w == needle)
}

/// Position of the last `needle` in `haystack`.
pub fn rfind(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).rposition(|w| w == needle)
}

/// The recovery files (`*.jogterm-recovery`) jogterm keeps in its state
/// directory `state` while a program is edited; none when it has none.
pub fn recoveries(state: &Path) -> Vec<String> {
    std::fs::read_dir(state.join("recovery"))
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".jogterm-recovery"))
                .collect()
        })
        .unwrap_or_default()
}
