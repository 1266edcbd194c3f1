//! Wire timing of the simulator shell, measured on real threads and fds.
//!
//! The bounds only fail on *early* delivery (a cycle faster than the wire):
//! that is what the shell guarantees. How close it gets to the wire limit
//! depends on the machine's load, so it is printed, not asserted.

use crate::sim_shell_support;

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use crate::timing::serial;
use jogterm::sim::shell::{PtyOptions, serve_pty, serve_socket};
use jogterm::wire::LineSettings;
use sim_shell_support::{LineAnswerer, REPLY, REQUEST, byte_time, cycle};

const CYCLES: u32 = 200;

/// 4 + 19 bytes at 19200 baud.
fn wire_limit() -> Duration {
    LineSettings::new(19200).transfer_time(REQUEST.len() + REPLY.len())
}

fn measure(port: &mut (impl Read + Write), label: &str) {
    for _ in 0..5 {
        assert_eq!(cycle(port, REQUEST, REPLY.len()), REPLY);
    }
    let limit = wire_limit();
    // The model adds whole (truncated) nanosecond byte times; allow that.
    let floor = limit - Duration::from_nanos(50);
    let mut times = Vec::with_capacity(CYCLES as usize);
    let start = Instant::now();
    for i in 0..CYCLES {
        let t = Instant::now();
        let reply = cycle(port, REQUEST, REPLY.len());
        let took = t.elapsed();
        assert_eq!(reply, REPLY, "cycle {i}");
        assert!(
            took >= floor,
            "cycle {i} took {took:?}, faster than the wire ({limit:?})"
        );
        times.push(took);
    }
    times.sort();
    let average = start.elapsed() / CYCLES;
    assert!(average >= floor);
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "{label}: {CYCLES} cycles, average {:.3} ms (wire limit {:.3} ms, {:.1} % of the wire rate); \
         fastest {:.3}, median {:.3}, slowest {:.3} ms",
        ms(average),
        ms(limit),
        100.0 * limit.as_secs_f64() / average.as_secs_f64(),
        ms(times[0]),
        ms(times[times.len() / 2]),
        ms(times[times.len() - 1]),
    );
}

#[test]
fn socket_request_reply_cycles_never_beat_the_wire() {
    let _serial = serial();
    let (shell, mut client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
    client
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    measure(&mut client, "socket pair");
    shell.shutdown();
}

#[test]
fn pty_request_reply_cycles_never_beat_the_wire() {
    let _serial = serial();
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    let mut client = serialport::new(path.to_string_lossy(), 19200)
        .timeout(Duration::from_millis(100))
        .open_native()
        .expect("open slave");
    measure(&mut client, "pty");
    drop(client);
    shell.shutdown();
}

#[test]
fn bytes_written_at_once_reach_the_device_one_byte_time_apart() {
    let _serial = serial();
    let (device, arrivals) = LineAnswerer::new(19200, Duration::ZERO);
    let (shell, mut client) = serve_socket(Box::new(device)).expect("serve");
    let written = Instant::now();
    client.write_all(b"0123456789\r").expect("write");
    client
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    let reply =
        sim_shell_support::read_exact_within(&mut client, REPLY.len(), Duration::from_secs(2));
    assert_eq!(reply, REPLY);
    let got = arrivals.lock().unwrap().clone();
    assert_eq!(
        got.iter().map(|&(b, _)| b).collect::<Vec<_>>(),
        b"0123456789\r"
    );
    let bt = byte_time(19200);
    let first = got[0].1;
    assert!(
        first >= written + bt,
        "first byte arrived {:?} after the write",
        first - written
    );
    for pair in got.windows(2) {
        assert_eq!(pair[1].1 - pair[0].1, bt, "one byte time apart");
    }
    shell.shutdown();
}

#[test]
fn a_reply_is_handed_out_byte_by_byte_at_line_speed() {
    let _serial = serial();
    let (shell, mut client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
    client
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    // Taken before the write: a test thread descheduled after the write must
    // not make bytes look early.
    let started = Instant::now();
    client.write_all(REQUEST).expect("write");
    let mut seen = Vec::new();
    let mut buf = [0u8; 64];
    while seen.len() < REPLY.len() {
        let n = client.read(&mut buf).expect("read");
        let at = started.elapsed();
        for _ in 0..n {
            seen.push(at);
        }
    }
    // Byte k cannot be there before (4 + k + 1) byte times after the write.
    let bt = byte_time(19200);
    for (k, at) in seen.iter().enumerate() {
        let earliest = bt * (REQUEST.len() as u32) + bt * (k as u32 + 1);
        assert!(
            *at + Duration::from_micros(1) >= earliest,
            "byte {k} at {at:?}, due {earliest:?}"
        );
    }
    shell.shutdown();
}
