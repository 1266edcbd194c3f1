//! Steps, go-to moves, jogs, homing and zero: what goes on the wire, the
//! estimate while a move runs, and how it ends.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    Activity, Dir, Event, Frame, JogEnd, JogId, PerAxis, PositionSource, Refusal, Request,
};
use crate::device::isel::{MoveEstimate, RampParams};
use crate::proto::isel::{AxisConfig, MovePair};

use super::harness::{Harness, ms, position_reply, speeds, xyz};

fn jog(id: u64, axes: Vec<(Axis, Dir)>, hz: f64, lease: Duration) -> Request {
    Request::Jog {
        id: JogId(id),
        axes,
        speed_hz: speeds(hz),
        lease,
    }
}

/// Ready at `(x, y, z)` with an overrun bound too large to cap any speed:
/// for the tests of what a jog does, not of how fast it may go.
fn ready_uncapped(x: i32, y: i32, z: i32) -> Harness {
    let mut h = Harness::with(|s| {
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            if let Some(mut l) = s.limits(axis) {
                l.max_overrun = 1e12;
                s.axes.set(axis, l);
            }
        }
    });
    h.connect();
    h.readback(x, y, z, b"0");
    h.expect_nothing();
    h.take_events();
    h
}

fn jog_ends(h: &Harness) -> Vec<(u64, JogEnd)> {
    h.events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { id, end } => Some((id.0, end.clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn a_step_is_estimated_while_it_runs_and_measured_after() {
    let mut h = Harness::ready_at(1_000, 0, 0);
    h.request(Request::Step {
        delta: xyz(4_000, 0, 0),
        speed_hz: speeds(2_000.0),
    });
    h.expect_text("@0A4000,2000,0,300,0,300,0,300");
    assert_eq!(h.state().activity, Activity::Stepping);
    let pairs = [
        MovePair::new(4_000, 2_000),
        MovePair::new(0, 300),
        MovePair::new(0, 300),
        MovePair::new(0, 300),
    ];
    let mut model = MoveEstimate::relative(
        AxisConfig::XYZ,
        &pairs,
        xyz(1_000, 0, 0),
        RampParams::CONTROLLER_DEFAULT,
        false,
    );
    let start = h.now;
    model.start(start);
    h.advance(ms(1_000));
    let estimates: Vec<_> = h
        .positions()
        .into_iter()
        .filter(|p| p.source == PositionSource::Estimated)
        .collect();
    // One at the start, then every 40 ms.
    assert_eq!(estimates.len(), 26, "{estimates:?}");
    for (i, p) in estimates.iter().enumerate() {
        assert_eq!(p.at, start + ms(40) * i as u32);
        assert_eq!(p.steps, model.position_at(p.at), "estimate {i}");
    }
    assert!(estimates[10].steps.get(Axis::X) > Some(1_000));
    h.expect_nothing();
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(5_000, 0, 0));
    h.expect_nothing();
    let last = h.positions().last().copied().expect("position");
    assert_eq!(last.source, PositionSource::Measured);
    assert_eq!(last.steps, xyz(5_000, 0, 0));
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn steps_are_coalesced_up_to_the_bound_and_then_refused() {
    let mut h = Harness::ready_at(0, 0, 0);
    let step = |x| Request::Step {
        delta: PerAxis::new().with(Axis::X, x),
        speed_hz: speeds(1_000.0),
    };
    h.request(step(40));
    h.expect_text("@0A40,1000,0,300,0,300,0,300");
    h.request(step(40));
    h.request(step(40));
    h.request(step(40));
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["step X=40: step dropped: steps are still running"]
    );
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(40, 0, 0));
    // The two remembered presses go as one move.
    h.expect_text("@0A80,1000,0,300,0,300,0,300");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(120, 0, 0));
    h.expect_nothing();
}

#[test]
fn a_step_beyond_the_soft_limit_is_refused_counting_the_steps_before_it() {
    let mut h = Harness::ready_at(119_900, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 60),
        speed_hz: speeds(1_000.0),
    });
    h.expect_text("@0A60,1000,0,300,0,300,0,300");
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 60),
        speed_hz: speeds(1_000.0),
    });
    assert_eq!(
        h.refusals(),
        ["step X=60: X target 120020 is outside the soft limits 0..120000 (steps)"]
    );
}

#[test]
fn speeds_are_capped_at_the_axis_maximum() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: xyz(100, 0, 100),
        speed_hz: speeds(50_000.0),
    });
    // X: 25 mm/s * 400 = 10000 Hz; Z: 15 mm/s * 400 = 6000 Hz.
    h.expect_text("@0A100,10000,0,300,100,6000,0,6000");
}

#[test]
fn move_to_uses_the_virtual_zero_and_checks_the_soft_limits() {
    let mut h = Harness::ready_at(10_000, 20_000, 4_000);
    h.request(Request::SetZero { axes: AxisSet::XYZ });
    h.expect_text("@0n7");
    h.reply(b"0");
    assert_eq!(h.state().work_zero, xyz(10_000, 20_000, 4_000));
    // Read right after: the positions did not change (machine positions).
    h.expect_text("@0P");
    h.reply(&position_reply(10_000, 20_000, 4_000));
    assert!(!h.notices().iter().any(|n| n.contains("virtual zero")));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 500),
        frame: Frame::Work,
        speed_hz: speeds(2_000.0),
    });
    // X to 500 in the work frame; Y and Z stay (0 in the work frame).
    h.expect_text("@0M500,2000,0,300,0,300,0,300");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(10_500, 20_000, 4_000));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::Y, 90_000),
        frame: Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["move to Y=90000 (machine): Y target 90000 is outside the soft limits 0..80000 (steps)"]
    );
}

#[test]
fn move_to_needs_a_known_zero() {
    // A controller that was referenced before jogterm connected: its virtual
    // zero may have been moved by someone else.
    let mut h = Harness::ready();
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 500),
        frame: Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    h.expect_nothing();
    assert!(h.refusals()[0].contains("zero point of XYZ was set before jogterm connected"));
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_text("@0R7");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 500),
        frame: Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    h.expect_text("@0M500,2000,0,300,0,300,0,300");
}

#[test]
fn a_jog_runs_towards_the_soft_limit_along_its_vector() {
    let mut h = ready_uncapped(100_000, 40_000, 0);
    h.request(jog(
        1,
        vec![(Axis::X, Dir::Plus), (Axis::Y, Dir::Minus)],
        2_000.0,
        ms(750),
    ));
    // X has 20000 steps of room, Y 40000 at the same speed: X limits both.
    h.expect_text("@0A20000,2000,-20000,2000,0,300,0,300");
    assert_eq!(h.state().activity, Activity::Jogging);
}

#[test]
fn a_jog_at_its_limit_is_refused() {
    let mut h = Harness::ready_at(120_000, 0, 0);
    h.request(jog(3, vec![(Axis::X, Dir::Plus)], 2_000.0, ms(750)));
    h.expect_nothing();
    assert_eq!(
        jog_ends(&h),
        [(
            3,
            JogEnd::Refused(Refusal::SoftLimit {
                axis: Axis::X,
                target: 120_001,
                min: 0,
                max: 120_000
            })
        )]
    );
}

#[test]
fn jog_speed_is_capped_by_the_allowed_overrun() {
    let mut h = Harness::with(|s| {
        if let Some(mut x) = s.limits(Axis::X) {
            x.max_overrun = 100.0;
            s.axes.set(Axis::X, x);
        }
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 9_000.0, ms(150)));
    let cap = crate::device::isel::overrun_cap(RampParams::CONTROLLER_DEFAULT, ms(150), 100.0);
    let expected = format!("@0A120000,{},0,300,0,300,0,300", cap.round() as u32);
    h.expect_text(&expected);
}

/// `@0A` of a jog along +X from 0 at `hz`.
fn x_jog(hz: f64) -> String {
    format!("@0A120000,{},0,300,0,300,0,300", hz.round() as u32)
}

fn cap(lease: Duration) -> f64 {
    // The default profile: 3 mm at 400 steps/mm.
    crate::device::isel::overrun_cap(RampParams::CONTROLLER_DEFAULT, lease, 1200.0)
}

#[test]
fn a_jog_starts_at_the_grace_leases_cap_and_speeds_up_on_the_first_repeat() {
    let mut h = Harness::ready_at(0, 0, 0);
    // 15 mm/s asked for; the first lease (750 ms) allows about 3.9 mm/s.
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 6_000.0, ms(750)));
    h.expect_text(&x_jog(cap(ms(750))));
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(150),
    });
    // The controller cannot change a running move's speed: stop, read where
    // it ended, go on faster. The jog itself goes on.
    h.expect(&[0xFD, 0xFF]);
    assert_eq!(h.state().activity, Activity::Jogging);
    h.advance(ms(15));
    h.reply(b"F");
    assert!(jog_ends(&h).is_empty(), "{:?}", jog_ends(&h));
    h.advance(ms(10));
    h.expect_text("@0P");
    h.reply(&position_reply(780, 0, 0));
    let room = 120_000 - 780;
    h.expect_text(&format!(
        "@0A{room},{},0,300,0,300,0,300",
        6_000.0f64.min(cap(ms(150))).round() as u32
    ));
    assert_eq!(h.state().activity, Activity::Jogging);
    // Further renewals keep it alive and change nothing on the wire.
    for _ in 0..5 {
        h.advance(ms(33));
        h.request(Request::JogRenew {
            id: JogId(1),
            lease: ms(150),
        });
        h.expect_nothing();
    }
    h.request(Request::JogRelease { id: JogId(1) });
    h.expect(&[0xFD, 0xFF]);
    h.reply(b"F");
    assert_eq!(jog_ends(&h), [(1, JogEnd::Released)]);
}

#[test]
fn a_slow_jog_never_stops_to_speed_up() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 800.0, ms(750)));
    h.expect_text(&x_jog(800.0));
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(150),
    });
    h.expect_nothing();
}

#[test]
fn a_release_or_a_lapsed_lease_while_speeding_up_ends_the_jog_without_a_restart() {
    for release in [true, false] {
        let mut h = Harness::ready_at(0, 0, 0);
        h.request(jog(3, vec![(Axis::X, Dir::Plus)], 6_000.0, ms(750)));
        h.send();
        h.advance(ms(500));
        h.request(Request::JogRenew {
            id: JogId(3),
            lease: ms(150),
        });
        h.expect(&[0xFD, 0xFF]);
        if release {
            h.request(Request::JogRelease { id: JogId(3) });
            h.expect_nothing();
        } else {
            h.advance(ms(200));
        }
        h.reply(b"F");
        h.advance(ms(10));
        h.expect_text("@0P");
        h.reply(&position_reply(900, 0, 0));
        h.expect_nothing();
        let end = if release {
            JogEnd::Released
        } else {
            JogEnd::DeadMan
        };
        assert_eq!(jog_ends(&h), [(3, end)]);
        assert_eq!(h.state().activity, Activity::Idle);
    }
}

#[test]
fn a_renewal_before_the_move_is_out_replans_it_without_a_stop() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(4, vec![(Axis::X, Dir::Plus)], 6_000.0, ms(750)));
    let planned = h.take();
    assert_eq!(
        planned.as_deref().map(crate::traffic::readable),
        Some(format!("{}<CR>", x_jog(cap(ms(750)))))
    );
    // Renewed while the command is still on its way: it is already out in
    // full here, so the speed-up goes the usual way; but a renewal before
    // the driver handed it out re-plans it.
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(5, vec![(Axis::X, Dir::Plus)], 6_000.0, ms(750)));
    h.request(Request::JogRenew {
        id: JogId(5),
        lease: ms(150),
    });
    h.expect_text(&x_jog(6_000.0f64.min(cap(ms(150)))));
}

#[test]
fn a_renewal_never_grants_more_than_the_speed_allows() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(6, vec![(Axis::X, Dir::Plus)], 800.0, ms(150)));
    h.expect_text(&x_jog(800.0));
    // 800 Hz may run (1200 - 10 ms reaction - braking) / 800 Hz ≈ 1.48 s;
    // a client asking for 10 s gets that, not more.
    h.request(Request::JogRenew {
        id: JogId(6),
        lease: ms(10_000),
    });
    h.advance(ms(1_470));
    h.expect_nothing();
    h.advance(ms(30));
    h.expect(&[0xFD, 0xFF]);
    h.reply(b"F");
    assert_eq!(jog_ends(&h), [(6, JogEnd::DeadMan)]);
}

#[test]
fn a_jog_whose_lease_runs_out_is_stopped_and_broken_off() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(7, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(750)));
    h.expect_text("@0A120000,1000,0,300,0,300,0,300");
    h.advance(ms(700));
    h.request(Request::JogRenew {
        id: JogId(7),
        lease: ms(150),
    });
    h.advance(ms(149));
    h.expect_nothing();
    h.advance(ms(1));
    // Dead-man: soft stop and break together (isel decision 6).
    h.expect(&[0xFD, 0xFF]);
    assert_eq!(h.state().activity, Activity::Stopping);
    h.advance(ms(30));
    h.reply(b"F");
    assert_eq!(jog_ends(&h), [(7, JogEnd::DeadMan)]);
    // The line settles before `@0P`, so a stray byte cannot pose as its reply.
    h.expect_nothing();
    h.advance(ms(10));
    h.expect_text("@0P");
    h.reply(&position_reply(1_900, 0, 0));
    h.expect_nothing();
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn a_released_jog_is_stopped_and_reported_when_it_ends() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(jog(2, vec![(Axis::Y, Dir::Plus)], 1_000.0, ms(750)));
    h.expect_text("@0A0,300,80000,1000,0,300,0,300");
    h.advance(ms(300));
    h.request(Request::JogRelease { id: JogId(2) });
    h.expect(&[0xFD, 0xFF]);
    assert!(jog_ends(&h).is_empty(), "reported when the move answers");
    h.reply(b"F");
    assert_eq!(jog_ends(&h), [(2, JogEnd::Released)]);
    // A late renewal or release of the ended jog does nothing.
    h.request(Request::JogRenew {
        id: JogId(2),
        lease: ms(150),
    });
    h.request(Request::JogRelease { id: JogId(2) });
    h.advance(ms(10));
    h.expect_text("@0P");
}

#[test]
fn a_jog_that_reaches_the_limit_ends_with_softlimit() {
    let mut h = ready_uncapped(119_000, 0, 0);
    h.request(jog(4, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(5_000)));
    h.expect_text("@0A1000,1000,0,300,0,300,0,300");
    h.advance(ms(1_200));
    h.reply(b"0");
    assert_eq!(jog_ends(&h), [(4, JogEnd::SoftLimit)]);
    h.expect_text("@0P");
}

#[test]
fn stop_brakes_the_estimate_and_shortens_the_deadline() {
    let mut h = ready_uncapped(0, 0, 0);
    h.request(jog(5, vec![(Axis::X, Dir::Plus)], 5_300.0, ms(5_000)));
    h.expect_text("@0A120000,5300,0,300,0,300,0,300");
    h.advance(ms(500));
    assert_eq!(h.stop(), [0xFD, 0xFF]);
    h.expect_nothing();
    h.take_events();
    h.advance(ms(200));
    let last = h.positions().last().copied().expect("estimate");
    // 500 ms at up to 5300 Hz, then 140 steps of braking (motion.rs).
    let pairs = [
        MovePair::new(120_000, 5_300),
        MovePair::new(0, 300),
        MovePair::new(0, 300),
        MovePair::new(0, 300),
    ];
    let mut model = MoveEstimate::relative(
        AxisConfig::XYZ,
        &pairs,
        xyz(0, 0, 0),
        RampParams::CONTROLLER_DEFAULT,
        false,
    );
    let start = h.now - ms(700);
    model.start(start);
    let at_stop = model.position_at(start + ms(500)).get(Axis::X).unwrap_or(0);
    assert_eq!(last.steps.get(Axis::X), Some(at_stop + 140));
    // Braking takes 50 ms: without a reply 1.0625 s after the stop, the
    // link is dead.
    h.advance(ms(800));
    assert!(h.faults().iter().all(|f| !f.ends_with("timeout")));
    h.advance(ms(100));
    assert!(
        h.faults().iter().any(|f| f.ends_with("timeout")),
        "{:?}",
        h.faults()
    );
    assert_eq!(jog_ends(&h), [(5, JogEnd::LinkLost)]);
}

#[test]
fn a_stop_before_the_move_is_on_the_wire_is_sent_again_after_it() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: xyz(4_000, 0, 0),
        speed_hz: speeds(2_000.0),
    });
    let mv = h.take().expect("the move");
    assert!(mv.starts_with(b"@0A4000"));
    // The stop overtakes the command's last bytes; the controller still
    // executes the command after it.
    assert_eq!(h.stop(), [0xFD, 0xFF]);
    h.expect_nothing();
    h.written();
    h.expect(&[0xFD, 0xFF]);
    h.reply(b"F");
    h.advance(ms(10));
    h.expect_text("@0P");
}

#[test]
fn the_stop_key_leaves_a_rest_that_is_broken_off() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::Z, 8_000),
        frame: Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    // zero unknown: home first
    h.take_events();
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_text("@0R7");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::Z, 8_000),
        frame: Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    h.expect_text("@0M0,300,0,300,8000,2000,0,2000");
    h.advance(ms(1_000));
    h.reply(b"F");
    h.expect(&[0xFF]);
    assert!(
        h.notices()
            .iter()
            .any(|n| n.contains("stopped at the controller"))
    );
}

#[test]
fn homing_runs_xyz_then_a_and_a_stopped_run_does_not_count() {
    let mut h = Harness::with(|s| {
        s.config = AxisConfig::XYZA;
        let x = s.limits(Axis::X).expect("X");
        s.axes.set(Axis::A, x);
    });
    h.connect();
    h.expect_text("@0P");
    h.reply(b"0000000000000000000000000");
    h.advance(ms(60));
    for r in [b"003", b"0E2", b"000"] {
        h.send();
        h.reply(r);
    }
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"R");
    for (cmd, r) in [
        ("@0j300", b"0"),
        ("@0J100", b"0"),
        ("@0d4000,4000,4000,4000", b"0"),
    ] {
        h.expect_text(cmd);
        h.reply(r);
    }
    h.request(Request::Home {
        axes: AxisSet::XYZA,
    });
    h.expect_text("@0R7");
    assert_eq!(h.state().activity, Activity::Homing);
    h.reply(b"0");
    assert_eq!(h.state().referenced, AxisSet::XYZ);
    h.expect_text("@0R8");
    h.stop();
    h.expect_nothing();
    h.reply(b"0");
    assert_eq!(h.state().referenced, AxisSet::XYZ, "A was stopped");
    h.advance(ms(10));
    h.expect_text("@0P");
}

#[test]
fn a_controller_that_reports_positions_from_the_virtual_zero_is_noticed_and_allowed_for() {
    let mut h = Harness::ready_at(10_000, 20_000, 4_000);
    h.request(Request::SetZero { axes: AxisSet::XYZ });
    h.expect_text("@0n7");
    h.reply(b"0");
    // Not what manual 2.2.19 says: `@0P` counts from the new zero.
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    assert!(
        h.notices()
            .iter()
            .any(|n| n.contains("from the virtual zero of @0n") && n.contains("X 10000 -> 0")),
        "{:?}",
        h.notices()
    );
    // Machine positions are shown, soft limits checked on them, and the
    // work zero is the machine position it was set at.
    assert_eq!(h.state().work_zero, xyz(10_000, 20_000, 4_000));
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 500),
        speed_hz: speeds(2_000.0),
    });
    h.expect_text("@0A500,2000,0,300,0,300,0,300");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(500, 0, 0));
    let at = h.positions().last().map(|p| p.steps);
    assert_eq!(at, Some(xyz(10_500, 20_000, 4_000)));
    // A reference run puts the zero back on the reference point: the
    // controller counts from there again.
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_text("@0R7");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    let at = h.positions().last().map(|p| p.steps);
    assert_eq!(at, Some(xyz(0, 0, 0)));
}
