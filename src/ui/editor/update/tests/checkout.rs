//! The check-out through `Editor::update`: refused before anything moves
//! when the linter or the DNC form say no, a hold that arms on its press
//! and runs from its first repeat, lines one after the other while held,
//! a pause and its resume, single step, the speed factor, a line the
//! controller refuses, a lost link, run from a line.

use super::*;
use crate::device::api::{CheckoutEnd, JogId, LinkState};
use crate::jog::KeyPhase;

const PROGRAM: &str = "; check\n\
    0 4000,2000,0,2000,0,2000,0,2000\n\
    0 0,2000,4000,2000,0,2000,0,2000\n\
    9\n";

fn checkout_lines(out: &Outcome) -> Vec<(JogId, String, Option<JogId>)> {
    requests(out)
        .into_iter()
        .filter_map(|r| match r {
            Request::Checkout {
                id, line, resume, ..
            } => Some((*id, line.clone(), *resume)),
            _ => None,
        })
        .collect()
}

fn hold(host: &mut Host, e: &mut Editor, after_ms: u64) -> Outcome {
    host.now += Duration::from_millis(after_ms);
    host.send(e, Input::Checkout(Action::CheckoutHold, KeyPhase::Press))
}

fn end(host: &mut Host, e: &mut Editor, id: JogId, end: CheckoutEnd) -> Outcome {
    host.send(e, Input::Device(&Event::Checkout { id, end }))
}

/// The check-out of `text` asked for and confirmed.
fn started(host: &mut Host, text: &str) -> Editor {
    let mut e = editing(host, text);
    let out = host.key(&mut e, Action::Checkout);
    assert!(
        matches!(&out.dialog, Some(Dialog::Ask(q)) if q.yes == Answer::Checkout { from: None }),
        "{:?}",
        said(&out)
    );
    host.key(&mut e, Action::Confirm);
    assert!(e.checkout.is_some());
    e
}

#[test]
fn a_hold_runs_the_lines_in_dnc_form_one_after_the_other() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    // The press arms; nothing moves on a tap.
    let out = hold(&mut host, &mut e, 0);
    assert!(requests(&out).is_empty(), "{:?}", out.effects);
    // The first repeat runs line 2 (command 1).
    let out = hold(&mut host, &mut e, 500);
    let lines = checkout_lines(&out);
    assert_eq!(lines.len(), 1);
    assert_eq!(lines[0].1, "@0A4000,2000,0,2000,0,2000,0,2000");
    assert_eq!(e.checkout.as_ref().and_then(|c| c.current_line()), Some(1));
    assert_eq!(e.buffer.cursor().line, 1, "the cursor follows the line");
    // Repeats renew its lease.
    let out = hold(&mut host, &mut e, 30);
    assert!(matches!(requests(&out)[..], [Request::JogRenew { id, .. }] if *id == lines[0].0));
    // Done while held: the next line goes at once.
    let out = end(
        &mut host,
        &mut e,
        lines[0].0,
        CheckoutEnd::Done { byte: None },
    );
    let next = checkout_lines(&out);
    assert_eq!(next[0].1, "@0A0,2000,4000,2000,0,2000,0,2000");
    host.now += Duration::from_millis(10);
    let out = end(
        &mut host,
        &mut e,
        next[0].0,
        CheckoutEnd::Done { byte: None },
    );
    assert!(checkout_lines(&out).is_empty());
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("check-out done: 2 lines")),
        "{:?}",
        said(&out)
    );
}

#[test]
fn a_pause_shows_paused_and_the_next_hold_resumes_the_same_line() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    let (id, text, _) = checkout_lines(&out).remove(0);
    // The repeats stop; the driver pauses the move (0xFD) and reads where.
    host.now += Duration::from_millis(400);
    let out = end(
        &mut host,
        &mut e,
        id,
        CheckoutEnd::Paused {
            dead_man: true,
            rest: true,
        },
    );
    assert!(
        said(&out)[0].starts_with("PAUSED at line 2"),
        "{:?}",
        said(&out)
    );
    assert_eq!(e.checkout.as_ref().map(|c| c.label()), Some("PAUSED"));
    // A new hold: press, then its first repeat resumes the same line.
    host.now += Duration::from_secs(2);
    assert!(checkout_lines(&hold(&mut host, &mut e, 0)).is_empty());
    let out = hold(&mut host, &mut e, 500);
    let resumed = checkout_lines(&out);
    assert_eq!(resumed.len(), 1);
    assert_eq!(resumed[0].1, text);
    assert_eq!(
        resumed[0].2,
        Some(id),
        "resumes the rest of the paused line"
    );
    assert_eq!(e.checkout.as_ref().and_then(|c| c.current_line()), Some(1));
}

#[test]
fn single_step_runs_one_line_per_press_and_the_factor_scales_the_speeds() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    host.send(
        &mut e,
        Input::Checkout(Action::CheckoutSingle, KeyPhase::Press),
    );
    for _ in 0..5 {
        host.send(
            &mut e,
            Input::Checkout(Action::CheckoutSlower, KeyPhase::Press),
        );
    }
    assert_eq!(e.checkout.as_ref().map(|c| c.factor), Some(50));
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    let (id, text, _) = checkout_lines(&out).remove(0);
    assert_eq!(text, "@0A4000,1000,0,1000,0,1000,0,1000");
    let out = end(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    assert!(checkout_lines(&out).is_empty(), "single step: one line");
    // Still held: nothing more until the key is let go.
    assert!(checkout_lines(&hold(&mut host, &mut e, 30)).is_empty());
    host.now += Duration::from_secs(1);
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    assert_eq!(
        checkout_lines(&out)[0].1,
        "@0A0,1000,4000,1000,0,1000,0,1000"
    );
}

#[test]
fn a_line_the_controller_refuses_stops_the_check_out_there_with_its_code() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    hold(&mut host, &mut e, 0);
    let (id, ..) = checkout_lines(&hold(&mut host, &mut e, 500)).remove(0);
    let fault = ControllerFault {
        command: "@0A4000,2000,0,2000,0,2000,0,2000".into(),
        code: "2".into(),
        meaning: "limit switch".into(),
        recovery: DeviceRecovery::ReinitialiseAndReference,
    };
    let out = end(&mut host, &mut e, id, CheckoutEnd::Fault(fault));
    assert!(
        said(&out)[0].contains("line 2: the controller answered 2 (limit switch)"),
        "{:?}",
        said(&out)
    );
    assert_eq!(e.checkout.as_ref().map(|c| c.label()), Some("STOPPED"));
    // Holding again moves nothing.
    host.now += Duration::from_secs(2);
    hold(&mut host, &mut e, 0);
    assert!(checkout_lines(&hold(&mut host, &mut e, 500)).is_empty());
}

#[test]
fn a_lost_link_stops_the_check_out_and_nothing_resumes() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    hold(&mut host, &mut e, 0);
    checkout_lines(&hold(&mut host, &mut e, 500));
    let out = host.send(
        &mut e,
        Input::Device(&Event::Link(LinkState::Lost {
            reason: "gone".into(),
        })),
    );
    assert!(said(&out)[0].contains("nothing resumes by itself"));
    host.send(&mut e, Input::Device(&Event::Link(LinkState::Connected)));
    host.now += Duration::from_secs(2);
    hold(&mut host, &mut e, 0);
    assert!(checkout_lines(&hold(&mut host, &mut e, 500)).is_empty());
}

#[test]
fn a_program_the_linter_rejects_or_with_lines_without_a_dnc_form_does_not_start() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, "0 1,900\n9\n");
    let out = host.key(&mut e, Action::Checkout);
    assert!(out.dialog.is_none());
    assert!(
        said(&out)[0].starts_with("check-out refused: 1 error"),
        "{:?}",
        said(&out)
    );
    let mut host = Host::isel();
    let mut e = editing(&mut host, "2 65,2\n0 1,900,0,900,0,900,0,900\n9\n");
    let out = host.key(&mut e, Action::Checkout);
    assert!(out.dialog.is_none());
    assert!(
        said(&out)[0].contains("line 1: `2` waits"),
        "{:?}",
        said(&out)
    );
}

#[test]
fn run_from_a_line_shows_the_start_and_goes_there_first() {
    let mut host = Host::isel();
    host.measured(
        PerAxis::new()
            .with(Axis::X, 0)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0),
    );
    let mut e = editing(&mut host, PROGRAM);
    e.buffer
        .move_to(crate::ui::editor::buffer::Cursor::new(2, 0));
    let out = host.key(&mut e, Action::CheckoutFromLine);
    let Some(Dialog::Ask(q)) = &out.dialog else {
        panic!("{:?}", said(&out));
    };
    assert!(
        q.text.contains("from line 3: 1 move before it skipped"),
        "{}",
        q.text
    );
    assert!(q.text.contains("Start position (work): X"), "{}", q.text);
    host.key(&mut e, Action::Confirm);
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    let (id, text, _) = checkout_lines(&out).remove(0);
    assert!(text.starts_with("@0M4000,"), "{text}");
    let out = end(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    assert_eq!(
        checkout_lines(&out)[0].1,
        "@0A0,2000,4000,2000,0,2000,0,2000"
    );
}

#[test]
fn a_stored_program_run_shows_its_elapsed_time() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, PROGRAM);
    let mut state = host.machine.clone();
    state.activity = Activity::RunningProgram;
    host.send(&mut e, Input::Device(&Event::State(state.clone())));
    assert!(e.run_started.is_some());
    host.now += Duration::from_millis(3200);
    state.activity = Activity::Idle;
    let out = host.send(&mut e, Input::Device(&Event::State(state)));
    assert!(
        said(&out).contains(&"the program ran 3.2 s"),
        "{:?}",
        said(&out)
    );
    assert!(e.run_started.is_none());
}

#[test]
fn after_a_stop_the_check_out_starts_again_from_its_line_when_asked() {
    let mut host = Host::isel();
    let mut e = started(&mut host, PROGRAM);
    hold(&mut host, &mut e, 0);
    let (id, ..) = checkout_lines(&hold(&mut host, &mut e, 500)).remove(0);
    end(&mut host, &mut e, id, CheckoutEnd::Stopped);
    host.now += Duration::from_secs(2);
    let out = host.send(
        &mut e,
        Input::Checkout(Action::CheckoutFromLine, KeyPhase::Press),
    );
    let Some(Dialog::Ask(q)) = &out.dialog else {
        panic!("{:?}", said(&out));
    };
    assert!(q.text.contains("from line 2: 0 moves"), "{}", q.text);
}

#[test]
fn f6_while_a_stored_program_runs_pauses_an_emcu_job_and_says_why_not_for_isel() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, PROGRAM);
    host.machine.activity = Activity::RunningProgram;
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty());
    assert!(
        said(&out)[0].contains("cannot be paused"),
        "{:?}",
        said(&out)
    );

    let mut host = Host::with_profile("emcu");
    let mut e = Editor::new(&host.setup, host.now);
    host.machine.activity = Activity::RunningProgram;
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert_eq!(requests(&out), [&Request::Raw { line: "@A".into() }]);
    assert!(e.run_paused);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert_eq!(requests(&out), [&Request::Raw { line: "@C".into() }]);
    assert!(!e.run_paused);
}

#[test]
fn a_speed_above_the_dead_man_cap_is_capped_as_a_jogs_and_said() {
    let mut host = Host::isel();
    let mut e = started(&mut host, "0 4000,10000,0,10000,0,10000,0,10000\n9\n");
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    let (_, text, _) = checkout_lines(&out).remove(0);
    let hz: u32 = text
        .trim_start_matches("@0A4000,")
        .split(',')
        .next()
        .and_then(|s| s.parse().ok())
        .expect("a speed");
    assert!(hz < 10_000 && hz > 1_000, "{text}");
    assert!(
        said(&out).iter().any(|s| s.contains("speed capped")),
        "{:?}",
        said(&out)
    );
}

#[test]
fn positions_read_while_a_stored_job_runs_show_its_progress_along_the_path() {
    let mut host = Host::isel();
    host.measured(
        PerAxis::new()
            .with(Axis::X, 0)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0),
    );
    let mut e = editing(&mut host, PROGRAM);
    // As uploaded from here.
    e.upload.state = Some(e.buffer.state());
    let mut state = host.machine.clone();
    state.activity = Activity::RunningProgram;
    host.send(&mut e, Input::Device(&Event::State(state)));
    let path = e.run_path.clone().expect("the path of the run");
    assert_eq!(path.len(), 2);
    let now = host.now;
    let at = |x: i64, y: i64| PositionSample {
        at: now,
        steps: PerAxis::new()
            .with(Axis::X, x)
            .with(Axis::Y, y)
            .with(Axis::Z, 0),
        source: PositionSource::Measured,
    };
    host.send(&mut e, Input::Device(&Event::Position(at(2000, 0))));
    assert_eq!(e.run_segment, Some(0));
    host.send(&mut e, Input::Device(&Event::Position(at(4000, 1500))));
    assert_eq!(e.run_segment, Some(1));
    assert_eq!(path[1].line, 2);
    // Estimated positions say nothing.
    let mut estimate = at(0, 0);
    estimate.source = PositionSource::Estimated;
    host.send(&mut e, Input::Device(&Event::Position(estimate)));
    assert_eq!(e.run_segment, Some(1));
}

#[test]
fn an_emcu_job_checks_out_line_by_line_and_a_halted_move_goes_on_with_what_is_left() {
    let mut host = Host::with_profile("emcu");
    host.measured(
        PerAxis::new()
            .with(Axis::X, 0)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0),
    );
    let mut e = Editor::new(&host.setup, host.now);
    let text = "#E1,1000\nL1,x4000\n";
    let path = PathBuf::from("/work/job.emcu");
    host.send(&mut e, Input::Msg(EditorMsg::Open(path.clone())));
    let loaded = Loaded {
        path: path.clone(),
        text: text.to_string(),
        fingerprint: Fingerprint::of(text.as_bytes()),
        lossy: false,
    };
    host.send(
        &mut e,
        Input::Msg(EditorMsg::Loaded {
            path,
            result: Ok(Some(loaded)),
            recovery: None,
        }),
    );
    host.settle(&mut e);
    let out = host.key(&mut e, Action::Checkout);
    assert!(
        matches!(&out.dialog, Some(Dialog::Ask(_))),
        "{:?}",
        said(&out)
    );
    host.key(&mut e, Action::Confirm);
    for _ in 0..3 {
        host.send(
            &mut e,
            Input::Checkout(Action::CheckoutSlower, KeyPhase::Press),
        );
    }
    hold(&mut host, &mut e, 0);
    let (id, line, _) = checkout_lines(&hold(&mut host, &mut e, 500)).remove(0);
    assert_eq!(line, "#E1,700\u{1}", "the slot speed through the factor");
    let out = end(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    let (id, line, _) = checkout_lines(&out).remove(0);
    assert_eq!(line, "L1,x4000\u{1}");
    // Halted at X 1500 (the EMCU keeps no rest).
    host.measured(
        PerAxis::new()
            .with(Axis::X, 1500)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0),
    );
    end(
        &mut host,
        &mut e,
        id,
        CheckoutEnd::Paused {
            dead_man: true,
            rest: false,
        },
    );
    host.now += Duration::from_secs(2);
    hold(&mut host, &mut e, 0);
    let out = hold(&mut host, &mut e, 500);
    let resumed = checkout_lines(&out);
    assert_eq!(resumed[0].1, "L1,x2500\u{1}", "what is left of it");
    assert_eq!(resumed[0].2, None);
}
