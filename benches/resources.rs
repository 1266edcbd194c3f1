//! What the console costs in memory and CPU over a long run. The console is
//! assembled as `jogterm` assembles it (`cli::tui`): the device task for the
//! shipped isel profile, the UI model and its runtime loop, drawing through
//! ratatui's crossterm backend into a writer that only counts the bytes a
//! terminal would get. The simulator runs in its own process (`jogterm sim
//! --pty`), so this process holds only the console.
//!
//! 1. Memory: `--minutes N` (default 10) of polling at full rate (the
//!    profile's plan: positions as fast as the line allows, the ports every
//!    4th cycle); resident memory (`VmRSS`) sampled every `--every S`
//!    seconds (default 5). Reports start, peak, end and the growth per
//!    minute after the first minute (least-squares slope of the samples).
//! 2. CPU: `--cpu-seconds S` (default 60) of polling at 10 Hz with the
//!    machine idle; user and system time of the process
//!    (`getrusage(RUSAGE_SELF)`) as a share of one core.
//!
//! Run: `cargo bench --bench resources` (optimised; takes the full 10
//! minutes and one more), or `cargo bench --bench resources -- --minutes 1
//! --cpu-seconds 20` for a short look. Results: `docs/performance.md`,
//! "Resources".
//!
//! Hand-written, not on divan: minutes of real time, sampling resident
//! memory and CPU of a running console; nothing in it is a function timed
//! in a loop.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use std::future::Future;
use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use jogterm::config::{ConfigDirs, Profile, load_profile, load_theme};
use jogterm::device::api::{Event, PositionSource, Request};
use jogterm::device::{DeviceHandle, EventReceiver, TaskOptions, spawn};
use jogterm::proto::Protocol;
use jogterm::transport::PortSpec;
use jogterm::ui::keymap::Keymap;
use jogterm::ui::palette::Palette;
use jogterm::ui::runtime::{self, DeviceLink, NotSent, RunOptions};
use jogterm::ui::{Model, Msg, Setup};
use ratatui::backend::CrosstermBackend;
use ratatui::layout::Rect;
use ratatui::{Terminal, TerminalOptions, Viewport};
use support::{Args, SimProcess, build_kind, process_cpu, resident_kib};

/// A terminal that keeps nothing but the count of bytes it was sent.
#[derive(Default, Clone)]
struct Counter(Arc<AtomicU64>);

impl Write for Counter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.fetch_add(buf.len() as u64, Ordering::Relaxed);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The device task as the UI loop drives it (as in `cli::tui`), counting
/// the measured positions that reach the screen.
struct Device {
    handle: DeviceHandle,
    events: EventReceiver,
    positions: Arc<AtomicU64>,
}

impl DeviceLink for Device {
    fn request(&mut self, request: Request) -> Result<(), NotSent> {
        self.handle.request(request).map_err(NotSent::from)
    }

    fn stop(&mut self) {
        drop(self.handle.stop());
    }

    fn next_event(&mut self) -> impl Future<Output = Option<Event>> + Send {
        let positions = self.positions.clone();
        let next = self.events.recv();
        async move {
            let event = next.await;
            if let Some(Event::Position(p)) = &event
                && p.source == PositionSource::Measured
            {
                positions.fetch_add(1, Ordering::Relaxed);
            }
            event
        }
    }
}

/// What a console run leaves to report.
struct Console {
    positions: Arc<AtomicU64>,
    bytes: Counter,
    stop: tokio::sync::mpsc::UnboundedSender<Msg>,
    done: tokio::task::JoinHandle<Result<(), String>>,
}

/// Start the console on the simulator's pty, polling as `profile` says.
fn console(profile: &Profile, sim: &SimProcess) -> Console {
    let dirs = ConfigDirs::builtin_only();
    let theme = load_theme("dark", &dirs).expect("shipped theme");
    let spec = PortSpec::Serial {
        path: sim.link.clone(),
        line: profile.connection.line(),
    };
    let (handle, events) = spawn(profile, spec, TaskOptions::default()).expect("device task");
    let mut model = Model::new(
        Setup::from_profile(profile, None),
        Keymap::builtin().expect("built-in keys"),
        Palette::from(&theme),
        Instant::now(),
    );
    let (width, height) = (120, 40);
    model.size = (width, height);
    let positions = Arc::new(AtomicU64::new(0));
    let mut device = Device {
        handle,
        events,
        positions: positions.clone(),
    };
    let bytes = Counter::default();
    let mut terminal = Terminal::with_options(
        CrosstermBackend::new(bytes.clone()),
        TerminalOptions {
            viewport: Viewport::Fixed(Rect::new(0, 0, width, height)),
        },
    )
    .expect("terminal");
    let (stop, mut input) = tokio::sync::mpsc::unbounded_channel();
    let done = tokio::spawn(async move {
        runtime::run(
            &mut terminal,
            &mut model,
            &mut device,
            &mut input,
            None,
            RunOptions::default(),
        )
        .await
        .map_err(|e| e.to_string())
    });
    Console {
        positions,
        bytes,
        stop,
        done,
    }
}

impl Console {
    async fn end(self) {
        let _ = self.stop.send(Msg::Terminate {
            reason: "the benchmark is over".into(),
        });
        match tokio::time::timeout(Duration::from_secs(10), self.done).await {
            Ok(Ok(Ok(()))) => {}
            other => eprintln!("the console did not end cleanly: {other:?}"),
        }
    }
}

fn mib(kib: u64) -> f64 {
    kib as f64 / 1024.0
}

/// Least-squares slope of (minutes, KiB) samples, in KiB per minute.
fn slope(samples: &[(f64, u64)]) -> f64 {
    let n = samples.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let mx = samples.iter().map(|s| s.0).sum::<f64>() / n;
    let my = samples.iter().map(|s| s.1 as f64).sum::<f64>() / n;
    let sxy: f64 = samples.iter().map(|s| (s.0 - mx) * (s.1 as f64 - my)).sum();
    let sxx: f64 = samples.iter().map(|s| (s.0 - mx).powi(2)).sum();
    if sxx == 0.0 { 0.0 } else { sxy / sxx }
}

async fn memory(profile: &Profile, sim: &SimProcess, span: Duration, every: Duration) {
    let before = resident_kib().map_or(0, |r| r.0);
    let console = console(profile, sim);
    let start = Instant::now();
    let mut samples: Vec<(f64, u64)> = Vec::new();
    let mut next = start + every;
    println!("minute  positions/s  terminal B/s  RSS MiB");
    let (mut last_positions, mut last_bytes, mut last_at) = (0u64, 0u64, start);
    let mut printed_minute = 0u64;
    while start.elapsed() < span {
        tokio::time::sleep_until(next.into()).await;
        next += every;
        let Some((rss, _)) = resident_kib() else {
            continue;
        };
        let minutes = start.elapsed().as_secs_f64() / 60.0;
        samples.push((minutes, rss));
        let whole = minutes.floor() as u64;
        if whole > printed_minute || start.elapsed() + every > span {
            printed_minute = whole;
            let (p, b) = (
                console.positions.load(Ordering::Relaxed),
                console.bytes.0.load(Ordering::Relaxed),
            );
            let dt = last_at.elapsed().as_secs_f64();
            println!(
                "{minutes:>6.1}  {:>11.1}  {:>12.0}  {:>7.2}",
                (p - last_positions) as f64 / dt,
                (b - last_bytes) as f64 / dt,
                mib(rss)
            );
            (last_positions, last_bytes, last_at) = (p, b, Instant::now());
        }
    }
    let positions = console.positions.load(Ordering::Relaxed);
    let elapsed = start.elapsed();
    console.end().await;
    // The kernel updates VmHWM lazily (when resident memory is about to
    // shrink), so a sample can be above it: the peak is the larger of both.
    let sampled_peak = samples.iter().map(|s| s.1).max().unwrap_or(0);
    let peak = resident_kib().map_or(0, |r| r.1).max(sampled_peak);
    let first = samples.first().map_or(0, |s| s.1);
    let last = samples.last().map_or(0, |s| s.1);
    let after_first_minute: Vec<(f64, u64)> =
        samples.iter().copied().filter(|s| s.0 >= 1.0).collect();
    let growth = slope(if after_first_minute.len() >= 2 {
        &after_first_minute
    } else {
        &samples
    });
    println!();
    println!(
        "| memory, {:.1} min polling at full rate | value |",
        elapsed.as_secs_f64() / 60.0
    );
    println!("| --- | ---: |");
    println!(
        "| RSS before the console started | {:.2} MiB |",
        mib(before)
    );
    println!(
        "| RSS at the first sample ({} s) | {:.2} MiB |",
        every.as_secs(),
        mib(first)
    );
    println!(
        "| RSS peak (VmHWM or the largest sample) | {:.2} MiB |",
        mib(peak)
    );
    println!("| RSS at the end | {:.2} MiB |", mib(last));
    println!("| growth after the first minute | {growth:+.1} KiB/min |");
    println!(
        "| positions shown | {positions} ({:.1}/s) |",
        positions as f64 / elapsed.as_secs_f64()
    );
}

async fn cpu(profile: &Profile, sim: &SimProcess, span: Duration) {
    let mut profile = profile.clone();
    profile.poll.rate_hz = 10.0;
    let console = console(&profile, sim);
    // Let it connect and read the machine back first.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let (p0, b0) = (
        console.positions.load(Ordering::Relaxed),
        console.bytes.0.load(Ordering::Relaxed),
    );
    let (cpu0, wall0) = (process_cpu(), Instant::now());
    tokio::time::sleep(span).await;
    let (cpu1, wall) = (process_cpu(), wall0.elapsed());
    let positions = console.positions.load(Ordering::Relaxed) - p0;
    let bytes = console.bytes.0.load(Ordering::Relaxed) - b0;
    console.end().await;
    let share = |a: Duration, b: Duration| 100.0 * (b - a).as_secs_f64() / wall.as_secs_f64();
    let (user, system) = (share(cpu0.0, cpu1.0), share(cpu0.1, cpu1.1));
    println!();
    println!(
        "| CPU, {} s polling at 10 Hz, machine idle | value |",
        span.as_secs()
    );
    println!("| --- | ---: |");
    println!(
        "| CPU (one core = 100 %) | {:.2} % ({user:.2} user, {system:.2} sys) |",
        user + system
    );
    println!(
        "| context switches | {:.0}/s |",
        (cpu1.2 - cpu0.2) as f64 / wall.as_secs_f64()
    );
    println!(
        "| positions shown | {:.1}/s |",
        positions as f64 / wall.as_secs_f64()
    );
    println!(
        "| bytes to the terminal | {:.0}/s |",
        bytes as f64 / wall.as_secs_f64()
    );
}

fn main() {
    let args = Args::from_env();
    let number = |name: &str, default: f64| {
        args.value(name)
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v > 0.0)
            .unwrap_or(default)
    };
    let span = Duration::from_secs_f64(60.0 * number("--minutes", 10.0));
    let every = Duration::from_secs_f64(number("--every", 5.0));
    let cpu_span = Duration::from_secs_f64(number("--cpu-seconds", 60.0));
    let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("shipped profile");
    println!(
        "jogterm resources ({} build): console for the isel profile, simulator in its own process",
        build_kind()
    );
    // The runtime the console runs on (`cli::tui`): two workers.
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("runtime");
    let sim = SimProcess::start(Protocol::Isel);
    runtime.block_on(async {
        memory(&profile, &sim, span, every).await;
        cpu(&profile, &sim, cpu_span).await;
    });
}
