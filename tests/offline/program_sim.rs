//! The predicted end position of a program (`path`) against the built-in
//! simulators: store the program the way an upload does (isel `@0i` … `9`,
//! EMCU a batch ended by 0x01), run it, read the counters, compare. Time is
//! synthetic: the simulators' deadlines are run in order.

use std::path::Path;
use std::time::{Duration, Instant};

use jogterm::axis::AxisSet;
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::program::{Language, LintConfig, Program, Severity, Start, lint, path};
use jogterm::proto::Protocol;
use jogterm::sim::SimDevice;
use jogterm::sim::registry;

/// A simulator on a synthetic line.
struct Bench {
    sim: Box<dyn SimDevice>,
    now: Instant,
    byte: Duration,
    out: Vec<u8>,
}

impl Bench {
    fn new(protocol: Protocol, profile: &str) -> Bench {
        let profile = load_profile(profile, &ConfigDirs::builtin_only()).expect("profile");
        let sim = registry::build(protocol, &profile).expect("simulator");
        let byte = sim.line().byte_time();
        Bench {
            sim,
            now: Instant::now(),
            byte,
            out: Vec::new(),
        }
    }

    fn drain(&mut self) {
        while let Some(m) = self.sim.poll_output() {
            self.out.extend(m);
        }
    }

    fn run_until(&mut self, until: Instant) {
        while let Some(d) = self.sim.next_deadline().filter(|d| *d <= until) {
            self.now = self.now.max(d);
            self.sim.advance(self.now);
            self.drain();
        }
        self.now = self.now.max(until);
        self.sim.advance(self.now);
        self.drain();
    }

    fn send(&mut self, line: &str, end: u8) {
        for b in line.bytes().chain([end]) {
            self.run_until(self.now + self.byte);
            self.sim.on_byte(b, self.now);
            self.drain();
        }
    }

    /// What arrives until `done` says it is complete, within `limit`.
    fn until(&mut self, limit: Duration, done: impl Fn(&[u8]) -> bool) -> String {
        let end = self.now + limit;
        while !done(&self.out) && self.now < end {
            let next = self
                .sim
                .next_deadline()
                .unwrap_or(end)
                .min(end)
                .max(self.now + Duration::from_millis(1));
            self.run_until(next);
        }
        let text = String::from_utf8_lossy(&self.out).into_owned();
        assert!(done(&self.out), "incomplete after {limit:?}: {text:?}");
        self.out.clear();
        text
    }

    /// isel: send a command, return its reply once it ends with a reply
    /// code (sync characters of a running program come before it).
    fn isel(&mut self, line: &str, limit: Duration) -> String {
        self.send(line, b'\r');
        self.until(limit, |out| {
            out.last()
                .is_some_and(|b| b.is_ascii_digit() || b"DFGHR".contains(b))
        })
    }

    fn isel_position(&mut self) -> [i64; 4] {
        self.send("@0P", b'\r');
        let reply = self.until(Duration::from_millis(50), |out| out.len() >= 19);
        let field = |i: usize| {
            let hex = reply.get(1 + 6 * i..7 + 6 * i).expect("field");
            let v = i64::from_str_radix(hex, 16).expect("hex");
            if v >= 1 << 23 { v - (1 << 24) } else { v }
        };
        [field(0), field(1), field(2), 0]
    }
}

const MINUTES: Duration = Duration::from_secs(600);

/// Store and run an isel program on the default machine after a reference
/// run; the counters at the end.
fn run_isel(text: &str) -> [i64; 4] {
    let program = Program::parse(Language::Isel, text);
    let lines = program.upload_lines().expect("the program parses");
    let mut b = Bench::new(Protocol::Isel, "default");
    assert_eq!(b.isel("@07", MINUTES), "0");
    assert_eq!(b.isel("@0R7", MINUTES), "0");
    assert_eq!(b.isel("@0i", MINUTES), "0");
    for line in &lines {
        assert_eq!(b.isel(line, MINUTES), "0", "storing {line}");
    }
    let reply = b.isel("@0S", MINUTES);
    assert!(reply.ends_with('0'), "the run: {reply:?}");
    b.isel_position()
}

fn predicted(text: &str) -> [i64; 4] {
    let program = Program::parse(Language::Isel, text);
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let errors: Vec<_> = lint(&program, &LintConfig::from_profile(&profile))
        .into_iter()
        .filter(|d| d.severity == Severity::Error)
        .collect();
    assert!(errors.is_empty(), "{errors:#?}");
    path(&program, &Start::at_zero(AxisSet::XYZ)).end
}

fn example(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/programs")
        .join(name);
    std::fs::read_to_string(path).expect("example")
}

#[test]
fn isel_examples_end_where_the_path_predicts() {
    for name in ["drill-pattern.isel", "circle.isel", "probe.isel"] {
        let text = example(name);
        assert_eq!(run_isel(&text), predicted(&text), "{name}");
    }
}

#[test]
fn loops_jumps_zero_points_and_arcs_end_where_the_path_predicts() {
    let programs = [
        // Loops nested, a jump over a move, 3 axes in 2.5D.
        "01000,2000,0,2000,500,2000,-200,2000\n3 2,-1\n3 0,2\n050000,2000,0,2000,0,2000,0,2000\n\
         00,2000,700,2000,0,2000,0,2000\n3 1,-5\n9\n",
        // Virtual zero points and a simulated reference.
        "m4000,2000,4000,2000,4000,2000,0,2000\nn3\nm1000,2000,1000,2000,0,2000,0,2000\n\
         N1\nm500,2000,0,2000,4000,2000,0,2000\n9\n",
        // Arcs both ways in two planes, a helix, 3D interpolation.
        "m20000,4000,20000,4000,10000,4000,0,4000\nf-1\ny400,1500,119,-141,141,-1,-1\n\
         f0\ny400,1500,119,-141,141,-1,-1\ne1\nw32000,600,-1000,-2000,0,1,-1,6000\n\
         z1\n0 300,2000,-200,2000,100,2000,0,2000\n9\n",
    ];
    for text in programs {
        assert_eq!(run_isel(text), predicted(text), "{text}");
    }
}

#[test]
fn an_emcu_job_ends_where_the_path_predicts() {
    let text = example("pick-and-place.job");
    let program = Program::parse(Language::Emcu, &text);
    let lines = program.upload_lines().expect("the job parses");
    let mut b = Bench::new(Protocol::Emcu, "emcu");
    let last = lines.len() - 1;
    for (i, line) in lines.iter().enumerate() {
        let end = if i == last { 0x01 } else { b'\r' };
        b.send(line, end);
        let ack = b.until(Duration::from_millis(600), |out| out.ends_with(b"\r"));
        assert_eq!(ack, "\r", "{line}");
    }
    // The batch runs and says so with 0x02 CR.
    b.until(MINUTES, |out| out.ends_with(b"\x02\r"));
    let mut end = [0i64; 4];
    for (i, axis) in ["X", "Y", "Z"].into_iter().enumerate() {
        b.send(&format!("@L{axis}"), b'\r');
        let reply = b.until(Duration::from_millis(600), |out| out.ends_with(b"\r"));
        let value = reply.trim_end().trim_start_matches(&format!("@L{axis}"));
        end[i] = value.parse().unwrap_or_else(|e| panic!("{reply:?}: {e}"));
    }
    let predicted = path(&program, &Start::at_zero(AxisSet::XYZ)).end;
    assert_eq!(end, predicted);
}
