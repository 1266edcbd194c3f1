//! Each fault does what `docs/simulator.md` says, seen from a client.

use crate::sim_shell_support;
use crate::timing::block_on;

use std::io::Write;
use std::os::unix::net::UnixStream;
use std::time::{Duration, Instant};

use jogterm::sim::InputControl;
use jogterm::sim::fault::{ByteIndex, Fault};
use jogterm::sim::shell::{PtyOptions, Shell, ShellError, serve_pty, serve_socket};
use jogterm::transport::{self, PortSpec, WriterConfig};
use jogterm::wire::LineSettings;
use serialport::SerialPort;
use sim_shell_support::{LineAnswerer, REPLY, REQUEST, cycle, read_exact_within, read_for};

fn socket_shell() -> (Shell, UnixStream) {
    let (shell, client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
    client
        .set_read_timeout(Some(Duration::from_millis(20)))
        .expect("timeout");
    (shell, client)
}

#[test]
fn drop_byte_leaves_out_the_middle_byte_of_the_next_reply_only() {
    let (shell, mut client) = socket_shell();
    shell
        .control()
        .fault(Fault::DropByte(ByteIndex::Middle))
        .expect("fault");
    let got = cycle(&mut client, REQUEST, REPLY.len() - 1);
    let mut expected = REPLY.to_vec();
    expected.remove(REPLY.len() / 2);
    assert_eq!(got, expected);
    assert!(
        read_for(&mut client, Duration::from_millis(30)).is_empty(),
        "nothing else"
    );
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY, "one-shot");
}

#[test]
fn drop_byte_at_an_index_past_the_end_drops_the_last_byte() {
    let (shell, mut client) = socket_shell();
    shell
        .control()
        .fault(Fault::DropByte(ByteIndex::At(1000)))
        .expect("fault");
    let got = cycle(&mut client, REQUEST, REPLY.len() - 1);
    assert_eq!(got, &REPLY[..REPLY.len() - 1]);
}

#[test]
fn corrupt_byte_flips_bit_seven_of_the_chosen_byte() {
    let (shell, mut client) = socket_shell();
    shell
        .control()
        .fault(Fault::CorruptByte(ByteIndex::At(3)))
        .expect("fault");
    let got = cycle(&mut client, REQUEST, REPLY.len());
    let mut expected = REPLY.to_vec();
    expected[3] ^= 0x80;
    assert_eq!(got, expected);
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY, "one-shot");
}

#[test]
fn withhold_swallows_exactly_the_next_reply() {
    let (shell, mut client) = socket_shell();
    shell.control().fault(Fault::Withhold).expect("fault");
    client.write_all(REQUEST).expect("write");
    assert!(read_for(&mut client, Duration::from_millis(40)).is_empty());
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
    assert!(
        shell
            .control()
            .show()
            .expect("show")
            .contains("withheld 1 messages")
    );
}

#[test]
fn delay_holds_the_next_reply_back_by_that_long() {
    let (shell, mut client) = socket_shell();
    shell
        .control()
        .fault(Fault::Delay(Duration::from_millis(200)))
        .expect("fault");
    let t = Instant::now();
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
    let wire = LineSettings::new(19200).transfer_time(REQUEST.len() + REPLY.len());
    assert!(
        t.elapsed() >= wire + Duration::from_millis(200),
        "{:?}",
        t.elapsed()
    );
    let t = Instant::now();
    cycle(&mut client, REQUEST, REPLY.len());
    assert!(
        t.elapsed() < Duration::from_millis(200),
        "one-shot: {:?}",
        t.elapsed()
    );
}

#[test]
fn garbage_is_sent_at_once_as_text_or_hex() {
    let (shell, mut client) = socket_shell();
    let control = shell.control();
    let t = Instant::now();
    control
        .fault(Fault::Garbage(b"?!".to_vec()))
        .expect("fault");
    assert_eq!(
        read_exact_within(&mut client, 2, Duration::from_secs(1)),
        b"?!"
    );
    assert!(t.elapsed() >= LineSettings::new(19200).transfer_time(2));
    control
        .fault(Fault::Garbage(vec![0x00, 0xFF, 0x1A]))
        .expect("fault");
    assert_eq!(
        read_exact_within(&mut client, 3, Duration::from_secs(1)),
        [0x00, 0xFF, 0x1A]
    );
    // Garbage is not a device message: a fault armed for the next message
    // still waits for the device's reply.
    control.fault(Fault::Withhold).expect("fault");
    control.fault(Fault::Garbage(b"x".to_vec())).expect("fault");
    assert_eq!(
        read_exact_within(&mut client, 1, Duration::from_secs(1)),
        b"x"
    );
    client.write_all(REQUEST).expect("write");
    assert!(
        read_for(&mut client, Duration::from_millis(40)).is_empty(),
        "reply withheld"
    );
}

#[test]
fn the_shell_keeps_what_the_device_received() {
    let (shell, mut client) = socket_shell();
    let control = shell.control();
    assert_eq!(control.received().expect("received").total, 0);
    cycle(&mut client, REQUEST, REPLY.len());
    client.write_all(&[0xFD, 0xFF]).expect("write");
    client.write_all(REQUEST).expect("write");
    read_exact_within(&mut client, REPLY.len(), Duration::from_secs(2));
    let received = control.received().expect("received");
    assert_eq!(received.bytes, b"@0P\r\xFD\xFF@0P\r");
    assert_eq!(
        received.to_string(),
        "received 10 bytes: @0P<CR><FD><FF>@0P<CR>"
    );
}

#[test]
fn faults_armed_together_hit_the_same_message() {
    let (shell, mut client) = socket_shell();
    let control = shell.control();
    control
        .fault(Fault::CorruptByte(ByteIndex::At(0)))
        .expect("fault");
    control
        .fault(Fault::DropByte(ByteIndex::At(18)))
        .expect("fault");
    let got = cycle(&mut client, REQUEST, REPLY.len() - 1);
    let mut expected = REPLY[..18].to_vec();
    expected[0] ^= 0x80;
    assert_eq!(got, expected);
}

#[tokio::test]
async fn closing_a_socket_line_is_link_lost_for_the_transport() {
    let (shell, client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
    let port = transport::open(PortSpec::InProcess {
        stream: client,
        line: shell.line(),
        name: "sim".into(),
    })
    .expect("open");
    let mut parts = port.split(WriterConfig::default()).expect("split");
    let err = shell
        .control()
        .fault(Fault::Close {
            reopen_after: Some(Duration::from_millis(10)),
        })
        .expect_err("a socket cannot reopen");
    assert!(matches!(err, ShellError::Rejected(_)), "{err}");
    shell
        .control()
        .fault(Fault::Close { reopen_after: None })
        .expect("close");
    let mut buf = [0u8; 8];
    let err = tokio::time::timeout(Duration::from_secs(2), parts.reader.read(&mut buf))
        .await
        .expect("in time")
        .expect_err("closed");
    assert!(err.is_link_lost(), "{err}");
    assert!(
        shell
            .control()
            .show()
            .expect("show")
            .contains("socket, closed")
    );
}

#[test]
fn closing_a_pty_line_with_reopen_gives_the_link_path_back() {
    block_on(async {
        let dir = tempfile::tempdir().expect("tempdir");
        let link = dir.path().join("isel");
        let shell = serve_pty(
            LineAnswerer::boxed(19200),
            PtyOptions {
                link: Some(link.clone()),
            },
        )
        .expect("serve");
        assert_eq!(shell.client_path(), Some(link.clone()));
        assert!(shell.slave_path().is_some());
        let spec = || PortSpec::Serial {
            path: link.clone(),
            line: LineSettings::new(19200),
        };

        let mut parts = transport::open(spec())
            .expect("open link")
            .split(WriterConfig::default())
            .expect("split");
        shell
            .control()
            .fault(Fault::Close {
                reopen_after: Some(Duration::from_millis(150)),
            })
            .expect("close");
        let mut buf = [0u8; 8];
        let err = tokio::time::timeout(Duration::from_secs(2), parts.reader.read(&mut buf))
            .await
            .expect("in time")
            .expect_err("closed");
        assert!(err.is_link_lost(), "{err}");
        drop(parts);

        // Gone like an unplugged adapter, then back under the same path.
        assert_eq!(shell.slave_path(), None, "no device while closed");
        let err = transport::open(spec()).expect_err("while closed");
        assert!(
            matches!(err, jogterm::transport::TransportError::NotFound { .. }),
            "{err:?}"
        );
        let deadline = Instant::now() + Duration::from_secs(3);
        let port = loop {
            match transport::open(spec()) {
                Ok(port) => break port,
                Err(_) if Instant::now() < deadline => {
                    tokio::time::sleep(Duration::from_millis(10)).await
                }
                Err(e) => panic!("not back: {e}"),
            }
        };
        assert!(shell.slave_path().is_some(), "a new device behind the link");
        let mut parts = port.split(WriterConfig::default()).expect("split");
        parts
            .writer
            .send(
                REQUEST.to_vec(),
                jogterm::transport::Interleave::BetweenBytes,
            )
            .expect("send");
        let mut got = Vec::new();
        while got.len() < REPLY.len() {
            let chunk = tokio::time::timeout(Duration::from_secs(2), parts.reader.read_chunk())
                .await
                .expect("in time")
                .expect("read");
            got.extend(chunk.bytes);
        }
        assert_eq!(got, REPLY);
        drop(parts);
        shell.shutdown();
        assert!(
            std::fs::symlink_metadata(&link).is_err(),
            "link removed at shutdown"
        );
    });
}

#[test]
fn controls_reach_the_device_and_its_refusals_come_back() {
    let (shell, mut client) = socket_shell();
    let control = shell.control();
    assert_eq!(
        control.input_levels().expect("levels"),
        vec![("hood", Some(true)), ("start", None)]
    );
    control
        .input(InputControl::Set {
            name: "hood".into(),
            level: false,
        })
        .expect("set");
    assert!(
        control
            .show()
            .expect("show")
            .starts_with("device: hood=0\n")
    );
    control
        .input(InputControl::Press {
            name: "start".into(),
        })
        .expect("press");
    assert_eq!(
        read_exact_within(&mut client, 2, Duration::from_secs(1)),
        b"S\r"
    );
    let err = control
        .input(InputControl::Press {
            name: "door".into(),
        })
        .expect_err("unknown");
    assert_eq!(
        err.to_string(),
        "unknown input `door`: expected hood or start"
    );
    assert_eq!(control.input_names().expect("names"), vec!["hood", "start"]);
    assert_eq!(
        control.input_levels().expect("levels"),
        vec![("hood", Some(false)), ("start", None)],
        "the level follows what was set"
    );
}

#[test]
fn a_stopped_shell_says_so() {
    let (shell, _client) = socket_shell();
    let control = shell.control();
    shell.shutdown();
    assert!(matches!(control.show(), Err(ShellError::Stopped)));
    assert!(matches!(
        control.fault(Fault::Withhold),
        Err(ShellError::Stopped)
    ));
}

#[test]
fn the_pty_master_can_be_read_by_a_serialport_client_after_garbage() {
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    let mut client = serialport::new(path.to_string_lossy(), 19200)
        .timeout(Duration::from_millis(20))
        .open_native()
        .expect("open");
    // The shell checks for a client every few ms; garbage sent before it
    // noticed would go nowhere.
    sim_shell_support::wait_for_show(&shell.control(), "client connected");
    shell
        .control()
        .fault(Fault::Garbage(b"\x02\r".to_vec()))
        .expect("fault");
    assert_eq!(
        read_exact_within(&mut client, 2, Duration::from_secs(1)),
        b"\x02\r"
    );
    assert_eq!(client.bytes_to_read().expect("empty"), 0);
}

#[test]
fn a_closed_pty_line_comes_back_with_a_later_close_and_a_time() {
    let dir = tempfile::tempdir().expect("tempdir");
    let link = dir.path().join("emcu");
    let shell = serve_pty(
        LineAnswerer::boxed(19200),
        PtyOptions {
            link: Some(link.clone()),
        },
    )
    .expect("serve");
    let control = shell.control();
    control
        .fault(Fault::Close { reopen_after: None })
        .expect("close");
    std::thread::sleep(Duration::from_millis(30));
    assert!(std::fs::symlink_metadata(&link).is_err(), "stays closed");
    assert!(control.show().expect("show").contains(", closed\n"));
    control
        .fault(Fault::Close {
            reopen_after: Some(Duration::from_millis(0)),
        })
        .expect("reopen");
    let deadline = Instant::now() + Duration::from_secs(2);
    while std::fs::symlink_metadata(&link).is_err() {
        assert!(Instant::now() < deadline, "did not come back");
        std::thread::sleep(Duration::from_millis(2));
    }
    let mut client = serialport::new(link.to_string_lossy(), 19200)
        .timeout(Duration::from_millis(20))
        .open_native()
        .expect("open");
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
    assert_eq!(client.bytes_to_read().expect("nothing more"), 0);
}
