//! The real `jogterm` binary in an 80x24 pseudo-terminal with a program in
//! its editor: edits survive a `SIGKILL` (the recovery file is written while
//! editing, not on exit) and are offered back on the next start; a save is
//! atomic and leaves no recovery behind.

mod ui_pty;

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use ui_pty::PtyRun;

const JOGTERM: &str = env!("CARGO_BIN_EXE_jogterm");
const WAIT: Duration = Duration::from_secs(20);

const PROGRAM: &str = "; drill\n7 7\nm8000,8000,8000,8000\n9\n";

fn spawn(args: &[&str], config: &Path, state: &Path) -> PtyRun {
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        ("JOGTERM_STATE_DIR", state.display().to_string()),
        ("RUST_BACKTRACE", "0".into()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    PtyRun::spawn(Path::new(JOGTERM), args, &env)
}

fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

/// The recovery files in `state`.
fn recoveries(state: &Path) -> Vec<String> {
    fs::read_dir(state.join("recovery"))
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".jogterm-recovery"))
                .collect()
        })
        .unwrap_or_default()
}

fn wait_until(what: &str, mut ok: impl FnMut() -> bool) {
    let end = Instant::now() + WAIT;
    while !ok() {
        assert!(Instant::now() < end, "{what} never happened");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn edits_survive_a_kill_and_are_offered_back() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("config");
    let state = dir.path().join("state");
    fs::create_dir_all(&config).expect("config dir");
    let file = dir.path().join("drill.isel");
    fs::write(&file, PROGRAM).expect("write the program");
    let file_arg = file.display().to_string();

    let mut run = spawn(&["--program", &file_arg], &config, &state);
    wait_for(&run, "connected");
    wait_for(&run, "drill.isel");
    // A new comment on the first line (Tab types the blank: Space stops).
    run.send(b";\tkept-after-kill\r");
    wait_for(&run, "kept-after-kill");
    wait_until("the recovery file", || !recoveries(&state).is_empty());
    // No goodbye: the process is killed outright.
    let pid = run.child.process_id().expect("pid");
    // SAFETY: a signal to our own child.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGKILL) }, 0);
    run.wait_exit(WAIT);
    drop(run);
    assert_eq!(fs::read_to_string(&file).expect("read"), PROGRAM);

    let mut run = spawn(&[], &config, &state);
    let screen = wait_for(&run, "Recovered edits");
    assert!(screen.contains("drill.isel"), "{screen}");
    run.send(b"y");
    let screen = wait_for(&run, "kept-after-kill");
    assert!(screen.contains("m8000,8000,8000,8000"), "{screen}");
    // Saved, the file has the edits and the recovery is gone.
    run.send(b"\x13");
    wait_until("the save", || {
        fs::read_to_string(&file).is_ok_and(|t| t.starts_with("; kept-after-kill\n; drill"))
    });
    wait_until("the recovery removed", || recoveries(&state).is_empty());
    // Nothing unsaved: F4 back to the machine screen, and q quits at once.
    run.send(b"\x1bOS");
    wait_for(&run, "Position");
    run.send(b"q");
    assert_eq!(run.wait_exit(WAIT), Some(0));
}

#[test]
fn quitting_with_unsaved_edits_asks_first() {
    let dir = tempfile::tempdir().expect("tempdir");
    let config = dir.path().join("config");
    let state = dir.path().join("state");
    fs::create_dir_all(&config).expect("config dir");
    let file = dir.path().join("part.isel");
    fs::write(&file, PROGRAM).expect("write the program");
    let file_arg = file.display().to_string();

    let mut run = spawn(&["--program", &file_arg], &config, &state);
    wait_for(&run, "part.isel");
    run.send(b";\tunsaved\r");
    wait_for(&run, "unsaved");
    // Back on the machine screen, q asks instead of quitting.
    run.send(b"\x1bOS");
    wait_for(&run, "Position");
    run.send(b"q");
    wait_for(&run, "Unsaved");
    // Save, then go on (quit): the file holds the edits.
    run.send(b"s");
    assert_eq!(run.wait_exit(WAIT), Some(0));
    assert!(
        fs::read_to_string(&file)
            .expect("read")
            .starts_with("; unsaved\n")
    );
    assert!(recoveries(&state).is_empty(), "{:?}", recoveries(&state));
}
