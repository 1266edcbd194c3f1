//! Opening ports and reading from them: data, a vanished port as `LinkLost`,
//! and the errors of `open` naming the port.

use std::io::Write;
use std::os::unix::net::UnixStream;
use std::pin::pin;
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use jogterm::transport::{self, PortParts, PortSpec, TransportError, WriterConfig};
use jogterm::wire::LineSettings;
use serialport::SerialPort;

use crate::timing::block_on;

fn socket_parts() -> (PortParts, UnixStream) {
    let (ours, theirs) = UnixStream::pair().expect("socketpair");
    let port = transport::open(PortSpec::InProcess {
        stream: ours,
        line: LineSettings::new(19200),
        name: "sim:test".into(),
    })
    .expect("open");
    assert_eq!(port.name(), "sim:test");
    assert_eq!(port.line(), LineSettings::new(19200));
    (port.split(WriterConfig::default()).expect("split"), theirs)
}

#[tokio::test]
async fn reads_bytes_with_timestamps() {
    let (mut parts, mut peer) = socket_parts();
    peer.write_all(b"0\r").expect("write");
    let chunk = tokio::time::timeout(Duration::from_secs(2), parts.reader.read_chunk())
        .await
        .expect("in time")
        .expect("read");
    assert_eq!(chunk.bytes, b"0\r");
    assert_eq!(chunk.traffic().readable(), "<< 0<CR>");
}

#[tokio::test]
async fn a_closed_socket_peer_is_link_lost_and_stays_so() {
    let (mut parts, peer) = socket_parts();
    drop(peer);
    let mut buf = [0u8; 16];
    for _ in 0..2 {
        let err = tokio::time::timeout(Duration::from_secs(2), parts.reader.read(&mut buf))
            .await
            .expect("in time")
            .expect_err("link lost");
        assert!(err.is_link_lost(), "{err}");
        assert!(err.to_string().starts_with("sim:test: link lost"), "{err}");
    }
}

#[tokio::test]
async fn data_sent_before_the_peer_closed_is_read_before_link_lost() {
    let (mut parts, mut peer) = socket_parts();
    peer.write_all(b"last words").expect("write");
    drop(peer);
    let mut got = Vec::new();
    let mut buf = [0u8; 4];
    let err = loop {
        match parts.reader.read(&mut buf).await {
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) => break e,
        }
    };
    assert_eq!(got, b"last words");
    assert!(err.is_link_lost());
}

#[test]
fn a_closed_pty_master_is_link_lost() {
    block_on(async {
        let (master, slave) = jogterm::sim::pty::pty_pair().expect("pty");
        let path = slave.name().expect("slave path");
        drop(slave);
        let port = transport::open(PortSpec::Serial {
            path: path.clone().into(),
            line: LineSettings::new(19200),
        })
        .expect("open slave");
        let mut parts = port.split(WriterConfig::default()).expect("split");
        drop(master);
        let mut buf = [0u8; 16];
        let err = tokio::time::timeout(Duration::from_secs(2), parts.reader.read(&mut buf))
            .await
            .expect("in time")
            .expect_err("link lost");
        assert!(err.is_link_lost(), "{err}");
        assert!(err.to_string().starts_with(&path), "{err}");
    });
}

#[test]
fn opening_a_missing_port_says_not_found() {
    let err = transport::open(PortSpec::Serial {
        path: "/dev/ttyDOES-NOT-EXIST".into(),
        line: LineSettings::new(19200),
    })
    .expect_err("missing");
    assert!(matches!(err, TransportError::NotFound { .. }), "{err:?}");
    assert_eq!(err.to_string(), "/dev/ttyDOES-NOT-EXIST: no such port");
}

#[test]
fn opening_a_port_twice_says_busy() {
    let (_master, slave) = jogterm::sim::pty::pty_pair().expect("pty");
    let path = slave.name().expect("slave path");
    drop(slave);
    let spec = || PortSpec::Serial {
        path: path.clone().into(),
        line: LineSettings::new(19200),
    };
    let first = transport::open(spec()).expect("first open");
    let err = transport::open(spec()).expect_err("second open");
    assert!(matches!(err, TransportError::Busy { .. }), "{err:?}");
    assert!(err.to_string().contains("busy"), "{err}");
    drop(first);
    // Other tests of this process spawn children all the time; a child
    // forked while `first` was open holds a copy of its descriptor (and so
    // the flock) until it execs and close-on-exec drops it: that window is
    // short but real, so the port is free again within a bounded time.
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    loop {
        match transport::open(spec()) {
            Ok(_) => break,
            Err(TransportError::Busy { .. }) if std::time::Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("free again after close: {e:?}"),
        }
    }
}

#[test]
fn a_file_that_is_not_a_terminal_cannot_be_opened_as_a_port() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("plain");
    std::fs::write(&path, b"").expect("file");
    let err = transport::open(PortSpec::Serial {
        path: path.clone(),
        line: LineSettings::new(19200),
    })
    .expect_err("not a tty");
    assert!(matches!(err, TransportError::Open { .. }), "{err:?}");
    assert!(err.to_string().starts_with(&path.display().to_string()));
}

#[test]
fn reading_outside_a_tokio_runtime_is_an_error_not_a_panic() {
    let (mut parts, _peer) = socket_parts();
    let mut buf = [0u8; 4];
    let mut fut = pin!(parts.reader.read(&mut buf));
    let mut cx = Context::from_waker(Waker::noop());
    match fut.as_mut().poll(&mut cx) {
        Poll::Ready(Err(TransportError::NoRuntime { port })) => assert_eq!(port, "sim:test"),
        other => panic!("{other:?}"),
    }
}
