//! jogterm's device task against an optimal client, in the same run, against
//! the same simulator process (`jogterm sim --pty`, wire timing on): poll
//! cycles per second of each (the mean over the span, not the median cycle),
//! and their ratio, so the figure is a ratio rather than an absolute rate
//! that depends on the machine and its load.
//!
//! The optimal client knows everything a poller could: it writes each
//! command whole (one `write`), reads exactly its reply (its length, or up
//! to its terminator for EMCU, whose replies vary in length), and writes the
//! next command at once, in one thread. jogterm polls the same commands at
//! line speed through its device task: driver, paced writer, reader,
//! events. Cycles: isel `@0P`; isel `@0P`, `@0b1`, `@0b3`; EMCU `@LX`,
//! `@LY`, `@LZ`; EMP `2C` (issue 18).
//!
//! Run: `cargo bench --bench reference` (optimised), `-- --quick` for 3 s
//! spans and one round. Results: `docs/performance.md`, "Against an
//! optimal client".
//!
//! Hand-written, not on divan: real-time poll rates and stop latencies of
//! two clients on a simulator at the line's real speed, set against each
//! other; not a function timed in a loop.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::driver::Driver;
use jogterm::device::emcu::{EmcuDriver, EmcuSettings};
use jogterm::device::emp::{EmpDriver, EmpSettings};
use jogterm::device::isel::{IselDriver, IselSettings, PollPlan, PollRate};
use jogterm::device::{Connector, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use jogterm::proto::isel::InputPort;
use support::{Args, SimProcess, build_kind, first_position, position_rate};

/// How a reply ends, as the optimal client knows it.
#[derive(Debug, Clone, Copy)]
enum Reply {
    /// Exactly this many bytes.
    Len(usize),
    /// At this byte (EMCU: its replies' length varies with the value).
    Until(u8),
}

/// One poll cycle as the controller sees it.
struct Case {
    name: &'static str,
    protocol: Protocol,
    /// Sent once after opening (EMP takes nothing before "unit on"), and
    /// the length of its reply.
    setup: (&'static [u8], usize),
    /// The cycle's exchanges, in jogterm's order.
    exchanges: &'static [(&'static [u8], Reply)],
    /// isel: the ports jogterm reads each cycle besides `@0P`.
    isel_ports: &'static [InputPort],
}

const CASES: [Case; 4] = [
    // isel manual 2.2.21: `0` and 18 hex digits for X, Y, Z.
    Case {
        name: "isel @0P",
        protocol: Protocol::Isel,
        setup: (b"", 0),
        exchanges: &[(b"@0P\r", Reply::Len(19))],
        isel_ports: &[],
    },
    // `@0b<n>` answers `0` and two hex digits.
    Case {
        name: "isel @0P + ports 1, 3",
        protocol: Protocol::Isel,
        setup: (b"", 0),
        exchanges: &[
            (b"@0P\r", Reply::Len(19)),
            (b"@0b1\r", Reply::Len(3)),
            (b"@0b3\r", Reply::Len(3)),
        ],
        isel_ports: &[InputPort::Status1, InputPort::LimitSwitches],
    },
    // EMCU manual 1.5.4: `@LX1234` CR, each axis of the shipped profile.
    Case {
        name: "emcu @LX @LY @LZ",
        protocol: Protocol::Emcu,
        setup: (b"", 0),
        exchanges: &[
            (b"@LX\r", Reply::Until(b'\r')),
            (b"@LY\r", Reply::Until(b'\r')),
            (b"@LZ\r", Reply::Until(b'\r')),
        ],
        isel_ports: &[],
    },
    // EMP `2C`: 16 hex characters and EOF; unit on first.
    Case {
        name: "emp 2C",
        protocol: Protocol::Emp,
        setup: (b"0211110000000000\x1a", 17),
        exchanges: &[(b"2C11000000000000\x1a", Reply::Len(17))],
        isel_ports: &[],
    },
];

/// What one optimal run measured.
struct Measured {
    /// Complete cycles per second over the span (the mean rate).
    rate: f64,
    /// Mean bytes on the wire per cycle, both ways.
    wire_bytes: f64,
}

/// Open the simulator's pty once the device task of the round before has
/// let go of it (seen: a moment after its shutdown had returned, the tty
/// was still held exclusively).
fn open_when_free(path: &Path, baud: u32) -> Box<dyn serialport::SerialPort> {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match serialport::new(path.to_string_lossy(), baud)
            .timeout(Duration::from_secs(2))
            .open()
        {
            Ok(port) => return port,
            Err(e) if e.kind() == serialport::ErrorKind::NoDevice && Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("open the simulator's pty: {e}"),
        }
    }
}

/// The optimal client over `span`.
fn optimal_rate(path: &Path, case: &Case, span: Duration) -> Measured {
    let mut port = open_when_free(path, case.protocol.default_line().baud);
    let mut buf = [0u8; 64];
    // What is still on its way from the round before (the reply to the
    // device task's last poll, cut off by its shutdown) would shift every
    // read by a few bytes, and the client would write each command before
    // its reply had ended: faster than the wire. Wait for quiet, as jogterm
    // does when it connects.
    port.set_timeout(Duration::from_millis(100))
        .expect("timeout");
    while port.read(&mut buf).is_ok_and(|n| n > 0) {}
    port.set_timeout(Duration::from_secs(2)).expect("timeout");
    let (setup, setup_reply) = case.setup;
    if !setup.is_empty() {
        port.write_all(setup).expect("write");
        let got = buf.get_mut(..setup_reply).expect("reply fits");
        port.read_exact(got).expect("the setup's reply");
    }
    let (mut cycles, mut bytes) = (0u64, 0usize);
    let start = Instant::now();
    while start.elapsed() < span {
        for (request, reply) in case.exchanges {
            port.write_all(request).expect("write");
            bytes += request.len();
            match *reply {
                Reply::Len(n) => {
                    let got = buf.get_mut(..n).expect("reply fits");
                    port.read_exact(got).expect("the reply");
                    bytes += n;
                }
                Reply::Until(end) => loop {
                    let n = port.read(&mut buf).expect("the reply");
                    bytes += n;
                    if buf.get(..n).is_some_and(|got| got.last() == Some(&end)) {
                        break;
                    }
                },
            }
        }
        cycles += 1;
    }
    Measured {
        rate: cycles as f64 / start.elapsed().as_secs_f64(),
        wire_bytes: bytes as f64 / cycles.max(1) as f64,
    }
}

fn profile(protocol: Protocol) -> Profile {
    load_profile(protocol.name(), &ConfigDirs::builtin_only()).expect("shipped profile")
}

/// The family's driver polling what the case's optimal client polls, as
/// fast as the line allows.
fn poll_driver(case: &Case) -> Result<Box<dyn Driver>, String> {
    let mut profile = profile(case.protocol);
    profile.poll.rate_hz = 0.0;
    match case.protocol {
        Protocol::Isel => {
            let mut s = IselSettings::from_profile(&profile).map_err(|e| e.to_string())?;
            s.poll = PollPlan {
                rate: PollRate::LineSpeed,
                positions: true,
                ports_every: 1,
                ports: case.isel_ports.to_vec(),
            };
            Ok(Box::new(IselDriver::new(s)))
        }
        // Every axis of the shipped profile, no `@X` status between.
        Protocol::Emcu => {
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

/// Poll cycles per second of jogterm's device task over the pty (one
/// measured position per cycle), the mean over the span.
async fn jogterm_rate(path: &Path, case: &Case, span: Duration) -> Result<f64, String> {
    let driver = poll_driver(case)?;
    let connector = Connector::Serial {
        path: path.to_path_buf(),
        line: case.protocol.default_line(),
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

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn main() {
    let args = Args::from_env();
    let quick = args.flag("--quick");
    let only = args.value("--only");
    let span = Duration::from_secs(if quick { 3 } else { 10 });
    let rounds = if quick { 1 } else { 3 };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    println!(
        "jogterm against an optimal client ({} build): {} s spans, mean of {rounds} rounds",
        build_kind(),
        span.as_secs()
    );
    println!(
        "| {:<22} | {:>10} | {:>10} | {:>8} | {:>15} | {:<20} |",
        "cycle", "jogterm/s", "optimal/s", "of wire", "jogterm/optimal", "per round"
    );
    println!(
        "| {:-<22} | {:->10} | {:->10} | {:->8} | {:->15} | {:-<20} |",
        "", ":", ":", ":", ":", ""
    );
    for case in CASES
        .iter()
        .filter(|c| only.is_none_or(|o| c.protocol.name() == o))
    {
        let sim = SimProcess::start(case.protocol);
        // Rounds alternate the two, so that load drifting on a shared
        // machine hits both alike.
        let (mut ours, mut theirs) = (Vec::new(), Vec::new());
        let mut wire_bytes = 0.0f64;
        let mut failed = None;
        for _ in 0..rounds {
            let m = optimal_rate(&sim.link, case, span);
            theirs.push(m.rate);
            wire_bytes = wire_bytes.max(m.wire_bytes);
            match runtime.block_on(jogterm_rate(&sim.link, case, span)) {
                Ok(rate) => ours.push(rate),
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            }
        }
        drop(sim);
        if let Some(e) = failed {
            println!("| {:<22} | jogterm: {e} |", case.name);
            continue;
        }
        // The line's limit: requests and replies back to back.
        let wire = case.protocol.default_line().bytes_per_second() / wire_bytes.max(1.0);
        let (o, t) = (mean(&ours), mean(&theirs));
        let per_round: Vec<String> = ours
            .iter()
            .zip(&theirs)
            .map(|(o, t)| format!("{:.3}", o / t.max(1e-9)))
            .collect();
        println!(
            "| {:<22} | {:>10.1} | {:>10.1} | {:>7.1}% | {:>15.3} | {:<20} |",
            case.name,
            o,
            t,
            100.0 * t / wire,
            o / t.max(1e-9),
            per_round.join(" ")
        );
    }
}
