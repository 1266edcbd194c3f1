//! jogterm's device task against a plain blocking reference poller, in the
//! same run, against the same simulator process (`jogterm sim --pty`, wire
//! timing on): positions per second of each, and their ratio, so the gain
//! is a ratio rather than an absolute time that depends on the machine.
//!
//! The reference is the loop a quick script would write with `serialport`:
//! write the poll command, then read with a fixed timeout per read until the
//! reply's length (or its terminator) is in, or a read times out; next poll.
//! A second reference does not know the reply's length and reads until the
//! line has been quiet for the timeout, as generic send-and-read tools do.
//!
//! Run: `cargo bench --bench reference` (optimised), `-- --quick` for 3 s
//! spans and one round. Results: `docs/performance.md`, "Against a blocking
//! reference poller".

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use jogterm::axis::Axis;
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::driver::Driver;
use jogterm::device::emcu::{EmcuDriver, EmcuSettings};
use jogterm::device::emp::{EmpDriver, EmpSettings};
use jogterm::device::isel::{IselDriver, IselSettings, PollPlan, PollRate};
use jogterm::device::{Connector, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use support::{Args, SimProcess, build_kind, first_position, position_rate};

/// How a reference poll reads its reply.
#[derive(Debug, Clone, Copy)]
enum Reading {
    /// Read until the reply is complete (its length, or its terminator),
    /// each read waiting at most this long.
    UntilComplete(Duration),
    /// Read until nothing has come for this long (the reply's end unknown).
    UntilQuiet(Duration),
}

/// One family's poll: what to send, and how its reply ends.
struct Poll {
    /// Sent once after opening (EMP takes nothing before "unit on").
    setup: &'static [u8],
    request: &'static [u8],
    /// The reply is complete at this length, or at this terminator.
    reply_len: Option<usize>,
    terminator: Option<u8>,
}

fn poll_of(protocol: Protocol) -> Poll {
    match protocol {
        // isel manual 2.2.21: `0` and 18 hex digits for X, Y, Z.
        Protocol::Isel => Poll {
            setup: b"",
            request: b"@0P\r",
            reply_len: Some(19),
            terminator: None,
        },
        // EMCU manual 1.5.4: `@LX1234` CR.
        Protocol::Emcu => Poll {
            setup: b"",
            request: b"@LX\r",
            reply_len: None,
            terminator: Some(b'\r'),
        },
        // EMP `2C`: 16 hex characters and EOF; unit on first.
        Protocol::Emp => Poll {
            setup: b"0211110000000000\x1a",
            request: b"2C11000000000000\x1a",
            reply_len: Some(17),
            terminator: None,
        },
    }
}

/// What one reference run measured.
struct Measured {
    /// Complete replies per second.
    rate: f64,
    /// Polls that got no complete reply.
    missed: u64,
    /// Mean length of the complete replies (EMCU's vary with the value).
    reply_len: f64,
}

/// The blocking loop over `span`.
fn reference_rate(path: &Path, protocol: Protocol, reading: Reading, span: Duration) -> Measured {
    let poll = poll_of(protocol);
    let timeout = match reading {
        Reading::UntilComplete(t) | Reading::UntilQuiet(t) => t,
    };
    let mut port = serialport::new(path.to_string_lossy(), protocol.default_line().baud)
        .timeout(timeout)
        .open()
        .expect("open the simulator's pty");
    if !poll.setup.is_empty() {
        port.write_all(poll.setup).expect("write");
        let mut sink = [0u8; 64];
        let _ = port.read(&mut sink);
    }
    let complete = |reply: &[u8]| {
        poll.reply_len.is_some_and(|n| reply.len() >= n)
            || poll.terminator.is_some_and(|t| reply.last() == Some(&t))
    };
    let mut buf = [0u8; 256];
    let (mut good, mut missed, mut bytes) = (0u64, 0u64, 0usize);
    let start = Instant::now();
    while start.elapsed() < span {
        port.write_all(poll.request).expect("write");
        let mut reply = Vec::with_capacity(32);
        loop {
            match port.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    reply.extend_from_slice(&buf[..n]);
                    if matches!(reading, Reading::UntilComplete(_)) && complete(&reply) {
                        break;
                    }
                }
                // The per-read timeout: the end of this poll.
                Err(_) => break,
            }
        }
        if complete(&reply) {
            good += 1;
            bytes += reply.len();
        } else {
            missed += 1;
        }
    }
    Measured {
        rate: good as f64 / start.elapsed().as_secs_f64(),
        missed,
        reply_len: bytes as f64 / good.max(1) as f64,
    }
}

fn profile(protocol: Protocol) -> Profile {
    load_profile(protocol.name(), &ConfigDirs::builtin_only()).expect("shipped profile")
}

/// The family's driver polling positions only, as fast as the line allows:
/// what the reference does.
fn poll_driver(protocol: Protocol) -> Result<Box<dyn Driver>, String> {
    let mut profile = profile(protocol);
    profile.poll.rate_hz = 0.0;
    match protocol {
        Protocol::Isel => {
            let mut s = IselSettings::from_profile(&profile).map_err(|e| e.to_string())?;
            s.poll = PollPlan {
                rate: PollRate::LineSpeed,
                positions: true,
                ports_every: 1,
                ports: Vec::new(),
            };
            Ok(Box::new(IselDriver::new(s)))
        }
        // The reference reads one axis (`@LX`) and no status: so does the
        // driver here, or the rows would compare a three-axis cycle with one.
        Protocol::Emcu => {
            profile.machine.axes = "X".into();
            profile.axes.retain(|axis, _| *axis == Axis::X);
            let mut s = EmcuSettings::from_profile(&profile).map_err(|e| e.to_string())?;
            s.poll.rate = PollRate::LineSpeed;
            s.poll.ports.clear();
            Ok(Box::new(EmcuDriver::new(s)))
        }
        // `2C` of the one drive, no `40` between.
        Protocol::Emp => {
            let mut s = EmpSettings::from_profile(&profile).map_err(|e| e.to_string())?;
            s.poll = PollRate::LineSpeed;
            s.ports_every = u32::MAX;
            Ok(Box::new(EmpDriver::new(s)))
        }
    }
}

/// Positions per second of jogterm's device task over the pty.
async fn jogterm_rate(path: &Path, protocol: Protocol, span: Duration) -> Result<f64, String> {
    let driver = poll_driver(protocol)?;
    let connector = Connector::Serial {
        path: path.to_path_buf(),
        line: protocol.default_line(),
    };
    let (handle, mut events) =
        spawn_with(driver, connector, TaskOptions::default()).map_err(|e| e.to_string())?;
    if !first_position(&mut events, Duration::from_secs(20)).await {
        handle.shutdown().await;
        return Err("no position within 20 s".into());
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let (rate, _) = position_rate(&mut events, span).await;
    handle.shutdown().await;
    Ok(rate)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

fn main() {
    let args = Args::from_env();
    let quick = args.flag("--quick");
    let span = Duration::from_secs(if quick { 3 } else { 10 });
    let rounds = if quick { 1 } else { 3 };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let readings = [
        (
            "reads until complete, 100 ms timeout",
            Reading::UntilComplete(Duration::from_millis(100)),
        ),
        (
            "reads until 50 ms quiet",
            Reading::UntilQuiet(Duration::from_millis(50)),
        ),
    ];
    println!(
        "jogterm against a blocking reference poller ({} build): {} s spans, median of {rounds} rounds",
        build_kind(),
        span.as_secs()
    );
    println!(
        "| {:<6} | {:<50} | {:>12} | {:>10} | {:>16} |",
        "family", "poller", "positions/s", "of wire", "jogterm / this"
    );
    println!(
        "| {:-<6} | {:-<50} | {:->12} | {:->10} | {:->16} |",
        "", "", ":", ":", ":"
    );
    for protocol in Protocol::ALL {
        let sim = SimProcess::start(protocol);
        let poll = poll_of(protocol);
        // Rounds alternate the pollers, so that load drifting on a shared
        // machine hits both alike.
        let mut ours = Vec::new();
        let mut theirs: Vec<Vec<f64>> = vec![Vec::new(); readings.len()];
        let mut missed = vec![0u64; readings.len()];
        let mut reply_len = 0.0f64;
        let mut unsupported = None;
        for _ in 0..rounds {
            for (i, (_, reading)) in readings.iter().enumerate() {
                let m = reference_rate(&sim.link, protocol, *reading, span);
                theirs[i].push(m.rate);
                missed[i] += m.missed;
                reply_len = reply_len.max(m.reply_len);
            }
            match runtime.block_on(jogterm_rate(&sim.link, protocol, span)) {
                Ok(rate) => ours.push(rate),
                Err(e) => {
                    unsupported = Some(e);
                    break;
                }
            }
        }
        // The line's limit: request and reply bytes back to back.
        let wire =
            protocol.default_line().bytes_per_second() / (poll.request.len() as f64 + reply_len);
        let ours = (!ours.is_empty()).then(|| median(ours));
        if let Some(rate) = ours {
            println!(
                "| {:<6} | {:<50} | {:>12.1} | {:>9.1}% | {:>16} |",
                protocol.name(),
                "jogterm device task",
                rate,
                100.0 * rate / wire,
                "1.00"
            );
        } else if let Some(e) = &unsupported {
            println!(
                "| {:<6} | {:<50} | {:>12} | {:>10} | {:>16} |",
                protocol.name(),
                format!("jogterm device task: {e}"),
                "-",
                "-",
                "-"
            );
        }
        for (i, (name, _)) in readings.iter().enumerate() {
            let rate = median(theirs[i].clone());
            let ratio = ours.map_or("-".to_owned(), |o| format!("{:.2}", o / rate.max(1e-9)));
            let name = if missed[i] > 0 {
                format!("{name} ({} misses)", missed[i])
            } else {
                (*name).to_owned()
            };
            println!(
                "| {:<6} | {:<50} | {:>12.1} | {:>9.1}% | {:>16} |",
                protocol.name(),
                name,
                rate,
                100.0 * rate / wire,
                ratio
            );
        }
        drop(sim);
    }
}
