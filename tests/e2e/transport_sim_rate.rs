//! The whole I/O stack as the device task will use it: paced writer and async
//! reader on one side, the simulator shell on the other, over a socket pair
//! and over a pty. Fails only if a cycle beats the wire; prints the rate.

use crate::sim_shell_support;

use std::time::{Duration, Instant};

use crate::timing::serialised;
use jogterm::sim::shell::{PtyOptions, serve_pty, serve_socket};
use jogterm::transport::{self, Interleave, PortParts, PortSpec, WriterConfig};
use jogterm::wire::LineSettings;
use sim_shell_support::{LineAnswerer, REPLY, REQUEST};

const CYCLES: u32 = 100;

async fn poll_cycles(parts: &mut PortParts, label: &str) {
    let limit = LineSettings::new(19200).transfer_time(REQUEST.len() + REPLY.len());
    let floor = limit - Duration::from_nanos(50);
    let run = async |parts: &mut PortParts| {
        let t = Instant::now();
        parts
            .writer
            .send(REQUEST.to_vec(), Interleave::BetweenBytes)
            .expect("send");
        let mut got = Vec::new();
        while got.len() < REPLY.len() {
            let chunk = tokio::time::timeout(Duration::from_secs(2), parts.reader.read_chunk())
                .await
                .expect("reply in time")
                .expect("read");
            got.extend(chunk.bytes);
        }
        assert_eq!(got, REPLY);
        t.elapsed()
    };
    for _ in 0..3 {
        run(parts).await;
    }
    let start = Instant::now();
    let mut fastest = Duration::MAX;
    for i in 0..CYCLES {
        let took = run(parts).await;
        assert!(
            took >= floor,
            "cycle {i} took {took:?}, faster than the wire ({limit:?})"
        );
        fastest = fastest.min(took);
    }
    let average = start.elapsed() / CYCLES;
    println!(
        "{label} through the transport: average {:.3} ms, fastest {:.3} ms ({:.1} % of the wire rate {:.3} ms)",
        average.as_secs_f64() * 1e3,
        fastest.as_secs_f64() * 1e3,
        100.0 * limit.as_secs_f64() / average.as_secs_f64(),
        limit.as_secs_f64() * 1e3,
    );
    // Drain the writer's reports so none are left unread.
    while parts.events.try_recv().is_ok() {}
}

#[test]
fn poll_cycles_over_an_in_process_simulator() {
    serialised(async {
        let (shell, client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
        let port = transport::open(PortSpec::InProcess {
            stream: client,
            line: shell.line(),
            name: "sim".into(),
        })
        .expect("open");
        let mut parts = port.split(WriterConfig::default()).expect("split");
        poll_cycles(&mut parts, "socket pair").await;
    });
}

#[test]
fn poll_cycles_over_a_pty_simulator() {
    serialised(async {
        let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
        let port = transport::open(PortSpec::Serial {
            path: shell.slave_path().expect("slave"),
            line: shell.line(),
        })
        .expect("open");
        let mut parts = port.split(WriterConfig::default()).expect("split");
        poll_cycles(&mut parts, "pty").await;
    });
}
