//! What sits between jogterm and the serial line on the network paths
//! (`docs/network.md`, "What can sit between jogterm and the line"): the
//! paced writer streams isel queries to the isel simulator's pty, tightly
//! paced (as while polling or jogging) and bulk paced (as while uploading),
//! and every 150 ms a stop (0xFD) is asked for; the delay from the request
//! to the stop byte read by the simulator from its line (`show received
//! times`, the simulator's own clock) is everything that was queued in
//! front of it plus the path. Links: the pty directly (the baseline), the
//! simulator served on TCP in-process (`sim --tcp`), and the real ser2net
//! in front of the pty, raw and RFC 2217.
//!
//! `cargo bench --bench network` (needs ser2net: `apt-get install ser2net`);
//! `-- --quick` for fewer stops.
//!
//! `-- --stall` (as root, in a network namespace of its own: `unshare -n
//! target/release/deps/network-… --stall`): the network stalls for 300 ms
//! while queries stream to `sim --tcp` (a `tc` token bucket on the
//! namespace's loopback that drops every packet; retransmissions, no
//! acknowledgements), a stop is asked for 250 ms into it; how many bytes
//! were ahead of the stop, with the bound on unacknowledged bytes
//! (`NetOptions::unacknowledged`) and without it.
//!
//! Hand-written, not on divan: real-time stop latency through real sockets
//! (and ser2net), and bytes queued during a stall in a network namespace;
//! percentiles of single events, not a function timed in a loop.

// Bench code: a failed unwrap, expect or panic is the run failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant, SystemTime};

use jogterm::config::{ConfigDirs, load_profile};
use jogterm::proto::Protocol;
use jogterm::sim::registry;
use jogterm::sim::shell::{PtyOptions, Shell, serve_pty, serve_tcp};
use jogterm::transport::{self, Interleave, NetOptions, PortSpec, WriterConfig, WriterEvent};
use jogterm::wire::LineSettings;

const BAUD: u32 = 19200;

fn isel_sim() -> Box<dyn jogterm::sim::SimDevice> {
    let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("isel profile");
    registry::build(Protocol::Isel, &profile).expect("isel simulator")
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// ser2net with a raw and an RFC 2217 accepter in front of `device`.
fn ser2net(device: &Path, dir: &Path) -> (Child, u16, u16) {
    let (raw, rfc) = (free_port(), free_port());
    let config = format!(
        "%YAML 1.1\n---\nconnection: &raw\n  accepter: tcp,127.0.0.1,{raw}\n  \
         connector: serialdev,{dev},{BAUD}n81,local\n\
         connection: &rfc\n  accepter: telnet(rfc2217),tcp,127.0.0.1,{rfc}\n  \
         connector: serialdev,{dev},{BAUD}n81,local\n",
        dev = device.display()
    );
    let path = dir.join("ser2net.yaml");
    std::fs::write(&path, config).expect("config");
    let child = Command::new("ser2net")
        .args(["-n", "-c"])
        .arg(&path)
        .arg("-P")
        .arg(dir.join("pid"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| {
            eprintln!("network bench: ser2net is needed (apt-get install ser2net): {e}");
            std::process::exit(1)
        });
    // Listening within a second on an idle machine.
    thread::sleep(Duration::from_millis(1000));
    (child, raw, rfc)
}

struct Figures {
    link: &'static str,
    pace: &'static str,
    delays: Vec<Duration>,
    /// Most bytes still on their way when a stop was asked for.
    ahead: usize,
}

/// Stream queries on `spec` and ask for `stops` stops; the delay of each,
/// read from the simulator's record.
fn measure(address: &str, shell: &Shell, bulk: bool, stops: usize) -> Vec<(Duration, usize)> {
    // ser2net lets go of the device a moment after the last client left.
    let end = Instant::now() + Duration::from_secs(5);
    let port = loop {
        match transport::open(spec_for(address)) {
            Ok(port) => break port,
            Err(e) if Instant::now() < end => {
                eprintln!("network bench: {e}; again");
                thread::sleep(Duration::from_millis(200));
            }
            Err(e) => panic!("{e}"),
        }
    };
    let mut parts = port.split(WriterConfig::default()).expect("split");
    // Replies are read and dropped, so nothing piles up unread.
    let mut reader = parts.reader;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let reading = {
        let done = done.clone();
        thread::spawn(move || {
            rt.block_on(async {
                while !done.load(std::sync::atomic::Ordering::Relaxed) {
                    let _ =
                        tokio::time::timeout(Duration::from_millis(50), reader.read_chunk()).await;
                }
            })
        })
    };
    let before = shell.control().received().expect("received").total;
    let mut asked = Vec::new();
    for _ in 0..stops {
        // Keep the queue full: a second of queries in front of the writer.
        for _ in 0..48 {
            let q = b"@0P\r".to_vec();
            let _ = if bulk {
                parts.writer.send_bulk(q, Interleave::BetweenBytes)
            } else {
                parts.writer.send(q, Interleave::BetweenBytes)
            };
        }
        thread::sleep(Duration::from_millis(150));
        asked.push(SystemTime::now());
        parts.writer.stop(vec![0xFD]).expect("stop");
        parts.writer.cancel_queued().expect("cancel");
        while let Ok(e) = parts.events.try_recv() {
            if let WriterEvent::Failed(e) = e {
                panic!("{e}");
            }
        }
    }
    thread::sleep(Duration::from_millis(300));
    done.store(true, std::sync::atomic::Ordering::Relaxed);
    parts.writer.close();
    let _ = reading.join();
    // Each 0xFD read after `before`, in order, belongs to the next stop;
    // the bytes read after the stop was asked for and before the 0xFD were
    // still on their way (writer, socket, server, pty) when it was.
    let timed = timed_bytes(shell, before);
    let mut out = Vec::new();
    let mut from = 0;
    for asked_at in asked {
        let Some(p) = timed[from..].iter().position(|(b, _)| *b == 0xFD) else {
            break;
        };
        let (_, arrived) = timed[from + p];
        let ahead = timed[from..from + p]
            .iter()
            .filter(|(_, at)| *at >= asked_at)
            .count();
        out.push((arrived.duration_since(asked_at).unwrap_or_default(), ahead));
        from += p + 1;
    }
    out
}

/// Stream 4000 bytes of queries bulk paced (as an upload) and time them
/// until the simulator has read the last: the fraction of the wire limit.
fn throughput(address: &str, shell: &Shell) -> f64 {
    let end = Instant::now() + Duration::from_secs(5);
    let port = loop {
        match transport::open(spec_for(address)) {
            Ok(port) => break port,
            Err(e) if Instant::now() < end => {
                eprintln!("network bench: {e}; again");
                thread::sleep(Duration::from_millis(200));
            }
            Err(e) => panic!("{e}"),
        }
    };
    let parts = port.split(WriterConfig::default()).expect("split");
    let before = shell.control().received().expect("received").total;
    let start = Instant::now();
    for _ in 0..1000 {
        let _ = parts
            .writer
            .send_bulk(b"@0P\r".to_vec(), Interleave::BetweenBytes);
    }
    while shell.control().received().expect("received").total < before + 4000 {
        thread::sleep(Duration::from_millis(2));
    }
    let took = start.elapsed();
    drop(parts);
    LineSettings::new(BAUD).transfer_time(4000).as_secs_f64() / took.as_secs_f64()
}

/// Every byte the simulator read since it had read `before` bytes, with
/// the time of the read that brought it.
fn timed_bytes(shell: &Shell, before: u64) -> Vec<(u8, SystemTime)> {
    let received = shell.control().received().expect("received");
    let first_kept = received.not_kept();
    let mut timed: Vec<(u8, SystemTime)> = Vec::new();
    for (i, (offset, at)) in received.reads.iter().enumerate() {
        let end = received
            .reads
            .get(i + 1)
            .map_or(received.total, |(n, _)| *n);
        if end <= before {
            continue;
        }
        let bytes = received
            .bytes
            .get((offset - first_kept) as usize..(end - first_kept) as usize)
            .unwrap_or_default();
        timed.extend(bytes.iter().map(|b| (*b, *at)));
    }
    timed
}

fn spec_for(address: &str) -> PortSpec {
    PortSpec::from_address(address, LineSettings::new(BAUD)).expect("address")
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted.get(i).copied().unwrap_or_default()
}

fn tc(args: &str) {
    let ok = Command::new("tc")
        .args(args.split_whitespace())
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "tc {args} failed: run --stall as root in `unshare -n`");
}

/// Queries stream tightly paced to `shell` over TCP; the network stalls
/// for 300 ms; a stop is asked for 250 ms into it. Bytes ahead of the
/// stop, and its delay.
fn stall_once(shell: &Shell, options: NetOptions) -> (usize, Duration) {
    let PortSpec::Network { target, line, .. } =
        spec_for(&format!("tcp://{}", shell.tcp_addr().expect("addr")))
    else {
        unreachable!("a tcp:// address")
    };
    let port = transport::open(PortSpec::Network {
        target,
        line,
        options,
    })
    .expect("open");
    let parts = port.split(WriterConfig::default()).expect("split");
    let before = shell.control().received().expect("received").total;
    for _ in 0..400 {
        let _ = parts
            .writer
            .send(b"@0P\r".to_vec(), Interleave::BetweenBytes);
    }
    thread::sleep(Duration::from_millis(100));
    // Every packet is larger than the bucket: all are dropped.
    tc("qdisc add dev lo root tbf rate 8bit burst 10 latency 1ms");
    thread::sleep(Duration::from_millis(250));
    let asked = SystemTime::now();
    parts.writer.stop(vec![0xFD]).expect("stop");
    parts.writer.cancel_queued().expect("cancel");
    thread::sleep(Duration::from_millis(50));
    tc("qdisc del dev lo root");
    thread::sleep(Duration::from_millis(1500));
    let timed = timed_bytes(shell, before);
    let p = timed
        .iter()
        .position(|(b, _)| *b == 0xFD)
        .expect("the stop arrived");
    let ahead = timed[..p].iter().filter(|(_, at)| *at >= asked).count();
    let delay = timed[p].1.duration_since(asked).unwrap_or_default();
    drop(parts);
    (ahead, delay)
}

fn stall() {
    let shell = serve_tcp(isel_sim(), "127.0.0.1:0".parse().expect("addr")).expect("tcp");
    let bounded = NetOptions::default();
    let unbounded = NetOptions {
        unacknowledged: Duration::from_secs(100),
        ..NetOptions::default()
    };
    let byte = LineSettings::new(BAUD).byte_time();
    println!(
        "a 300 ms network stall while streaming @0P at {BAUD} baud; a stop asked for 250 ms into it"
    );
    println!(
        "{:<34} {:>14} {:>18} {:>14}",
        "unacknowledged bound", "bytes ahead", "their wire time", "stop delay"
    );
    for (name, options) in [
        (
            format!(
                "{} bytes ({} ms, default)",
                bounded.queue_limit(LineSettings::new(BAUD)),
                bounded.unacknowledged.as_millis()
            ),
            bounded,
        ),
        ("none (socket buffer only)".to_owned(), unbounded),
    ] {
        for _ in 0..3 {
            let (ahead, delay) = stall_once(&shell, options);
            println!(
                "{:<34} {:>14} {:>15.1} ms {:>11.1} ms",
                name,
                ahead,
                (byte * ahead as u32).as_secs_f64() * 1000.0,
                delay.as_secs_f64() * 1000.0
            );
        }
    }
}

fn main() {
    if std::env::args().any(|a| a == "--stall") {
        stall();
        return;
    }
    let quick = std::env::args().any(|a| a == "--quick");
    let stops = if quick { 10 } else { 40 };
    let dir = tempfile::tempdir().expect("dir");
    let link = dir.path().join("ttyisel");
    let pty = serve_pty(
        isel_sim(),
        PtyOptions {
            link: Some(link.clone()),
        },
    )
    .expect("pty");
    let tcp = serve_tcp(isel_sim(), "127.0.0.1:0".parse().expect("addr")).expect("tcp");
    let tcp_url = format!("tcp://{}", tcp.tcp_addr().expect("addr"));
    let (mut s2n, raw, rfc) = ser2net(&link, dir.path());
    let links: [(&str, String, &Shell); 4] = [
        ("pty (baseline)", link.display().to_string(), &pty),
        ("sim --tcp", tcp_url, &tcp),
        ("ser2net raw", format!("tcp://127.0.0.1:{raw}"), &pty),
        (
            "ser2net rfc2217",
            format!("rfc2217://127.0.0.1:{rfc}"),
            &pty,
        ),
    ];
    let mut rows = Vec::new();
    for (name, address, shell) in &links {
        for (pace, bulk) in [("tight", false), ("bulk", true)] {
            let measured = measure(address, shell, bulk, stops);
            let ahead = measured.iter().map(|(_, a)| *a).max().unwrap_or(0);
            let mut delays: Vec<Duration> = measured.into_iter().map(|(d, _)| d).collect();
            delays.sort();
            rows.push(Figures {
                link: name,
                pace,
                delays,
                ahead,
            });
        }
    }
    let rates: Vec<(&str, f64)> = links
        .iter()
        .map(|(name, address, shell)| (*name, throughput(address, shell)))
        .collect();
    // SIGTERM: ser2net removes its lock files as it ends.
    if let Ok(pid) = libc::pid_t::try_from(s2n.id()) {
        // SAFETY: a signal to the child this bench started.
        unsafe {
            libc::kill(pid, libc::SIGTERM);
        }
    }
    let _ = s2n.wait();
    let byte = LineSettings::new(BAUD).byte_time();
    println!(
        "stop request -> 0xFD read by the simulator, while streaming @0P at {BAUD} baud \
         (one byte: {byte:?}); {stops} stops each"
    );
    println!(
        "{:<18} {:<6} {:>10} {:>10} {:>10} {:>10} {:>14}",
        "link", "pace", "min", "median", "p95", "max", "bytes ahead"
    );
    for r in &rows {
        let ms = |d: Duration| format!("{:.2} ms", d.as_secs_f64() * 1000.0);
        println!(
            "{:<18} {:<6} {:>10} {:>10} {:>10} {:>10} {:>14}",
            r.link,
            r.pace,
            ms(percentile(&r.delays, 0.0)),
            ms(percentile(&r.delays, 0.5)),
            ms(percentile(&r.delays, 0.95)),
            ms(percentile(&r.delays, 1.0)),
            format!("{} (max)", r.ahead),
        );
    }
    println!("\n4000 bytes of @0P bulk paced (an upload's pace): share of the wire limit");
    for (name, rate) in rates {
        println!("{name:<18} {:>6.1} %", rate * 100.0);
    }
}
