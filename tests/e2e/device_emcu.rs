//! The EMCU driver in the device task against the EMCU simulator on a
//! pseudo-terminal: initialise, home, move, positions during the move, the
//! I/O snapshot, outputs, stop, faults on the line, and a line that is
//! closed mid-move and brought back.

use crate::device_support;

use std::time::Duration;

use device_support::{Rig, pty_rig_for};
use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Activity, Event, Frame, PerAxis, PositionSource, Request};
use jogterm::device::common::PollRate;
use jogterm::device::emcu::{EmcuDriver, EmcuSettings, output_id};
use jogterm::proto::emcu::Output;
use jogterm::sim::fault::{ByteIndex, Fault};

fn secs(n: u64) -> Duration {
    Duration::from_secs(n)
}

fn profile() -> Profile {
    let mut p = load_profile("emcu", &ConfigDirs::builtin_only()).expect("emcu profile");
    // A short way to the reference switches: 2 mm at the start speed.
    p.sim.start_position = 2.0;
    p.emcu.start_speed_hz = 1_000;
    p
}

fn rig(link: &std::path::Path) -> Rig {
    let p = profile();
    let mut s = EmcuSettings::from_profile(&p).expect("settings");
    s.poll.rate = PollRate::LineSpeed;
    s.poll.ports_every = 4;
    // A test thread that is late must not declare the link dead.
    s.timing.reply_margin = Duration::from_millis(400);
    pty_rig_for(Box::new(EmcuDriver::new(s)), &p, link)
}

fn idle(e: &Event) -> bool {
    matches!(e, Event::State(s) if s.activity == Activity::Idle)
}

/// Connected, initialised and referenced.
async fn homed(rig: &mut Rig) {
    rig.connected().await;
    rig.request(Request::Initialise);
    rig.request(Request::Home { axes: AxisSet::XYZ });
    rig.wait_for("referenced", secs(30), |e| {
        matches!(e, Event::State(s) if s.referenced == AxisSet::XYZ && s.activity == Activity::Idle)
    })
    .await;
}

fn is_move(sent: &str) -> bool {
    sent.starts_with('L') || sent.starts_with("$H") || sent.starts_with("@J")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn home_move_read_during_the_move_switch_and_stop() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut rig = rig(&dir.path().join("emcu"));
    homed(&mut rig).await;
    let homes: Vec<String> = rig
        .sent_since(0)
        .into_iter()
        .filter(|s| s.starts_with("$H"))
        .collect();
    assert_eq!(homes, ["$HZYX<01>"]);
    // Read-back and reference run leave I/O snapshots with the flags.
    let io = rig
        .seen
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Io(io) => Some(io.clone()),
            _ => None,
        })
        .expect("an I/O snapshot");
    assert_eq!(
        io.groups.first().map(|g| g.name.as_str()),
        Some("status: @X flags")
    );

    rig.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 40_000),
        frame: Frame::Machine,
        speed_hz: PerAxis::new().with(Axis::X, 2_000.0),
    });
    let from = rig.seen.len();
    rig.run_for(Duration::from_millis(1_500)).await;
    let xs: Vec<i64> = rig.seen[from..]
        .iter()
        .filter_map(|e| match e {
            Event::Position(p) => {
                assert_eq!(p.source, PositionSource::Measured);
                p.steps.get(Axis::X)
            }
            _ => None,
        })
        .collect();
    assert!(xs.len() > 10, "{xs:?}");
    assert!(xs.windows(2).all(|w| w[0] <= w[1]), "{xs:?}");
    assert!(xs.last().is_some_and(|x| *x > 0 && *x < 40_000), "{xs:?}");

    // Stop: `@B` at once, the ramp down, positions kept.
    let written = rig.handle.stop().written().await;
    assert!(written.is_some());
    rig.wait_for("idle after the stop", secs(5), idle).await;
    rig.run_for(Duration::from_millis(300)).await;
    let state = rig
        .seen
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::State(s) => Some(s.clone()),
            _ => None,
        })
        .expect("state");
    assert_eq!(state.referenced, AxisSet::XYZ);
    assert!(state.fault.is_none(), "{state:?}");

    rig.request(Request::SetOutput {
        output: output_id(Output::new(2).expect("A2")),
        value: 1,
    });
    rig.wait_for("A2 on", secs(5), |e| {
        matches!(e, Event::Io(io) if io.groups.iter().any(|g| g.bits.iter().any(|b| b.name.starts_with("A2") && b.value)))
    })
    .await;
    let shown = rig.shell.control().show().expect("show");
    assert!(shown.contains("A2 on"), "{shown}");
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_corrupted_or_withheld_answer_costs_no_motion_and_no_hang() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut rig = rig(&dir.path().join("emcu"));
    homed(&mut rig).await;
    // A garbled poll answer: lost, polling goes on.
    rig.shell
        .control()
        .fault(Fault::CorruptByte(ByteIndex::Middle))
        .expect("fault");
    rig.run_for(Duration::from_millis(500)).await;
    let from = rig.seen.len();
    rig.wait_for(
        "a position after the garbled answer",
        secs(5),
        |e| matches!(e, Event::Position(p) if p.source == PositionSource::Measured),
    )
    .await;
    // Unsolicited bytes: reported, no panic.
    rig.shell
        .control()
        .fault(Fault::Garbage(b"\x02\r".to_vec()))
        .expect("fault");
    rig.run_for(Duration::from_millis(500)).await;
    // An answer that never comes: the link counts as dead (a fault that
    // says to check it), is opened again and read back; a step asked for
    // meanwhile is sent once at most.
    rig.shell.control().fault(Fault::Withhold).expect("fault");
    rig.request(Request::Step {
        delta: PerAxis::new().with(Axis::Y, 400),
        speed_hz: PerAxis::new().with(Axis::Y, 1_000.0),
    });
    rig.wait_for(
        "the timeout",
        secs(5),
        |e| matches!(e, Event::Fault(f) if f.code == "timeout"),
    )
    .await;
    rig.wait_for(
        "the read-back after it",
        secs(10),
        |e| matches!(e, Event::Notice(n) if n.starts_with("state read back")),
    )
    .await;
    rig.wait_for(
        "polling again",
        secs(5),
        |e| matches!(e, Event::Position(p) if p.source == PositionSource::Measured),
    )
    .await;
    let moves: Vec<String> = rig
        .sent_since(from)
        .into_iter()
        .filter(|s| s.starts_with('L'))
        .collect();
    assert!(moves.len() <= 1, "{moves:?}");
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_line_closed_mid_move_is_reconnected_halted_and_read_back() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut rig = rig(&dir.path().join("emcu"));
    homed(&mut rig).await;
    rig.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 40_000),
        speed_hz: PerAxis::new().with(Axis::X, 2_000.0),
    });
    rig.wait_for(
        "the move",
        secs(5),
        |e| matches!(e, Event::Position(p) if p.steps.get(Axis::X).is_some_and(|x| x > 100)),
    )
    .await;
    let before = rig.close_and_reconnect().await;
    let after = rig.sent_since(before);
    assert_eq!(
        after.first().map(String::as_str),
        Some("<CR>@B<CR>"),
        "{after:?}"
    );
    assert!(!after.iter().any(|s| is_move(s)), "{after:?}");
    // Halted on reconnect, well short of its target, and still referenced
    // (`@B` keeps the positions).
    rig.run_for(secs(2)).await;
    let shown = rig.shell.control().show().expect("show");
    assert!(!shown.contains("moving"), "{shown}");
    let x = rig
        .seen
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Position(p) => p.steps.get(Axis::X),
            _ => None,
        })
        .expect("a position");
    assert!(x > 0 && x < 40_000, "{x}");
    rig.handle.shutdown().await;
}
