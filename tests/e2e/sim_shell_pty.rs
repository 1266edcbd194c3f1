//! Serving on a pseudo-terminal: clients come and go, the stable link, and
//! the control loop as `jogterm sim --pty` runs it.

use crate::sim_shell_support;

use std::io::{BufReader, Cursor, Write};
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::sync::mpsc;
use std::thread;
use std::time::Duration;

use jogterm::sim::InputControl;
use jogterm::sim::control::run_control_loop;
use jogterm::sim::shell::{PtyOptions, run_pty_simulator_with, serve_pty, serve_socket};
use jogterm::transport::{self, PortSpec, TransportError};
use jogterm::wire::LineSettings;
use sim_shell_support::{LineAnswerer, REPLY, REQUEST, cycle, read_for, wait_for_show};

fn open_client(path: &std::path::Path) -> serialport::TTYPort {
    serialport::new(path.to_string_lossy(), 19200)
        .timeout(Duration::from_millis(20))
        .open_native()
        .expect("open the slave")
}

#[test]
fn clients_may_close_and_another_may_open() {
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    for _ in 0..3 {
        let mut client = open_client(&path);
        assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
        drop(client);
    }
    assert!(
        shell
            .control()
            .show()
            .expect("show")
            .contains("received 12 bytes")
    );
}

#[test]
fn what_the_device_sends_while_no_client_is_there_is_lost() {
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    let control = shell.control();
    {
        let mut client = open_client(&path);
        assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
    }
    // Once the shell has seen the client go, make the device talk.
    wait_for_show(&control, "waiting for a client");
    control
        .input(InputControl::Press {
            name: "start".into(),
        })
        .expect("press");
    wait_for_show(&control, "lost without a client 2,");
    let mut client = open_client(&path);
    assert!(
        read_for(&mut client, Duration::from_millis(30)).is_empty(),
        "no stale bytes"
    );
    assert!(
        control
            .show()
            .expect("show")
            .contains("lost without a client 2,")
    );
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
}

#[test]
fn a_second_client_at_the_same_time_is_refused() {
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    let spec = || PortSpec::Serial {
        path: path.clone(),
        line: LineSettings::new(19200),
    };
    let _first = transport::open(spec()).expect("first");
    assert!(matches!(
        transport::open(spec()),
        Err(TransportError::Busy { .. })
    ));
}

#[test]
fn the_link_follows_the_slave_and_goes_with_the_shell() {
    let dir = tempfile::tempdir().expect("tempdir");
    let link = dir.path().join("emp0");
    // A stale link from an earlier run is replaced.
    std::os::unix::fs::symlink("/dev/pts/nothing", &link).expect("stale link");
    let shell = serve_pty(
        LineAnswerer::boxed(38400),
        PtyOptions {
            link: Some(link.clone()),
        },
    )
    .expect("serve");
    assert_eq!(shell.link_path(), Some(link.as_path()));
    assert_eq!(std::fs::read_link(&link).ok(), shell.slave_path());
    let mut client = open_client(&link);
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);
    drop(client);
    shell.shutdown();
    assert!(std::fs::symlink_metadata(&link).is_err());
}

#[test]
fn a_link_path_holding_a_file_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("precious");
    std::fs::write(&path, b"data").expect("file");
    let err = serve_pty(
        LineAnswerer::boxed(19200),
        PtyOptions {
            link: Some(path.clone()),
        },
    )
    .expect_err("refused");
    assert!(err.to_string().contains("not a symbolic link"), "{err}");
    assert_eq!(std::fs::read(&path).expect("kept"), b"data");
}

/// Collects what the simulator writes, line by line.
struct Lines(mpsc::Sender<String>, Vec<u8>);

impl Write for Lines {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.1.extend_from_slice(buf);
        while let Some(i) = self.1.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.1.drain(..=i).collect();
            let _ = self
                .0
                .send(String::from_utf8_lossy(&line[..i]).into_owned());
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn the_pty_simulator_prints_its_path_first_and_obeys_stdin() {
    let dir = tempfile::tempdir().expect("tempdir");
    let link = dir.path().join("sim");
    let (mut stdin, stdin_end) = UnixStream::pair().expect("pipe");
    let (out_tx, out) = mpsc::channel();
    let (err_tx, err) = mpsc::channel();
    let options = PtyOptions {
        link: Some(link.clone()),
    };
    let sim = thread::spawn(move || {
        run_pty_simulator_with(
            LineAnswerer::boxed(19200),
            options,
            BufReader::new(stdin_end),
            &mut Lines(out_tx, Vec::new()),
            &mut Lines(err_tx, Vec::new()),
        )
    });
    let recv =
        |rx: &mpsc::Receiver<String>| rx.recv_timeout(Duration::from_secs(2)).expect("a line");
    let first = recv(&out);
    assert_eq!(PathBuf::from(&first), link, "the path to open comes first");
    let mut client = open_client(&link);
    assert_eq!(cycle(&mut client, REQUEST, REPLY.len()), REPLY);

    stdin.write_all(b"set hood open\n").expect("stdin");
    assert_eq!(recv(&out), "ok");
    stdin.write_all(b"show\n").expect("stdin");
    assert_eq!(recv(&out), "device: hood=0");
    assert!(recv(&out).starts_with("line: 19200 baud, pty /dev/pts/"));
    assert!(recv(&out).starts_with("wire: received 4 bytes; sent 19 bytes in 1 messages"));
    assert_eq!(recv(&out), "faults armed: none");
    stdin.write_all(b"\n# a comment\nbogus\n").expect("stdin");
    assert_eq!(
        recv(&err),
        "error: line 5: unknown command `bogus`: expected set, press, value, pulse, chatter, after, fault, memory, show, help or quit"
    );
    stdin.write_all(b"fault withhold\nshow\n").expect("stdin");
    assert_eq!(recv(&out), "ok");
    let shown: Vec<String> = (0..4).map(|_| recv(&out)).collect();
    assert_eq!(shown[3], "faults armed: withhold");
    stdin.write_all(b"press door\n").expect("stdin");
    assert_eq!(
        recv(&err),
        "error: line 8: unknown input `door`: expected hood or start"
    );
    drop(stdin); // stdin closes: the simulator ends
    sim.join().expect("thread").expect("ran");
    assert!(std::fs::symlink_metadata(&link).is_err(), "link removed");
}

#[test]
fn the_control_loop_prints_help_with_the_device_inputs_and_stops_at_quit() {
    let (shell, _client) = serve_socket(LineAnswerer::boxed(19200)).expect("serve");
    let script = "help\nquit\nset hood open\n";
    let mut out = Vec::new();
    let mut err = Vec::new();
    run_control_loop(Cursor::new(script), &mut out, &mut err, &shell.control()).expect("loop");
    let out = String::from_utf8(out).expect("utf8");
    assert!(out.starts_with("commands:\n"), "{out}");
    assert!(out.trim_end().ends_with("inputs: hood, start"), "{out}");
    assert!(err.is_empty());
    assert!(
        shell
            .control()
            .show()
            .expect("show")
            .starts_with("device: hood=1"),
        "nothing after quit ran"
    );
    let mut out = Vec::new();
    let mut err = Vec::new();
    run_control_loop(
        Cursor::new(b"fault close 100\nfault delay x\n\xff\n".to_vec()),
        &mut out,
        &mut err,
        &shell.control(),
    )
    .expect("loop");
    assert_eq!(
        String::from_utf8(err).expect("utf8"),
        "error: line 1: reopening needs a pseudo-terminal or TCP line; this one is a socket pair\n\
         error: line 2: `x` is not a time in ms: expected a whole number from 0 to 600000\n\
         error: line 3: not valid UTF-8 text\n"
    );
    assert!(out.is_empty());
}

/// A client that opens, writes and closes before the simulator has noticed
/// it (a `jogterm send break` takes about a millisecond) still reaches the
/// device: on a real line its bytes went out. Before, they waited in the pty
/// for the next client, and the machine went on moving.
#[test]
fn a_client_that_writes_and_leaves_at_once_is_still_heard() {
    let shell = serve_pty(LineAnswerer::boxed(19200), PtyOptions::default()).expect("serve");
    let path = shell.slave_path().expect("slave");
    let mut first = open_client(&path);
    assert_eq!(cycle(&mut first, REQUEST, REPLY.len()), REPLY);
    drop(first);
    for round in 0..20u8 {
        let before = shell.control().received().expect("received").total;
        let mut quick = open_client(&path);
        quick.write_all(&[0xFD, 0xFF]).expect("write");
        drop(quick);
        let end = std::time::Instant::now() + Duration::from_secs(2);
        while shell.control().received().expect("received").total < before + 2 {
            assert!(
                std::time::Instant::now() < end,
                "round {round}: the bytes of a client that left at once never arrived"
            );
            thread::sleep(Duration::from_millis(5));
        }
    }
}
