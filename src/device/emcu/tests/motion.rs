//! Steps, go-to moves, jogs, reference runs, outputs and the work zero:
//! what goes on the wire, and how each ends.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    Activity, Dir, Event, Frame, JogEnd, JogId, OutputId, PerAxis, Refusal, Request,
};
use crate::device::common::testing::refusal_reasons;

use super::harness::{Harness, ms, settings, speeds, xyz};

/// The slot speed a jog holding `lease` may run at: the fastest that stops
/// within X's `jog.max_overrun` (`motion::speed_cap` with the `#R` ramp), in
/// whole Hz below the cap.
fn cap(lease: Duration) -> u16 {
    let s = settings();
    let bound = s.limits(Axis::X).expect("X").max_overrun;
    crate::motion::speed_cap(&s.braking(), lease, bound).floor() as u16
}

fn jog(id: u64, axes: Vec<(Axis, Dir)>, hz: f64, lease: Duration) -> Request {
    Request::Jog {
        id: JogId(id),
        axes,
        speed_hz: speeds(hz),
        lease,
    }
}

#[test]
fn a_step_runs_as_a_batch_and_is_measured_at_its_end() {
    let mut h = Harness::ready_at(1_000, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 4_000),
        speed_hz: speeds(500.0),
    });
    h.expect_text("#E9,500");
    h.reply(b"\r");
    h.expect(b"L9,x4000\x01");
    assert_eq!(h.state().activity, Activity::Stepping);
    h.reply(b"\r");
    h.expect_nothing();
    // A second without its end: `@X` is asked.
    h.advance(ms(1_000));
    h.expect_text("@X");
    h.reply(b"@X100001\r");
    h.expect_nothing();
    h.run_ends();
    h.positions_read(5_000, 0, 0);
    h.expect_nothing();
    let last = h.positions().last().copied().expect("position");
    assert_eq!(last.steps, xyz(5_000, 0, 0));
    assert_eq!(h.state().activity, Activity::Idle);
    // The slot keeps its speed: the next step at it is the move alone.
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, -10),
        speed_hz: speeds(500.0),
    });
    h.expect(b"L9,x-10\x01");
}

#[test]
fn steps_are_coalesced_up_to_the_bound_and_then_refused() {
    let mut h = Harness::ready_at(0, 0, 0);
    let step = |x| Request::Step {
        delta: PerAxis::new().with(Axis::X, x),
        speed_hz: speeds(400.0),
    };
    h.request(step(40));
    h.expect_text("#E9,400");
    h.reply(b"\r");
    h.expect(b"L9,x40\x01");
    h.reply(b"\r");
    h.request(step(40));
    h.request(step(40));
    h.request(step(40));
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["step X=40: step dropped: steps are still running"]
    );
    h.run_ends();
    h.positions_read(40, 0, 0);
    // The two remembered presses go as one move.
    h.expect(b"L9,x80\x01");
}

#[test]
fn a_step_beyond_the_soft_limit_is_refused_counting_the_steps_before_it() {
    // X: 0..300 mm at 200 steps/mm.
    let mut h = Harness::ready_at(59_900, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 60),
        speed_hz: speeds(400.0),
    });
    h.expect_text("#E9,400");
    h.reply(b"\r");
    h.expect(b"L9,x60\x01");
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 60),
        speed_hz: speeds(400.0),
    });
    assert_eq!(
        h.refusals(),
        ["step X=60: X target 60020 is outside the soft limits 0..60000 (steps)"]
    );
}

#[test]
fn the_lead_axis_runs_no_faster_than_any_axis_allows() {
    let mut h = Harness::ready_at(0, 0, 0);
    // Z: 5 mm/s at 200 steps/mm = 1000 Hz; X would be 2000.
    h.request(Request::Step {
        delta: xyz(200, 0, 100),
        speed_hz: speeds(50_000.0),
    });
    h.expect_text("#E9,2000");
    h.reply(b"\r");
    h.expect(b"L9,x200,z100\x01");
}

#[test]
fn a_move_to_is_absolute_in_machine_steps_with_jogterms_work_zero() {
    let mut h = Harness::ready_at(1_000, 2_000, 0);
    h.request(Request::SetZero {
        axes: AxisSet::from_mask(0b011),
    });
    h.expect_nothing();
    assert_eq!(h.state().work_zero.get(Axis::X), Some(1_000));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 500).with(Axis::Y, 0),
        frame: Frame::Work,
        speed_hz: speeds(800.0),
    });
    // Y is already there: only X moves, to machine 1500.
    h.expect_text("#E9,800");
    h.reply(b"\r");
    h.expect(b"L9,X1500\x01");
    assert_eq!(h.state().activity, Activity::Moving);
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(1_500, 2_000, 0);
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 70_000),
        frame: Frame::Machine,
        speed_hz: speeds(800.0),
    });
    h.expect_nothing();
    assert_eq!(
        refusal_reasons(&h.events),
        [Refusal::SoftLimit {
            axis: Axis::X,
            target: 70_000,
            min: 0,
            max: 60_000
        }]
    );
}

#[test]
fn a_jog_runs_to_the_soft_limit_until_its_lease_runs_out() {
    let mut h = Harness::ready_at(10_000, 0, 0);
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(300)));
    // Capped for the lease it holds: 0.3 s at speed, the stop's way to the
    // wire and the 500 ms ramp from speed to 200 Hz within 3 mm = 600
    // steps: v = (600 - 50) / (0.31 + 0.25) = 982 Hz.
    assert!(cap(ms(300)) < 1_000);
    h.expect_text(&format!("#E9,{}", cap(ms(300))));
    h.reply(b"\r");
    h.expect(b"L9,x50000\x01");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Jogging);
    h.advance(ms(200));
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(300),
    });
    h.advance(ms(299));
    h.expect_nothing();
    h.advance(ms(1));
    // The dead-man: halted with its ramp, positions kept.
    h.expect(b"@B\r");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Stopping);
    assert!(h.jog_ends().is_empty());
    h.run_ends();
    h.positions_read(10_600, 0, 0);
    assert_eq!(h.jog_ends(), [(1, JogEnd::DeadMan)]);
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn a_jog_speed_is_capped_by_the_overrun() {
    let mut h = Harness::ready_at(10_000, 0, 0);
    h.request(jog(1, vec![(Axis::X, Dir::Minus)], 2_000.0, ms(300)));
    h.expect_text(&format!("#E9,{}", cap(ms(300))));
}

#[test]
fn release_and_stop_end_a_jog() {
    let mut h = Harness::ready_at(10_000, 10_000, 0);
    h.request(jog(
        2,
        vec![(Axis::X, Dir::Minus), (Axis::Y, Dir::Plus)],
        1_000.0,
        ms(500),
    ));
    // 723 Hz: (600 - 50) / (0.51 + 0.25).
    h.expect_text(&format!("#E9,{}", cap(ms(500))));
    h.reply(b"\r");
    // X reaches 0 first: 10000 steps each way.
    h.expect(b"L9,x-10000,y10000\x01");
    h.reply(b"\r");
    h.request(Request::JogRelease { id: JogId(2) });
    h.expect(b"@B\r");
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(9_000, 11_000, 0);
    assert_eq!(h.jog_ends(), [(2, JogEnd::Released)]);
    h.take_events();
    h.request(jog(3, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(500)));
    h.expect(b"L9,x51000\x01");
    h.reply(b"\r");
    assert_eq!(h.stop(), b"@B\r");
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(9_500, 11_000, 0);
    assert_eq!(h.jog_ends(), [(3, JogEnd::Stopped)]);
}

#[test]
fn a_jog_released_before_its_move_went_out_never_starts() {
    let mut h = Harness::ready_at(10_000, 0, 0);
    h.request(jog(4, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(500)));
    h.expect_text(&format!("#E9,{}", cap(ms(500))));
    h.request(Request::JogRelease { id: JogId(4) });
    // `@B` also drops the `#E` stored for it.
    h.expect(b"@B\r");
    h.reply(b"\r\r");
    h.expect_text("@LX");
    assert_eq!(h.jog_ends(), [(4, JogEnd::Released)]);
    assert!(!h.sent_any(b"L9"));
}

#[test]
fn a_stop_before_the_move_is_on_the_wire_is_sent_again_after_it() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100),
        speed_hz: speeds(400.0),
    });
    h.expect_text("#E9,400");
    h.reply(b"\r");
    // The move is handed to the writer but not yet written.
    assert_eq!(h.take().as_deref(), Some(&b"L9,x100\x01"[..]));
    assert_eq!(h.stop(), b"@B\r");
    h.written();
    // The run starts after the stop: it is halted once more.
    h.expect(b"@B\r");
    h.reply(b"\r\r\r");
    h.run_ends();
    h.positions_read(20, 0, 0);
    h.expect_nothing();
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn home_runs_z_first_and_references_when_the_position_is_known() {
    let mut h = Harness::new();
    h.connect();
    h.readback("000100", 0, 0, 0);
    h.initialise(0, 0, 0);
    h.take_events();
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect(b"$HZYX\x01");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Homing);
    h.advance(ms(1_000));
    h.expect_text("@X");
    h.reply(b"@X100110\r");
    h.reply(b"\x02\r");
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    h.positions_read(0, 0, 0);
    assert_eq!(h.state().referenced, AxisSet::XYZ);
    // A stopped reference run references nothing.
    h.request(Request::Home {
        axes: AxisSet::from_mask(0b001),
    });
    h.expect(b"$HX\x01");
    h.reply(b"\r");
    h.stop();
    h.reply(b"\r\x02\r");
    h.expect_text("@X");
    h.reply(b"@X000100\r");
    h.positions_read(5, 0, 0);
    assert_eq!(h.state().referenced, AxisSet::EMPTY);
}

#[test]
fn outputs_are_switched_by_a_batch_of_one_and_remembered() {
    let mut h = Harness::ready();
    h.request(Request::SetOutput {
        output: OutputId {
            group: 2,
            bit: None,
        },
        value: 1,
    });
    h.expect(b"A2,1\x01");
    h.reply(b"\r");
    h.run_ends();
    h.expect_nothing();
    let io = h
        .events
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Io(io) => Some(io.clone()),
            _ => None,
        })
        .expect("io");
    let outputs = io
        .groups
        .iter()
        .find(|g| g.name.starts_with("outputs"))
        .expect("outputs");
    assert_eq!(
        outputs.bits.iter().map(|b| b.value).collect::<Vec<_>>(),
        [false, true]
    );
    h.request(Request::SetOutput {
        output: OutputId {
            group: 3,
            bit: None,
        },
        value: 1,
    });
    h.expect_nothing();
    assert!(
        h.refusals()[0].contains("there is no output 3"),
        "{:?}",
        h.refusals()
    );
}

#[test]
fn a_jog_speeds_up_once_at_the_first_short_renewal() {
    let mut h = Harness::ready_at(10_000, 0, 0);
    // The first lease covers the terminal's repeat delay: slow.
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(750)));
    h.expect_text(&format!("#E9,{}", cap(ms(750))));
    h.reply(b"\r");
    h.expect(b"L9,x50000\x01");
    h.reply(b"\r");
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(150),
    });
    // `#E` cannot reach a running batch (manual 1.4.2): halted, not ended.
    h.expect(b"@B\r");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Jogging);
    h.run_ends();
    // Only the jog's axis is read before the restart: Y and Z stood.
    h.expect_text("@LX");
    h.reply(b"@LX10300\r");
    assert!(h.jog_ends().is_empty());
    // From where it stopped, as fast as asked: 1000 Hz is below cap(150 ms).
    assert!(cap(ms(150)) > 1_000);
    h.expect_text("#E9,1000");
    h.reply(b"\r");
    h.expect(b"L9,x49700\x01");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Jogging);
    // Once: the next repeats only renew.
    h.advance(ms(33));
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(150),
    });
    h.expect_nothing();
    h.advance(ms(149));
    h.expect_nothing();
    h.advance(ms(1));
    h.expect(b"@B\r");
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(10_500, 0, 0);
    assert_eq!(h.jog_ends(), [(1, JogEnd::DeadMan)]);
    assert_eq!(h.state().activity, Activity::Idle);
}

/// The jog halted with `@B` to speed up, then released (or stopped) before
/// the halt has been read back: the faster batch never goes out, the jog
/// ends as released (stopped), and nothing moves again.
#[test]
fn a_release_or_a_stop_during_the_speed_up_halt_starts_no_faster_batch() {
    for stop in [false, true] {
        let mut h = Harness::ready_at(10_000, 0, 0);
        h.request(jog(1, vec![(Axis::X, Dir::Plus)], 1_000.0, ms(750)));
        h.expect_text(&format!("#E9,{}", cap(ms(750))));
        h.reply(b"\r");
        h.expect(b"L9,x50000\x01");
        h.reply(b"\r");
        h.advance(ms(500));
        h.request(Request::JogRenew {
            id: JogId(1),
            lease: ms(150),
        });
        h.expect(b"@B\r");
        h.reply(b"\r");
        let end = if stop {
            assert_eq!(h.stop(), b"@B\r");
            h.reply(b"\r");
            JogEnd::Stopped
        } else {
            h.request(Request::JogRelease { id: JogId(1) });
            JogEnd::Released
        };
        h.run_ends();
        h.positions_read(10_300, 0, 0);
        assert_eq!(h.jog_ends(), [(1, end)], "stop: {stop}");
        h.advance(ms(1_000));
        let sent: String = h.sent.iter().map(|m| crate::traffic::readable(m)).collect();
        assert!(
            !sent.contains("#E9,1000") && sent.matches("L9,").count() == 1,
            "stop: {stop}: {sent}"
        );
        assert_eq!(h.state().activity, Activity::Idle, "stop: {stop}");
    }
}

#[test]
fn a_renewal_is_granted_no_longer_lease_than_the_speed_allows() {
    let mut h = Harness::ready_at(10_000, 0, 0);
    h.request(jog(1, vec![(Axis::X, Dir::Plus)], 2_000.0, ms(150)));
    let hz = cap(ms(150));
    h.expect_text(&format!("#E9,{hz}"));
    h.reply(b"\r");
    h.expect(b"L9,x50000\x01");
    h.reply(b"\r");
    h.advance(ms(100));
    // A toggle tick or a late repeat asking for 750 ms at this speed.
    h.request(Request::JogRenew {
        id: JogId(1),
        lease: ms(750),
    });
    let s = settings();
    let bound = s.limits(Axis::X).expect("X").max_overrun;
    let allowed = crate::motion::lease_cap(&s.braking(), f64::from(hz), bound);
    assert!(allowed < ms(151), "{allowed:?}");
    h.advance(ms(149));
    h.expect_nothing();
    h.advance(allowed - ms(149));
    h.expect(b"@B\r");
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(10_400, 0, 0);
    assert_eq!(h.jog_ends(), [(1, JogEnd::DeadMan)]);
}

#[test]
fn a_jog_off_a_limit_switch_is_refused_with_its_reason_and_nothing_moves() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::LimitJog {
        id: JogId(5),
        axis: Axis::X,
        dir: Dir::Plus,
    });
    h.expect_nothing();
    assert_eq!(
        h.jog_ends(),
        [(5, JogEnd::Refused(refusal_reasons(&h.events)[0].clone()))]
    );
    let refusals = h.refusals();
    assert!(
        refusals
            .iter()
            .any(|r| r.contains("the EMCU reports no limit switches")),
        "{refusals:?}"
    );
}
