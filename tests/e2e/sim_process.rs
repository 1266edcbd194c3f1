//! `jogterm sim --pty --link <tmp>/tty<family>` (or `--tcp 127.0.0.1:0`,
//! [`SimProcess::start_tcp`]) as a child process, shared
//! by the end-to-end tests (`mod sim_process;`) and the fault suite: its
//! stdin is the control channel (`set`, `press`, `fault …`; kept open, as a
//! closed stdin ends the simulator), `show received` is the controller's own
//! view of what it was sent, and [`SimProcess::jogterm`] runs the `jogterm`
//! binary against its link.
//!
//! [`SimProcess::options`] starts one with everything that can differ
//! (configuration files, variants, TCP, a time scale); the `start_*`
//! shorthands cover the usual cases.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Output, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

pub const JOGTERM: &str = env!("CARGO_BIN_EXE_jogterm");

/// Every wait on the simulator is bounded by this: generous under load, and
/// a hang still ends the test.
pub const WAIT: Duration = Duration::from_secs(20);

/// The process' output once it has ended; killed and failed if it does not
/// end within [`WAIT`] (a hang is a failure, not a stuck test).
pub fn wait_child(mut child: Child, what: &str) -> Output {
    let end = Instant::now() + WAIT;
    while matches!(child.try_wait(), Ok(None)) {
        if Instant::now() > end {
            let _ = child.kill();
            let out = child.wait_with_output();
            panic!("{what} hangs: {out:?}");
        }
        thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("the output")
}

/// The time scale of a simulator whose test checks logic only (where a move
/// or a program ends, what went over the wire, what jogterm says) and
/// waits for real motion to end: `SimOptions::time_scale(LOGIC_SCALE)`.
/// Each such test says why its assertions do not depend on the scale
/// (`docs/testing.md`, "The time scale").
pub const LOGIC_SCALE: f64 = 10.0;

/// A configuration file for [`SimOptions::files`]: the isel simulator's
/// axes stand 1 mm from their reference point at power-up (the simulator's
/// own profile; a jogterm with another configuration directory keeps the
/// unchanged default), so the reference run takes a moment.
pub const ISEL_NEAR_REFERENCE: (&str, &str) =
    ("profiles/default.toml", "[sim]\nstart_position = 1.0\n");

/// A configuration file for [`SimOptions::files`]: the EMCU simulator's
/// axes stand 5 mm from machine 0 at power-up instead of the shipped
/// profile's 40 mm, so a reference run at 2 kHz takes about half a second
/// per axis, not four. For tests in which the reference run is only the
/// way to a referenced machine (it still runs, and it is still long enough
/// to be read while it runs).
pub const EMCU_NEAR_REFERENCE: (&str, &str) = (
    "profiles/emcu.toml",
    "base = \"emcu\"\n[sim]\nstart_position = 5.0\n",
);

/// A configuration file for [`SimOptions::files`]: the EMP simulator's
/// drive stands 1 mm from its home at power-up, so homing takes a moment.
pub const EMP_NEAR_REFERENCE: (&str, &str) = (
    "profiles/emp.toml",
    "base = \"emp\"\n[sim]\nstart_position = 1.0\n",
);

/// The configuration file that puts `family`'s simulated axes near their
/// reference point: [`ISEL_NEAR_REFERENCE`], [`EMCU_NEAR_REFERENCE`] or
/// [`EMP_NEAR_REFERENCE`].
pub fn near_reference(family: &str) -> (&'static str, &'static str) {
    match family {
        "emcu" => EMCU_NEAR_REFERENCE,
        "emp" => EMP_NEAR_REFERENCE,
        _ => ISEL_NEAR_REFERENCE,
    }
}

/// Whether a process' output carries a Rust panic message.
/// The isel commands a reading session sends, none of which moves an axis:
/// reads (`@0P`, `@0b`), test mode off at every connect (`@0T0`,
/// docs/device.md) and the read-back's reference probe, a relative move of
/// zero steps on every axis (`docs/protocols.md`, isel).
pub fn isel_reads_or_moves_nothing(command: &str) -> bool {
    if command == "@0P" || command == "@0T0" || command.starts_with("@0b") {
        return true;
    }
    command.strip_prefix("@0A").is_some_and(|params| {
        params
            .split(',')
            .step_by(2)
            .all(|steps| steps.trim() == "0")
    })
}

pub fn contains_panic(output: &[u8]) -> bool {
    output.windows(b"panicked".len()).any(|w| w == b"panicked")
}

/// A process' output as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `jogterm poll --json` output: one JSON object a line.
pub fn json_lines(stdout: &[u8]) -> Vec<serde_json::Value> {
    text(stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect()
}

/// `jogterm <args[0]> --port <port> --protocol <family> <args[1..]>`, with
/// a configuration directory that does not exist (the defaults).
pub fn jogterm(port: &Path, family: &str, args: &[&str]) -> Command {
    let (subcommand, rest) = args
        .split_first()
        .map_or((None, args), |(s, r)| (Some(s), r));
    let mut c = Command::new(JOGTERM);
    c.args(subcommand)
        .arg("--port")
        .arg(port)
        .arg("--protocol")
        .arg(family)
        .args(rest)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config");
    c
}

/// Spawn `command` with its stdin and stdout piped: the child, its stdin
/// (the simulator's control channel) and its stdout line by line, read on a
/// thread of its own so that a wait on a line can be bounded.
pub fn spawn_with_lines(command: &mut Command) -> (Child, ChildStdin, Receiver<String>) {
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("spawn jogterm");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, lines) = mpsc::channel();
    thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let stdin = child.stdin.take().expect("stdin");
    (child, stdin, lines)
}

/// A running simulator; killed when dropped.
pub struct SimProcess {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
    stderr: Arc<Mutex<Vec<u8>>>,
    pub family: &'static str,
    /// `jogterm sim --time-scale`: 1.0 is real time (`sim::timescale`).
    pub time_scale: f64,
    /// What `--port` takes: the pty's link, or `tcp://127.0.0.1:PORT`.
    pub link: PathBuf,
    pub dir: tempfile::TempDir,
}

/// Where a simulator serves.
#[derive(Clone, Copy)]
enum Serving {
    Pty,
    Tcp,
}

/// How to start a simulator: [`SimProcess::options`], then the builder's
/// methods, then [`SimOptions::start`].
#[must_use]
pub struct SimOptions<'a> {
    family: &'static str,
    files: &'a [(&'a str, &'a str)],
    variants: &'a [&'a str],
    args: &'a [&'a str],
    serving: Serving,
    time_scale: f64,
}

impl<'a> SimOptions<'a> {
    /// Files (path relative to the configuration directory, contents)
    /// written there first: a profile in `profiles/<name>.toml` patches the
    /// shipped one for the simulator and for every `jogterm` that shares
    /// the directory.
    pub fn files(mut self, files: &'a [(&'a str, &'a str)]) -> Self {
        self.files = files;
        self
    }

    /// A controller that differs from the default as `variants` say
    /// (`jogterm sim --variant`, `docs/simulator.md`, "Variants").
    pub fn variants(mut self, variants: &'a [&'a str]) -> Self {
        self.variants = variants;
        self
    }

    /// Further options of `jogterm sim` (`--probe-surface 8000`).
    pub fn args(mut self, args: &'a [&'a str]) -> Self {
        self.args = args;
        self
    }

    /// Serve as a serial port server in raw mode (`jogterm sim --tcp
    /// 127.0.0.1:0`): [`SimProcess::link`] is the `tcp://127.0.0.1:PORT` it
    /// printed.
    pub fn tcp(mut self) -> Self {
        self.serving = Serving::Tcp;
        self
    }

    /// Run the simulated machine `scale` times faster than the wall clock
    /// (`jogterm sim --time-scale`): only for a test that checks logic (end
    /// positions, bytes on the wire, messages), never for one that measures
    /// a timing promise or asserts a position jogterm estimates during a
    /// move (`docs/testing.md`, "The time scale").
    pub fn time_scale(mut self, scale: f64) -> Self {
        self.time_scale = scale;
        self
    }

    /// Start it and wait for its first line (the link).
    pub fn start(self) -> SimProcess {
        SimProcess::start_serving(self)
    }
}

impl SimProcess {
    /// The simulator of `family` with the defaults (a pty, the shipped
    /// profile, real time), to be changed before [`SimOptions::start`].
    pub fn options<'a>(family: &'static str) -> SimOptions<'a> {
        SimOptions {
            family,
            files: &[],
            variants: &[],
            args: &[],
            serving: Serving::Pty,
            time_scale: 1.0,
        }
    }

    /// Start the simulator of `family` and wait for its first line (the link).
    pub fn start(family: &'static str) -> SimProcess {
        Self::options(family).start()
    }

    /// [`SimProcess::start`] with `files` (path relative to the directory,
    /// contents) written into its configuration directory first: a profile
    /// in `profiles/<name>.toml` patches the shipped one for the simulator
    /// and for every `jogterm` that shares the directory.
    pub fn start_with_files(family: &'static str, files: &[(&str, &str)]) -> SimProcess {
        Self::options(family).files(files).start()
    }

    /// [`SimProcess::start_with_files`] serving a controller that differs
    /// from the default as `variants` say (`jogterm sim --variant`,
    /// `docs/simulator.md`, "Variants": `hood-unwired`, `memory=64` …).
    pub fn start_variant(
        family: &'static str,
        files: &[(&str, &str)],
        variants: &[&str],
    ) -> SimProcess {
        Self::options(family)
            .files(files)
            .variants(variants)
            .start()
    }

    /// The simulator of `family` as a serial port server in raw mode
    /// (`jogterm sim --tcp 127.0.0.1:0`): [`SimProcess::link`] is the
    /// `tcp://127.0.0.1:PORT` it printed.
    pub fn start_tcp(family: &'static str) -> SimProcess {
        Self::options(family).tcp().start()
    }

    fn start_serving(options: SimOptions<'_>) -> SimProcess {
        let SimOptions {
            family,
            files,
            variants,
            args,
            serving,
            time_scale,
        } = options;
        let dir = tempfile::tempdir().expect("temp dir");
        for (path, contents) in files {
            let path = dir.path().join(path);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).expect("create the config directory");
            }
            std::fs::write(&path, contents).expect("write a config file");
        }
        let mut link = dir.path().join(format!("tty{family}"));
        let mut command = Command::new(JOGTERM);
        command
            .args(["sim", "--protocol", family])
            .args(variants.iter().flat_map(|v| ["--variant", v]))
            .args(args)
            .arg("--time-scale")
            .arg(time_scale.to_string());
        match serving {
            Serving::Pty => command.arg("--pty").arg("--link").arg(&link),
            Serving::Tcp => command.args(["--tcp", "127.0.0.1:0"]),
        };
        let (mut child, stdin, lines) = spawn_with_lines(
            command
                .env("JOGTERM_CONFIG_DIR", dir.path())
                .env("RUST_BACKTRACE", "0")
                .stderr(Stdio::piped()),
        );
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let sink = stderr.clone();
        let mut err = child.stderr.take().expect("stderr");
        thread::spawn(move || {
            let mut buf = [0u8; 1024];
            while let Ok(n) = err.read(&mut buf) {
                if n == 0 {
                    break;
                }
                sink.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .extend_from_slice(&buf[..n]);
            }
        });
        let mut sim = SimProcess {
            child,
            stdin,
            lines,
            stderr,
            family,
            time_scale,
            link: link.clone(),
            dir,
        };
        let first = sim.line("the link path");
        match serving {
            Serving::Pty => {
                assert_eq!(Path::new(&first), sim.link, "the first line is the link")
            }
            Serving::Tcp => {
                assert!(first.starts_with("tcp://127.0.0.1:"), "{first}");
                link = PathBuf::from(first);
                sim.link = link;
            }
        }
        sim
    }

    /// The process id of the simulator.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// `show received times`: each read of the line with the wall-clock time
    /// it was read, and its bytes in readable form.
    pub fn received_times(&mut self) -> Vec<(std::time::SystemTime, String)> {
        self.write("show received times");
        let head = self.line("show received times");
        let count: usize = head
            .split_once(" in ")
            .and_then(|(_, rest)| rest.split_once(" reads"))
            .and_then(|(n, _)| n.parse().ok())
            .unwrap_or_else(|| panic!("unexpected answer to `show received times`: {head}"));
        (0..count)
            .map(|_| {
                let line = self.line("a read");
                let (at, bytes) = line.split_once(' ').unwrap_or((line.as_str(), ""));
                let (secs, micros) = at.split_once('.').expect("seconds.micros");
                let at = std::time::UNIX_EPOCH
                    + Duration::from_secs(secs.parse().expect("seconds"))
                    + Duration::from_micros(micros.parse().expect("micros"));
                (at, bytes.to_string())
            })
            .collect()
    }

    fn line(&self, what: &str) -> String {
        match self.lines.recv_timeout(WAIT) {
            Ok(line) => line,
            Err(_) => panic!(
                "the simulator printed no line for {what} within {WAIT:?}; stderr:\n{}",
                self.stderr_text()
            ),
        }
    }

    fn write(&mut self, command: &str) {
        writeln!(self.stdin, "{command}").expect("write to the simulator");
        self.stdin.flush().expect("flush the simulator's stdin");
    }

    /// A control line the simulator must accept (`ok`).
    pub fn control(&mut self, command: &str) {
        self.write(command);
        let answer = self.line(command);
        assert_eq!(
            answer,
            "ok",
            "`{command}` was not accepted; stderr:\n{}",
            self.stderr_text()
        );
    }

    /// Everything the controller has received, in `traffic::readable` form.
    pub fn received(&mut self) -> String {
        self.write("show received");
        let answer = self.line("show received");
        match answer.split_once(": ") {
            Some((head, bytes)) if head.starts_with("received ") && !head.contains("not kept") => {
                bytes.to_string()
            }
            _ => panic!("unexpected answer to `show received`: {answer}"),
        }
    }

    /// How many bytes the controller has received since it started.
    pub fn received_total(&mut self) -> u64 {
        self.write("show received");
        let answer = self.line("show received");
        answer
            .strip_prefix("received ")
            .and_then(|rest| rest.split_once(" bytes"))
            .and_then(|(n, _)| n.parse().ok())
            .unwrap_or_else(|| panic!("unexpected answer to `show received`: {answer}"))
    }

    /// The device's state line of `show` (`device: …`); the other lines
    /// (line, wire counters, faults armed, a last error) are read and left.
    pub fn device_state(&mut self) -> String {
        // `show received` behind it marks where `show`'s answer ends (the
        // control loop answers in order), so its optional fifth line is
        // known at once rather than waited for.
        self.write("show\nshow received");
        let device = self.line("show");
        for _ in 0..3 {
            self.line("show");
        }
        // A fifth line only when reopening the line failed.
        let mut next = self.line("show received");
        if !next.starts_with("received ") {
            assert!(next.starts_with("last error"), "after `show`: {next}");
            next = self.line("show received");
        }
        assert!(next.starts_with("received "), "after `show`: {next}");
        device
    }

    /// Wait until the device's state line satisfies `done`; the line.
    pub fn wait_device(&mut self, what: &str, done: impl Fn(&str) -> bool) -> String {
        let end = Instant::now() + WAIT;
        loop {
            let state = self.device_state();
            if done(&state) {
                return state;
            }
            assert!(
                Instant::now() < end,
                "the device never was {what}:\n{state}"
            );
            thread::sleep(Duration::from_millis(50));
        }
    }

    /// Wait until what the controller received satisfies `done`; the
    /// received text. Bounded by [`WAIT`].
    pub fn wait_received(&mut self, what: &str, done: impl Fn(&str) -> bool) -> String {
        let end = Instant::now() + WAIT;
        loop {
            let received = self.received();
            if done(&received) {
                return received;
            }
            assert!(
                Instant::now() < end,
                "the controller never received {what}:\n{received}"
            );
            thread::sleep(Duration::from_millis(50));
        }
    }

    /// [`jogterm`] against this simulator's link, with a state directory
    /// of its own (work offsets, the job log: a run of one test never
    /// offers a resume in another).
    pub fn jogterm(&self, args: &[&str]) -> Command {
        let mut command = jogterm(&self.link, self.family, args);
        command.env("JOGTERM_STATE_DIR", self.state_dir());
        command
    }

    /// The state directory of the commands run against this simulator.
    pub fn state_dir(&self) -> PathBuf {
        self.dir.path().join("state")
    }

    /// [`SimProcess::jogterm`] configured from the simulator's directory
    /// (the profiles its test wrote there), with no stdin.
    pub fn configured(&self, args: &[&str]) -> Command {
        let mut command = self.jogterm(args);
        command
            .env("JOGTERM_CONFIG_DIR", self.dir.path())
            .stdin(Stdio::null());
        command
    }

    /// [`SimProcess::jogterm`] run to its end.
    pub fn run(&self, args: &[&str]) -> Output {
        self.jogterm(args).output().expect("run jogterm")
    }

    /// `jogterm poll --json --count <count> --ports --interval-ms
    /// <interval_ms>` run to its end, which must succeed: its samples.
    pub fn poll_json(&self, count: &str, interval_ms: &str) -> Vec<serde_json::Value> {
        let out = self.run(&[
            "poll",
            "--json",
            "--count",
            count,
            "--ports",
            "--interval-ms",
            interval_ms,
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        json_lines(&out.stdout)
    }

    pub fn stderr_text(&self) -> String {
        String::from_utf8_lossy(&self.stderr.lock().unwrap_or_else(|p| p.into_inner())).into_owned()
    }

    /// The simulator is still running and has not panicked.
    pub fn assert_alive(&mut self) {
        assert!(
            matches!(self.child.try_wait(), Ok(None)),
            "the simulator ended; stderr:\n{}",
            self.stderr_text()
        );
        assert!(
            !contains_panic(self.stderr_text().as_bytes()),
            "the simulator panicked:\n{}",
            self.stderr_text()
        );
    }
}

impl Drop for SimProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// When the byte at `index` of the reads put together (`received_times`)
/// was read from the line: the time of the read that holds it.
pub fn read_time_at(
    reads: &[(std::time::SystemTime, String)],
    index: usize,
) -> std::time::SystemTime {
    let mut end = 0;
    reads
        .iter()
        .find(|(_, bytes)| {
            end += bytes.len();
            end > index
        })
        .map(|(at, _)| *at)
        .unwrap_or_else(|| panic!("no read holds byte {index}: {reads:?}"))
}
