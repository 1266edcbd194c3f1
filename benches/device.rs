//! The device task against the isel and EMCU simulators, with the wire
//! modelled at 19200 baud: poll rates against the line's limit, the latency
//! from a stop request to the first stop byte on the wire while polling at
//! full rate, and the CPU a 10 Hz poll loop costs. Prints a table;
//! `docs/performance.md` says how to run it and what it measured.
//!
//! EMP rows: the same against the EMP simulator at 38400 baud (`2C` poll
//! rate against one round trip, stop latency).
//!
//! `cargo bench --bench device` (optimised) or `cargo test --bench device`
//! (debug build); add `-- --quick` for shorter runs, `-- --only cpu` (or
//! `bare`, `poll`, `stop`, `tcp`, `emcu`, `emp`) for one measure, e.g. under a profiler.
//!
//! TCP rows: the isel poll rates and stop latency again through the network
//! transport (`tcp://`) to the simulator served as a raw serial port server.
//!
//! Hand-written, not on divan: a real-time end-to-end measure (the device
//! task against a simulator in its own process, over a pty, at the line's
//! real speed). Its figures are rates against the wire limit and
//! latency percentiles of single stops, which a micro-benchmark harness's
//! repeated-closure timing cannot express.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Activity, Event, Frame, PerAxis, PositionSource, Request};
use jogterm::device::driver::Driver;
use jogterm::device::emcu::{EmcuDriver, EmcuSettings};
use jogterm::device::emp::{EmpDriver, EmpSettings};
use jogterm::device::isel::{IselDriver, IselSettings, PollPlan, PollRate};
use jogterm::device::{Connector, DeviceHandle, EventReceiver, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use jogterm::proto::isel::InputPort;
use jogterm::sim::registry;
use jogterm::sim::shell::{Shell, serve_socket, serve_tcp};
use jogterm::transport::PortSpec;
use jogterm::wire::LineSettings;

struct Row {
    what: String,
    result: String,
    target: String,
    ok: bool,
}

fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("default profile")
}

fn settings(rate: PollRate, ports: Vec<InputPort>) -> IselSettings {
    let mut s = IselSettings::from_profile(&profile()).expect("settings");
    s.poll = PollPlan {
        rate,
        positions: true,
        ports_every: 1,
        ports,
    };
    s
}

/// The device task talking to the isel simulator over a socket pair.
fn socket_task(settings: IselSettings) -> (Shell, DeviceHandle, EventReceiver) {
    socket_task_for(Box::new(IselDriver::new(settings)), &profile())
}

/// Any family's driver and the simulator of `profile`'s family.
fn socket_task_for(
    driver: Box<dyn Driver>,
    profile: &Profile,
) -> (Shell, DeviceHandle, EventReceiver) {
    let device = registry::build(profile.connection.protocol, profile).expect("simulator");
    let (shell, stream) = serve_socket(device).expect("serve");
    let spec = PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: format!("{} simulator", profile.connection.protocol),
    };
    let (handle, events) =
        spawn_with(driver, Connector::from(spec), TaskOptions::default()).expect("device task");
    (shell, handle, events)
}

/// The device task talking to the isel simulator served on TCP in-process
/// (as `jogterm sim --tcp` does: a serial port server in raw mode), through
/// the network transport (`tcp://`, docs/network.md).
fn tcp_task(settings: IselSettings) -> (Shell, DeviceHandle, EventReceiver) {
    let profile = profile();
    let device = registry::build(profile.connection.protocol, &profile).expect("simulator");
    let shell = serve_tcp(device, "127.0.0.1:0".parse().expect("addr")).expect("serve");
    let url = format!("tcp://{}", shell.tcp_addr().expect("addr"));
    let spec = PortSpec::from_address(&url, shell.line()).expect("address");
    let (handle, events) = spawn_with(
        Box::new(IselDriver::new(settings)),
        Connector::from(spec),
        TaskOptions::default(),
    )
    .expect("device task");
    (shell, handle, events)
}

async fn read_back(events: &mut EventReceiver) {
    loop {
        match events.recv().await {
            Some(Event::Notice(n)) if n.starts_with("state read back") => return,
            Some(_) => {}
            None => panic!("the device task ended"),
        }
    }
}

/// Measured positions per second over `span` after the read-back, and the
/// median time between two (which load spikes on a shared machine do not
/// move).
async fn poll_rate(ports: Vec<InputPort>, span: Duration) -> (f64, Duration) {
    let (shell, handle, mut events) = socket_task(settings(PollRate::LineSpeed, ports));
    read_back(&mut events).await;
    measure_rate((shell, handle, events), span).await
}

/// The rate and median cycle of a task polling at line speed, once its
/// controller is ready.
async fn measure_rate(
    (shell, handle, mut events): (Shell, DeviceHandle, EventReceiver),
    span: Duration,
) -> (f64, Duration) {
    // Let the first cycles settle.
    tokio::time::sleep(Duration::from_millis(200)).await;
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
    handle.shutdown().await;
    drop(shell);
    let mut gaps: Vec<Duration> = at.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort();
    (rate, percentile(&gaps, 0.5))
}

/// The same loop without the device task: the transport alone sends `@0P`
/// and reads the 19 bytes back, as fast as it can. What the machine allows
/// at all; the device task can only come close to it.
async fn bare_rate(span: Duration) -> f64 {
    let device = registry::build(Protocol::Isel, &profile()).expect("simulator");
    let (shell, stream) = serve_socket(device).expect("serve");
    let mut parts = jogterm::transport::open(PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: "isel simulator".into(),
    })
    .and_then(|p| p.split(jogterm::transport::WriterConfig::default()))
    .expect("port");
    let start = Instant::now();
    let mut cycles = 0u64;
    while start.elapsed() < span {
        parts
            .writer
            .send(
                b"@0P\r".to_vec(),
                jogterm::transport::Interleave::BetweenBytes,
            )
            .expect("send");
        let mut got = 0;
        while got < 19 {
            match tokio::time::timeout(Duration::from_secs(1), parts.reader.read_chunk()).await {
                Ok(Ok(chunk)) => got += chunk.bytes.len(),
                _ => panic!("the simulator did not answer"),
            }
        }
        cycles += 1;
        while parts.events.try_recv().is_ok() {}
    }
    let rate = cycles as f64 / start.elapsed().as_secs_f64();
    parts.writer.close();
    drop(shell);
    rate
}

/// Stop request to first stop byte on the wire, while polling `@0P` at
/// full rate: `n` stops at pseudo-random moments.
async fn stop_latency(n: usize) -> Vec<Duration> {
    let (shell, handle, mut events) = socket_task(settings(PollRate::LineSpeed, Vec::new()));
    read_back(&mut events).await;
    measure_stops((shell, handle, events), n).await
}

/// `n` stops at pseudo-random moments while the task polls at full rate,
/// once its controller is ready.
async fn measure_stops(
    (shell, handle, mut events): (Shell, DeviceHandle, EventReceiver),
    n: usize,
) -> Vec<Duration> {
    let drain = tokio::spawn(async move { while events.recv().await.is_some() {} });
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut latencies = Vec::with_capacity(n);
    for _ in 0..n {
        // xorshift: 10-40 ms apart, so stops land anywhere in a poll cycle.
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        tokio::time::sleep(Duration::from_micros(10_000 + seed % 30_000)).await;
        if let Some(w) = handle.stop().written().await {
            latencies.push(w.latency());
        }
    }
    handle.shutdown().await;
    let _ = drain.await;
    drop(shell);
    latencies.sort();
    latencies
}

/// The isel rows again over the TCP transport: poll rates and the stop
/// latency (the modelled start of the first stop byte on the server's
/// serial line, as on a tty: the loopback adds microseconds).
async fn tcp_rows(span: Duration, stops: usize, p_limit: f64, p13_limit: f64, rows: &mut Vec<Row>) {
    for (what, ports, limit) in [
        ("@0P", Vec::new(), p_limit),
        (
            "@0P + ports 1, 3",
            vec![InputPort::Status1, InputPort::LimitSwitches],
            p13_limit,
        ),
    ] {
        let (shell, handle, mut events) = tcp_task(settings(PollRate::LineSpeed, ports));
        read_back(&mut events).await;
        let (rate, _) = measure_rate((shell, handle, events), span).await;
        rows.push(Row {
            what: format!("TCP: {what} poll rate"),
            result: format!(
                "{rate:.1}/s = {:.1} % of {limit:.1}/s",
                100.0 * rate / limit
            ),
            target: ">= 97 %".into(),
            ok: rate >= 0.97 * limit,
        });
    }
    let (shell, handle, mut events) = tcp_task(settings(PollRate::LineSpeed, Vec::new()));
    read_back(&mut events).await;
    let lat = measure_stops((shell, handle, events), stops).await;
    stop_rows(
        rows,
        "TCP: stop -> first stop byte",
        &lat,
        Duration::from_millis(1),
        Duration::from_millis(2),
    );
}

/// The p50 and p99 rows of a stop latency measure: `what` names the
/// stop's first byte, the targets are p50 and p99 bounds.
fn stop_rows(
    rows: &mut Vec<Row>,
    what: &str,
    lat: &[Duration],
    p50_max: Duration,
    p99_max: Duration,
) {
    let ms = |d: Duration| d.as_secs_f64() * 1000.0;
    let (p50, p99) = (percentile(lat, 0.5), percentile(lat, 0.99));
    rows.push(Row {
        what: format!("{what}, p50 ({} stops)", lat.len()),
        result: format!("{:.3} ms", ms(p50)),
        target: format!("< {:.1} ms", ms(p50_max)),
        ok: p50 < p50_max,
    });
    rows.push(Row {
        what: format!("{what}, p99"),
        result: format!(
            "{:.3} ms (max {:.3} ms)",
            ms(p99),
            ms(lat.last().copied().unwrap_or_default())
        ),
        target: format!("< {:.1} ms", ms(p99_max)),
        ok: p99 < p99_max,
    });
}

// ----- EMCU ------------------------------------------------------------

/// The shipped `emcu` profile with a short, fast way to the reference
/// switches, so the set-up of a measure takes a second or two.
fn emcu_profile() -> Profile {
    let mut p = load_profile("emcu", &ConfigDirs::builtin_only()).expect("emcu profile");
    p.sim.start_position = 2.0;
    p.emcu.start_speed_hz = 1_000;
    p
}

/// Where the EMCU measures poll: four-digit counters on every axis, the
/// positions the brief's 53 cycles/s are reckoned for.
const EMCU_AT: i64 = 5_000;

/// The EMCU device task polling `@LX @LY @LZ` at line speed (no `@X`),
/// initialised, referenced and standing at [`EMCU_AT`] on every axis.
async fn emcu_task() -> (Shell, DeviceHandle, EventReceiver) {
    let profile = emcu_profile();
    let mut s = EmcuSettings::from_profile(&profile).expect("settings");
    s.poll.rate = PollRate::LineSpeed;
    s.poll.ports.clear();
    let (shell, handle, mut events) = socket_task_for(Box::new(EmcuDriver::new(s)), &profile);
    read_back(&mut events).await;
    let idle = |e: &Event| matches!(e, Event::State(s) if s.activity == Activity::Idle);
    handle.request(Request::Initialise).expect("request");
    handle
        .request(Request::Home { axes: AxisSet::XYZ })
        .expect("request");
    wait_for(&mut events, |e| {
        matches!(e, Event::State(s) if s.referenced == AxisSet::XYZ && s.activity == Activity::Idle)
    })
    .await;
    let at = PerAxis::new()
        .with(Axis::X, EMCU_AT)
        .with(Axis::Y, EMCU_AT)
        .with(Axis::Z, EMCU_AT);
    handle
        .request(Request::MoveTo {
            target: at,
            frame: Frame::Machine,
            speed_hz: PerAxis::new()
                .with(Axis::X, 2_000.0)
                .with(Axis::Y, 2_000.0)
                .with(Axis::Z, 1_000.0),
        })
        .expect("request");
    wait_for(
        &mut events,
        |e| matches!(e, Event::State(s) if s.activity != Activity::Idle),
    )
    .await;
    wait_for(&mut events, idle).await;
    wait_for(
        &mut events,
        |e| matches!(e, Event::Position(p) if p.steps == at),
    )
    .await;
    (shell, handle, events)
}

async fn wait_for(events: &mut EventReceiver, pred: impl Fn(&Event) -> bool) {
    let within = Duration::from_secs(60);
    loop {
        match tokio::time::timeout(within, events.recv()).await {
            Ok(Some(e)) if pred(&e) => return,
            Ok(Some(_)) => {}
            _ => panic!("the EMCU set-up did not come through"),
        }
    }
}

/// Position cycles (`@LX @LY @LZ`) per second at line speed, and the median
/// time between two.
async fn emcu_poll_rate(span: Duration) -> (f64, Duration) {
    let (shell, handle, mut events) = emcu_task().await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    while events.try_recv().is_ok() {}
    let start = Instant::now();
    let mut at = Vec::new();
    while start.elapsed() < span {
        if let Ok(Some(Event::Position(p))) =
            tokio::time::timeout(Duration::from_millis(100), events.recv()).await
        {
            at.push(p.at);
        }
    }
    let rate = at.len() as f64 / start.elapsed().as_secs_f64();
    handle.shutdown().await;
    drop(shell);
    let mut gaps: Vec<Duration> = at.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort();
    (rate, percentile(&gaps, 0.5))
}

/// Stop request to the first byte of `@B` on the wire while polling at line
/// speed. A line is never cut, so a stop waits for the poll line on the
/// wire (4 bytes, 2.1 ms at most).
async fn emcu_stop_latency(n: usize) -> Vec<Duration> {
    let (shell, handle, events) = emcu_task().await;
    let mut events = events;
    let drain = tokio::spawn(async move { while events.recv().await.is_some() {} });
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut latencies = Vec::with_capacity(n);
    for _ in 0..n {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        tokio::time::sleep(Duration::from_micros(10_000 + seed % 30_000)).await;
        if let Some(w) = handle.stop().written().await {
            latencies.push(w.latency());
        }
    }
    handle.shutdown().await;
    let _ = drain.await;
    drop(shell);
    latencies.sort();
    latencies
}

/// The EMCU rows: poll rate and median cycle against the wire limit at
/// four-digit positions (3 x (4 + 8) bytes: 53.3/s), stop latency.
async fn emcu_rows(span: Duration, stops: usize, rows: &mut Vec<Row>) {
    let line = LineSettings::new(19200);
    let digits = EMCU_AT.to_string().len() as f64;
    let limit = line.bytes_per_second() / (3.0 * (4.0 + 4.0 + digits));
    let (rate, median) = emcu_poll_rate(span).await;
    rows.push(Row {
        what: "EMCU @LX @LY @LZ poll rate".into(),
        result: format!(
            "{rate:.1}/s = {:.1} % of {limit:.1}/s",
            100.0 * rate / limit
        ),
        target: ">= 97 %".into(),
        ok: rate >= 0.97 * limit,
    });
    let median_rate = 1.0 / median.as_secs_f64().max(1e-9);
    rows.push(Row {
        what: "EMCU @LX @LY @LZ median cycle".into(),
        result: format!(
            "{:.3} ms = {:.1} % of the limit",
            median.as_secs_f64() * 1000.0,
            100.0 * median_rate / limit
        ),
        target: "-".into(),
        ok: true,
    });
    let lat = emcu_stop_latency(stops).await;
    stop_rows(
        rows,
        "EMCU stop -> first @B byte",
        &lat,
        Duration::from_micros(2_100),
        Duration::from_micros(3_100),
    );
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// User and system CPU time of this process so far, and its context switches
/// (voluntary + involuntary: how often it went to sleep and woke again).
fn cpu_time() -> (Duration, Duration, i64) {
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

/// The simulator in its own process (`jogterm sim --pty`), so the CPU this
/// process spends is the device side's alone.
struct SimProcess {
    child: Child,
    link: PathBuf,
    _dir: tempfile::TempDir,
}

impl Drop for SimProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn sim_process() -> SimProcess {
    let dir = tempfile::tempdir().expect("temp dir");
    let link = dir.path().join("isel");
    let mut child = Command::new(env!("CARGO_BIN_EXE_jogterm"))
        .args(["sim", "--protocol", "isel", "--pty", "--link"])
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

/// CPU share of one core (user, system) for polling at 10 Hz for `span`, and
/// context switches per second.
async fn poll_cpu(span: Duration) -> (f64, f64, f64) {
    let sim = sim_process();
    let connector = Connector::Serial {
        path: sim.link.clone(),
        line: LineSettings::new(19200),
    };
    // The shipped profile's plan: ports 1, 3, 2 every 4th cycle.
    let mut s = IselSettings::from_profile(&profile()).expect("settings");
    s.poll.rate = PollRate::Hz(10.0);
    let (handle, mut events) = spawn_with(
        Box::new(IselDriver::new(s)),
        connector,
        TaskOptions::default(),
    )
    .expect("device task");
    read_back(&mut events).await;
    // A consumer like a screen at 10 frames a second: it takes what has
    // come every 100 ms instead of waking for every event.
    let drain = tokio::spawn(async move {
        let mut n = 0u64;
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        loop {
            tick.tick().await;
            loop {
                match events.try_recv() {
                    Ok(e) => n += u64::from(matches!(e, Event::Position(_))),
                    Err(jogterm::device::TryRecvError::Empty) => break,
                    Err(jogterm::device::TryRecvError::Closed) => return n,
                }
            }
        }
    });
    let (cpu0, wall0) = (cpu_time(), Instant::now());
    tokio::time::sleep(span).await;
    let (cpu1, wall) = (cpu_time(), wall0.elapsed());
    handle.shutdown().await;
    let polled = drain.await.unwrap_or(0);
    assert!(
        polled as f64 >= 0.9 * 10.0 * span.as_secs_f64(),
        "{polled} polls"
    );
    drop(sim);
    let share = |a: Duration, b: Duration| 100.0 * (b - a).as_secs_f64() / wall.as_secs_f64();
    let switches = (cpu1.2 - cpu0.2) as f64 / wall.as_secs_f64();
    (share(cpu0.0, cpu1.0), share(cpu0.1, cpu1.1), switches)
}

/// EMP: the device task with the EMP driver against the EMP simulator of the
/// `emp` profile (one drive, 38400 baud), polling `2C` only, the drive
/// switched on (before `02` it answers `2C` with `EE`).
async fn emp_task() -> (Shell, DeviceHandle, EventReceiver) {
    let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("emp profile");
    let mut settings = EmpSettings::from_profile(&profile).expect("emp settings");
    settings.poll = PollRate::LineSpeed;
    // `40` once at the start only: the row measures `2C`.
    settings.ports_every = u32::MAX;
    let (shell, handle, mut events) = socket_task_for(Box::new(EmpDriver::new(settings)), &profile);
    read_back(&mut events).await;
    handle
        .request(jogterm::device::api::Request::Initialise)
        .expect("request");
    loop {
        match events.recv().await {
            Some(Event::Notice(n)) if n.starts_with("initialised") => break,
            Some(_) => {}
            None => panic!("the device task ended"),
        }
    }
    (shell, handle, events)
}

/// The EMP rows: `2C` poll rate against one round trip (two 17-byte frames
/// at 38400 baud and the drive's 1.6 ms, 10.45 ms; the manual rounds it to
/// 10.8 ms), and the stop latency while polling.
async fn emp_rows(span: Duration, stops: usize, rows: &mut Vec<Row>) {
    let line = jogterm::proto::emp::LINE;
    let round_trip =
        line.transfer_time(2 * jogterm::proto::emp::FRAME_WIRE_LEN) + Duration::from_micros(1600);
    let limit = 1.0 / round_trip.as_secs_f64();
    let manual = 1.0 / 0.0108;
    let (rate, median) = measure_rate(emp_task().await, span).await;
    rows.push(Row {
        what: "EMP 2C poll rate".into(),
        result: format!(
            "{rate:.1}/s = {:.1} % of {limit:.1}/s",
            100.0 * rate / limit
        ),
        target: ">= 97 %".into(),
        ok: rate >= 0.97 * limit,
    });
    rows.push(Row {
        what: "EMP 2C rate against 1/10.8 ms".into(),
        result: format!("{:.1} % of {manual:.1}/s", 100.0 * rate / manual),
        target: ">= 97 %".into(),
        ok: rate >= 0.97 * manual,
    });
    let median_rate = 1.0 / median.as_secs_f64().max(1e-9);
    rows.push(Row {
        what: "EMP 2C median cycle".into(),
        result: format!(
            "{:.3} ms = {:.1} % of the limit",
            median.as_secs_f64() * 1000.0,
            100.0 * median_rate / limit
        ),
        target: "-".into(),
        ok: true,
    });
    let lat = measure_stops(emp_task().await, stops).await;
    // A stop frame waits for the frame on the wire (17 bytes, 4.4 ms).
    let frame = line.transfer_time(jogterm::proto::emp::FRAME_WIRE_LEN);
    stop_rows(
        rows,
        "EMP stop -> first byte",
        &lat,
        frame,
        frame + Duration::from_millis(1),
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1))
        .cloned();
    let wanted = |what: &str| only.as_deref().is_none_or(|o| o == what);
    let span = Duration::from_secs(if quick { 2 } else { 10 });
    let stops = if quick { 50 } else { 300 };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let line = LineSettings::new(19200);
    // @0P CR + 19 bytes; each port 5 + 3 bytes.
    let p_limit = line.bytes_per_second() / 23.0;
    let p13_limit = line.bytes_per_second() / 39.0;
    let mut rows = Vec::new();
    runtime.block_on(async {
        if wanted("bare") {
            let bare = bare_rate(span).await;
            rows.push(Row {
                what: "bare transport @0P loop (reference)".into(),
                result: format!(
                    "{bare:.1}/s = {:.1} % of {p_limit:.1}/s",
                    100.0 * bare / p_limit
                ),
                target: "-".into(),
                ok: true,
            });
        }
        for (what, ports, limit) in [
            ("@0P", Vec::new(), p_limit),
            (
                "@0P + ports 1, 3",
                vec![InputPort::Status1, InputPort::LimitSwitches],
                p13_limit,
            ),
        ] {
            if !wanted("poll") {
                continue;
            }
            let (rate, median) = poll_rate(ports, span).await;
            rows.push(Row {
                what: format!("{what} poll rate"),
                result: format!(
                    "{rate:.1}/s = {:.1} % of {limit:.1}/s",
                    100.0 * rate / limit
                ),
                target: ">= 97 %".into(),
                ok: rate >= 0.97 * limit,
            });
            let median_rate = 1.0 / median.as_secs_f64().max(1e-9);
            rows.push(Row {
                what: format!("{what} median cycle"),
                result: format!(
                    "{:.3} ms = {:.1} % of the limit",
                    median.as_secs_f64() * 1000.0,
                    100.0 * median_rate / limit
                ),
                target: "-".into(),
                ok: true,
            });
        }
        if wanted("stop") {
            let lat = stop_latency(stops).await;
            stop_rows(
                &mut rows,
                "stop -> first stop byte",
                &lat,
                Duration::from_millis(1),
                Duration::from_millis(2),
            );
        }
        if wanted("tcp") {
            tcp_rows(span, stops, p_limit, p13_limit, &mut rows).await;
        }
        if wanted("emcu") {
            emcu_rows(span, stops, &mut rows).await;
        }
        if wanted("emp") {
            emp_rows(span, stops, &mut rows).await;
        }
        if wanted("cpu") {
            let (user, system, switches) = poll_cpu(span).await;
            rows.push(Row {
                what: format!("CPU, 10 Hz poll loop, {} s", span.as_secs()),
                result: format!(
                    "{:.2} % of a core ({user:.2} user, {system:.2} sys)",
                    user + system
                ),
                target: "< 1 %".into(),
                ok: user + system < 1.0,
            });
            rows.push(Row {
                what: "  context switches, 10 Hz poll loop".into(),
                result: format!("{switches:.0}/s"),
                target: "-".into(),
                ok: true,
            });
        }
    });
    println!(
        "jogterm device benchmark: isel and EMCU simulators at 19200 baud, EMP at 38400 ({} build)",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "optimised"
        }
    );
    println!("{:<42} {:<36} {:<10} ok", "measure", "result", "target");
    for r in &rows {
        println!(
            "{:<42} {:<36} {:<10} {}",
            r.what,
            r.result,
            r.target,
            if r.ok { "yes" } else { "NO" }
        );
    }
}
