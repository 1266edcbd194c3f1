//! The driver against the isel simulator model in memory: no I/O, synthetic
//! time, both directions of the wire modelled at 19200 baud. What the driver
//! believes is compared with what the simulated controller holds.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{
    Activity, Dir, Event, JogEnd, JogId, PerAxis, PositionSource, ProgramState, Recovery, Request,
    UploadEvent,
};
use crate::device::isel::{IselDriver, IselSettings, PollRate};
use crate::sim::InputControl;
use crate::sim::isel::IselSim;
use crate::wire::LineSettings;

use super::harness::{ms, speeds};

/// The isel driver and simulator joined by a modelled wire at 19200 baud.
pub(super) type Bench = crate::device::common::testing::Bench<IselDriver, IselSim>;

pub(super) fn bench(rate: PollRate) -> Bench {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let mut settings = IselSettings::from_profile(&profile).expect("settings");
    settings.poll.rate = rate;
    let sim = IselSim::from_profile(&profile).expect("simulator");
    Bench::new(IselDriver::new(settings), sim, LineSettings::new(19200))
}

pub(super) trait IselBench {
    fn counters(&self) -> [f64; 4];
    fn set(&mut self, name: &str, level: bool);
}

impl IselBench for Bench {
    fn counters(&self) -> [f64; 4] {
        self.sim.counters_at(self.now)
    }

    fn set(&mut self, name: &str, level: bool) {
        self.control(InputControl::Set {
            name: name.into(),
            level,
        });
    }
}

/// Initialise and reference a fresh controller.
pub(super) fn homed(rate: PollRate) -> Bench {
    let mut b = bench(rate);
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(Duration::from_secs(120));
    assert_eq!(b.driver.state().referenced, AxisSet::XYZ, "{:?}", b.events);
    b.events.clear();
    b
}

#[test]
fn a_fresh_controller_reads_back_uninitialised_and_its_positions() {
    let mut b = bench(PollRate::Off);
    b.run(ms(500));
    let s = b.driver.state().clone();
    assert!(s.link_up);
    assert_eq!(s.initialised, AxisSet::EMPTY);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    // The simulator reports its counters even without axes.
    let p = b.last_measured().expect("position");
    assert_eq!(p.get(Axis::X), Some(b.counters()[0] as i64));
    assert!(b.sim.physical_positions(b.now)[0] > 15_000.0);
}

#[test]
fn initialise_and_home_reference_the_axes_at_zero() {
    let mut b = homed(PollRate::Off);
    b.run(ms(100));
    assert_eq!(b.counters()[..3], [0.0, 0.0, 0.0]);
    let s = b.driver.state();
    assert_eq!(s.initialised, AxisSet::XYZ);
    assert!(s.fault.is_none());
    // The virtual zero is back at the reference point (manual 2.2.19): a
    // move taught now (`m`, counted from it) needs no `z` first.
    assert_eq!(s.work_zero.axes(), AxisSet::XYZ);
    assert!(s.work_zero.iter().all(|(_, z)| z == 0), "{:?}", s.work_zero);
}

#[test]
fn the_estimate_follows_the_controllers_counters() {
    let mut b = homed(PollRate::Off);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 20_000).with(Axis::Y, 8_000),
        speed_hz: speeds(8_000.0),
    });
    for _ in 0..30 {
        b.run(ms(40));
        let estimate = b.events.iter().rev().find_map(|e| match e {
            Event::Position(p) if p.source == PositionSource::Estimated => Some(*p),
            _ => None,
        });
        if let Some(p) = estimate {
            let real = b.sim.counters_at(p.at);
            let dx = (p.steps.get(Axis::X).unwrap_or(0) as f64 - real[0]).abs();
            let dy = (p.steps.get(Axis::Y).unwrap_or(0) as f64 - real[1]).abs();
            // The estimate starts when the command's last byte goes out, the
            // controller when its CR has arrived: one byte time at most.
            assert!(
                dx <= 8.0 && dy <= 4.0,
                "estimate {p:?} vs counters {real:?}"
            );
        }
    }
    b.run(Duration::from_secs(2));
    assert_eq!(
        b.last_measured(),
        Some(
            PerAxis::new()
                .with(Axis::X, 20_000)
                .with(Axis::Y, 8_000)
                .with(Axis::Z, 0)
        )
    );
}

#[test]
fn a_jog_left_without_renewal_stops_and_cannot_be_resumed() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::Y, Dir::Plus)],
        speed_hz: speeds(4_000.0),
        lease: ms(300),
    });
    b.run(ms(600));
    let ended = b.events.iter().find_map(|e| match e {
        Event::JogEnded { id, end } => Some((*id, end.clone())),
        _ => None,
    });
    assert_eq!(ended, Some((JogId(1), JogEnd::DeadMan)));
    let stopped = b.counters()[1];
    assert!(stopped > 500.0 && stopped < 1_500.0, "{stopped}");
    assert_eq!(
        b.last_measured().and_then(|p| p.get(Axis::Y)),
        Some(stopped as i64)
    );
    // The break discarded the rest: a start finds nothing to resume.
    b.request(Request::Raw { line: "@0S".into() });
    b.run(ms(200));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Fault(f) if f.code == "G"))
    );
    assert_eq!(b.counters()[1], stopped);
}

#[test]
fn stop_during_polling_ends_a_move_and_the_position_is_read() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 100_000),
        frame: crate::device::api::Frame::Machine,
        speed_hz: speeds(10_000.0),
    });
    b.run(ms(700));
    b.stop();
    b.run(ms(300));
    let x = b.counters()[0];
    assert!(x > 1_000.0 && x < 100_000.0, "{x}");
    assert_eq!(
        b.last_measured().and_then(|p| p.get(Axis::X)),
        Some(x as i64)
    );
    assert!(b.driver.state().fault.is_none());
}

#[test]
fn a_limit_switch_during_a_move_answers_2_and_costs_init_and_reference() {
    let mut b = homed(PollRate::Off);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 40_000),
        speed_hz: speeds(4_000.0),
    });
    b.run(ms(500));
    b.set("limit-x2", true);
    b.run(ms(200));
    let s = b.driver.state().clone();
    assert_eq!(s.fault.as_ref().map(|f| f.code.as_str()), Some("2"));
    assert_eq!(s.initialised, AxisSet::EMPTY);
    b.set("limit-x2", false);
    b.events.clear();
    b.request(Request::Initialise);
    b.run(ms(500));
    assert_eq!(
        b.driver.state().fault.as_ref().map(|f| f.recovery),
        Some(Recovery::Reference)
    );
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(Duration::from_secs(120));
    assert!(b.driver.state().fault.is_none());
}

#[test]
fn a_program_is_stored_and_run() {
    let mut b = homed(PollRate::Off);
    b.request(Request::Upload {
        lines: vec![
            "0400,1000,0,1000,0,1000,0,1000".into(),
            "133".into(),
            "0-400,1000,0,1000,0,1000,0,1000".into(),
        ],
        erase_first: true,
    });
    b.run(Duration::from_secs(5));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Upload(UploadEvent::Finished { total: 3, .. }))),
        "{:?}",
        b.events
    );
    assert_eq!(b.driver.state().program, ProgramState::Stored);
    b.request(Request::RunProgram);
    b.run(Duration::from_secs(3));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Notice(n) if n == "program sync character `!`"))
    );
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Notice(n) if n == "the program has ended"))
    );
    assert_eq!(b.last_measured().and_then(|p| p.get(Axis::X)), Some(0));
}

#[test]
fn a_stopped_upload_leaves_an_invalid_program() {
    let mut b = homed(PollRate::Off);
    let lines: Vec<String> = (0..200).map(|i| format!("1{}", 33 + i % 60)).collect();
    b.request(Request::Upload {
        lines,
        erase_first: true,
    });
    b.run(ms(300));
    b.stop();
    b.run(ms(300));
    let aborted = b.events.iter().find_map(|e| match e {
        Event::Upload(UploadEvent::Aborted { done, .. }) => Some(*done),
        _ => None,
    });
    assert!(aborted.is_some_and(|d| d > 0 && d < 200), "{:?}", b.events);
    assert_eq!(b.driver.state().program, ProgramState::Invalid);
    let stored = b.sim.flash().program.clone().expect("a partial program");
    assert!(!stored.valid, "never a valid-looking partial program");
    // Back in DNC mode: a poll is answered.
    b.request(Request::Raw { line: "@0P".into() });
    b.run(ms(100));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Reply { command, .. } if command == "@0P"))
    );
}

#[test]
fn polling_at_line_speed_reaches_the_wire_limit() {
    let mut b = homed(PollRate::LineSpeed);
    b.run(Duration::from_secs(3));
    let stats: Vec<_> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Stats(s) => Some(*s),
            _ => None,
        })
        .collect();
    let last = stats.last().expect("stats");
    // @0P and ports 1, 3, 2 every 4th cycle: 23 + 24 / 4 = 29 bytes a cycle.
    assert!(
        last.position_rate_hz > 0.97 * last.wire_limit_hz,
        "{last:?}"
    );
}

/// Safety audit (docs/safety-tests.md): a reference run stopped half way
/// stands, is never resumed and does not count.
#[test]
fn a_stop_during_homing_halts_the_run_and_nothing_resumes() {
    let mut b = bench(PollRate::LineSpeed);
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(ms(1_000));
    assert_eq!(b.driver.state().activity, Activity::Homing);
    let before = b.counters();
    b.run(ms(100));
    assert_ne!(b.counters(), before, "homing moves");
    b.stop();
    b.run(Duration::from_secs(2));
    let at = b.counters();
    b.run(Duration::from_secs(60));
    assert_eq!(b.counters(), at, "nothing resumed");
    assert_eq!(b.driver.state().activity, Activity::Idle);
    assert_ne!(b.driver.state().referenced, AxisSet::XYZ);
}

/// Safety audit (docs/safety-tests.md): a stored program stopped while it
/// runs stands and the rest of it never runs.
#[test]
fn a_stop_during_a_running_program_halts_it_and_nothing_resumes() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Upload {
        lines: vec![
            "04000,1000,0,1000,0,1000,0,1000".into(),
            "00,1000,4000,1000,0,1000,0,1000".into(),
        ],
        erase_first: true,
    });
    b.run(Duration::from_secs(5));
    assert_eq!(b.driver.state().program, ProgramState::Stored);
    b.request(Request::RunProgram);
    b.run(ms(1_000));
    let before = b.counters();
    b.run(ms(100));
    assert_ne!(b.counters(), before, "the program moves");
    b.stop();
    b.run(Duration::from_secs(2));
    let at = b.counters();
    assert!(at[0] > 0.0 && at[0] < 4_000.0, "{at:?}");
    b.run(Duration::from_secs(60));
    assert_eq!(b.counters(), at, "nothing resumed");
    assert_eq!(at[1], 0.0, "the second line never ran");
    assert_eq!(b.driver.state().activity, Activity::Idle);
}

/// The speed-up at the first repeat stops the move and sends a faster one
/// from where it ended (manual 2.2.2): the axis stands between them for
/// the `F`, the quiet after it, `@0P` and the faster move's bytes, all at
/// 19200 baud (`docs/jogging.md`, "Speed caps").
#[test]
fn a_hold_stands_still_once_and_briefly_at_its_first_repeat() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(6_000.0),
        lease: ms(750),
    });
    let trace = b.hold_trace(JogId(1), ms(150), ms(500), ms(1500), |sim, t| {
        sim.counters_at(t)[0]
    });
    let still = crate::motion::standstill::standstill(&trace);
    eprintln!("isel: standing still {still:?} at the first repeat");
    assert!(still > ms(5) && still < ms(60), "{still:?}");
}

/// Initialise a fresh controller (not referenced) whose driver starts
/// stored programs jogterm does not know as `policy` says.
fn initialised(policy: crate::config::StartUnreferenced) -> Bench {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let mut settings = IselSettings::from_profile(&profile).expect("settings");
    settings.poll.rate = PollRate::Off;
    settings.start_unreferenced = policy;
    let sim = IselSim::from_profile(&profile).expect("simulator");
    let mut b = Bench::new(IselDriver::new(settings), sim, LineSettings::new(19200));
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    assert_eq!(
        b.driver.state().referenced,
        AxisSet::EMPTY,
        "{:?}",
        b.events
    );
    b.events.clear();
    b
}

fn store(b: &mut Bench, lines: &[&str]) {
    b.request(Request::Upload {
        lines: lines.iter().map(|l| (*l).to_owned()).collect(),
        erase_first: true,
    });
    b.run(Duration::from_secs(5));
    assert_eq!(
        b.driver.state().program,
        ProgramState::Stored,
        "{:?}",
        b.events
    );
    b.events.clear();
}

fn not_referenced(b: &Bench) -> bool {
    crate::device::common::testing::refusal_reasons(&b.events)
        .iter()
        .any(|r| matches!(r, crate::device::api::Refusal::NotReferenced { .. }))
}

/// Issue 24: a program jogterm stored that begins with the reference run of
/// every axis (`7 7`, manual 3.2.8; settings may come first) starts on an
/// unreferenced controller, runs, and leaves the axes referenced.
#[test]
fn a_stored_program_that_references_its_axes_first_starts_unreferenced() {
    use crate::config::StartUnreferenced::Refuse;
    let mut b = initialised(Refuse);
    store(&mut b, &["j300", "7 7", "0400,1000,0,1000,0,1000,0,1000"]);
    b.request(Request::RunProgram);
    b.run(Duration::from_secs(60));
    assert!(!not_referenced(&b), "{:?}", b.events);
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Notice(n) if n == "the program has ended")),
        "{:?}",
        b.events
    );
    assert_eq!(b.driver.state().referenced, AxisSet::XYZ);
    assert_eq!(b.last_measured().and_then(|p| p.get(Axis::X)), Some(400));
}

/// What stays refused on axes not referenced: a program jogterm stored whose
/// reference run covers only some axes or comes after a move, and a program
/// jogterm does not know (stored by hand) unless the profile allows it.
#[test]
fn programs_that_do_not_reference_their_axes_first_stay_refused() {
    use crate::config::StartUnreferenced::{Allow, Refuse};
    for lines in [
        &["71", "0400,1000,0,1000,0,1000,0,1000"][..],
        &["0400,1000,0,1000,0,1000,0,1000", "7 7"][..],
        &["5 1", "7 7"][..],
    ] {
        let mut b = initialised(Refuse);
        store(&mut b, lines);
        b.request(Request::RunProgram);
        b.run(ms(500));
        assert!(not_referenced(&b), "{lines:?}: {:?}", b.events);
        assert_eq!(b.driver.state().activity, Activity::Idle, "nothing runs");
    }
    // Stored with raw lines: jogterm does not know what it does.
    for (policy, refused) in [(Refuse, true), (Allow, false)] {
        let mut b = initialised(policy);
        for line in ["@0i", "77", "9"] {
            b.request(Request::Raw { line: line.into() });
            b.run(ms(300));
        }
        assert_eq!(b.driver.state().program, ProgramState::Stored);
        b.events.clear();
        b.request(Request::RunProgram);
        b.run(Duration::from_secs(60));
        assert_eq!(not_referenced(&b), refused, "{policy:?}: {:?}", b.events);
    }
}
