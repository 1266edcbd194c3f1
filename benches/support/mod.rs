//! Helpers shared by the bench binaries (`benches/*.rs`, each `harness =
//! false`): timing with the thread's CPU clock, percentiles, the process's
//! CPU and memory, and a simulator in its own process.
#![allow(dead_code)]

use std::hint::black_box;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jogterm::proto::Protocol;

/// "optimised" or "debug": which build the figures come from.
pub fn build_kind() -> &'static str {
    if cfg!(debug_assertions) {
        "debug"
    } else {
        "optimised"
    }
}

/// CPU time this thread has used: on a machine shared with other work the
/// wall time of a run includes time the scheduler gave to others.
pub fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    if ok {
        Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
    } else {
        Duration::ZERO
    }
}

/// Wall and thread-CPU times of several runs of the same work.
#[derive(Debug, Clone, Copy)]
pub struct Timing {
    pub median: Duration,
    pub max: Duration,
    pub cpu: Duration,
}

/// Median and maximum wall time and median CPU time of `runs` runs of `f`.
pub fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> Timing {
    let runs = runs.max(1);
    let mut wall = Vec::with_capacity(runs);
    let mut cpu = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (start, start_cpu) = (Instant::now(), thread_cpu());
        black_box(f());
        wall.push(start.elapsed());
        cpu.push(thread_cpu().saturating_sub(start_cpu));
    }
    wall.sort();
    cpu.sort();
    Timing {
        median: wall[runs / 2],
        max: wall[runs - 1],
        cpu: cpu[runs / 2],
    }
}

/// The `p` quantile (0..=1) of sorted durations; zero when there are none.
pub fn percentile(sorted: &[Duration], p: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// User and system CPU time of this process so far, and its context switches
/// (voluntary + involuntary: how often it went to sleep and woke again).
pub fn process_cpu() -> (Duration, Duration, i64) {
    // SAFETY: getrusage fills the struct it is given; a zeroed rusage is valid.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer to a rusage for the calling process.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) };
    if rc != 0 {
        return (Duration::ZERO, Duration::ZERO, 0);
    }
    let tv = |t: libc::timeval| {
        Duration::from_secs(t.tv_sec.max(0) as u64) + Duration::from_micros(t.tv_usec.max(0) as u64)
    };
    (
        tv(usage.ru_utime),
        tv(usage.ru_stime),
        usage.ru_nvcsw + usage.ru_nivcsw,
    )
}

/// Resident memory of this process in KiB (`VmRSS`), and its peak
/// (`VmHWM`), from `/proc/self/status`.
pub fn resident_kib() -> Option<(u64, u64)> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse::<u64>().ok())
    };
    Some((field("VmRSS:")?, field("VmHWM:")?))
}

/// A simulator in its own process (`jogterm sim --pty`), so that what this
/// process measures is the host side's alone. Killed when dropped.
pub struct SimProcess {
    child: Child,
    pub link: PathBuf,
    _dir: tempfile::TempDir,
}

impl SimProcess {
    /// Start the simulator of `protocol` (its shipped profile) and wait for
    /// the path it serves.
    pub fn start(protocol: Protocol) -> SimProcess {
        Self::start_with(protocol, &[], None)
    }

    /// As [`SimProcess::start`], with more `args` to `jogterm sim` and the
    /// configuration directory `config` (its profiles) when given.
    pub fn start_with(
        protocol: Protocol,
        args: &[&str],
        config: Option<&std::path::Path>,
    ) -> SimProcess {
        let dir = tempfile::tempdir().expect("temp dir");
        let link = dir.path().join(protocol.name());
        let mut command = Command::new(env!("CARGO_BIN_EXE_jogterm"));
        if let Some(config) = config {
            command.env("JOGTERM_CONFIG_DIR", config);
        }
        let mut child = command
            .args(["sim", "--protocol", protocol.name()])
            .args(args)
            .args(["--pty", "--link"])
            .arg(&link)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn jogterm sim");
        let mut first = String::new();
        if let Some(out) = child.stdout.take() {
            let _ = BufReader::new(out).read_line(&mut first);
        }
        assert_eq!(first.trim(), link.to_string_lossy(), "the simulator's path");
        SimProcess {
            child,
            link,
            _dir: dir,
        }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for SimProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Options after `--` of `cargo bench --bench <name> -- ...`: the value of
/// `--name VALUE`, and whether a flag is present.
pub struct Args(Vec<String>);

impl Args {
    pub fn from_env() -> Args {
        Args(std::env::args().skip(1).collect())
    }

    pub fn flag(&self, name: &str) -> bool {
        self.0.iter().any(|a| a == name)
    }

    pub fn value(&self, name: &str) -> Option<&str> {
        self.0
            .iter()
            .position(|a| a == name)
            .and_then(|i| self.0.get(i + 1))
            .map(String::as_str)
    }
}

/// Waits until the device task reports its first measured position (the
/// driver has connected, initialised and read the machine back), at most
/// `limit`. False when it did not come.
pub async fn first_position(events: &mut jogterm::device::EventReceiver, limit: Duration) -> bool {
    use jogterm::device::api::{Event, PositionSource};
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        match tokio::time::timeout_at(deadline, events.recv()).await {
            Ok(Some(Event::Position(p))) if p.source == PositionSource::Measured => return true,
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => return false,
        }
    }
}

/// Measured positions per second over `span`, and the median time between
/// two (which load spikes on a shared machine do not move).
pub async fn position_rate(
    events: &mut jogterm::device::EventReceiver,
    span: Duration,
) -> (f64, Duration) {
    use jogterm::device::api::{Event, PositionSource};
    while events.try_recv().is_ok() {}
    let start = Instant::now();
    let mut at = Vec::new();
    while start.elapsed() < span {
        if let Ok(Some(Event::Position(p))) =
            tokio::time::timeout(Duration::from_millis(100), events.recv()).await
            && p.source == PositionSource::Measured
        {
            at.push(p.at);
        }
    }
    let rate = at.len() as f64 / start.elapsed().as_secs_f64();
    let mut gaps: Vec<Duration> = at.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort();
    (rate, percentile(&gaps, 0.5))
}
