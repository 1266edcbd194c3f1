//! The program editor through `update` and the view, as the running console
//! drives it (effects carried out here the way the runtime's worker does):
//! inline diagnostics, gutter numbers that are the controller's command
//! numbers, upload refused while errors remain, a stored program offered to
//! be erased, a controller error at command N marked on the line of command
//! N with the text untouched, teach-in from the measured position. Snapshots
//! at 80x24 and 160x48 (review with `cargo insta review`).

use crate::ui_support;

use std::path::PathBuf;
use std::time::Instant;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use jogterm::axis::Axis;
use jogterm::device::api::{
    ControllerFault, Event, MachineState, PerAxis, PositionSample, PositionSource, ProgramState,
    Recovery, Request, UploadEvent,
};
use jogterm::program::store::Fingerprint;
use jogterm::proto::Protocol;
use jogterm::ui::editor::io::{EditorIo, EditorMsg};
use jogterm::ui::editor::upload::Phase;
use jogterm::ui::model::{PanelId, Popup};
use jogterm::ui::{Effect, Model, Msg, update};
use ui_support::{SIZES, State, carry_out, model_in, render, text};

/// Three comments, a blank line and five commands; `m` on line 7 has too
/// few pairs for XYZ.
const PROGRAM: &str = "\
; drill
; two holes
7 7

j300
; first
m8000,8000
0 400,900,0,900,0,900,0,900
9
";

const GOOD: &str = "\
; drill
7 7
; first hole
m8000,8000,8000,8000,0,8000,0,8000
0 400,900,0,900,0,900,0,900
; done
9
";

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn ctrl(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL))
}

fn screen(m: &Model, w: u16, h: u16) -> String {
    text(render(m, w, h).backend().buffer())
}

fn row<'a>(screen: &'a str, needle: &str) -> &'a str {
    screen
        .lines()
        .find(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no row with {needle}:\n{screen}"))
}

#[test]
fn the_program_screen_shows_command_numbers_and_problems_inline() {
    let m = editing(PROGRAM);
    assert_eq!(m.focus, PanelId::Editor);
    for (w, h) in SIZES {
        let shown = screen(&m, w, h);
        // Command numbers from 1, comments and blank lines without one:
        // `m8000,8000` is command 3 on line 7.
        assert!(
            row(&shown, "m8000,8000").starts_with(" 3E m8000,8000"),
            "{shown}"
        );
        assert!(row(&shown, "j300").starts_with(" 2  j300"), "{shown}");
        assert!(row(&shown, "; first").starts_with("    ; first"), "{shown}");
        assert!(shown.contains("\n 5  9 "), "{shown}");
        // The message of the error is on the screen.
        assert!(shown.contains("takes 4 steps"), "{shown}");
        insta::assert_snapshot!(format!("editor_errors_{w}x{h}"), shown);
    }
}

#[test]
fn upload_is_refused_while_errors_remain() {
    let mut m = editing(PROGRAM);
    let effects = update(&mut m, key(KeyCode::F(5)));
    assert!(
        !effects
            .iter()
            .any(|e| matches!(e, Effect::Request(Request::Upload { .. }))),
        "{effects:?}"
    );
    let message = m
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default();
    assert!(message.contains("upload refused"), "{message}");
    assert!(message.contains("line 7"), "{message}");
    // The cursor went to the error.
    assert_eq!(m.editor.buffer.cursor().line, 6);
}

fn upload_request(effects: &[Effect]) -> Option<(Vec<String>, bool)> {
    effects.iter().find_map(|e| match e {
        Effect::Request(Request::Upload { lines, erase_first }) => {
            Some((lines.clone(), *erase_first))
        }
        _ => None,
    })
}

fn with_program_state(m: &mut Model, program: ProgramState) {
    let axes = m.setup.axis_set();
    let state = MachineState {
        link_up: true,
        initialised: axes,
        referenced: axes,
        program,
        work_zero: PerAxis::new()
            .with(Axis::X, 0)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0),
        ..MachineState::default()
    };
    update(m, Msg::Device(Event::State(state)));
}

#[test]
fn a_stored_program_is_offered_to_be_erased_first() {
    let mut m = editing(GOOD);
    with_program_state(&mut m, ProgramState::Stored);
    let effects = update(&mut m, key(KeyCode::F(5)));
    assert!(upload_request(&effects).is_none());
    assert!(matches!(m.popup, Some(Popup::Editor(_))));
    let effects = update(&mut m, key(KeyCode::Char('y')));
    let (lines, erase) = upload_request(&effects).expect("the upload");
    assert!(erase);
    // Comments are not sent; each command in its canonical spelling.
    assert_eq!(lines.len(), 4);
    assert_eq!(lines.first().map(String::as_str), Some("77"));
}

#[test]
fn after_a_failed_upload_erase_and_retry_is_offered_and_run_is_refused() {
    let mut m = editing(GOOD);
    with_program_state(&mut m, ProgramState::Invalid);
    // Starting the invalid partial program is refused with what to do.
    let effects = update(&mut m, key(KeyCode::F(6)));
    assert!(
        !effects
            .iter()
            .any(|e| matches!(e, Effect::Request(Request::RunProgram))),
        "{effects:?}"
    );
    let message = m
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default();
    assert!(message.contains("upload it again"), "{message}");
    // Uploading asks to erase the partial program first, then retries.
    let effects = update(&mut m, key(KeyCode::F(5)));
    assert!(upload_request(&effects).is_none());
    assert!(matches!(m.popup, Some(Popup::Editor(_))));
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("invalid program"), "{shown}");
    let effects = update(&mut m, key(KeyCode::Char('y')));
    let (_, erase) = upload_request(&effects).expect("the upload");
    assert!(erase);
}

#[test]
fn a_controller_error_at_command_n_marks_its_line_and_keeps_the_text() {
    let mut m = editing(GOOD);
    with_program_state(&mut m, ProgramState::None);
    let effects = update(&mut m, key(KeyCode::F(5)));
    let (lines, erase) = upload_request(&effects).expect("the upload");
    assert!(!erase);
    let before = m.editor.buffer.text();
    let t0 = m.now;
    let events = [
        UploadEvent::Started { total: lines.len() },
        UploadEvent::Progress {
            done: 2,
            total: lines.len(),
            lines_per_second: 40.0,
        },
    ];
    for e in events {
        update(&mut m, Msg::Device(Event::Upload(e)));
    }
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("2/4"), "{shown}");
    insta::assert_snapshot!("editor_upload_progress_80x24", shown);
    // Typing waits while the upload runs.
    update(&mut m, key(KeyCode::Char('x')));
    assert_eq!(m.editor.buffer.text(), before);
    // Command 3 (index 2) is `0 400,…` on line 5.
    update(
        &mut m,
        Msg::Device(Event::Upload(UploadEvent::Failed {
            line: 2,
            fault: ControllerFault {
                command: "0400,900,0,900,0,900,0,900".into(),
                code: "1".into(),
                meaning: "invalid number".into(),
                recovery: Recovery::None,
            },
        })),
    );
    assert!(matches!(
        m.editor.upload.phase,
        Phase::Failed { command: 2, .. }
    ));
    assert_eq!(m.editor.upload.mark.as_ref().map(|k| k.line), Some(4));
    assert_eq!(m.editor.buffer.text(), before);
    let message = m
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default();
    assert!(message.contains("command 3 (line 5)"), "{message}");
    for (w, h) in SIZES {
        let shown = screen(&m, w, h);
        assert!(row(&shown, "0 400,900").contains('!'), "{shown}");
        insta::assert_snapshot!(format!("editor_upload_failed_{w}x{h}"), shown);
    }
    // The partial program is invalid: the next upload offers erase first.
    with_program_state(&mut m, ProgramState::Invalid);
    m.popup = None;
    let _ = t0;
    let effects = update(&mut m, key(KeyCode::F(5)));
    assert!(upload_request(&effects).is_none());
    let effects = update(&mut m, key(KeyCode::Enter));
    assert_eq!(upload_request(&effects).map(|(_, e)| e), Some(true));
}

#[test]
fn teach_in_appends_an_absolute_move_to_the_measured_position() {
    let mut m = editing(GOOD);
    with_program_state(&mut m, ProgramState::None);
    // Back to the machine screen; the cursor stays on the last line.
    update(&mut m, key(KeyCode::F(4)));
    assert_ne!(m.focus, PanelId::Editor);
    let at = PerAxis::new()
        .with(Axis::X, 1200)
        .with(Axis::Y, 800)
        .with(Axis::Z, 400);
    let now = m.now;
    update(
        &mut m,
        Msg::Device(Event::Position(PositionSample {
            at: now,
            steps: at,
            source: PositionSource::Measured,
        })),
    );
    let lines_before = m.editor.buffer.line_count();
    update(&mut m, key(KeyCode::Char('t')));
    assert_eq!(
        m.editor.buffer.line_count(),
        lines_before + 1,
        "{:?} {:?}",
        m.focus,
        m.message.as_ref().map(|m| &m.text)
    );
    let text = m.editor.buffer.text();
    let taught = text
        .lines()
        .find(|l| l.starts_with("m1200,"))
        .unwrap_or_else(|| panic!("no taught move:\n{text}"));
    assert!(
        taught.contains(",800,") && taught.contains(",400,"),
        "{taught}"
    );
    // The `9` stays last: the move goes in before it.
    assert_eq!(text.lines().last(), Some("9"));
    // A relative move from the point taught before.
    let next = at.with(Axis::X, 2000);
    update(
        &mut m,
        Msg::Device(Event::Position(PositionSample {
            at: now,
            steps: next,
            source: PositionSource::Measured,
        })),
    );
    update(&mut m, key(KeyCode::Char('T')));
    let text = m.editor.buffer.text();
    assert!(
        text.lines()
            .any(|l| l.starts_with("0 800,") || l.starts_with("0800,")),
        "{text}"
    );
    // Undo takes the taught line back (in the editor).
    update(&mut m, key(KeyCode::Char('e')));
    assert_eq!(m.focus, PanelId::Editor);
    update(&mut m, ctrl('z'));
    assert!(!m.editor.buffer.text().contains("0 800,"));
}

/// Issue 20, finding 6: F5 on an EMP machine said "the program is an isel
/// program, the machine a emp controller".
#[test]
fn emp_machines_refuse_uploads_and_teach_in_saying_why() {
    let t0 = Instant::now();
    let mut m = model_in(Protocol::Emp, "dark", State::Idle, t0);
    let said = |m: &Model| {
        m.message
            .as_ref()
            .map(|n| n.text.clone())
            .unwrap_or_default()
    };
    let effects = update(&mut m, key(KeyCode::F(5)));
    assert!(upload_request(&effects).is_none());
    assert_eq!(
        said(&m),
        "upload refused: EMP drives store no programs (EMP manual: every command runs at once)"
    );
    update(&mut m, key(KeyCode::Char('t')));
    assert_eq!(
        said(&m),
        "teach-in refused: EMP drives store no programs (EMP manual: every command runs at once)"
    );
    // A program of the other family on EMCU.
    let mut m = model_in(Protocol::Emcu, "dark", State::Idle, t0);
    let loaded = jogterm::program::store::Loaded {
        path: PathBuf::from("/work/part.isel"),
        text: GOOD.to_string(),
        fingerprint: Fingerprint::of(GOOD.as_bytes()),
        lossy: false,
    };
    update(
        &mut m,
        Msg::Editor(EditorMsg::Loaded {
            path: "/work/part.isel".into(),
            result: Ok(Some(loaded)),
            recovery: None,
        }),
    );
    update(&mut m, key(KeyCode::F(5)));
    assert_eq!(
        said(&m),
        "upload refused: the program is an isel program and the machine has an emcu controller"
    );
}

/// The load the effects ask for, if any.
fn load_request(effects: &[Effect]) -> Option<PathBuf> {
    effects.iter().find_map(|e| match e {
        Effect::Editor(EditorIo::Load { path, .. }) => Some(path.clone()),
        _ => None,
    })
}

/// Issue 20, finding 6: Ctrl-O starts with the open file's folder; an
/// absolute path typed after it was looked for inside that folder
/// (`/work//tmp/…`), found nowhere, and an empty buffer opened without a
/// word of warning.
#[test]
fn ctrl_o_takes_an_absolute_path_typed_after_the_folder_and_says_when_nothing_is_there() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut m = editing(GOOD);
    update(&mut m, key(KeyCode::F(4)));
    update(&mut m, key(KeyCode::Char('e')));
    assert_eq!(m.focus, PanelId::Editor);
    let open = |m: &mut Model, typed: &str| {
        update(m, ctrl('o'));
        for c in typed.chars() {
            update(m, key(KeyCode::Char(c)));
        }
        update(m, key(KeyCode::Enter))
    };
    // `/work/` is there already: the typed absolute path replaces it.
    let missing = dir.path().join("no-such-folder").join("part.isel");
    let effects = open(&mut m, &missing.display().to_string());
    assert_eq!(load_request(&effects).as_deref(), Some(missing.as_path()));
    // No folder of that name: refused, the program stays.
    carry_out(&mut m, effects);
    let said = m
        .message
        .as_ref()
        .map(|n| n.text.clone())
        .unwrap_or_default();
    assert!(
        said.starts_with("cannot open:") && said.contains("there is no folder"),
        "{said}"
    );
    assert_eq!(m.editor.buffer.text(), GOOD);
    // A folder without the file: a new program, and a warning that says so.
    let new = dir.path().join("new.isel");
    let effects = open(&mut m, &format!("/{}", new.display()));
    assert_eq!(load_request(&effects).as_deref(), Some(new.as_path()));
    carry_out(&mut m, effects);
    let note = m.message.as_ref().expect("a message");
    assert_eq!(note.level, jogterm::ui::traffic_log::NoteLevel::Warning);
    assert!(
        note.text
            .contains("does not exist: a new, empty isel program"),
        "{}",
        note.text
    );
}

/// The model of a ready isel machine with `program` loaded in the editor.
fn editing(program: &str) -> Model {
    ui_support::editing_isel(program, Instant::now())
}
