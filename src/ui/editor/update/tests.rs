//! The component alone: [`Editor::update`] driven with input sequences in a
//! context built from a shipped profile, no `Model`. A small [`Host`] plays
//! the console's part (it keeps the focus and the open dialog as
//! `ui::update` does), so that a dialog opened by one input is answered by
//! the next.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::config::{ConfigDirs, load_profile, load_theme};
use crate::device::api::{
    Activity, ControllerFault, Event, MachineState, PerAxis, PositionSample, PositionSource,
    ProgramState, Recovery as DeviceRecovery, Request, UploadEvent,
};
use crate::program::store::{Fingerprint, Loaded, RecoveryStore};
use crate::ui::editor::Editor;
use crate::ui::editor::component::{Context, Effect, Focus, Input, Outcome};
use crate::ui::editor::dialog::{Answer, Dialog, FormKind, Then};
use crate::ui::editor::io::{EditorIo, EditorMsg, SaveFailure};
use crate::ui::editor::upload::Phase;
use crate::ui::keymap::{Action, Keymap};
use crate::ui::palette::Palette;
use crate::ui::position::Positions;
use crate::ui::setup::Setup;
use crate::ui::traffic_log::NoteLevel;

/// A program without problems: a reference run, one move, the end.
const GOOD: &str = "; drill\n7 7\nm8000,8000,8000,8000,0,8000,0,8000\n9\n";

/// What the console keeps for the editor, and the context built from it.
struct Host {
    setup: Setup,
    machine: MachineState,
    positions: Positions,
    palette: Palette,
    keymap: Keymap,
    now: Instant,
    focused: bool,
    /// The editor's dialog in the popup slot.
    dialog: Option<Dialog>,
    /// The session's work offsets.
    offsets: crate::offsets::WorkOffsets,
    tools: crate::ui::tools::ToolsState,
}

impl Host {
    /// A ready isel machine (initialised, referenced, work zero at the
    /// reference point, nothing stored), standing still.
    fn isel() -> Host {
        Host::with_profile("isel")
    }

    /// The same for another shipped profile.
    fn with_profile(name: &str) -> Host {
        let dirs = ConfigDirs::builtin_only();
        let profile = load_profile(name, &dirs).expect("shipped profile");
        let theme = load_theme("dark", &dirs).expect("shipped theme");
        let setup = Setup::from_profile(&profile, None);
        let axes = setup.axis_set();
        let machine = MachineState {
            link_up: true,
            initialised: axes,
            referenced: axes,
            program: ProgramState::None,
            work_zero: axes.iter().fold(PerAxis::new(), |z, a| z.with(a, 0)),
            ..MachineState::default()
        };
        Host {
            setup,
            machine,
            positions: Positions::default(),
            palette: Palette::from(&theme),
            keymap: Keymap::builtin().expect("built-in keys"),
            now: Instant::now(),
            focused: false,
            dialog: None,
            offsets: crate::offsets::WorkOffsets::default(),
            tools: crate::ui::tools::ToolsState::default(),
        }
    }

    fn context(&self) -> Context<'_> {
        Context {
            setup: &self.setup,
            machine: &self.machine,
            positions: &self.positions,
            offsets: &self.offsets,
            tools: &self.tools,
            now: self.now,
            palette: &self.palette,
            keymap: &self.keymap,
            size: (80, 24),
            focused: self.focused,
            popup_open: self.dialog.is_some(),
        }
    }

    /// One input, its outcome kept as the console keeps it (focus, dialog).
    fn send(&mut self, e: &mut Editor, input: Input) -> Outcome {
        let out = e.update(&self.context(), input);
        match out.focus {
            Some(Focus::Editor) => self.focused = true,
            Some(Focus::Back) => self.focused = false,
            None => {}
        }
        if let Some(dialog) = &out.dialog {
            self.dialog = Some(dialog.clone());
        }
        out
    }

    /// A key action: to the open dialog if there is one, else the panel's.
    fn key(&mut self, e: &mut Editor, action: Action) -> Outcome {
        match self.dialog.take() {
            Some(dialog) => self.send(e, Input::Dialog(dialog, action)),
            None => self.send(e, Input::Key(action)),
        }
    }

    /// Characters typed: into the open dialog's form, else the text.
    fn type_text(&mut self, e: &mut Editor, text: &str) -> Vec<Outcome> {
        text.chars()
            .map(|c| match self.dialog.take() {
                Some(dialog) => self.send(e, Input::DialogChar(dialog, c)),
                None => self.send(e, Input::Char(c)),
            })
            .collect()
    }

    fn measured(&mut self, steps: PerAxis<i64>) {
        self.positions.apply(&PositionSample {
            at: self.now,
            steps,
            source: PositionSource::Measured,
        });
    }

    /// Time passes until the lint due has run on the text as it is.
    fn settle(&mut self, e: &mut Editor) {
        for _ in 0..3 {
            self.now += Duration::from_secs(1);
            let out = self.send(e, Input::Tick);
            for effect in out.effects {
                if let Effect::Io(EditorIo::Lint(job)) = effect {
                    let result = Box::new(job.run());
                    self.send(e, Input::Msg(EditorMsg::Linted(result)));
                }
            }
        }
    }
}

/// The editor with `text` loaded from `/work/part.isel`, the program
/// screen shown, the lint run.
fn editing(host: &mut Host, text: &str) -> Editor {
    let mut e = Editor::new(&host.setup, host.now);
    let path = PathBuf::from("/work/part.isel");
    let out = host.send(&mut e, Input::Msg(EditorMsg::Open(path.clone())));
    assert_eq!(out.focus, Some(Focus::Editor));
    assert!(matches!(
        out.effects.as_slice(),
        [Effect::Io(EditorIo::Load { path: p, .. })] if *p == path
    ));
    let loaded = Loaded {
        path: path.clone(),
        text: text.to_string(),
        fingerprint: Fingerprint::of(text.as_bytes()),
        lossy: false,
    };
    let out = host.send(
        &mut e,
        Input::Msg(EditorMsg::Loaded {
            path,
            result: Ok(Some(loaded)),
            recovery: None,
        }),
    );
    let lines = text.lines().count();
    assert_eq!(
        said(&out),
        [format!("opened /work/part.isel ({lines} lines, isel)")]
    );
    host.settle(&mut e);
    e
}

fn said(out: &Outcome) -> Vec<&str> {
    out.notes.iter().map(|n| n.text.as_str()).collect()
}

fn requests(out: &Outcome) -> Vec<&Request> {
    out.effects
        .iter()
        .filter_map(|e| match e {
            Effect::Device(r) => Some(r),
            _ => None,
        })
        .collect()
}

fn saves(out: &Outcome) -> Vec<(&PathBuf, bool, &Option<Then>)> {
    out.effects
        .iter()
        .filter_map(|e| match e {
            Effect::Io(EditorIo::Save {
                path, fresh, then, ..
            }) => Some((path, *fresh, then)),
            _ => None,
        })
        .collect()
}

#[test]
fn typing_changes_the_text_and_says_nothing_and_waits_while_uploading() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    assert!(!e.modified());
    host.key(&mut e, Action::CursorBottom);
    let outs = host.type_text(&mut e, "\np0,1,1");
    assert!(outs.iter().all(|o| *o == Outcome::default()), "{outs:?}");
    assert!(e.modified());
    assert!(
        e.buffer.text().ends_with("9\np0,1,1\n"),
        "{}",
        e.buffer.text()
    );
    // An edit is recovered within the autosave time: due now.
    assert!(e.file.recovery_due.is_some());
    // While an upload runs the text is read-only, and the editor says so.
    let before = e.buffer.text();
    e.upload
        .start(e.language(), vec![1, 2, 3], e.buffer.state());
    let out = host.send(&mut e, Input::Char('x'));
    assert_eq!(e.buffer.text(), before);
    assert_eq!(out.notes.first().map(|n| n.level), Some(NoteLevel::Warning));
    assert!(said(&out)[0].contains("being uploaded"), "{out:?}");
}

#[test]
fn save_of_an_untitled_program_asks_for_a_name_then_saves_and_quits_after_the_question() {
    let mut host = Host::isel();
    let mut e = Editor::new(&host.setup, host.now);
    host.focused = true;
    host.type_text(&mut e, "7 7");
    // Untitled: Ctrl-S asks for a name.
    let out = host.key(&mut e, Action::Save);
    assert!(matches!(&out.dialog, Some(Dialog::Form(f)) if f.kind == FormKind::SaveAs));
    assert!(out.effects.is_empty());
    host.type_text(&mut e, "/tmp/new.isel");
    let out = host.key(&mut e, Action::Submit);
    assert_eq!(out.dialog, None, "the form closed");
    assert_eq!(
        saves(&out),
        [(&PathBuf::from("/tmp/new.isel"), true, &None)]
    );
    assert!(e.file.saving);
    let saved = |e: &Editor, then| {
        Input::Msg(EditorMsg::Saved {
            path: "/tmp/new.isel".into(),
            state: e.buffer.state(),
            result: Ok(Fingerprint::of(b"77\n")),
            then,
        })
    };
    let msg = saved(&e, None);
    let out = host.send(&mut e, msg);
    assert_eq!(said(&out), ["saved /tmp/new.isel (1 lines)"]);
    assert!(!e.modified());
    assert!(!e.file.saving);
    assert_eq!(e.name(), "new.isel");
    // Nothing unsaved: nothing holds a quit.
    assert_eq!(host.send(&mut e, Input::Quit), Outcome::default());
    // Unsaved edits ask first.
    host.type_text(&mut e, "\n9");
    let out = host.send(&mut e, Input::Quit);
    assert_eq!(out.dialog, Some(Dialog::Unsaved(Then::Quit)));
    assert!(!out.quit);
    // Save from the question: the save carries the quit with it…
    let out = host.key(&mut e, Action::Save);
    assert!(!out.quit);
    assert_eq!(
        saves(&out),
        [(&PathBuf::from("/tmp/new.isel"), false, &Some(Then::Quit))]
    );
    // …and the quit follows once the file is written.
    let msg = saved(&e, Some(Then::Quit));
    let out = host.send(&mut e, msg);
    assert_eq!(said(&out), ["saved /tmp/new.isel (2 lines)"]);
    assert!(out.quit);
    assert_eq!(e.name(), "new.isel");
}

#[test]
fn a_file_changed_on_disk_is_overwritten_only_when_the_operator_says_so() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    host.type_text(&mut e, "; more\n");
    let out = host.key(&mut e, Action::Save);
    let [(path, false, None)] = saves(&out)[..] else {
        panic!("{out:?}")
    };
    let path = path.clone();
    let state = e.buffer.state();
    let out = host.send(
        &mut e,
        Input::Msg(EditorMsg::Saved {
            path: path.clone(),
            state,
            result: Err(SaveFailure::Changed),
            then: None,
        }),
    );
    let Some(Dialog::Ask(q)) = &out.dialog else {
        panic!("{out:?}")
    };
    assert!(q.text.contains("changed on disk"), "{}", q.text);
    assert_eq!(q.no, Answer::Nothing);
    // No: nothing happens, the edits stay.
    let out = host.key(&mut e, Action::Cancel);
    assert_eq!(out, Outcome::default());
    assert!(e.modified());
    // Yes (asked again): saved over it, without the fingerprint check.
    host.dialog = Some(Dialog::Ask(q.clone()));
    let out = host.key(&mut e, Action::Confirm);
    assert!(matches!(
        out.effects.as_slice(),
        [Effect::Io(EditorIo::Save {
            expect: None,
            fresh: false,
            ..
        })]
    ));
}

#[test]
fn teach_in_inserts_the_measured_position_before_the_end_only_while_standing_still() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    let at = PerAxis::new()
        .with(Axis::X, 1200)
        .with(Axis::Y, 800)
        .with(Axis::Z, 400);
    host.measured(at);
    host.key(&mut e, Action::CursorBottom);
    // Moving: nothing is taught.
    host.machine.activity = Activity::Jogging;
    let out = host.send(&mut e, Input::Main(Action::TeachAbsolute));
    assert_eq!(
        said(&out),
        ["teach-in waits until the machine stands still"]
    );
    assert!(!e.modified());
    host.machine.activity = Activity::Idle;
    let out = host.send(&mut e, Input::Main(Action::TeachAbsolute));
    assert!(out.effects.is_empty() && out.dialog.is_none(), "{out:?}");
    let lines: Vec<String> = e.buffer.text().lines().map(String::from).collect();
    // 15 mm/s (the last jog speed) at 400 steps/mm: 6000 Hz.
    assert_eq!(
        lines,
        [
            "; drill",
            "7 7",
            "m8000,8000,8000,8000,0,8000,0,8000",
            "m1200,6000,800,6000,400,6000,0,6000",
            "9",
        ]
    );
    assert_eq!(
        said(&out),
        ["taught `m1200,6000,800,6000,400,6000,0,6000` (line 4)"]
    );
    // A relative move from the point taught before, after it.
    host.measured(at.with(Axis::X, 2000));
    host.send(&mut e, Input::Main(Action::TeachRelative));
    assert_eq!(
        e.buffer.text().lines().nth(4),
        Some("0800,6000,0,6000,0,6000,0,6000")
    );
    // Slower: the speed is said, the next move taught at it.
    let out = host.send(&mut e, Input::Main(Action::TeachSlower));
    assert_eq!(said(&out), ["teach speed 5 mm/s"]);
}

#[test]
fn an_upload_is_requested_refused_with_errors_and_asks_before_erasing() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    // Nothing stored: the upload goes out at once, comments left out.
    let out = host.send(&mut e, Input::Main(Action::Upload));
    assert_eq!(
        requests(&out),
        [&Request::Upload {
            lines: vec![
                "77".into(),
                "m8000,8000,8000,8000,0,8000,0,8000".into(),
                "9".into()
            ],
            erase_first: false,
        }]
    );
    assert_eq!(said(&out), ["uploading 3 commands"]);
    assert!(e.upload.busy());
    // The device's report names the line of the command it refused.
    let fault = ControllerFault {
        command: "9".into(),
        code: "1".into(),
        meaning: "invalid number".into(),
        recovery: DeviceRecovery::None,
    };
    let failed = Event::Upload(UploadEvent::Failed { line: 2, fault });
    let out = host.send(&mut e, Input::Device(&failed));
    assert_eq!(out.notes.len(), 1);
    assert_eq!(out.notes[0].level, NoteLevel::Danger);
    assert!(said(&out)[0].contains("command 3 (line 4)"), "{out:?}");
    assert!(matches!(e.upload.phase, Phase::Failed { command: 2, .. }));
    // A stored program: asked first, uploaded with the erase on yes.
    host.machine.program = ProgramState::Stored;
    let out = host.send(&mut e, Input::Main(Action::Upload));
    assert!(requests(&out).is_empty());
    assert!(matches!(&out.dialog, Some(Dialog::Ask(q)) if q.yes == Answer::Upload { erase: true }));
    let out = host.key(&mut e, Action::Confirm);
    assert!(matches!(
        requests(&out)[..],
        [Request::Upload {
            erase_first: true,
            ..
        }]
    ));
    // With an error in the text: refused, the cursor on it, the program
    // screen shown.
    let mut host = Host::isel();
    let mut e = editing(&mut host, "7 7\nm8000,8000\n9\n");
    host.focused = false;
    let out = host.send(&mut e, Input::Main(Action::Upload));
    assert!(requests(&out).is_empty());
    assert_eq!(out.focus, Some(Focus::Editor));
    assert!(
        said(&out)[0].starts_with("upload refused: 1 error"),
        "{out:?}"
    );
    assert_eq!(e.buffer.cursor().line, 1);
}

#[test]
fn run_asks_first_and_the_answer_sends_the_request() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert_eq!(said(&out), ["no program is stored: upload one first"]);
    host.machine.program = ProgramState::Stored;
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let Some(Dialog::Ask(q)) = &out.dialog else {
        panic!("{out:?}")
    };
    assert!(
        q.text.contains("not the one uploaded from here"),
        "{}",
        q.text
    );
    let out = host.key(&mut e, Action::Confirm);
    assert_eq!(requests(&out), [&Request::RunProgram]);
    assert_eq!(out.dialog, None);
}

#[test]
fn dialog_answers_discard_cancel_and_keep_the_question_open() {
    let mut host = Host::isel();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut e = editing(&mut host, GOOD);
    e.keep_recoveries(RecoveryStore::new(dir.path()), "test");
    host.type_text(&mut e, "; more\n");
    // Any other key leaves the question open.
    host.send(&mut e, Input::Quit);
    let out = host.key(&mut e, Action::CursorDown);
    assert_eq!(out.dialog, Some(Dialog::Unsaved(Then::Quit)));
    // Back: nothing happens, the edits stay.
    let out = host.key(&mut e, Action::Cancel);
    assert_eq!(out, Outcome::default());
    assert!(e.modified());
    // Discard: the last edits go to the recovery file and aside, then the
    // quit, last.
    host.send(&mut e, Input::Quit);
    let out = host.key(&mut e, Action::Discard);
    assert!(out.quit);
    assert!(matches!(
        out.effects.as_slice(),
        [
            Effect::Io(EditorIo::WriteRecovery { .. }),
            Effect::Io(EditorIo::DiscardRecovery { .. })
        ]
    ));
    assert!(!e.modified());
}

#[test]
fn the_program_screen_opens_and_closes_and_forms_take_characters() {
    let mut host = Host::isel();
    let mut e = editing(&mut host, GOOD);
    host.focused = false;
    let out = host.send(&mut e, Input::Main(Action::EditProgram));
    assert_eq!(out.focus, Some(Focus::Editor));
    let out = host.send(&mut e, Input::Main(Action::EditProgram));
    assert_eq!(out.focus, Some(Focus::Back));
    // The circle helper: a form whose note shows the lines as they are
    // typed; submitted, they go in before the end.
    host.focused = true;
    host.key(&mut e, Action::CursorTop);
    host.key(&mut e, Action::CursorDown);
    let out = host.key(&mut e, Action::Circle);
    assert!(matches!(&out.dialog, Some(Dialog::Form(f)) if f.kind == FormKind::Circle));
    let outs = host.type_text(&mut e, "5");
    let Some(Dialog::Form(f)) = &outs[0].dialog else {
        panic!("{outs:?}")
    };
    assert_eq!(f.error, None);
    let note = f.note.clone().unwrap_or_default();
    assert!(
        note.starts_with("XY plane, R 2000 steps, 6000 Hz: f-1  y"),
        "{note}"
    );
    let out = host.key(&mut e, Action::Submit);
    assert_eq!(out.dialog, None);
    let text = e.buffer.text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[2], "f-1", "{text}");
    assert!(lines[3].starts_with('y'), "{text}");
    assert_eq!(lines.last(), Some(&"9"));
}

mod checkout;
mod gcode;
mod job;
mod measure;
mod outputs;
mod pieces;
mod recent;

#[test]
fn a_program_converted_from_gcode_opens_unsaved_and_asks_before_replacing_a_file() {
    let mut host = Host::isel();
    let mut e = Editor::new(&host.setup, host.now);
    let path = PathBuf::from("/work/part.isel");
    let out = host.send(
        &mut e,
        Input::Msg(EditorMsg::Imported {
            path: path.clone(),
            language: crate::program::Language::Isel,
            text: GOOD.to_string(),
            notes: vec![(NoteLevel::Info, "part.nc: 1 moves".into())],
            gcode: None,
        }),
    );
    assert_eq!(out.focus, Some(Focus::Editor));
    assert_eq!(said(&out), ["part.nc: 1 moves"]);
    assert!(e.modified(), "unsaved until saved");
    assert_eq!(e.name(), "part.isel");
    // Ctrl-S writes it under its name, but only as a new file: an existing
    // part.isel is not replaced without a question.
    let out = host.key(&mut e, Action::Save);
    assert_eq!(saves(&out), [(&path, true, &None)]);
    let state = e.buffer.state();
    let out = host.send(
        &mut e,
        Input::Msg(EditorMsg::Saved {
            path: path.clone(),
            state,
            result: Err(SaveFailure::Exists),
            then: None,
        }),
    );
    assert!(
        matches!(&out.dialog, Some(Dialog::Ask(q)) if q.yes == Answer::Overwrite { path: path.clone(), then: None }),
        "{out:?}"
    );
}
