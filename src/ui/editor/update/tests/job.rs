//! The run key on a program converted from G-code: the question with the
//! ways, and a job bigger than the memory run in parts (store part 1, run
//! it, its end, store part 2 erasing the one before, …); F6 pauses before
//! the next part; a stop ends the job.

use super::*;
use crate::device::api::{CheckoutEnd, JogId};
use crate::gcode::ways::Way;
use crate::ui::editor::checkout::STREAM_LEASE;
use crate::ui::editor::job::tests::{converted, pockets};
use crate::ui::editor::job::{Converted, Phase as JobPhase};

/// The editor with `converted` opened as `--program pockets.nc` opens it,
/// the lint run.
pub(super) fn opened(host: &mut Host, converted: Converted) -> Editor {
    let mut e = Editor::new(&host.setup, host.now);
    let text = converted.program.text(&converted.header);
    host.send(
        &mut e,
        Input::Msg(EditorMsg::Imported {
            path: PathBuf::from("/jobs/pockets.isel"),
            language: crate::program::Language::Isel,
            text,
            notes: Vec::new(),
            gcode: Some(Box::new(converted)),
        }),
    );
    host.settle(&mut e);
    e
}

pub(super) fn question(host: &Host) -> &crate::ui::editor::dialog::Question {
    match &host.dialog {
        Some(Dialog::Ask(q)) => q,
        other => panic!("no question: {other:?}"),
    }
}

/// The upload request of `out`: its lines and whether it erases first.
pub(super) fn upload(out: &Outcome) -> Option<(&[String], bool)> {
    requests(out).into_iter().find_map(|r| match r {
        Request::Upload { lines, erase_first } => Some((lines.as_slice(), *erase_first)),
        _ => None,
    })
}

/// The device reports `activity`.
pub(super) fn activity(host: &mut Host, e: &mut Editor, activity: Activity) -> Outcome {
    let state = MachineState {
        activity,
        ..host.machine.clone()
    };
    let out = host.send(e, Input::Device(&Event::State(state.clone())));
    host.machine = state;
    out
}

/// A position read from the controller, as the device reports it.
pub(super) fn read_back(host: &mut Host, e: &mut Editor, steps: PerAxis<i64>) -> Outcome {
    position(host, e, steps, PositionSource::Measured)
}

/// The position the driver estimates while a move runs.
fn estimated(host: &mut Host, e: &mut Editor, steps: PerAxis<i64>) -> Outcome {
    position(host, e, steps, PositionSource::Estimated)
}

fn position(
    host: &mut Host,
    e: &mut Editor,
    steps: PerAxis<i64>,
    source: PositionSource,
) -> Outcome {
    let sample = PositionSample {
        at: host.now,
        steps,
        source,
    };
    host.positions.apply(&sample);
    host.send(e, Input::Device(&Event::Position(sample)))
}

pub(super) fn stored(host: &mut Host, e: &mut Editor, total: usize) -> Outcome {
    host.send(
        e,
        Input::Device(&Event::Upload(UploadEvent::Finished {
            total,
            elapsed: Duration::from_secs(1),
        })),
    )
}

/// Part `k` (1-based) stored, started and run to its end; the outcome of
/// its end.
pub(super) fn run_part(host: &mut Host, e: &mut Editor, total: usize) -> Outcome {
    let out = stored(host, e, total);
    assert_eq!(requests(&out), [&Request::RunProgram], "{out:?}");
    activity(host, e, Activity::RunningProgram);
    host.now += Duration::from_secs(3);
    activity(host, e, Activity::Idle)
}

/// The 88-command pocket job on a controller that stores 30, F6 answered
/// yes: part 1's upload.
fn started(host: &mut Host) -> (Editor, Outcome) {
    let mut e = opened(host, converted(&pockets(12), 30));
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(host);
    assert_eq!(q.yes, Answer::RunInParts);
    let out = host.key(&mut e, Action::Confirm);
    (e, out)
}

#[test]
fn the_question_says_every_way_and_the_one_chosen() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(&pockets(12), 30));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "nothing before the answer");
    let q = question(&host);
    assert_eq!(q.title, "Run pockets.nc");
    for expected in [
        "pockets.nc: 88 commands, the controller stores 30.",
        "stream: ",
        "with the tool in the part",
        "chunked: ",
        "in 4 parts",
        "motion by the controller's ramps",
        "chosen: chunked (",
        "Store and run it in 4 parts",
        "F6 pauses before the next part, Space stops",
    ] {
        assert!(q.text.contains(expected), "`{expected}` in:\n{}", q.text);
    }
    // No: nothing runs.
    let out = host.key(&mut e, Action::Cancel);
    assert!(requests(&out).is_empty());
    assert_eq!(e.chunked, None);
}

#[test]
fn the_parts_are_stored_run_and_replaced_in_turn() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let (lines, erase) = upload(&out).expect("part 1 stored");
    assert!(erase, "whatever is stored goes first");
    assert!(lines.len() <= 30 && lines[0] == "77", "{lines:?}");
    assert_eq!(
        said(&out),
        [format!("part 1/4: storing {} commands", lines.len())]
    );
    assert!(e.read_only().is_some(), "the text waits while the job runs");
    let mut total = lines.len();
    for k in 2..=4 {
        let out = run_part(&mut host, &mut e, total);
        let (lines, erase) = upload(&out).unwrap_or_else(|| panic!("part {k}: {out:?}"));
        assert!(erase, "part {k} erases the one before");
        assert_eq!(lines[0], "z1", "part {k} starts in 3D again");
        assert_eq!(
            said(&out),
            [format!("part {k}/4: storing {} commands", lines.len())]
        );
        let chunked = e.chunked.as_ref().expect("runs");
        assert_eq!((chunked.part, chunked.phase), (k - 1, JobPhase::Uploading));
        total = lines.len();
    }
    let out = run_part(&mut host, &mut e, total);
    assert!(upload(&out).is_none());
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("the job ended: 4 parts in")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    assert!(e.read_only().is_none());
}

/// The seconds of `left M:SS` in a status line's progress.
pub(super) fn seconds_left(progress: &str) -> u64 {
    let clock = progress
        .split(" left ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .unwrap_or_else(|| panic!("no time left in {progress:?}"));
    clock
        .split(':')
        .try_fold(0, |s, part| part.parse::<u64>().map(|v| s * 60 + v))
        .unwrap_or_else(|_| panic!("{clock:?} in {progress:?}"))
}

#[test]
fn a_job_in_parts_says_the_models_time_left_counted_down_and_at_the_pace_so_far() {
    let mut host = Host::isel();
    let c = converted(&pockets(12), 30);
    let model: Vec<u64> = c.ways.part_s.iter().map(|s| *s as u64).collect();
    let model_s = c.ways.part_s.clone();
    assert_eq!(model.len(), 4, "{model:?}");
    let mut e = opened(&mut host, c);
    host.send(&mut e, Input::Main(Action::RunProgram));
    let out = host.key(&mut e, Action::Confirm);
    let total = upload(&out).expect("part 1 stored").0.len();
    // At the start: every part's time by the model.
    let whole: f64 = model_s.iter().sum();
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(status.word, "STORING");
    assert!(
        status.progress.starts_with("part 1/4 0:00 left "),
        "{status:?}"
    );
    assert_eq!(seconds_left(&status.progress), whole as u64, "{status:?}");
    // Within the part it counts down with the time.
    host.now += Duration::from_secs(1);
    assert_eq!(
        seconds_left(&e.job_status(host.now, false).expect("a status").progress),
        (whole - 1.0) as u64
    );
    // Part 1 took 1 + 3 s (`run_part`) against the model's: the parts
    // after it at that pace, within its bounds.
    run_part(&mut host, &mut e, total);
    let pace = (4.0 / model_s[0]).clamp(0.5, 3.0);
    let after: f64 = model_s[1..].iter().sum();
    let status = e.job_status(host.now, false).expect("a status");
    assert!(status.progress.starts_with("part 2/4 "), "{status:?}");
    assert_eq!(
        seconds_left(&status.progress),
        (after * pace) as u64,
        "{status:?}"
    );
}

#[test]
fn f6_pauses_before_the_next_part_and_goes_on_from_there() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("part 1").0.len();
    stored(&mut host, &mut e, total);
    activity(&mut host, &mut e, Activity::RunningProgram);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "the part runs to its end");
    assert!(said(&out)[0].contains("pauses before part 2/4"), "{out:?}");
    // Part 1 ends where the tool stands retracted: part 2 waits, nothing
    // is stored. When the end is reported, the position shown is still
    // the estimate of the part's last move (issue 37, 15: the pause was
    // measured from it, and F6 then refused "the axes moved" for ever).
    let retracted = PerAxis::new()
        .with(Axis::X, 24_000)
        .with(Axis::Y, 24_000)
        .with(Axis::Z, 26_000);
    estimated(&mut host, &mut e, retracted.with(Axis::Z, 25_400));
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)[0].starts_with("PAUSED before part 2/4"),
        "{out:?}"
    );
    assert_eq!(e.chunked.as_ref().map(|c| c.phase), Some(JobPhase::Paused));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(said(&out)[0].contains("being read"), "{out:?}");
    // The read after the end: where the axes stand.
    read_back(&mut host, &mut e, retracted);
    // Jogged away while paused: the next part's first move would start
    // from there, so F6 refuses until the axes are back.
    read_back(&mut host, &mut e, retracted.with(Axis::Z, 20_000));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)[0].starts_with("the axes moved since the pause"),
        "{out:?}"
    );
    read_back(&mut host, &mut e, retracted);
    // F6 again: part 2 is stored.
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let (lines, erase) = upload(&out).expect("part 2");
    assert!(erase && lines[0] == "z1", "{lines:?}");
    // F6 twice while a part runs takes the pause back.
    stored(&mut host, &mut e, lines.len());
    activity(&mut host, &mut e, Activity::RunningProgram);
    host.send(&mut e, Input::Main(Action::RunProgram));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert_eq!(said(&out), ["no pause: the job goes on with the next part"]);
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(upload(&out).is_some(), "part 3 follows at once");
}

#[test]
fn a_stop_ends_the_job_and_no_later_part_is_stored() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("part 1").0.len();
    stored(&mut host, &mut e, total);
    activity(&mut host, &mut e, Activity::RunningProgram);
    let out = host.send(&mut e, Input::Stopped);
    assert!(
        said(&out)[0].starts_with("the job stopped in part 1/4"),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    activity(&mut host, &mut e, Activity::Stopping);
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
}

#[test]
fn a_refused_upload_or_a_fault_ends_the_job() {
    let mut host = Host::isel();
    let (mut e, _) = started(&mut host);
    let out = host.send(
        &mut e,
        Input::Device(&Event::Upload(UploadEvent::Failed {
            line: 28,
            fault: ControllerFault {
                command: "m1".into(),
                code: "6".into(),
                meaning: "memory full".into(),
                recovery: DeviceRecovery::None,
            },
        })),
    );
    assert!(
        said(&out)
            .iter()
            .any(|s| s.contains("part 1/4 was not stored")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    // The refused command is marked on its line of the text.
    let mark = e.upload.mark.as_ref().expect("marked");
    assert!(e.buffer.line(mark.line).starts_with('m'), "{mark:?}");

    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("part 1").0.len();
    stored(&mut host, &mut e, total);
    activity(&mut host, &mut e, Activity::RunningProgram);
    let out = host.send(
        &mut e,
        Input::Device(&Event::Fault(ControllerFault {
            command: "@0S".into(),
            code: "2".into(),
            meaning: "limit switch".into(),
            recovery: DeviceRecovery::None,
        })),
    );
    assert!(
        said(&out)
            .iter()
            .any(|s| s.contains("part 1/4 ended with `2`")),
        "{out:?}"
    );
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
}

#[test]
fn a_refused_start_ends_the_job_and_another_refusal_does_not() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("part 1").0.len();
    stored(&mut host, &mut e, total);
    let refused = |request: &str| Event::Refused {
        request: request.into(),
        reason: crate::device::api::Refusal::NotInitialised,
    };
    host.send(&mut e, Input::Device(&refused("jog X+")));
    assert!(e.chunked.is_some(), "a jog refused changes nothing");
    let out = host.send(&mut e, Input::Device(&refused("run program")));
    assert!(
        said(&out)[0].starts_with("part 1/4 did not start"),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
}

#[test]
fn a_job_that_fits_asks_as_a_stored_program_does_with_its_ways() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(&pockets(2), 30));
    assert_eq!(
        e.gcode.as_ref().map(|g| g.converted.ways.chosen),
        Some(Way::Stored)
    );
    host.machine.program = ProgramState::Stored;
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(&host);
    assert_eq!(q.yes, Answer::Run);
    assert!(q.text.contains("stored: "), "{}", q.text);
    assert!(q.text.contains("chosen: stored"), "{}", q.text);
    assert!(q.text.contains("Start the program stored"), "{}", q.text);
    let out = host.key(&mut e, Action::Confirm);
    assert_eq!(requests(&out), [&Request::RunProgram]);
}

#[test]
fn an_edited_job_too_big_for_the_memory_is_not_cut_from_another_text() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(&pockets(12), 30));
    host.key(&mut e, Action::CursorBottom);
    host.type_text(&mut e, "\n; edited");
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(host.dialog.is_none());
    assert!(
        said(&out)[0].contains("edited since it was converted"),
        "{out:?}"
    );
    assert!(
        said(&out)[0].contains("jogterm run /jobs/pockets.nc --chunked"),
        "{out:?}"
    );
}

/// Issue 37 (14): a converted job is unsaved when it opens, and it stays
/// unsaved after an edit, whichever edit. Before, the first typed
/// character brought the buffer to the state taken for "saved": the title
/// lost its `[+]`, `q` quit without asking and no recovery file was kept.
#[test]
fn an_edit_of_a_converted_job_leaves_it_unsaved() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(&pockets(2), 2000));
    assert!(e.modified(), "converted, never saved");
    host.type_text(&mut e, "x");
    assert!(e.modified(), "one character typed");
    assert!(e.file.recovery_due.is_some(), "the recovery file is due");
    host.key(&mut e, Action::Undo);
    assert!(e.modified(), "undone: still the converted text, unsaved");
}

/// The checkout line of `out`: its id, text, lease and resume.
fn line(out: &Outcome) -> Option<(JogId, &str, Duration, Option<JogId>)> {
    requests(out).into_iter().find_map(|r| match r {
        Request::Checkout {
            id,
            line,
            lease,
            resume,
            ..
        } => Some((*id, line.as_str(), *lease, *resume)),
        _ => None,
    })
}

fn ended(host: &mut Host, e: &mut Editor, id: JogId, end: CheckoutEnd) -> Outcome {
    host.send(e, Input::Device(&Event::Checkout { id, end }))
}

#[test]
fn without_a_place_to_cut_the_job_is_streamed_without_a_key_held() {
    let mut host = Host::isel();
    // 12 pockets never retracted between: no place to cut within 30.
    let gcode = pockets(12).replace("G0 Z65\nG0 X", "G0 X");
    let c = converted(&gcode, 30);
    assert_eq!(c.ways.chosen, Way::Stream);
    let mut e = opened(&mut host, c);
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(&host);
    assert_eq!(q.yes, Answer::Stream);
    assert!(q.text.contains("chosen: stream"), "{}", q.text);
    assert!(q.text.contains("chunked: not possible"), "{}", q.text);
    assert!(q.text.contains("F10 pauses and goes on"), "{}", q.text);
    // Yes: the first line goes out at once, held by the stream's lease.
    let out = host.key(&mut e, Action::Confirm);
    let (id, text, lease, resume) = line(&out).expect("the first line");
    assert_eq!((text, lease, resume), ("@0R7", STREAM_LEASE, None));
    // The tick renews the lease a third of it before it would run out.
    host.now += Duration::from_millis(100);
    assert!(requests(&host.send(&mut e, Input::Tick)).is_empty());
    host.now += STREAM_LEASE / 3;
    let out = host.send(&mut e, Input::Tick);
    assert!(
        requests(&out).contains(&&Request::JogRenew {
            id,
            lease: STREAM_LEASE
        }),
        "{out:?}"
    );
    // Its end sends the next line, no key held.
    let out = ended(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    let (id, text, _, _) = line(&out).expect("the next line");
    assert_eq!(text, "@0z1", "3D mode, which the conversion adds");
    let out = ended(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    let (id, text, _, _) = line(&out).expect("the first move");
    assert!(text.starts_with("@0M"), "{text}");
    // The title: STREAM, the G-code line, the share done.
    let title = crate::ui::editor::view::panel::title_text(&e, &host.context());
    assert!(title.contains("STREAM RUNNING G-code line"), "{title}");
    // F10 pauses: the line is let go, the driver keeps the rest.
    host.now += Duration::from_secs(2);
    let out = host.send(
        &mut e,
        Input::Checkout(Action::CheckoutHold, crate::jog::KeyPhase::Press),
    );
    assert_eq!(requests(&out), [&Request::JogRelease { id }]);
    let out = ended(
        &mut host,
        &mut e,
        id,
        CheckoutEnd::Paused {
            rest: true,
            dead_man: false,
        },
    );
    assert!(said(&out)[0].starts_with("PAUSED at line"), "{out:?}");
    assert!(line(&out).is_none(), "nothing follows while paused");
    // F10 again (a new press): the rest is finished, then the stream goes on.
    host.now += Duration::from_secs(2);
    let out = host.send(
        &mut e,
        Input::Checkout(Action::CheckoutHold, crate::jog::KeyPhase::Press),
    );
    let (next, _, _, resume) = line(&out).expect("resumed");
    assert_eq!(resume, Some(id));
    // A stop ends it: nothing follows.
    let out = ended(&mut host, &mut e, next, CheckoutEnd::Stopped);
    assert!(line(&out).is_none(), "{out:?}");
    assert!(matches!(
        e.checkout.as_ref().map(|c| &c.state),
        Some(crate::ui::editor::checkout::RunState::Stopped { .. })
    ));
}

/// Issue 41 (3): the stream's status line says the model's time left
/// (`gcode::eta`) from the line running, at the speed factor, not the pace
/// of the set-up before the first G-code line.
#[test]
fn a_streamed_jobs_status_says_the_models_time_left() {
    let mut host = Host::isel();
    let gcode = pockets(12).replace("G0 Z65\nG0 X", "G0 X");
    let c = converted(&gcode, 30);
    let first = c
        .program
        .lines
        .iter()
        .position(|l| l.origin.is_some())
        .expect("a G-code line");
    let model = c.ways.stream_left(c.program.lines.len(), 1.0);
    let mut e = opened(&mut host, c);
    host.send(&mut e, Input::Main(Action::RunProgram));
    let mut out = host.key(&mut e, Action::Confirm);
    // The reference run and `z1` before the first G-code line take long:
    // no pace is taken from them.
    for _ in 0..2 {
        let (id, ..) = line(&out).expect("a line");
        host.now += Duration::from_secs(20);
        out = ended(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
    }
    // The model is by the text's lines: from the line running on.
    let says = |e: &Editor, host: &Host| {
        let line = e
            .checkout
            .as_ref()
            .and_then(|c| c.current_line())
            .expect("a line running");
        let status = e.job_status(host.now, false).expect("a status");
        let left = crate::ui::editor::progress::clock(Duration::from_secs_f64(model[line]));
        assert!(
            status.progress.contains(&format!("left {left} x100%")),
            "{status:?}, the model from line {line}: {} s",
            model[line]
        );
        line
    };
    // The set-up's 40 s are no pace: the model from the first G-code
    // line, which runs now.
    assert_eq!(says(&e, &host), first);
    // Each line taking what the model says: the time left stays the
    // model's.
    for _ in 0..3 {
        let (id, ..) = line(&out).expect("a line");
        let at = e
            .checkout
            .as_ref()
            .and_then(|c| c.current_line())
            .expect("a line");
        let next = e
            .buffer
            .program()
            .line_of(e.buffer.program().index_of(at).expect("a command") + 1);
        host.now += Duration::from_secs_f64(model[at] - model[next.expect("a next line")]);
        out = ended(&mut host, &mut e, id, CheckoutEnd::Done { byte: None });
        says(&e, &host);
    }
}
