//! A converted job with tool changes and pauses run from the editor in
//! pieces (`update::pieces`): F6 asks with every wait, each piece is
//! stored and run, at each wait the piece that ran is erased (isel) and
//! the job waits, saying what for, until F6 (not a key pressed before
//! the wait, not before the erase has answered, not with the axes moved);
//! Space ends the job at a wait.

use super::job::{activity, opened, question, read_back, run_part, seconds_left, upload};
use super::*;
use crate::device::api::{CheckoutEnd, ReplyKind};
use crate::ui::editor::job::Phase as JobPhase;
use crate::ui::editor::job::tests::converted;

/// Two tools and a program pause: four pieces (the set-up before `M6 T1`,
/// T1's cut, T2's cut, after the `M0`), placed for the shipped isel
/// profile with its work zero at the reference point.
pub(crate) const TWO_TOOLS: &str = "(T1 D=6 CR=0 - ZMIN=-1 - flat end mill)\n\
(T2 D=3.175 CR=0 - ZMIN=-1 - ball end mill)\n\
G21 G90 G17\n\
M6 T1\n\
G0 Z65\n\
G0 X60 Y60\nG1 Z59 F300\nG1 X70 F600\nG0 Z65\n\
M6 T2\n\
G0 X80 Y60\nG1 Z59 F300\nG1 X90 F600\nG0 Z65\n\
M0\n\
G0 X60 Y60\n\
M30\n";

/// Where the tool stands at a wait (as read back after the piece).
pub(super) fn at_wait() -> PerAxis<i64> {
    PerAxis::new()
        .with(Axis::X, 36_000)
        .with(Axis::Y, 24_000)
        .with(Axis::Z, 26_000)
}

pub(super) fn erased(host: &mut Host, e: &mut Editor) -> Outcome {
    host.send(
        e,
        Input::Device(&Event::Reply {
            kind: ReplyKind::Answer,
            command: "@0k".into(),
            text: "0: done".into(),
        }),
    )
}

/// F6 answered yes on the two-tool job: piece 1's upload.
pub(super) fn started(host: &mut Host) -> (Editor, Outcome) {
    let mut e = opened(host, converted(TWO_TOOLS, 2000));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "nothing before the answer");
    let q = question(host);
    assert_eq!(q.yes, Answer::RunPieces);
    let out = host.key(&mut e, Action::Confirm);
    (e, out)
}

/// The piece stored and run to its end, the erase answered, the
/// position read and the wait armed: the outcome of the piece's end.
pub(super) fn to_the_wait(host: &mut Host, e: &mut Editor, total: usize) -> Outcome {
    let out = run_part(host, e, total);
    erased(host, e);
    host.now += Duration::from_secs(1);
    read_back(host, e, at_wait());
    out
}

#[test]
fn the_question_lists_every_wait_and_says_without_a_sensor_the_tool_keeps_its_length() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(TWO_TOOLS, 2000));
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(&host);
    for expected in [
        "pockets.nc: 3 tool changes and pauses: the console runs it in 4 pieces",
        "line 4: M6: change to tool T1 flat end mill, D=6",
        "line 10: M6: change to tool T2 ball end mill, D=3.175",
        "line 15: M0: program pause",
        "no tool sensor (probe.tool_sensor): the new tool must have the old one's length",
        "F6 goes on, Space ends the job",
    ] {
        assert!(q.text.contains(expected), "`{expected}` in:\n{}", q.text);
    }
    let out = host.key(&mut e, Action::Cancel);
    assert!(requests(&out).is_empty());
    assert_eq!(e.chunked, None);
}

#[test]
fn each_piece_is_stored_and_the_job_waits_at_each_change_until_f6() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let (lines, erase) = upload(&out).expect("piece 1 stored");
    assert!(erase && lines[0] == "77", "{lines:?}");
    assert_eq!(
        said(&out),
        [format!("piece 1/4: storing {} commands", lines.len())]
    );
    // The time left is every piece's by the model; the three waits are
    // the operator's, named and not guessed.
    let model = e
        .chunked
        .as_ref()
        .and_then(|c| c.pieces.as_ref())
        .and_then(|p| p.model_s.clone())
        .expect("the pieces' model");
    assert_eq!(model.len(), 4, "{model:?}");
    assert!(model.iter().all(|s| *s > 0.0), "{model:?}");
    let status = e.job_status(host.now, false).expect("a status");
    assert!(status.progress.ends_with(" +3 waits"), "{status:?}");
    assert_eq!(
        seconds_left(&status.progress),
        model.iter().sum::<f64>() as u64,
        "{status:?}"
    );
    // Piece 1 ends: the stored piece is erased, the job waits for T1.
    let out = run_part(&mut host, &mut e, lines.len());
    assert_eq!(
        requests(&out),
        [&Request::Raw { line: "@0k".into() }],
        "{out:?}"
    );
    assert!(
        said(&out)[0].starts_with(
            "WAIT piece 1/4 ended: line 4: M6: change to tool T1 flat end mill, D=6: the \
             spindle off, the tool at machine"
        ),
        "{out:?}"
    );
    assert_eq!(e.chunked.as_ref().map(|c| c.phase), Some(JobPhase::Waiting));
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(status.word, "WAIT");
    assert_eq!(status.progress, "T1 flat end mill, D=6: erasing (@0k)");
    // F6 before the erase has answered goes on with nothing.
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(said(&out)[0].contains("being erased"), "{out:?}");
    let out = erased(&mut host, &mut e);
    assert_eq!(
        said(&out),
        ["the piece that ran is erased: WAIT T1 flat end mill, D=6: F6 goes on, Space ends"]
    );
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(
        status.progress,
        "T1 flat end mill, D=6: F6 goes on, Space ends"
    );
    assert_eq!(
        status.waiting.as_deref(),
        Some("WAIT T1 flat end mill, D=6: F6 goes on, Space ends")
    );
    // At once: the wait has just begun (a key pressed before it, or held
    // into it, confirms nothing).
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(said(&out)[0].contains("just begun"), "{out:?}");
    host.now += Duration::from_secs(1);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(said(&out)[0].contains("being read"), "{out:?}");
    read_back(&mut host, &mut e, at_wait());
    // F6: piece 2, erasing first, without a reference run.
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let (lines, erase) = upload(&out).expect("piece 2");
    assert!(erase, "{out:?}");
    assert!(!lines.iter().any(|l| l == "77"), "{lines:?}");
    assert_eq!(said(&out)[0], "line 4: going on with piece 2/4");
    assert!(
        e.job_status(host.now, false)
            .is_some_and(|s| s.waiting.is_none())
    );
    // Piece 2 and the two after it by the model, two waits to come.
    let status = e.job_status(host.now, false).expect("a status");
    assert!(status.progress.ends_with(" +2 waits"), "{status:?}");
    let after_first = model[1..].iter().sum::<f64>();
    assert!(
        seconds_left(&status.progress).abs_diff(after_first as u64) <= 1,
        "{status:?}, the model {after_first} s"
    );

    // Piece 2 runs; F6 meanwhile says the wait comes anyway, and does not
    // answer it.
    super::job::stored(&mut host, &mut e, lines.len());
    activity(&mut host, &mut e, Activity::RunningProgram);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(
        said(&out)[0].starts_with("the job waits after piece 2/4 anyway (line 10"),
        "{out:?}"
    );
    host.now += Duration::from_secs(3);
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(
        said(&out)[0].starts_with("WAIT piece 2/4 ended: line 10: M6: change to tool T2"),
        "{out:?}"
    );
    erased(&mut host, &mut e);
    host.now += Duration::from_secs(1);
    read_back(&mut host, &mut e, at_wait());
    // Jogged away at the change: F6 refuses until the axes are back.
    read_back(&mut host, &mut e, at_wait().with(Axis::Z, 20_000));
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)[0].starts_with("the axes moved since the wait"),
        "{out:?}"
    );
    read_back(&mut host, &mut e, at_wait());
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let total = upload(&out).expect("piece 3").0.len();
    // The M0 waits in place, said with its line.
    to_the_wait(&mut host, &mut e, total);
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(
        status.waiting.as_deref(),
        Some("WAIT M0 line 15: F6 goes on, Space ends")
    );
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let total = upload(&out).expect("piece 4").0.len();
    let out = run_part(&mut host, &mut e, total);
    assert!(
        requests(&out).is_empty(),
        "no erase after the last: {out:?}"
    );
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("the job ended: 4 pieces in")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
}

/// A piece the model has no time for: the job says no time left, not
/// the time of the others as if it were all.
#[test]
fn without_a_model_of_every_piece_no_time_left_is_said() {
    let mut host = Host::isel();
    let (mut e, _) = started(&mut host);
    if let Some(p) = e.chunked.as_mut().and_then(|c| c.pieces.as_mut()) {
        p.model_s = None;
    }
    let status = e.job_status(host.now, false).expect("a status");
    assert!(!status.progress.contains(" left "), "{status:?}");
}

#[test]
fn space_at_a_wait_ends_the_job_and_nothing_is_stored_after() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let out = host.send(&mut e, Input::Stopped);
    assert!(
        said(&out)[0].starts_with("the job stopped in piece 1/4"),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    host.now += Duration::from_secs(1);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "F6 asks again: {out:?}");
    assert_eq!(question(&host).yes, Answer::RunPieces);
}

#[test]
fn space_while_the_piece_is_erased_says_it_may_still_be_stored() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("piece 1").0.len();
    run_part(&mut host, &mut e, total);
    let out = host.send(&mut e, Input::Stopped);
    assert!(
        said(&out)[0].ends_with(
            "the erase of the piece that ran was cut short: it may still be stored, and the \
             controller's start key would run it"
        ),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
}

#[test]
fn a_refused_erase_before_the_wait_ends_the_job() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("piece 1").0.len();
    run_part(&mut host, &mut e, total);
    let out = host.send(
        &mut e,
        Input::Device(&Event::Refused {
            request: crate::device::describe::describe(&Request::Raw { line: "@0k".into() }),
            reason: crate::device::api::Refusal::NotConnected,
        }),
    );
    assert!(
        said(&out)[0].contains("was not erased before the wait ("),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
}

#[test]
fn an_edited_conversion_runs_as_any_program_with_the_controllers_own_waits() {
    let mut host = Host::isel();
    let mut e = opened(&mut host, converted(TWO_TOOLS, 2000));
    e.buffer.bottom();
    host.type_text(&mut e, "; edited");
    host.machine.program = ProgramState::Stored;
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(&host);
    assert_eq!(q.yes, Answer::Run, "{q:?}");
    assert_eq!(e.chunked, None);
}

/// The piece after a wait has no reference run: a machine that lost its
/// reference (or its link, or moves) at the wait does not go on.
#[test]
fn f6_at_a_wait_goes_on_only_from_a_ready_machine() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let referenced = host.machine.referenced;
    host.machine.referenced = crate::axis::AxisSet::default();
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert_eq!(
        said(&out),
        ["the axes are no longer referenced: the job cannot go on from here; Space ends it"]
    );
    host.machine.referenced = referenced;
    host.machine.activity = Activity::Jogging;
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)[0].starts_with("the machine must stand still"),
        "{out:?}"
    );
    host.machine.activity = Activity::Idle;
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(upload(&out).is_some(), "{out:?}");
}

/// An EMCU job with a pause: its pieces stored as EMCU jobs, and the wait
/// needs no erase (only the iMC runs a stored program on its start key).
#[test]
fn an_emcu_job_waits_without_an_erase() {
    let mut host = Host::with_profile("emcu");
    let profile = host.setup.profile.as_ref().clone();
    let gcode = "G21 G90\nG0 X2 Y2 Z2\nG1 X4 F100\nM0\nG1 X6 F100\nM30\n";
    let import = crate::gcode::import(
        gcode,
        "job.nc",
        &profile,
        &crate::offsets::WorkOffsets::default(),
        crate::gcode::Target::Emcu,
    )
    .unwrap_or_else(|e| panic!("imports: {e:?}"));
    let converted = crate::ui::editor::job::Converted::new(
        "/jobs/job.nc".into(),
        "job.nc".into(),
        import.program.clone(),
        import.summary.estimated_s,
        &profile,
        crate::program::Language::Emcu,
    )
    .with_waits(
        &import.plan,
        &import.toolpath,
        crate::gcode::output::Header {
            file: "job.nc".into(),
            profile: profile.name.clone(),
            system: import.summary.system.to_string(),
            zero: import.summary.zero,
        },
    );
    let mut e = Editor::new(&host.setup, host.now);
    let text = converted.program.text(&converted.header);
    host.send(
        &mut e,
        Input::Msg(EditorMsg::Imported {
            path: PathBuf::from("/jobs/job.emcu"),
            language: crate::program::Language::Emcu,
            text,
            notes: Vec::new(),
            gcode: Some(Box::new(converted)),
        }),
    );
    host.settle(&mut e);
    host.send(&mut e, Input::Main(Action::RunProgram));
    assert_eq!(question(&host).yes, Answer::RunPieces);
    let out = host.key(&mut e, Action::Confirm);
    let total = upload(&out)
        .unwrap_or_else(|| panic!("piece 1: {out:?}"))
        .0
        .len();
    let out = run_part(&mut host, &mut e, total);
    assert!(requests(&out).is_empty(), "no erase on EMCU: {out:?}");
    assert!(
        said(&out)[0].starts_with("WAIT piece 1/2 ended: line 4: M0"),
        "{out:?}"
    );
    host.now += Duration::from_secs(1);
    read_back(&mut host, &mut e, PerAxis::new());
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let total = upload(&out)
        .unwrap_or_else(|| panic!("piece 2: {out:?}"))
        .0
        .len();
    let out = run_part(&mut host, &mut e, total);
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("the job ended: 2 pieces")),
        "{out:?}"
    );
}

/// The shipped isel profile's start key, reading pressed or released.
fn start_key(host: &Host, pressed: bool) -> Event {
    let wiring = host.setup.profile.wiring().expect("the profile's wiring");
    let bit = wiring
        .bits()
        .iter()
        .find(|b| b.role == crate::wiring::Role::Start && b.kind == crate::wiring::BitKind::Input)
        .expect("the shipped isel profile wires a start key")
        .clone();
    let value = [false, true]
        .into_iter()
        .find(|v| bit.is_active(*v) == pressed)
        .expect("a level");
    Event::Io(crate::device::api::IoSnapshot {
        at: host.now,
        groups: vec![crate::device::api::IoGroup {
            name: "in 1".into(),
            raw: None,
            bits: vec![crate::device::api::IoBit {
                name: "start key".into(),
                value,
                output: None,
                hazardous: false,
                wiring: Some(bit),
            }],
            read: None,
        }],
    })
}

/// The machine's start key goes on at a wait as F6 does, once it has been
/// seen released since the wait began: a key held down into the wait
/// confirms nothing, and the same guards hold (not before the erase).
#[test]
fn the_start_key_pressed_after_a_release_goes_on_at_a_wait() {
    let mut host = Host::isel();
    let (mut e, out) = started(&mut host);
    let total = upload(&out).expect("piece 1").0.len();
    let out = run_part(&mut host, &mut e, total);
    assert!(
        said(&out)[0].contains("F6 (or the start key) goes on"),
        "{out:?}"
    );
    // Held down since before the wait, then released and pressed before
    // the erase has answered: nothing goes on.
    let out = host.send(&mut e, Input::Device(&start_key(&host, true)));
    assert!(upload(&out).is_none(), "{out:?}");
    host.send(&mut e, Input::Device(&start_key(&host, false)));
    let out = host.send(&mut e, Input::Device(&start_key(&host, true)));
    assert!(upload(&out).is_none(), "{out:?}");
    erased(&mut host, &mut e);
    host.now += Duration::from_secs(1);
    read_back(&mut host, &mut e, at_wait());
    // Still held from that press: no new press, nothing.
    let out = host.send(&mut e, Input::Device(&start_key(&host, true)));
    assert!(upload(&out).is_none(), "{out:?}");
    host.send(&mut e, Input::Device(&start_key(&host, false)));
    let out = host.send(&mut e, Input::Device(&start_key(&host, true)));
    let (lines, erase) = upload(&out).expect("piece 2 on the start key");
    assert!(erase && !lines.iter().any(|l| l == "77"), "{lines:?}");
}

/// T2's cut a raster that never leaves the material: 25 commands with no
/// retract to cut at, more than a controller that stores 12 holds.
fn raster_after_the_change() -> String {
    let mut gcode = String::from(
        "(T1 D=6 CR=0 - ZMIN=-1 - flat end mill)\n\
         (T2 D=3.175 CR=0 - ZMIN=-1 - ball end mill)\n\
         G21 G90 G17\n\
         M6 T1\n\
         G0 Z65\n\
         G0 X60 Y60\nG1 Z59 F300\nG1 X70 F600\nG0 Z65\n\
         M6 T2\n\
         G0 X80 Y60\nG1 Z59 F300\n",
    );
    for k in 0..12 {
        let x = if k % 2 == 0 { 90 } else { 80 };
        gcode.push_str(&format!("G1 X{x}\nG1 Y{}\n", 60 + k + 1));
    }
    gcode.push_str("G0 Z65\nM30\n");
    gcode
}

/// The raster job opened on a controller that stores 12.
fn raster_opened(host: &mut Host) -> Editor {
    let mut profile = (*host.setup.profile).clone();
    profile.gcode.memory = Some(12);
    host.setup.profile = std::sync::Arc::new(profile);
    opened(host, converted(&raster_after_the_change(), 12))
}

/// The stream's line sent, if one was.
fn streamed(out: &Outcome) -> Option<(crate::device::api::JogId, &str)> {
    requests(out).into_iter().find_map(|r| match r {
        Request::Checkout { id, line, .. } => Some((*id, line.as_str())),
        _ => None,
    })
}

/// The job run to T2's wait and F6 there: piece 3's first streamed line.
fn to_the_stream(host: &mut Host, e: &mut Editor) -> Outcome {
    host.send(e, Input::Main(Action::RunProgram));
    let out = host.key(e, Action::Confirm);
    let total = upload(&out).expect("piece 1 stored").0.len();
    to_the_wait(host, e, total);
    let out = host.send(e, Input::Main(Action::RunProgram));
    let total = upload(&out).expect("piece 2 stored").0.len();
    to_the_wait(host, e, total);
    host.send(e, Input::Main(Action::RunProgram))
}

#[test]
fn a_piece_with_no_retract_to_cut_at_streams_and_the_job_ends_after_it() {
    let mut host = Host::isel();
    let mut e = raster_opened(&mut host);
    host.send(&mut e, Input::Main(Action::RunProgram));
    let q = question(&host);
    assert_eq!(q.yes, Answer::RunPieces);
    assert!(
        q.text
            .contains("piece 1: stored; piece 2: stored; piece 3: streamed ("),
        "{}",
        q.text
    );
    host.key(&mut e, Action::Cancel);
    let out = to_the_stream(&mut host, &mut e);
    assert!(upload(&out).is_none(), "nothing stored: {out:?}");
    let said_now = said(&out);
    assert!(
        said_now
            .iter()
            .any(|s| s.starts_with("piece 3/3: streaming ")),
        "{said_now:?}"
    );
    assert_eq!(
        e.chunked.as_ref().map(|c| c.phase),
        Some(JobPhase::Streaming)
    );
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(status.word, "STREAM");
    // Its first lines are the way back from the change, of no G-code line.
    assert!(status.progress.starts_with("piece 3/3 0% "), "{status:?}");
    // The time left is the model's from the first line (not the pace, of
    // which nothing is known yet).
    let mut left = vec![seconds_left(&status.progress)];
    // F6 meanwhile says how the stream is paused and ended.
    let f6 = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(streamed(&f6).is_none(), "{f6:?}");
    // Each line sent when the one before has ended, the raster's cuts
    // among them, each line's G-code line in the editor's text.
    let mut out = out;
    let mut lines = Vec::new();
    while let Some((id, line)) = streamed(&out) {
        lines.push(line.to_owned());
        let shown = e.checkout.as_ref().and_then(|c| c.buffer_line());
        let text = shown
            .map(|l| e.buffer.line(l).to_owned())
            .unwrap_or_default();
        assert!(text.contains("pockets.nc:"), "line {shown:?}: {text}");
        assert!(lines.len() < 100, "{lines:?}");
        let status = e.job_status(host.now, false).expect("a status");
        left.push(seconds_left(&status.progress));
        out = host.send(
            &mut e,
            Input::Device(&Event::Checkout {
                id,
                end: CheckoutEnd::Done { byte: None },
            }),
        );
    }
    assert!(lines.len() > 12, "more than the memory holds: {lines:?}");
    assert!(left[0] > 0, "{left:?}");
    assert!(left.windows(2).all(|w| w[1] <= w[0]), "{left:?}");
    assert!(left.last() < left.first(), "{left:?}");
    assert!(
        !lines.iter().any(|l| l == "77"),
        "no reference run: {lines:?}"
    );
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("the job ended: 3 pieces in")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    assert_eq!(e.checkout, None);
}

#[test]
fn space_in_a_streamed_piece_ends_the_job_and_no_line_follows() {
    let mut host = Host::isel();
    let mut e = raster_opened(&mut host);
    let out = to_the_stream(&mut host, &mut e);
    let (id, _) = streamed(&out).expect("a line");
    let out = host.send(&mut e, Input::Stopped);
    assert!(
        said(&out)[0].starts_with("the job stopped in piece 3/3"),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    let out = host.send(
        &mut e,
        Input::Device(&Event::Checkout {
            id,
            end: CheckoutEnd::Stopped,
        }),
    );
    assert!(streamed(&out).is_none(), "{out:?}");
    assert!(upload(&out).is_none(), "{out:?}");
    assert!(
        matches!(
            e.checkout.as_ref().map(|c| &c.state),
            Some(crate::ui::editor::checkout::RunState::Stopped { .. })
        ),
        "{:?}",
        e.checkout.as_ref().map(|c| &c.state)
    );
}

#[test]
fn x_or_a_lost_link_in_a_streamed_piece_ends_the_job_and_nothing_follows() {
    // x: the stream is left, its line stopped, the job ended.
    let mut host = Host::isel();
    let mut e = raster_opened(&mut host);
    to_the_stream(&mut host, &mut e);
    let out = host.send(
        &mut e,
        Input::Checkout(Action::CheckoutAbort, crate::jog::KeyPhase::Press),
    );
    assert!(out.effects.contains(&Effect::Stop), "{out:?}");
    assert!(
        streamed(&out).is_none() && upload(&out).is_none(),
        "{out:?}"
    );
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("the job ends in piece 3/3")),
        "{out:?}"
    );
    assert_eq!((e.chunked.as_ref(), e.checkout.as_ref()), (None, None));

    // A lost link: the job ends, and the link's return resumes nothing.
    let mut host = Host::isel();
    let mut e = raster_opened(&mut host);
    to_the_stream(&mut host, &mut e);
    host.send(
        &mut e,
        Input::Device(&Event::Link(crate::device::api::LinkState::Lost {
            reason: "unplugged".into(),
        })),
    );
    assert_eq!(e.chunked, None);
    let out = host.send(
        &mut e,
        Input::Device(&Event::Link(crate::device::api::LinkState::Connected)),
    );
    assert!(
        streamed(&out).is_none() && upload(&out).is_none(),
        "{out:?}"
    );
}
