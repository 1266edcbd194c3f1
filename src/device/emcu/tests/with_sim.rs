//! The driver against the EMCU simulator model in memory: no I/O, synthetic
//! time, both directions of the wire modelled at 19200 baud. What the driver
//! believes is compared with what the simulated interface holds.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{
    Activity, Dir, Event, JogEnd, JogId, PerAxis, PositionSource, ProgramState, Recovery, Refusal,
    Request, UploadEvent,
};
use crate::device::common::PollRate;
use crate::device::common::testing::refusal_reasons;
use crate::device::driver::Driver;
use crate::device::emcu::{EmcuDriver, EmcuSettings, output_id};
use crate::proto::emcu::{EmcuAxis, Output};
use crate::sim::SimDevice;
use crate::sim::emcu::EmcuSim;
use crate::wire::LineSettings;

use super::harness::{ms, speeds};

pub(super) type Bench = crate::device::common::testing::Bench<EmcuDriver, EmcuSim>;

fn bench(rate: PollRate) -> Bench {
    let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
    let mut settings = EmcuSettings::from_profile(&profile).expect("settings");
    settings.poll.rate = rate;
    let sim = EmcuSim::from_profile(&profile).expect("simulator");
    Bench::new(EmcuDriver::new(settings), sim, LineSettings::new(19200))
}

pub(super) fn counters(b: &mut Bench) -> [i32; 3] {
    let now = b.now;
    EmcuAxis::ALL.map(|a| b.sim.counter(a, now))
}

fn a1() -> Output {
    Output::new(1).expect("A1")
}

fn a2() -> Output {
    Output::new(2).expect("A2")
}

fn secs(n: u64) -> Duration {
    Duration::from_secs(n)
}

/// Initialised and referenced.
pub(super) fn homed(rate: PollRate) -> Bench {
    let mut b = bench(rate);
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    b.request(Request::Home { axes: AxisSet::XYZ });
    // At the start speed (200 Hz) from 40 mm: 40 s an axis, one after the other.
    b.run(secs(200));
    assert_eq!(
        b.driver.state().referenced,
        AxisSet::XYZ,
        "{:?}",
        b.driver.state()
    );
    assert_eq!(b.driver.state().activity, Activity::Idle);
    b.events.clear();
    b
}

#[test]
fn a_fresh_interface_reads_back_position_unknown_and_refuses_moves() {
    let mut b = bench(PollRate::Off);
    b.run(ms(500));
    let s = b.driver.state().clone();
    assert!(s.link_up);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    assert_eq!(
        b.last_measured(),
        Some(
            PerAxis::new()
                .with(Axis::X, 0)
                .with(Axis::Y, 0)
                .with(Axis::Z, 0)
        )
    );
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100),
        speed_hz: speeds(500.0),
    });
    b.run(ms(100));
    let reasons = refusal_reasons(&b.events);
    assert!(
        matches!(
            reasons.as_slice(),
            [Refusal::NotInitialised
                | Refusal::NotReferenced { .. }
                | Refusal::Fault {
                    recovery: Recovery::Reference
                }]
        ),
        "{reasons:?}"
    );
    // Nothing moved.
    assert_eq!(counters(&mut b), [0, 0, 0]);
    assert!(!b.sim.status(b.now).moving);
}

#[test]
fn initialise_and_home_reference_every_axis_at_zero() {
    let mut b = homed(PollRate::Off);
    b.run(ms(100));
    assert_eq!(counters(&mut b), [0, 0, 0]);
    // Every carriage stands next to its reference switch.
    for axis in EmcuAxis::ALL {
        let now = b.now;
        assert!(b.sim.machine_position(axis, now).abs() < 100, "{axis:?}");
    }
    assert!(b.driver.state().fault.is_none());
    // One reference run, Z first, then Y, then X.
    let homes: Vec<String> = b
        .sent_text()
        .into_iter()
        .filter(|t| t.starts_with("$H"))
        .collect();
    assert_eq!(homes, ["$HZYX<01>"]);
}

#[test]
fn positions_are_measured_during_a_move_and_match_the_counters_at_its_end() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 4_000).with(Axis::Y, 2_000),
        speed_hz: speeds(1_000.0),
    });
    b.run(ms(1_500));
    assert!(b.sim.status(b.now).moving, "still moving after 1.5 s");
    let during: Vec<i64> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Position(p) => {
                assert_eq!(p.source, PositionSource::Measured);
                p.steps.get(Axis::X)
            }
            _ => None,
        })
        .collect();
    assert!(
        during.iter().filter(|x| **x > 0 && **x < 4_000).count() > 10,
        "{during:?}"
    );
    assert!(during.windows(2).all(|w| w[0] <= w[1]), "{during:?}");
    b.run(secs(5));
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_eq!(counters(&mut b), [4_000, 2_000, 0]);
    let last = b.last_measured().expect("measured");
    assert_eq!(last.get(Axis::X), Some(4_000));
    assert_eq!(last.get(Axis::Y), Some(2_000));
}

#[test]
fn a_stop_during_a_move_halts_with_the_ramp_and_keeps_the_reference() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 40_000),
        frame: crate::device::api::Frame::Machine,
        speed_hz: speeds(2_000.0),
    });
    b.run(ms(1_500));
    assert!(b.sim.status(b.now).moving);
    b.stop();
    b.run(secs(3));
    let st = b.sim.status(b.now);
    assert!(!st.moving && !st.position_unknown, "{st:?}");
    let x = counters(&mut b)[0];
    assert!(x > 0 && x < 40_000, "{x}");
    assert_eq!(b.driver.state().referenced, AxisSet::XYZ);
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_eq!(
        b.last_measured().and_then(|p| p.get(Axis::X)),
        Some(i64::from(x))
    );
    // The move was sent once.
    let moves = b.sent_text().iter().filter(|t| t.starts_with('L')).count();
    assert_eq!(moves, 1, "{:?}", b.sent_text());
}

#[test]
fn a_jog_whose_lease_runs_out_is_halted_inside_the_soft_limits() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(1_000.0),
        lease: ms(400),
    });
    b.run(ms(300));
    assert!(b.sim.status(b.now).moving);
    b.run(secs(3));
    assert!(!b.sim.status(b.now).moving);
    let ends: Vec<_> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { id, end } => Some((*id, end.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(ends, [(JogId(1), JogEnd::DeadMan)]);
    let x = counters(&mut b)[0];
    assert!(x > 0 && x < 2_000, "{x}");
}

#[test]
fn a_jog_towards_the_limit_stops_at_the_soft_limit() {
    let mut b = homed(PollRate::LineSpeed);
    let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
    let z = profile.axes.get(&Axis::Z).expect("Z");
    let max = z.to_steps(z.max);
    b.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::Z, max - 300),
        frame: crate::device::api::Frame::Machine,
        speed_hz: speeds(1_000.0),
    });
    // 5 mm/s at most on Z: 15 700 steps at 1 kHz.
    b.run(secs(25));
    assert_eq!(i64::from(counters(&mut b)[2]), max - 300);
    // A lease so long that only the soft limit ends the jog; the speed its
    // overrun bound allows for it sets how long the last 300 steps take.
    let lease = secs(30);
    let hz = lease_speed(Axis::Z, lease).min(500.0);
    b.request(Request::Jog {
        id: JogId(2),
        axes: vec![(Axis::Z, Dir::Plus)],
        speed_hz: speeds(500.0),
        lease,
    });
    b.run(Duration::from_secs_f64(300.0 / hz) + secs(2));
    assert!(!b.sim.status(b.now).moving);
    assert_eq!(i64::from(counters(&mut b)[2]), max);
    let ends: Vec<_> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { id, end } => Some((*id, end.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(ends, [(JogId(2), JogEnd::SoftLimit)]);
}

fn settings() -> EmcuSettings {
    let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
    EmcuSettings::from_profile(&profile).expect("settings")
}

/// The jog speed (whole Hz) the overrun bound allows `axis` with `lease`.
fn lease_speed(axis: Axis, lease: Duration) -> f64 {
    let s = settings();
    let bound = s.limits(axis).expect("axis").max_overrun;
    crate::motion::speed_cap(&s.braking(), lease, bound).floor()
}

fn bound_and_top(axis: Axis) -> (f64, f64) {
    let l = settings().limits(axis).expect("axis");
    (l.max_overrun, l.max_hz)
}

/// The profile's dead-man leases: before the first key repeat, and after.
fn leases() -> (Duration, Duration) {
    let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
    (
        Duration::from_millis(profile.jog.first_repeat_grace_ms),
        Duration::from_millis(profile.jog.repeat_timeout_ms),
    )
}

fn sent_count(b: &Bench, prefix: &str) -> usize {
    b.sent_text()
        .iter()
        .filter(|t| t.starts_with(prefix))
        .count()
}

#[test]
fn a_tap_at_top_speed_stops_within_the_overrun_bound() {
    let mut b = homed(PollRate::LineSpeed);
    let (bound, top) = bound_and_top(Axis::X);
    let (grace, _) = leases();
    // Press, no repeat, no release (a tap on a terminal without release
    // events): the first lease runs out and the dead-man stops the axis.
    let from = counters(&mut b)[0];
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(top),
        lease: grace,
    });
    b.run(secs(3));
    assert!(!b.sim.status(b.now).moving);
    let overrun = f64::from(counters(&mut b)[0] - from);
    eprintln!("EMCU tap at {top} Hz: {overrun} steps after the press (bound {bound})");
    assert!(overrun > 0.0 && overrun <= bound, "{overrun} > {bound}");
    assert!(
        b.events.iter().any(|e| matches!(
            e,
            Event::JogEnded {
                end: JogEnd::DeadMan,
                ..
            }
        )),
        "{:?}",
        b.events
    );
}

#[test]
fn a_hold_speeds_up_once_and_stops_within_the_bound_after_its_last_repeat() {
    let mut b = homed(PollRate::LineSpeed);
    let (bound, top) = bound_and_top(Axis::X);
    let (grace, repeat) = leases();
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(top),
        lease: grace,
    });
    // The terminal's repeat delay, then repeats at 30 Hz for 3 s.
    b.run(ms(500));
    let mut resumed = None;
    let first_repeat = b.now;
    for i in 0..90 {
        if i > 0 {
            b.run(ms(33));
        }
        if resumed.is_none() && sent_count(&b, "L9") == 2 {
            resumed = Some(b.now - first_repeat);
        }
        b.request(Request::JogRenew {
            id: JogId(1),
            lease: repeat,
        });
    }
    let last = counters(&mut b)[0];
    // One halt to speed up, and the faster move as fast as the short
    // lease allows (or as asked).
    assert_eq!(sent_count(&b, "L9"), 2, "{:?}", b.sent_text());
    assert_eq!(sent_count(&b, "@B"), 1, "{:?}", b.sent_text());
    let fast = lease_speed(Axis::X, repeat).min(top);
    assert!(fast > lease_speed(Axis::X, grace));
    assert_eq!(
        sent_count(&b, &format!("#E9,{fast}")),
        1,
        "{:?}",
        b.sent_text()
    );
    eprintln!("EMCU speed-up: the faster move went out {resumed:?} after the first repeat");
    b.run(secs(3));
    assert!(!b.sim.status(b.now).moving);
    let overrun = f64::from(counters(&mut b)[0] - last);
    eprintln!("EMCU hold at {fast} Hz: {overrun} steps after the last repeat (bound {bound})");
    assert!(overrun > 0.0 && overrun <= bound, "{overrun} > {bound}");
}

#[test]
fn outputs_switch_on_the_interface() {
    let mut b = homed(PollRate::Off);
    b.request(Request::SetOutput {
        output: output_id(a1()),
        value: 1,
    });
    b.run(ms(300));
    assert!(b.sim.output(a1()));
    assert!(!b.sim.output(a2()));
    b.request(Request::SetOutput {
        output: output_id(a1()),
        value: 0,
    });
    b.run(ms(300));
    assert!(!b.sim.output(a1()));
}

#[test]
fn an_uploaded_job_runs_and_ends() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Upload {
        lines: vec!["#E1,1000".into(), "L1,x1000".into(), "L1,y500".into()],
        erase_first: false,
    });
    b.run(ms(500));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Upload(UploadEvent::Finished { .. }))),
        "{:?}",
        b.events
    );
    assert_eq!(b.driver.state().program, ProgramState::Stored);
    // Storing ran nothing.
    assert_eq!(counters(&mut b), [0, 0, 0]);
    b.request(Request::RunProgram);
    b.run(ms(200));
    assert_eq!(b.driver.state().activity, Activity::RunningProgram);
    b.run(secs(10));
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_eq!(counters(&mut b), [1_000, 500, 0]);
    let last = b.last_measured().expect("measured");
    assert_eq!(last.get(Axis::X), Some(1_000));
    assert_eq!(last.get(Axis::Y), Some(500));
}

/// A running stored job paused with `@A` stands and keeps its rest; `@C`
/// takes it on to its target (manual 1.5.13, 1.5.14; `docs/editor.md`, "What
/// each family can do").
#[test]
fn a_stored_job_paused_with_at_a_stands_and_at_c_takes_it_to_its_end() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Upload {
        lines: vec!["#E1,1000".into(), "L1,x4000".into()],
        erase_first: false,
    });
    b.run(ms(500));
    b.request(Request::RunProgram);
    b.run(ms(1500));
    // Positions are read between the job's lines while it runs: its
    // progress (`docs/editor.md`).
    assert!(
        b.events.iter().any(|e| matches!(e,
            Event::Position(p) if p.source == PositionSource::Measured
                && p.steps.get(Axis::X).is_some_and(|x| x > 0 && x < 4_000))),
        "no position read during the job"
    );
    b.request(Request::Raw { line: "@A".into() });
    b.run(ms(1500));
    let paused = counters(&mut b);
    assert!(paused[0] > 0 && paused[0] < 4_000, "{paused:?}");
    b.run(ms(1000));
    assert_eq!(counters(&mut b), paused, "it stands while paused");
    assert_eq!(b.driver.state().activity, Activity::RunningProgram);
    b.request(Request::Raw { line: "@C".into() });
    b.run(secs(10));
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_eq!(counters(&mut b), [4_000, 0, 0]);
}

/// A job paused with `@A` is still motion that may start again: Space
/// (the stop, `@B`) ends it, and a `@C` after that moves nothing.
#[test]
fn a_stored_job_paused_with_at_a_is_ended_by_the_stop_and_at_c_then_moves_nothing() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Upload {
        lines: vec!["#E1,1000".into(), "L1,x4000".into()],
        erase_first: false,
    });
    b.run(ms(500));
    b.request(Request::RunProgram);
    b.run(ms(1500));
    b.request(Request::Raw { line: "@A".into() });
    b.run(ms(1500));
    let paused = counters(&mut b);
    assert!(paused[0] > 0 && paused[0] < 4_000, "{paused:?}");
    b.stop();
    b.run(ms(1000));
    assert_eq!(b.driver.state().activity, Activity::Idle);
    let stopped = counters(&mut b);
    b.request(Request::Raw { line: "@C".into() });
    b.run(secs(5));
    assert_eq!(counters(&mut b), stopped, "nothing resumes the stopped job");
}

#[test]
fn a_bad_raw_line_is_refused_and_never_reaches_the_interface() {
    let mut b = homed(PollRate::Off);
    let before = b.sent.len();
    b.request(Request::Raw {
        line: "L1,q100".into(),
    });
    b.run(ms(200));
    assert_eq!(b.sent.len(), before, "{:?}", b.sent_text());
    assert_eq!(refusal_reasons(&b.events).len(), 1);
    assert!(!b.sim.status(b.now).error);
}

#[test]
fn a_line_cut_by_a_broken_link_cannot_swallow_the_halt_on_reconnect() {
    let mut b = homed(PollRate::Off);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 40_000),
        speed_hz: speeds(2_000.0),
    });
    b.run(ms(1_500));
    assert!(b.sim.status(b.now).moving);
    // The link breaks with `@X` half sent: the interface holds `@X`.
    b.driver.disconnected("cut", b.now);
    let now = b.now;
    b.sim.on_byte(b'@', now);
    b.sim.on_byte(b'X', now);
    b.driver.connected(b.now);
    b.run(secs(3));
    let st = b.sim.status(b.now);
    assert!(!st.moving && !st.error, "{st:?}");
    assert_eq!(b.driver.state().referenced, AxisSet::XYZ);
}

/// Safety audit (docs/safety-tests.md): a reference run stopped half way
/// stands, is never resumed and references nothing it did not finish.
#[test]
fn a_stop_during_homing_halts_the_run_and_nothing_resumes() {
    let mut b = bench(PollRate::LineSpeed);
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(secs(5));
    assert_eq!(b.driver.state().activity, Activity::Homing);
    assert!(b.sim.status(b.now).moving);
    b.stop();
    b.run(secs(3));
    assert!(!b.sim.status(b.now).moving, "{:?}", b.sim.status(b.now));
    let at = counters(&mut b);
    b.run(secs(60));
    assert!(!b.sim.status(b.now).moving);
    assert_eq!(counters(&mut b), at, "nothing resumed");
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_eq!(b.driver.state().referenced, AxisSet::EMPTY);
    let runs = b.sent_text().iter().filter(|t| t.starts_with("$H")).count();
    assert_eq!(runs, 1, "{:?}", b.sent_text());
}

/// Safety audit (docs/safety-tests.md): a stored job stopped while it runs
/// stands and its remaining lines never run.
#[test]
fn a_stop_during_a_running_job_halts_it_and_nothing_resumes() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Upload {
        lines: vec!["#E1,1000".into(), "L1,x20000".into(), "L1,y20000".into()],
        erase_first: false,
    });
    b.run(ms(500));
    assert_eq!(b.driver.state().program, ProgramState::Stored);
    b.request(Request::RunProgram);
    b.run(secs(2));
    assert_eq!(b.driver.state().activity, Activity::RunningProgram);
    assert!(b.sim.status(b.now).moving);
    b.stop();
    b.run(secs(3));
    assert!(!b.sim.status(b.now).moving, "{:?}", b.sim.status(b.now));
    let at = counters(&mut b);
    assert!(at[0] > 0 && at[0] < 20_000, "{at:?}");
    b.run(secs(60));
    assert!(!b.sim.status(b.now).moving);
    assert_eq!(counters(&mut b), at, "nothing resumed");
    assert_eq!(at[1], 0, "the second line never ran");
    assert_eq!(b.driver.state().activity, Activity::Idle);
}

/// The speed-up at the first repeat halts the batch and sends a faster one
/// (`#E` is buffered, manual 1.4.2): the axis stands between them for the
/// run's end, `@X`, the jog's own `@LX`, `#E` and `L` (`docs/jogging.md`).
#[test]
fn a_hold_stands_still_once_and_briefly_at_its_first_repeat() {
    let mut b = homed(PollRate::LineSpeed);
    let (_, top) = bound_and_top(Axis::X);
    let (grace, repeat) = leases();
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(top),
        lease: grace,
    });
    let trace = b.hold_trace(JogId(1), repeat, ms(500), ms(2500), |sim, t| {
        sim.machine_position(EmcuAxis::X, t) as f64
    });
    let still = crate::motion::standstill::standstill(&trace);
    eprintln!("EMCU: standing still {still:?} at the first repeat");
    assert!(still < ms(50), "{still:?}");
}
