//! `F` in the console frames the G-code job open in the editor, through
//! `update`: the question first and nothing sent; yes sends Z up alone,
//! then each corner once the leg before has ended (the controller's state
//! going back to idle), in machine coordinates at the safe height; a stop
//! ends it and nothing resumes; a declined question arms nothing, so a jog
//! that follows is never taken for a leg; refused without a job, and
//! unreferenced.

use crate::ui_support;

use std::sync::Arc;
use std::time::Instant;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::device::api::{
    Activity, Event, Frame, MachineState, PerAxis, PositionSample, PositionSource, Request,
};
use jogterm::offsets::WorkOffsets;
use jogterm::program::Language;
use jogterm::proto::Protocol;
use jogterm::ui::editor::gcode_open::OpenJob;
use jogterm::ui::editor::job::Converted;
use jogterm::ui::editor::job_report::JobReport;
use jogterm::ui::model::Popup;
use jogterm::ui::{Effect, Model, Msg, update};
use ui_support::{State, model_in};

/// Cuts at Z 10 between X 10..30 and Y 20..25, entered from Z 30, left to Z 40.
const JOB: &str = "G21 G90\nG0 Z30\nG0 X10 Y20\nG1 Z10 F100\nG1 X30\nG1 Y25\nG0 Z40\nM2\n";

/// 400 steps a mm on every axis of the shipped isel profile.
fn steps(mm: f64) -> i64 {
    (mm * 400.0).round() as i64
}

/// The console on the isel profile with `JOB` open in the editor, as
/// Ctrl-O leaves it (the machine stands at X 112.345 Y 50 Z 0).
fn opened(t0: Instant) -> Model {
    let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
    let offsets = WorkOffsets::default();
    let import = jogterm::gcode::import(
        JOB,
        "part.nc",
        &profile,
        &offsets,
        jogterm::gcode::Target::Isel,
    )
    .expect("imports");
    let converted = Converted::new(
        "part.nc".into(),
        "part.nc".into(),
        import.program.clone(),
        import.summary.estimated_s,
        &profile,
        Language::Isel,
    );
    let report = JobReport::imported("part.nc", JOB, &import, &converted.ways);
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    m.keypad.offsets.table = offsets.clone();
    m.editor.job = Some(OpenJob {
        path: "part.nc".into(),
        source: Arc::from(JOB),
        height_map: None,
        offsets,
        tool: None,
        report,
        checking: false,
    });
    m
}

fn key(m: &mut Model, c: char) -> Vec<Effect> {
    update(
        m,
        Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE)),
    )
}

fn device(m: &mut Model, event: Event) -> Vec<Effect> {
    update(m, Msg::Device(event))
}

fn state(activity: Activity) -> Event {
    let axes: AxisSet = [Axis::X, Axis::Y, Axis::Z].into_iter().collect();
    Event::State(MachineState {
        link_up: true,
        initialised: axes,
        referenced: axes,
        activity,
        ..MachineState::default()
    })
}

fn at(m: &mut Model, x: i64, y: i64, z: i64) {
    device(
        m,
        Event::Position(PositionSample {
            at: Instant::now(),
            steps: PerAxis::new()
                .with(Axis::X, x)
                .with(Axis::Y, y)
                .with(Axis::Z, z),
            source: PositionSource::Measured,
        }),
    );
}

/// The go-to among `effects`: its target (machine steps).
fn goto(effects: &[Effect]) -> Option<(i64, i64, i64)> {
    effects.iter().find_map(|e| match e {
        Effect::Request(Request::MoveTo {
            target,
            frame: Frame::Machine,
            ..
        }) => Some((
            target.get(Axis::X)?,
            target.get(Axis::Y)?,
            target.get(Axis::Z)?,
        )),
        _ => None,
    })
}

/// The leg runs: moving, then standing at its end.
fn leg_ends(m: &mut Model, to: (i64, i64, i64)) -> Vec<Effect> {
    device(m, state(Activity::Moving));
    at(m, to.0, to.1, to.2);
    device(m, state(Activity::Idle))
}

fn message(m: &Model) -> String {
    m.message
        .as_ref()
        .map(|x| x.text.clone())
        .unwrap_or_default()
}

#[test]
fn f_asks_then_traces_z_up_alone_and_the_four_corners_leg_by_leg() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    let (x0, y0) = (44_938, 20_000);
    at(&mut m, x0, y0, 0);
    let asked = key(&mut m, 'F');
    assert!(
        asked.is_empty(),
        "nothing goes out before the answer: {asked:?}"
    );
    let Some(Popup::Confirm(c)) = &m.popup else {
        panic!("F asks first: {:?}", m.popup);
    };
    assert!(
        c.question
            .contains("X 10 to 30, Y 20 to 25 (machine) at Z 40"),
        "{}",
        c.question
    );
    let up = goto(&key(&mut m, 'y')).expect("yes sends the first leg");
    assert_eq!(
        up,
        (x0, y0, steps(40.0)),
        "Z up alone, X and Y where they stand"
    );
    let corners = [
        (10.0, 20.0),
        (30.0, 20.0),
        (30.0, 25.0),
        (10.0, 25.0),
        (10.0, 20.0),
    ];
    let mut here = up;
    for (n, (x, y)) in corners.into_iter().enumerate() {
        let next = goto(&leg_ends(&mut m, here)).unwrap_or_else(|| {
            panic!(
                "leg {} sent after the one before ended: {}",
                n + 2,
                message(&m)
            )
        });
        assert_eq!(next, (steps(x), steps(y), steps(40.0)), "corner {}", n + 1);
        here = next;
    }
    let last = leg_ends(&mut m, here);
    assert_eq!(goto(&last), None, "nothing after the first corner again");
    assert!(m.frame.is_none());
    assert!(message(&m).contains("frame traced"), "{}", message(&m));
}

#[test]
fn a_leg_is_sent_only_after_the_one_before_was_seen_moving() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    key(&mut m, 'F');
    assert!(goto(&key(&mut m, 'y')).is_some());
    // An idle report from before the move began ends no leg.
    assert_eq!(goto(&device(&mut m, state(Activity::Idle))), None);
    assert!(m.frame.is_some());
}

#[test]
fn a_stop_ends_the_frame_and_nothing_resumes() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    key(&mut m, 'F');
    let up = goto(&key(&mut m, 'y')).expect("first leg");
    device(&mut m, state(Activity::Moving));
    let stopped = key(&mut m, ' ');
    assert!(stopped.contains(&Effect::Stop), "{stopped:?}");
    assert!(m.frame.is_none());
    assert_eq!(goto(&leg_ends(&mut m, up)), None, "no leg after a stop");
}

#[test]
fn a_declined_frame_arms_nothing_and_a_jog_after_it_is_no_leg() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    key(&mut m, 'F');
    key(&mut m, 'n');
    assert!(m.frame.is_none());
    assert_eq!(goto(&leg_ends(&mut m, (44_000, 20_000, 0))), None);
}

#[test]
fn an_answer_after_the_axes_moved_starts_nothing() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    key(&mut m, 'F');
    // Moved between the question and the answer (the first leg, Z alone
    // up, would keep X and Y where they stood at the question).
    at(&mut m, 40_000, 20_000, 0);
    assert_eq!(goto(&key(&mut m, 'y')), None);
    assert!(m.frame.is_none());
    assert!(message(&m).contains("the axes moved"), "{}", message(&m));
}

#[test]
fn a_second_frame_skips_the_corner_the_tool_already_stands_above() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, steps(10.0), steps(20.0), steps(40.0));
    key(&mut m, 'F');
    let first = goto(&key(&mut m, 'y')).expect("a leg");
    assert_eq!(
        first,
        (steps(30.0), steps(20.0), steps(40.0)),
        "corner 2 first"
    );
}

#[test]
fn refused_without_a_job_unreferenced_or_outside_the_soft_limits() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    m.editor.job = None;
    assert!(key(&mut m, 'F').is_empty());
    assert!(
        message(&m).contains("no G-code job is open"),
        "{}",
        message(&m)
    );

    let mut m = opened(t0);
    let mut s = MachineState {
        link_up: true,
        initialised: [Axis::X, Axis::Y, Axis::Z].into_iter().collect(),
        ..MachineState::default()
    };
    s.referenced = [Axis::X, Axis::Y].into_iter().collect();
    device(&mut m, Event::State(s));
    assert!(key(&mut m, 'F').is_empty());
    assert!(m.popup.is_none());
    assert!(message(&m).contains("frame refused"), "{}", message(&m));

    let mut m = opened(t0);
    if let Some(f) = m
        .editor
        .job
        .as_mut()
        .and_then(|j| j.report.figures.as_mut())
        .and_then(|f| f.frame.as_mut().ok())
    {
        f.max_x = 400.0;
    }
    assert!(key(&mut m, 'F').is_empty());
    assert!(m.popup.is_none());
    assert!(
        message(&m).contains("outside the soft limits"),
        "{}",
        message(&m)
    );
}

/// The holds among `effects`: each `Request::Hold`'s lease in ms.
fn holds(effects: &[Effect]) -> Vec<u128> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Request(Request::Hold { lease }) => Some(lease.as_millis()),
            _ => None,
        })
        .collect()
}

#[test]
fn f_held_runs_the_frame_without_a_question_and_each_repeat_renews_the_hold() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    let first = key(&mut m, 'f');
    assert!(m.popup.is_none(), "no question: {:?}", m.popup);
    // The hold goes before the leg, for the terminal's delay before its
    // first repeat (the profile's first_repeat_grace_ms).
    assert_eq!(holds(&first), [750]);
    let hold_at = first
        .iter()
        .position(|e| matches!(e, Effect::Request(Request::Hold { .. })));
    let leg_at = first
        .iter()
        .position(|e| matches!(e, Effect::Request(Request::MoveTo { .. })));
    assert!(hold_at < leg_at, "{first:?}");
    let up = goto(&first).expect("the way up");
    // A repeat renews the hold for the repeat timeout, and starts nothing.
    let repeat = key(&mut m, 'f');
    assert_eq!(holds(&repeat), [150]);
    assert_eq!(goto(&repeat), None);
    // The next leg once the first ended, the hold still held.
    assert!(goto(&leg_ends(&mut m, up)).is_some());
    // The device task's hold ran out: the frame ends, the idle after the
    // stop sends no leg.
    let lapsed = device(&mut m, Event::HoldLapsed);
    assert!(m.frame.is_none());
    assert!(goto(&lapsed).is_none());
    assert!(message(&m).contains("frame stopped"), "{}", message(&m));
    device(&mut m, state(Activity::Moving));
    assert_eq!(goto(&device(&mut m, state(Activity::Idle))), None);
}

#[test]
fn a_release_of_f_stops_the_frame_and_f_held_past_its_end_starts_nothing() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    assert!(goto(&key(&mut m, 'f')).is_some());
    let mut release = KeyEvent::new(KeyCode::Char('f'), KeyModifiers::NONE);
    release.kind = crossterm::event::KeyEventKind::Release;
    let released = update(&mut m, Msg::Key(release));
    assert!(released.contains(&Effect::Stop), "{released:?}");
    assert!(m.frame.is_none());

    // Traced to its end with the key held: a repeat after the end starts
    // no second frame.
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    let mut here = goto(&key(&mut m, 'f')).expect("the way up");
    while let Some(next) = {
        key(&mut m, 'f');
        goto(&leg_ends(&mut m, here))
    } {
        here = next;
    }
    assert!(m.frame.is_none());
    let after = key(&mut m, 'f');
    assert!(after.is_empty(), "{after:?}");
    assert!(m.frame.is_none());
}

#[test]
fn ten_f_keys_read_together_start_no_frame_and_a_paste_moves_nothing() {
    let t0 = Instant::now();
    let mut m = opened(t0);
    at(&mut m, 44_938, 20_000, 0);
    let burst = update(
        &mut m,
        Msg::KeysAt(
            (0..10)
                .map(|_| (KeyEvent::new(KeyCode::Char('f'), KeyModifiers::NONE), t0))
                .collect(),
        ),
    );
    assert_eq!(goto(&burst), None, "{burst:?}");
    assert!(holds(&burst).is_empty(), "{burst:?}");
    assert!(m.frame.is_none());
    let pasted = update(&mut m, Msg::Paste("ffffffffff".into()));
    assert!(pasted.is_empty(), "{pasted:?}");
    assert!(m.frame.is_none());
}
