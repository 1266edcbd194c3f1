//! The run key on a program converted from G-code, through the console's
//! `update` and view: F6 asks with every way, its estimate and the one
//! chosen (snapshots at 80x24 and 160x48); yes stores part 1 of 4 and the
//! title says which part runs; Space stops the job. A job with no retract
//! to cut at asks to stream, and yes sends its first line.

use crate::ui_support;

use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::device::api::{Event, MachineState, Request, UploadEvent};
use jogterm::program::Language;
use jogterm::proto::Protocol;
use jogterm::ui::editor::io::EditorMsg;
use jogterm::ui::editor::job::Converted;
use jogterm::ui::model::Popup;
use jogterm::ui::{Effect, Model, Msg, update};
use ui_support::{SIZES, State, carry_out, model_in, render, settle, text};

/// `n` square pockets, each entered from and left to the safe height.
fn pockets(n: usize) -> String {
    let mut text = String::from("%\nG21 G90 G17\nG0 Z65\n");
    for i in 0..n {
        let (x, y) = (60 + (i % 4) * 12, 60 + (i / 4) * 12);
        text.push_str(&format!(
            "G0 X{x} Y{y}\nG1 Z59 F600\nG1 X{} F1500\nG1 Y{}\nG1 X{x}\nG1 Y{y}\nG0 Z65\n",
            x + 5,
            y + 5
        ));
    }
    text.push_str("M30\n%\n");
    text
}

/// The console with `gcode` opened as `--program pockets.nc` opens it,
/// for a controller that stores 30 commands.
fn opened(t0: Instant, gcode: &str) -> Model {
    let mut profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
    profile.gcode.memory = Some(30);
    let import = jogterm::gcode::import(
        gcode,
        "pockets.nc",
        &profile,
        &jogterm::offsets::WorkOffsets::default(),
        jogterm::gcode::Target::Isel,
    )
    .expect("imports");
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::Imported {
            path: "/jobs/pockets.isel".into(),
            language: Language::Isel,
            text: import.program.text("pockets.nc"),
            notes: Vec::new(),
            gcode: Some(Box::new(Converted::new(
                "/jobs/pockets.nc".into(),
                "pockets.nc".into(),
                import.program,
                import.summary.estimated_s,
                &profile,
                Language::Isel,
            ))),
        }),
    );
    carry_out(&mut m, effects);
    settle(&mut m, t0);
    m
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn upload(effects: &[Effect]) -> Option<usize> {
    effects.iter().find_map(|e| match e {
        Effect::Request(Request::Upload { lines, .. }) => Some(lines.len()),
        _ => None,
    })
}

#[test]
fn f6_on_a_job_bigger_than_the_memory_asks_with_its_ways_and_runs_it_in_parts() {
    let t0 = Instant::now();
    let mut m = opened(t0, &pockets(12));
    let effects = update(&mut m, key(KeyCode::F(6)));
    assert!(carry_out(&mut m, effects).is_empty(), "nothing before yes");
    assert!(matches!(m.popup, Some(Popup::Editor(_))), "{:?}", m.popup);
    for (w, h) in SIZES {
        let shown = text(render(&m, w, h).backend().buffer());
        assert!(shown.contains("Run pockets.nc"), "{shown}");
        assert!(shown.contains("chosen: chunked"), "{shown}");
        insta::assert_snapshot!(format!("editor_gcode_run_question_{w}x{h}"), shown);
    }
    let effects = update(&mut m, key(KeyCode::Char('y')));
    let effects = carry_out(&mut m, effects);
    let total = upload(&effects).expect("part 1 stored");
    let effects = update(
        &mut m,
        Msg::Device(Event::Upload(UploadEvent::Finished {
            total,
            elapsed: Duration::from_secs(1),
        })),
    );
    assert!(
        effects
            .iter()
            .any(|e| matches!(e, Effect::Request(Request::RunProgram))),
        "{effects:?}"
    );
    let running = MachineState {
        activity: jogterm::device::api::Activity::RunningProgram,
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::State(running)));
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("RUNNING part 1/4"), "{shown}");
    assert!(shown.contains(" left "), "the time left: {shown}");
    // The controller says nothing while a stored part runs: the clock
    // alone redraws the job's elapsed time and time left, each second.
    let t = m.now;
    for second in 1..=3u64 {
        m.dirty = false;
        update(&mut m, Msg::Tick(t + Duration::from_secs(second)));
        assert!(m.dirty, "no redraw after {second} s");
    }
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("RUNNING part 1/4 0:03 left "), "{shown}");
    // Space stops the machine and the job: no later part.
    let effects = update(&mut m, key(KeyCode::Char(' ')));
    assert!(effects.contains(&Effect::Stop), "{effects:?}");
    assert_eq!(m.editor.chunked, None);
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(!shown.contains("RUNNING part"), "{shown}");
}

#[test]
fn f6_on_a_job_that_cannot_be_cut_asks_to_stream_it() {
    let t0 = Instant::now();
    let mut m = opened(t0, &pockets(12).replace("G0 Z65\nG0 X", "G0 X"));
    let effects = update(&mut m, key(KeyCode::F(6)));
    assert!(carry_out(&mut m, effects).is_empty(), "nothing before yes");
    for (w, h) in SIZES {
        let shown = text(render(&m, w, h).backend().buffer());
        assert!(shown.contains("chosen: stream"), "{shown}");
        insta::assert_snapshot!(format!("editor_gcode_stream_question_{w}x{h}"), shown);
    }
    let effects = update(&mut m, key(KeyCode::Char('y')));
    let effects = carry_out(&mut m, effects);
    assert!(
        effects.iter().any(|e| matches!(
            e,
            Effect::Request(Request::Checkout { line, .. }) if line == "@0R7"
        )),
        "{effects:?}"
    );
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("STREAM RUNNING"), "{shown}");
}

/// A two-tool job opened as Ctrl-O and `--program` open a G-code file
/// (`EditorMsg::OpenGcode`, imported by the editor's worker): the job
/// panel beside the program says its figures, tools and waits, whole at
/// 80x24 and at 160x48.
#[test]
fn the_job_panel_of_an_opened_gcode_file() {
    let t0 = Instant::now();
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("tools.nc");
    std::fs::write(
        &path,
        "(T1 D=6 flat end mill)\nG21 G90\nG0 X10 Y10 Z5\nG1 Z1 F100\nG0 Z5\nT2 M6\nG1 Z1 F100\nG0 Z5\nM0\nM30\n",
    )
    .expect("write");
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::OpenGcode {
            path,
            height_map: None,
        }),
    );
    carry_out(&mut m, effects);
    settle(&mut m, t0);
    let job = m.editor.job.as_ref().expect("the job is open");
    assert!(job.report.figures.is_some(), "{:?}", job.report.errors);
    // The message line says the temporary path: not part of the picture.
    m.message = None;
    for (w, h) in SIZES {
        let shown = text(render(&m, w, h).backend().buffer());
        for needle in ["Job tools.nc", "tools: T2", "2 waits for the", "line 6:"] {
            assert!(shown.contains(needle), "{w}x{h}: `{needle}`:\n{shown}");
        }
        insta::assert_snapshot!(format!("editor_gcode_job_panel_{w}x{h}"), shown);
    }
}

/// A two-tool job with its waits (issue 40, 3): F6 asks with every wait,
/// yes stores piece 1 of 3; at its end the console erases it (isel) and
/// waits for T1, saying on the status line, in the panel's title and on
/// the message line what for and that F6 goes on (snapshots at 80x24 and
/// 160x48 of the wait).
#[test]
fn a_job_with_tool_changes_waits_at_each_and_says_what_for() {
    let t0 = Instant::now();
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("tools.nc");
    std::fs::write(
        &path,
        "(T1 D=6 CR=0 - ZMIN=-1 - flat end mill)\n(T2 D=3.175 CR=0 - ZMIN=-1 - ball end mill)\n\
         G21 G90 G17\nM6 T1\nG0 X10 Y10 Z5\nG1 Z1 F100\nG1 X20 F300\nG0 Z5\n\
         M6 T2\nG0 X30 Y10\nG1 Z1 F100\nG1 X40 F300\nG0 Z5\nM30\n",
    )
    .expect("write");
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::OpenGcode {
            path,
            height_map: None,
        }),
    );
    carry_out(&mut m, effects);
    settle(&mut m, t0);
    let effects = update(&mut m, key(KeyCode::F(6)));
    assert!(carry_out(&mut m, effects).is_empty(), "nothing before yes");
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("Run tools.nc"), "{shown}");
    let effects = update(&mut m, key(KeyCode::Char('y')));
    let effects = carry_out(&mut m, effects);
    let total = upload(&effects).expect("piece 1 stored");
    update(
        &mut m,
        Msg::Device(Event::Upload(UploadEvent::Finished {
            total,
            elapsed: Duration::from_secs(1),
        })),
    );
    let standing = m.machine.clone();
    let state = |activity| MachineState {
        activity,
        ..standing.clone()
    };
    let running = state(jogterm::device::api::Activity::RunningProgram);
    update(&mut m, Msg::Device(Event::State(running)));
    let idle = state(jogterm::device::api::Activity::Idle);
    let effects = update(&mut m, Msg::Device(Event::State(idle)));
    assert!(
        effects.iter().any(|e| matches!(
            e,
            Effect::Request(Request::Raw { line }) if line == "@0k"
        )),
        "the piece that ran is erased: {effects:?}"
    );
    update(
        &mut m,
        Msg::Device(Event::Reply {
            command: "@0k".into(),
            text: "0: done".into(),
            kind: jogterm::device::api::ReplyKind::Answer,
        }),
    );
    // The steady wait: the message line says what ends it.
    m.message = None;
    for (w, h) in SIZES {
        let shown = text(render(&m, w, h).backend().buffer());
        for needle in [
            "WAIT T1 flat end mill, D=6: F6 goes on, Space ends",
            "WAIT T1 flat end mill, D=6",
        ] {
            assert!(shown.contains(needle), "{w}x{h}: `{needle}`:\n{shown}");
        }
        insta::assert_snapshot!(format!("editor_gcode_tool_change_wait_{w}x{h}"), shown);
    }
    // Space ends the job at the wait.
    let effects = update(&mut m, key(KeyCode::Char(' ')));
    assert!(effects.contains(&Effect::Stop), "{effects:?}");
    assert_eq!(m.editor.chunked, None);
}
