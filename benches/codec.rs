//! Codec throughput of the three protocol cores: messages encoded and
//! decoded per second, on both sides of the line (the host encodes requests
//! and decodes replies; a controller, or the simulator, does the opposite),
//! with a reply decoded whole and fed one byte at a time. Each figure is set
//! against how many such messages the serial line itself can carry, so the
//! headroom reads as a factor.
//!
//! Run: `cargo bench --bench codec` (optimised), `-- --quick` for fewer
//! runs, `-- emp` for the rows whose name contains `emp`. Results and their
//! reading: `docs/performance.md`, "Codecs".

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod support;

use std::hint::black_box;
use std::time::Duration;

use jogterm::proto::{Protocol, emcu, emp, isel};
use support::{Args, Timing, build_kind, time};

/// Messages per timed run.
const BATCH: usize = 20_000;

struct Row {
    what: String,
    /// Bytes of one message on the wire.
    len: usize,
    /// Messages per second the line carries (its bytes per second / `len`).
    wire: f64,
    timing: Timing,
}

fn run(what: String, len: usize, protocol: Protocol, runs: usize, f: impl FnMut() -> usize) -> Row {
    let timing = time(runs, f);
    Row {
        what,
        len,
        wire: protocol.default_line().bytes_per_second() / len as f64,
        timing,
    }
}

/// `f` once per message of the batch, returning something that depends on
/// the work so it cannot be optimised away.
fn batch(mut f: impl FnMut(usize) -> usize) -> impl FnMut() -> usize {
    move || (0..BATCH).map(|i| black_box(f(i))).sum::<usize>()
}

fn isel_rows(runs: usize, rows: &mut Vec<Row>) {
    let p = Protocol::Isel;
    let poll = isel::parse_frame("@0P").expect("@0P").value;
    let moving = isel::parse_frame("@0A30,800,10,900,4,90,-4,30")
        .expect("move")
        .value;
    for (name, frame) in [("@0P", &poll), ("@0A XYZ move", &moving)] {
        let bytes = frame.encode();
        rows.push(run(
            format!("isel request encode: {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| frame.encode().len()),
        ));
        // The controller's side: cut the line, parse it.
        let mut framer = isel::RequestFramer::new();
        rows.push(run(
            format!("isel request decode (framer + parse): {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| {
                framer
                    .push_all(&bytes)
                    .iter()
                    .filter_map(|r| match r {
                        isel::Received::Line(l) => isel::parse_frame(l).ok(),
                        _ => None,
                    })
                    .count()
            }),
        ));
    }
    let reply = isel::Reply::Positions(isel::Positions {
        x: 256,
        y: 131_087,
        z: -2,
        a: None,
    });
    let bytes = reply.encode().expect("positions encode");
    let expect = isel::Expect::Positions { with_a: false };
    rows.push(run(
        "isel reply encode: @0P positions".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| reply.encode().map_or(0, |b| b.len())),
    ));
    let mut decoder = isel::ReplyDecoder::new();
    rows.push(run(
        "isel reply decode, whole: @0P positions".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| {
            let _ = decoder.expect(expect);
            decoder.feed(&bytes).len()
        }),
    ));
    rows.push(run(
        "isel reply decode, byte by byte: @0P positions".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| {
            let _ = decoder.expect(expect);
            bytes.iter().map(|b| decoder.feed(&[*b]).len()).sum()
        }),
    ));
}

fn emcu_rows(runs: usize, rows: &mut Vec<Row>) {
    let p = Protocol::Emcu;
    let poll: emcu::Command = "@LX".parse().expect("@LX");
    let moving: emcu::Command = "L1,X200,Y500,Z-35".parse().expect("move");
    for (name, command) in [("@LX", poll), ("L1 XYZ move", moving)] {
        let bytes = command.encode(emcu::Terminator::Cr).expect("encode");
        rows.push(run(
            format!("emcu request encode: {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| command.encode(emcu::Terminator::Cr).map_or(0, |b| b.len())),
        ));
        let mut framer = emcu::CommandFramer::new();
        rows.push(run(
            format!("emcu request decode (framer + parse): {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| framer.feed(&bytes).len()),
        ));
    }
    let reply = emcu::Reply::Position {
        axis: emcu::EmcuAxis::X,
        steps: -123_456,
    };
    let bytes = reply.encode();
    rows.push(run(
        "emcu reply encode: @LX position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| reply.encode().len()),
    ));
    let mut decoder = emcu::ReplyDecoder::new();
    rows.push(run(
        "emcu reply decode, whole: @LX position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| decoder.feed(&bytes).len()),
    ));
    rows.push(run(
        "emcu reply decode, byte by byte: @LX position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| bytes.iter().filter_map(|b| decoder.push(*b)).count()),
    ));
}

fn emp_rows(runs: usize, rows: &mut Vec<Row>) {
    let p = Protocol::Emp;
    let poll: emp::Request = "2C11000000000000".parse().expect("2C");
    let moving: emp::Request = "2A110110000186A0".parse().expect("2A 01");
    for (name, request) in [("2C read position", poll), ("2A 01 move to", moving)] {
        let bytes = request.encode();
        rows.push(run(
            format!("emp request encode: {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| request.encode().len()),
        ));
        // The drive's side: frame, then type the request.
        let mut decoder = emp::FrameDecoder::new();
        rows.push(run(
            format!("emp request decode (frame + request): {name}"),
            bytes.len(),
            p,
            runs,
            batch(|_| {
                decoder
                    .feed(&bytes)
                    .iter()
                    .filter_map(|r| match r {
                        Ok(emp::Incoming::Frame(f)) => emp::Request::decode(f).ok(),
                        _ => None,
                    })
                    .count()
            }),
        ));
    }
    let frame: emp::Frame = "2D110022000186A0".parse().expect("2D");
    let reply = emp::Reply::decode(&emp::Incoming::Frame(frame), &poll).expect("2D reply");
    let bytes = reply.encode();
    rows.push(run(
        "emp reply encode: 2D position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| reply.encode().len()),
    ));
    let mut decoder = emp::FrameDecoder::new();
    let mut typed = |r: &Result<emp::Incoming, emp::FrameError>| match r {
        Ok(incoming) => usize::from(emp::Reply::decode(incoming, &poll).is_ok()),
        Err(_) => 0,
    };
    rows.push(run(
        "emp reply decode, whole: 2D position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| decoder.feed(&bytes).iter().map(&mut typed).sum()),
    ));
    rows.push(run(
        "emp reply decode, byte by byte: 2D position".into(),
        bytes.len(),
        p,
        runs,
        batch(|_| {
            bytes
                .iter()
                .filter_map(|b| decoder.push(*b))
                .map(|r| typed(&r))
                .sum()
        }),
    ));
}

fn main() {
    let args = Args::from_env();
    let runs = if args.flag("--quick") { 5 } else { 15 };
    let filter = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .unwrap_or_default();
    let mut rows = Vec::new();
    isel_rows(runs, &mut rows);
    emcu_rows(runs, &mut rows);
    emp_rows(runs, &mut rows);
    println!(
        "jogterm codecs ({} build): {BATCH} messages per run, median of {runs} runs; \
         rates from the thread's CPU time",
        build_kind()
    );
    println!(
        "| {:<54} | {:>5} | {:>12} | {:>8} | {:>8} | {:>10} |",
        "what", "bytes", "messages/s", "ns/msg", "MB/s", "x the wire"
    );
    println!(
        "| {:-<54} | {:->5} | {:->12} | {:->8} | {:->8} | {:->10} |",
        "", ":", ":", ":", ":", ":"
    );
    for r in rows.iter().filter(|r| r.what.contains(&filter)) {
        let per = r.timing.cpu.max(Duration::from_nanos(1)).as_secs_f64() / BATCH as f64;
        let rate = 1.0 / per;
        println!(
            "| {:<54} | {:>5} | {:>12.0} | {:>8.1} | {:>8.1} | {:>10.0} |",
            r.what,
            r.len,
            rate,
            per * 1e9,
            rate * r.len as f64 / 1e6,
            rate / r.wire,
        );
    }
}
