//! The EMP driver in the device task against the EMP simulator shell: over a
//! socket pair (switch on, home, move, positions during the move, I/O,
//! stop) and over a pty whose line is closed under it and brought back
//! (`fault close`): the drive is stopped first, read back, and the jog is
//! not resumed.

use std::path::Path;
use std::time::Duration;

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Activity, Dir, Event, Frame, JogId, PerAxis, PositionSource, Request};
use jogterm::device::emp::{EmpDriver, EmpSettings};
use jogterm::device::{Connector, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use jogterm::proto::emp::Speed;
use jogterm::sim::InputControl;
use jogterm::sim::registry;
use jogterm::sim::shell::{PtyOptions, Shell, serve_pty, serve_socket};
use jogterm::transport::PortSpec;

use crate::device_support::Rig;

fn profile() -> Profile {
    load_profile("emp", &ConfigDirs::builtin_only()).expect("emp profile")
}

/// Settings for a loaded test machine: a wider reply margin; homing out at
/// the drive's top speed so the test does not wait for it.
fn settings() -> EmpSettings {
    let mut s = EmpSettings::from_profile(&profile()).expect("settings");
    s.timing.reply_margin = Duration::from_millis(400);
    s.home_fast = Speed::new(127).expect("speed");
    s.home_slow = Speed::new(32).expect("speed");
    s
}

fn rig(connector: Connector, shell: Shell) -> Rig {
    let (handle, events) = spawn_with(
        Box::new(EmpDriver::new(settings())),
        connector,
        TaskOptions::default(),
    )
    .expect("device task");
    Rig {
        shell,
        handle,
        events,
        seen: Vec::new(),
    }
}

fn socket_rig() -> Rig {
    let device = registry::build(Protocol::Emp, &profile()).expect("simulator");
    let (shell, stream) = serve_socket(device).expect("serve");
    let spec = PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: "EMP simulator".into(),
    };
    rig(Connector::from(spec), shell)
}

fn pty_rig(link: &Path) -> Rig {
    let device = registry::build(Protocol::Emp, &profile()).expect("simulator");
    let shell = serve_pty(
        device,
        PtyOptions {
            link: Some(link.to_path_buf()),
        },
    )
    .expect("serve");
    let connector = Connector::Serial {
        path: link.to_path_buf(),
        line: shell.line(),
    };
    rig(connector, shell)
}

impl Rig {
    async fn state(
        &mut self,
        what: &str,
        within: Duration,
        pred: impl Fn(&jogterm::device::api::MachineState) -> bool,
    ) {
        self.wait_for(what, within, |e| matches!(e, Event::State(s) if pred(s)))
            .await;
    }

    /// Switched on and referenced.
    async fn emp_ready(&mut self) {
        self.connected().await;
        self.request(Request::Initialise);
        self.state("initialised", Duration::from_secs(5), |s| {
            s.initialised.contains(Axis::X)
        })
        .await;
        self.request(Request::Home {
            axes: AxisSet::EMPTY.with(Axis::X),
        });
        self.state("referenced", Duration::from_secs(30), |s| {
            s.referenced.contains(Axis::X) && s.activity == Activity::Idle
        })
        .await;
    }
}

fn x(e: &Event) -> Option<i64> {
    match e {
        Event::Position(p) if p.source == PositionSource::Measured => p.steps.get(Axis::X),
        _ => None,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn switch_on_home_move_read_positions_and_io_then_stop() {
    // A timing promise (the stop written within 50 ms): one at a time.
    let _serial = crate::timing::SERIAL.lock().await;
    let mut rig = socket_rig();
    rig.emp_ready().await;
    rig.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 1_000_000),
        frame: Frame::Machine,
        speed_hz: PerAxis::new().with(Axis::X, 56_000.0),
    });
    rig.state("moving", Duration::from_secs(5), |s| {
        s.activity == Activity::Moving
    })
    .await;
    let from = rig.seen.len();
    rig.run_for(Duration::from_millis(500)).await;
    let during: Vec<i64> = rig.seen[from..].iter().filter_map(x).collect();
    assert!(during.len() > 10, "{during:?}");
    assert!(during.windows(2).all(|w| w[0] <= w[1]), "{during:?}");
    assert!(during.first() < during.last(), "{during:?}");
    rig.shell
        .control()
        .input(InputControl::Set {
            name: "i3".into(),
            level: true,
        })
        .expect("input");
    rig.wait_for("I3 on", Duration::from_secs(3), |e| {
        matches!(e, Event::Io(io) if io.groups[0].bits.iter().any(|b| b.name == "I3" && b.value))
    })
    .await;
    let ticket = rig.handle.stop();
    let written = ticket.written().await.expect("stop written");
    assert!(written.latency() < Duration::from_millis(50), "{written:?}");
    rig.state("idle", Duration::from_secs(3), |s| {
        s.activity == Activity::Idle
    })
    .await;
    rig.run_for(Duration::from_millis(300)).await;
    let a = rig
        .wait_for("a position", Duration::from_secs(2), |e| x(e).is_some())
        .await;
    rig.run_for(Duration::from_millis(300)).await;
    let b = rig
        .wait_for("a position", Duration::from_secs(2), |e| x(e).is_some())
        .await;
    assert_eq!(x(&a), x(&b), "held after the stop");
    assert!(x(&a).is_some_and(|v| v < 1_000_000));
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lost_line_is_reconnected_stopped_and_read_back_without_resuming_the_jog() {
    let dir = tempfile::tempdir().expect("temp dir");
    let link = dir.path().join("emp");
    let mut rig = pty_rig(&link);
    rig.emp_ready().await;
    rig.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: PerAxis::new().with(Axis::X, 11_200.0),
        lease: Duration::from_secs(60),
    });
    rig.state("jogging", Duration::from_secs(5), |s| {
        s.activity == Activity::Jogging
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let before = rig.close_and_reconnect().await;
    let after = rig.sent_since(before);
    assert_eq!(
        after.first().map(String::as_str),
        Some("0811000000000000<EOF>"),
        "{after:?}"
    );
    assert!(!after.iter().any(|s| s.starts_with("2A")), "{after:?}");
    assert!(rig.seen.iter().any(|e| matches!(
        e,
        Event::JogEnded {
            id: JogId(1),
            end: jogterm::device::api::JogEnd::LinkLost
        }
    )));
    // Held where it stopped: the drive stayed on and keeps its reference.
    rig.run_for(Duration::from_millis(300)).await;
    let a = rig
        .wait_for("a position", Duration::from_secs(2), |e| x(e).is_some())
        .await;
    rig.run_for(Duration::from_millis(300)).await;
    let b = rig
        .wait_for("a position", Duration::from_secs(2), |e| x(e).is_some())
        .await;
    assert_eq!(x(&a), x(&b));
    rig.handle.shutdown().await;
}
