//! The network transport below the commands (`docs/network.md`): the RFC
//! 2217 negotiation against a server this test runs (a small one built on
//! jogterm's own Telnet decoder, recording every byte), the writer's
//! escaping and its PURGE-DATA rule, the reader stripping the server's
//! notifications, the emergency handle over TCP; and the device task
//! reconnecting a port that vanished and came back, by a by-id style link
//! and by a serial port server's address, with the stop first.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use jogterm::device::api::{Event, LinkState};
use jogterm::device::isel::{IselDriver, PollRate};
use jogterm::device::{Connector, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use jogterm::sim::fault::Fault;
use jogterm::sim::registry;
use jogterm::sim::shell::{PtyOptions, serve_pty, serve_tcp};
use jogterm::traffic::Direction;
use jogterm::transport::rfc2217::{PURGE_DATA, SET_BAUDRATE, purge_transmit};
use jogterm::transport::telnet::{self, Command, DO, IAC, OPT_BINARY, OPT_COM_PORT, WILL};
use jogterm::transport::{self, Interleave, NetOptions, PortSpec, WriterConfig, WriterEvent};
use jogterm::wire::LineSettings;

use crate::device_support;
use device_support::{profile, settings};

/// An RFC 2217 server: agrees to COM-PORT-OPTION, answers every setting
/// with what was asked (as ser2net does), sends a modem-state notification
/// and `data_first` before anything else, and records the serial bytes it
/// received (Telnet undone) and every COM-PORT request.
struct Server {
    addr: std::net::SocketAddr,
    serial: Arc<Mutex<Vec<u8>>>,
    requests: Arc<Mutex<Vec<Vec<u8>>>>,
    /// Everything as it came off the socket.
    raw: Arc<Mutex<Vec<u8>>>,
}

impl Server {
    fn start(answer_to_client: &'static [u8]) -> Server {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        let serial = Arc::new(Mutex::new(Vec::new()));
        let requests = Arc::new(Mutex::new(Vec::new()));
        let raw = Arc::new(Mutex::new(Vec::new()));
        let (s, r, w) = (serial.clone(), requests.clone(), raw.clone());
        thread::spawn(move || {
            let Ok((mut stream, _)) = listener.accept() else {
                return;
            };
            // Binary both ways (RFC 856) and the COM port option, as
            // ser2net offers them.
            let _ = stream.write_all(&[
                IAC,
                WILL,
                OPT_BINARY,
                IAC,
                DO,
                OPT_BINARY,
                IAC,
                DO,
                OPT_COM_PORT,
            ]);
            let mut decoder = telnet::Decoder::new();
            let mut buf = [0u8; 512];
            let mut greeted = false;
            while let Ok(n) = stream.read(&mut buf) {
                if n == 0 {
                    break;
                }
                w.lock().expect("raw").extend_from_slice(&buf[..n]);
                let (mut data, mut commands) = (Vec::new(), Vec::new());
                decoder.feed(&buf[..n], &mut data, &mut commands);
                s.lock().expect("serial").extend_from_slice(&data);
                for c in commands {
                    if let Command::Subnegotiation {
                        option: OPT_COM_PORT,
                        payload,
                        ..
                    } = c
                    {
                        let mut answer = payload.clone();
                        if let Some(code) = answer.first_mut() {
                            *code += 100;
                        }
                        let _ = stream.write_all(&telnet::subnegotiation(OPT_COM_PORT, &answer));
                        r.lock().expect("requests").push(payload);
                    }
                }
                if !greeted && !s.lock().expect("serial").is_empty() {
                    greeted = true;
                    // The first serial bytes came (the port is jogterm's):
                    // a notification, then the controller's answer with an
                    // escaped 0xFF in it.
                    let _ = stream.write_all(&telnet::subnegotiation(OPT_COM_PORT, &[107, 0x30]));
                    let _ = stream.write_all(answer_to_client);
                }
            }
        });
        Server {
            addr,
            serial,
            requests,
            raw,
        }
    }

    fn url(&self) -> String {
        format!("rfc2217://{}", self.addr)
    }

    fn serial(&self) -> Vec<u8> {
        self.serial.lock().expect("serial").clone()
    }

    fn raw(&self) -> Vec<u8> {
        self.raw.lock().expect("raw").clone()
    }
}

fn wait_until(what: &str, done: impl Fn() -> bool) {
    let end = Instant::now() + Duration::from_secs(10);
    while !done() {
        if Instant::now() > end {
            panic!("never: {what}");
        }
        thread::sleep(Duration::from_millis(5));
    }
}

fn spec(url: &str, baud: u32, purge: bool) -> PortSpec {
    let PortSpec::Network { target, line, .. } =
        PortSpec::from_address(url, LineSettings::new(baud)).expect("address")
    else {
        panic!("{url} is a network address");
    };
    PortSpec::Network {
        target,
        line,
        options: NetOptions {
            purge_before_stop: purge,
            refusal_window: Duration::from_millis(20),
            ..NetOptions::default()
        },
    }
}

/// Wait until message `id` is reported written whole.
fn written(
    events: &mut tokio::sync::mpsc::UnboundedReceiver<WriterEvent>,
    id: transport::MessageId,
) {
    let end = Instant::now() + Duration::from_secs(5);
    loop {
        match events.try_recv() {
            Ok(WriterEvent::Written(c)) if c.id == id && c.done => return,
            Ok(WriterEvent::Failed(e)) => panic!("{e}"),
            Ok(_) => {}
            Err(_) => {
                assert!(Instant::now() < end, "message never written");
                thread::sleep(Duration::from_micros(200));
            }
        }
    }
}

#[tokio::test]
async fn rfc2217_sets_the_line_escapes_both_ways_and_purges_only_before_an_isel_stop() {
    // The controller's answer `0`, an escaped 0xFF, `1`.
    let server = Server::start(&[b'0', IAC, IAC, b'1']);
    let port = transport::open(spec(&server.url(), 38400, true)).expect("negotiated");
    assert_eq!(port.name(), server.url());
    let requests = server.requests.lock().expect("requests").clone();
    assert_eq!(
        requests.first().map(Vec::as_slice),
        Some(&[SET_BAUDRATE, 0, 0, 0x96, 0][..]),
        "38400 baud asked first: {requests:?}"
    );
    assert!(requests.contains(&vec![2, 8]) && requests.contains(&vec![3, 1]));
    assert!(requests.contains(&vec![4, 1]) && requests.contains(&vec![5, 1]));

    let mut parts = port.split(WriterConfig::default()).expect("split");
    // isel (a stop may go between any bytes): after a message written
    // whole, PURGE-DATA goes right before the stop; 0xFF goes doubled.
    let id = parts
        .writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    written(&mut parts.events, id);
    // The reader hands over serial bytes only: the notification is gone,
    // IAC IAC is one 0xFF.
    let mut got = Vec::new();
    while got.len() < 3 {
        let chunk = tokio::time::timeout(Duration::from_secs(5), parts.reader.read_chunk())
            .await
            .expect("data in time")
            .expect("read");
        got.extend(chunk.bytes);
    }
    assert_eq!(got, [b'0', 0xFF, b'1']);

    let stop = parts.writer.stop(vec![0xFD, 0xFF]).expect("stop");
    written(&mut parts.events, stop);
    // EMCU-like frames: never a purge (it could cut the frame the stop
    // frame follows).
    let id = parts
        .writer
        .send(b"@X\r".to_vec(), Interleave::WholeMessage)
        .expect("send");
    written(&mut parts.events, id);
    let stop = parts.writer.stop(b"@B\r".to_vec()).expect("stop");
    written(&mut parts.events, stop);
    let mut want = b"@0P\r".to_vec();
    want.extend(purge_transmit());
    want.extend([0xFD, 0xFF, 0xFF]);
    want.extend(b"@X\r@B\r");
    wait_until("everything at the server", || server.raw().ends_with(&want));
    assert_eq!(server.serial(), b"@0P\r\xFD\xFF@X\r@B\r");
    assert_eq!(
        server
            .requests
            .lock()
            .expect("requests")
            .last()
            .map(Vec::as_slice),
        Some(&[PURGE_DATA, 2][..])
    );

    // The emergency handle escapes too, and waits for the acknowledgement.
    parts.emergency.write_now(&[0xFF]).expect("emergency");
    wait_until("the emergency byte", || {
        server.raw().ends_with(&[0xFF, 0xFF])
    });
}

#[tokio::test]
async fn without_purge_before_stop_the_stop_follows_the_message_directly() {
    let server = Server::start(b"");
    let port = transport::open(spec(&server.url(), 19200, false)).expect("negotiated");
    let mut parts = port.split(WriterConfig::default()).expect("split");
    let id = parts
        .writer
        .send(b"@0P\r".to_vec(), Interleave::BetweenBytes)
        .expect("send");
    written(&mut parts.events, id);
    let stop = parts.writer.stop(vec![0xFD]).expect("stop");
    written(&mut parts.events, stop);
    wait_until("the stop", || server.serial().ends_with(b"@0P\r\xFD"));
    assert!(
        !server
            .requests
            .lock()
            .expect("requests")
            .iter()
            .any(|r| r.first() == Some(&PURGE_DATA)),
        "the default sends no PURGE-DATA"
    );
}

#[test]
fn a_server_that_sets_another_baud_rate_is_refused_with_why() {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr");
    thread::spawn(move || {
        let (mut s, _) = listener.accept().expect("accept");
        let _ = s.write_all(&[IAC, DO, OPT_COM_PORT]);
        let mut buf = [0u8; 256];
        let _ = s.read(&mut buf);
        let _ = s.write_all(&telnet::subnegotiation(
            OPT_COM_PORT,
            &[101, 0, 0, 0x25, 0x80],
        ));
        thread::sleep(Duration::from_millis(500));
    });
    let err =
        transport::open(spec(&format!("rfc2217://{addr}"), 19200, false)).expect_err("wrong baud");
    assert!(err.to_string().contains("9600 baud, not 19200"), "{err}");
}

async fn wait_event(
    events: &mut jogterm::device::EventReceiver,
    seen: &mut Vec<Event>,
    what: &str,
    pred: impl Fn(&Event) -> bool,
) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
    loop {
        match tokio::time::timeout_at(deadline, events.recv()).await {
            Ok(Some(e)) => {
                let hit = pred(&e);
                seen.push(e);
                if hit {
                    return;
                }
            }
            Ok(None) => panic!("the device task ended while waiting for {what}"),
            Err(_) => panic!("no {what} within 15 s: {seen:?}"),
        }
    }
}

/// The device task on `connector` through a vanishing line: connected,
/// the line closed and brought back after 300 ms, connected again; the
/// first bytes after the reconnect are the stop.
async fn reconnects_with_the_stop_first(connector: Connector, shell: &jogterm::sim::shell::Shell) {
    let (handle, mut events) = spawn_with(
        Box::new(IselDriver::new(settings(PollRate::LineSpeed))),
        connector,
        TaskOptions::default(),
    )
    .expect("task");
    let mut seen = Vec::new();
    let connected = |e: &Event| matches!(e, Event::Link(LinkState::Connected));
    wait_event(&mut events, &mut seen, "the link", connected).await;
    shell
        .control()
        .fault(Fault::Close {
            reopen_after: Some(Duration::from_millis(300)),
        })
        .expect("close");
    wait_event(&mut events, &mut seen, "the loss", |e| {
        matches!(e, Event::Link(LinkState::Lost { .. }))
    })
    .await;
    let from = seen.len();
    wait_event(&mut events, &mut seen, "the reconnect", connected).await;
    wait_event(
        &mut events,
        &mut seen,
        "traffic",
        |e| matches!(e, Event::Traffic(r) if r.direction == Direction::Sent),
    )
    .await;
    let after = device_support::sent_after(&seen, from);
    assert_eq!(
        after.first().map(String::as_str),
        Some("<FD><FF>"),
        "{after:?}"
    );
    handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_port_by_a_by_id_style_link_is_reconnected_after_a_replug_with_the_stop_first() {
    let dir = tempfile::tempdir().expect("dir");
    let link = dir.path().join("ttyUSB-sim");
    let device = registry::build(Protocol::Isel, &profile()).expect("sim");
    let shell = serve_pty(
        device,
        PtyOptions {
            link: Some(link.clone()),
        },
    )
    .expect("pty");
    // /dev/serial/by-id/… is a link to ../../ttyUSB0, which udev makes
    // again when the adapter comes back: here a link to the link.
    let by_id = dir.path().join("by-id");
    std::fs::create_dir(&by_id).expect("dir");
    let name = by_id.join("usb-jogterm_sim_isel-if00-port0");
    std::os::unix::fs::symlink("../ttyUSB-sim", &name).expect("link");
    let spec = PortSpec::from_address(&name.display().to_string(), shell.line()).expect("path");
    reconnects_with_the_stop_first(Connector::from(spec), &shell).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_serial_port_server_that_drops_the_line_is_reconnected_with_the_stop_first() {
    let device = registry::build(Protocol::Isel, &profile()).expect("sim");
    let shell = serve_tcp(device, "127.0.0.1:0".parse().expect("addr")).expect("tcp");
    let url = format!("tcp://{}", shell.tcp_addr().expect("addr"));
    let spec = PortSpec::from_address(&url, shell.line()).expect("url");
    reconnects_with_the_stop_first(Connector::from(spec), &shell).await;
    // Nobody is connected any more: the next client is taken.
    let mut s = TcpStream::connect(shell.tcp_addr().expect("addr")).expect("connect");
    s.write_all(b"@0P\r").expect("write");
    s.set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let mut buf = [0u8; 1];
    s.read_exact(&mut buf).expect("an answer");
}
