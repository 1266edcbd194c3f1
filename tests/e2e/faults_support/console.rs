//! The real `jogterm` console in a pseudo-terminal, driven as an operator
//! would, against a simulator's link; the screen read back with vt100.

use std::cell::RefCell;
use std::num::NonZeroU16;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::sim_process::{JOGTERM, SimProcess, WAIT, contains_panic};
use crate::ui_pty::PtyRun;

/// Wide enough that the message line is never cut.
pub const ROWS: u16 = 40;
pub const COLS: u16 = 300;

const LEAVE_ALTERNATE: &[u8] = b"\x1b[?1049l";

pub struct Console {
    pub run: PtyRun,
    pub log: PathBuf,
    /// The screen, fed only the output that is new since the last look
    /// (parsing everything again every 20 ms would load the machine the
    /// scenarios run on).
    screen: RefCell<(vt100::Parser, usize)>,
}

impl Console {
    /// `jogterm --port <link> --protocol <family> --log <dir>/traffic.log`,
    /// waiting until the state has been read back.
    pub fn start(sim: &SimProcess) -> Console {
        Self::start_with(sim, &[])
    }

    pub fn start_with(sim: &SimProcess, extra: &[&str]) -> Console {
        let log = sim.dir.path().join("traffic.log");
        let link = sim.link.display().to_string();
        let log_arg = log.display().to_string();
        let config = sim.dir.path().display().to_string();
        // Recovery files and other state stay in the scenario's directory.
        let state = sim.dir.path().join("state").display().to_string();
        let mut args = vec![
            "--port",
            link.as_str(),
            "--protocol",
            sim.family,
            "--log",
            log_arg.as_str(),
        ];
        args.extend_from_slice(extra);
        let env = [
            ("JOGTERM_NO_KEYBOARD_QUERY", "1"),
            ("JOGTERM_CONFIG_DIR", config.as_str()),
            ("JOGTERM_STATE_DIR", state.as_str()),
            ("RUST_BACKTRACE", "0"),
        ];
        let run = PtyRun::spawn_sized(Path::new(JOGTERM), &args, &env, ROWS, COLS);
        let console = Console {
            run,
            log,
            screen: RefCell::new((
                vt100::Parser::new(
                    NonZeroU16::MIN.saturating_add(ROWS - 1),
                    NonZeroU16::MIN.saturating_add(COLS - 1),
                    0,
                ),
                0,
            )),
        };
        console.wait_for("state read back");
        console
    }

    /// The screen now.
    pub fn screen(&self) -> String {
        let mut screen = self.screen.borrow_mut();
        let (parser, seen) = &mut *screen;
        let new = self.run.output_since(*seen);
        *seen += new.len();
        parser.process(&new);
        parser.screen().contents()
    }

    /// The status bar (the first row).
    pub fn status_bar(&self) -> String {
        self.screen().lines().next().unwrap_or_default().to_string()
    }

    /// Wait until the screen satisfies `done`; the screen. Bounded by [`WAIT`];
    /// on timeout the screen and the traffic log are shown.
    pub fn wait_until(&self, what: &str, done: impl Fn(&str) -> bool) -> String {
        let end = Instant::now() + WAIT;
        loop {
            let screen = self.screen();
            if done(&screen) {
                return screen;
            }
            if Instant::now() > end {
                panic!(
                    "the console never showed {what} within {WAIT:?}:\n{screen}\n--- traffic log (tail):\n{}",
                    self.log_tail()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Whether `needle` shows up within `timeout` (for a step that may be
    /// retried).
    pub fn shows_within(&self, needle: &str, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        loop {
            if self.screen().contains(needle) {
                return true;
            }
            if Instant::now() > end {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn wait_for(&self, needle: &str) -> String {
        self.wait_until(&format!("`{needle}`"), |s| s.contains(needle))
    }

    /// Wait until one line of the screen holds every one of `needles`: the
    /// message line, or the same message kept in the traffic console (the
    /// message line shows it for 10 s, later messages replace it). The line.
    pub fn wait_message(&self, needles: &[&str]) -> String {
        let holds = |l: &str| needles.iter().all(|n| l.contains(n));
        let screen = self.wait_until(&format!("a message with {needles:?}"), |s| {
            s.lines().any(holds)
        });
        screen
            .lines()
            .find(|l| holds(l))
            .unwrap_or_default()
            .trim()
            .to_string()
    }

    /// Type `bytes` key by key, as a person does: keys written together
    /// are a burst, which never moves, answers or sends anything.
    pub fn keys(&mut self, bytes: &[u8]) {
        self.run.type_bytes(bytes);
    }

    /// In continuous jog mode, hold `key` as a terminal repeats it (every
    /// 30 ms) until the status bar says JOGGING, then `more` repeats.
    pub fn hold_until_jogging(&mut self, key: &[u8], more: usize) {
        let end = Instant::now() + WAIT;
        // A held key's repeats: one write each, 30 ms apart.
        loop {
            self.run.send(key);
            std::thread::sleep(Duration::from_millis(30));
            if self.status_bar().contains("JOGGING") {
                break;
            }
            assert!(
                Instant::now() < end,
                "the jog never started:\n{}",
                self.screen()
            );
        }
        for _ in 0..more {
            self.run.send(key);
            std::thread::sleep(Duration::from_millis(30));
        }
    }

    /// Initialise (`i`) and reference (`h`, confirmed) until the status bar
    /// says READY, as an operator would; a step that a reconnect refused
    /// is taken again. Bounded by twice [`WAIT`] (reference runs take time).
    pub fn initialise_and_reference(&mut self) {
        let end = Instant::now() + WAIT * 2;
        loop {
            let bar = self.status_bar();
            if bar.contains("READY") {
                return;
            }
            assert!(
                Instant::now() < end,
                "never READY:\n{}\n{}",
                self.screen(),
                self.log_tail()
            );
            if bar.contains("NOT INIT") {
                self.keys(b"i");
                self.shows_within("NOT REF", Duration::from_secs(5));
            } else if bar.contains("NOT REF") {
                self.keys(b"h");
                self.wait_for("Start the reference run?");
                self.keys(b"y");
                self.shows_within("HOMING", Duration::from_secs(5));
            } else {
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }

    pub fn log_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(40)..].join("\n")
    }

    /// Nothing the console wrote says it panicked (the pty carries its stderr).
    pub fn assert_no_panic(&self) {
        let output = self.run.output();
        assert!(
            !contains_panic(&output),
            "jogterm panicked:\n{}",
            String::from_utf8_lossy(&output)
        );
    }

    /// Quit with `q`: exit status 0 in time, no panic, the terminal given back.
    pub fn quit(mut self) {
        self.keys(b"q");
        self.assert_exits(Some(0));
        self.assert_terminal_restored();
    }

    /// The console ends within [`WAIT`] (with `code` if given), without a
    /// panic.
    pub fn assert_exits(&mut self, code: Option<u32>) {
        let exit = self.run.wait_exit(WAIT);
        self.run.drain(Duration::from_secs(5));
        let screen = self.run.screen();
        assert!(
            exit.is_some(),
            "jogterm did not end within {WAIT:?}:\n{}",
            screen.screen().contents()
        );
        if code.is_some() {
            assert_eq!(exit, code, "{}", screen.screen().contents());
        }
        self.assert_no_panic();
    }

    /// After the end: the alternate screen was left and the cursor is shown.
    pub fn assert_terminal_restored(&self) {
        let screen = self.run.screen();
        let output = self.run.output();
        assert!(
            output
                .windows(LEAVE_ALTERNATE.len())
                .any(|w| w == LEAVE_ALTERNATE),
            "the alternate screen was not left"
        );
        assert!(!screen.screen().hide_cursor(), "the cursor is still hidden");
    }
}
