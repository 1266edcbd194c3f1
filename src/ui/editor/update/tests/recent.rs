//! The files opened last (issue 40): a program or a G-code file that
//! opened goes first in the list, which the worker keeps in the state
//! directory, and Up/Down in the open form (Ctrl-O) bring them back.

use super::*;
use crate::program::recent;
use crate::ui::editor::gcode_open::check;

fn kept(out: &Outcome) -> Vec<Vec<PathBuf>> {
    out.effects
        .iter()
        .filter_map(|e| match e {
            Effect::Io(EditorIo::KeepRecent { list, .. }) => Some(list.clone()),
            _ => None,
        })
        .collect()
}

/// Open `path` as Ctrl-O's form does and carry out the worker's part.
fn open(host: &mut Host, e: &mut Editor, path: &std::path::Path) -> Vec<Vec<PathBuf>> {
    let out = host.send(e, Input::Msg(EditorMsg::Open(path.to_path_buf())));
    let mut lists = kept(&out);
    for effect in out.effects {
        let msg = match effect {
            Effect::Io(EditorIo::ImportGcode(job)) => {
                EditorMsg::GcodeChecked(Box::new(check(*job)))
            }
            Effect::Io(io @ EditorIo::Load { .. }) => crate::ui::editor::io::perform(io),
            _ => continue,
        };
        lists.extend(kept(&host.send(e, Input::Msg(msg))));
    }
    lists
}

#[test]
fn files_that_opened_come_back_with_up_and_down_in_the_open_form() {
    let dir = tempfile::tempdir().expect("dir");
    let program = dir.path().join("drill.isel");
    std::fs::write(&program, "7\n").expect("write");
    let job = dir.path().join("part.nc");
    std::fs::write(&job, "G21 G90\nG0 X10 Y10 Z5\nM30\n").expect("write");
    let mut host = Host::isel();
    let mut e = Editor::new(&host.setup, host.now);
    e.keep_recent(dir.path().join("state"), Vec::new());

    assert_eq!(open(&mut host, &mut e, &program), [vec![program.clone()]]);
    assert_eq!(
        open(&mut host, &mut e, &job),
        [vec![job.clone(), program.clone()]]
    );
    // A file that does not exist opened nothing: not kept.
    assert!(open(&mut host, &mut e, &dir.path().join("gone.isel")).is_empty());

    host.focused = true;
    let out = host.key(&mut e, Action::Open);
    let Some(Dialog::Form(form)) = &out.dialog else {
        panic!("the open form: {:?}", out.dialog);
    };
    assert_eq!(
        form.note.as_deref(),
        Some("Up/Down: the 2 files opened last")
    );
    host.send(
        &mut e,
        Input::Dialog(host.dialog.clone().expect("form"), Action::ClearLine),
    );
    let out = host.key(&mut e, Action::NextField);
    let Some(Dialog::Form(form)) = &out.dialog else {
        panic!("still the form");
    };
    assert_eq!(form.field(0), job.display().to_string());
    assert_eq!(form.note.as_deref(), Some("opened last 1/2 (Up/Down)"));
    let out = host.key(&mut e, Action::NextField);
    let Some(Dialog::Form(form)) = &out.dialog else {
        panic!("still the form");
    };
    assert_eq!(form.field(0), program.display().to_string());
    // Enter opens it.
    let out = host.key(&mut e, Action::Submit);
    assert!(
        out.effects
            .iter()
            .any(|e| matches!(e, Effect::Io(EditorIo::Load { path, .. }) if *path == program)),
        "{:?}",
        out.effects
    );
    // The worker keeps what it is handed, and the next session reads it.
    let state = dir.path().join("state");
    recent::write(&state, &e.recent).expect("write");
    assert_eq!(recent::read(&state), [job, program]);
}
