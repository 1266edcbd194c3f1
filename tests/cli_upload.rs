//! End to end: `jogterm upload` against the real `jogterm sim --protocol
//! isel --pty`: a program with a loop and a branch is checked, stored and
//! run, and the simulated machine ends where the toolpath preview
//! (`program::path`) predicts; a program in the way needs `--erase`; a
//! program with errors sends nothing and names its lines.

use std::path::Path;
use std::process::{Output, Stdio};

use jogterm::axis::AxisSet;
use jogterm::program::path::{Start, path};
use jogterm::program::{Language, Program};

mod sim_process;
use sim_process::{SimProcess, jogterm};

/// `jogterm` against the simulator, configured from the simulator's
/// directory, with no stdin.
fn run(sim: &SimProcess, args: &[&str]) -> Output {
    sim.jogterm(args)
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .stdin(Stdio::null())
        .output()
        .expect("run jogterm")
}

/// A program file in the simulator's directory; its path.
fn write_program(sim: &SimProcess, name: &str, text: &str) -> String {
    let path = sim.dir.path().join(name);
    std::fs::write(&path, text).expect("write the program");
    path.display().to_string()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Referenced, the machine starts at 0 on every axis.
const LOOP_AND_BRANCH: &str = "\
; a loop and a branch
j300
J100
m2000,4000,1000,4000,400,4000,0,4000     ; absolute start point
0 400,4000,0,4000,0,4000,0,4000          ; step along X
3 2,-1                                   ; twice more
o0,0,1,2                                 ; input 0.0 set: skip the next move
0 0,4000,800,4000,0,4000,0,4000          ; input clear: along Y
3 0,2                                    ; jump over the next move
0 4000,4000,0,4000,0,4000,0,4000         ; never run
9
";

fn predicted_end(text: &str) -> [i64; 4] {
    let program = Program::parse(Language::Isel, text);
    path(&program, &Start::new(AxisSet::XYZ, [0; 4])).end
}

#[test]
fn a_program_with_a_loop_and_a_branch_ends_where_the_preview_said() {
    let sim = SimProcess::start("isel");
    let reference = run(&sim, &["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", stderr(&reference));
    let file = write_program(&sim, "loop.isel", LOOP_AND_BRANCH);
    let out = run(&sim, &["upload", &file, "--start"]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("10 commands stored"), "{said}");
    assert!(said.contains("upload 10/10 (100 %)"), "{said}");
    let end = predicted_end(LOOP_AND_BRANCH);
    assert_eq!(end, [3200, 1800, 400, 0]);
    let expected = format!("position (steps): X {}, Y {}, Z {}", end[0], end[1], end[2]);
    assert!(said.contains(&expected), "{expected}\n{said}");

    // Stored now: another upload stops unless it may erase.
    let out = run(&sim, &["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(said.contains("a program is already stored"), "{said}");
    let out = run(&sim, &["upload", &file, "--erase"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

#[test]
fn a_program_with_errors_sends_nothing_and_names_its_lines() {
    let sim = SimProcess::start("isel");
    let file = write_program(&sim, "bad.isel", "; head\n7 7\nm8000,8000\nq\n9\n");
    let out = run(&sim, &["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("bad.isel:3:1: error:"), "{said}");
    assert!(said.contains("bad.isel:4:1: error:"), "{said}");
    assert!(
        said.contains("2 errors to fix first; nothing was sent"),
        "{said}"
    );
}

#[test]
fn a_missing_file_or_a_dead_port_have_their_exit_codes() {
    let sim = SimProcess::start("isel");
    let out = run(&sim, &["upload", "/nonexistent/x.isel"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let file = write_program(&sim, "ok.isel", "7 7\n9\n");
    let out = jogterm(Path::new("/nonexistent/tty"), "isel", &["upload", &file])
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .output()
        .expect("run jogterm");
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
}

#[test]
fn other_families_are_sent_to_the_console_editor_before_anything_is_opened() {
    let sim = SimProcess::start("isel");
    let file = write_program(&sim, "job.emcu", "L1,x100\n");
    for family in ["emcu", "emp"] {
        let out = jogterm(Path::new("/nonexistent/tty"), family, &["upload", &file])
            .env("JOGTERM_CONFIG_DIR", sim.dir.path())
            .output()
            .expect("run jogterm");
        let said = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{family}: {said}");
        assert!(
            said.contains("stores isel CNC programs"),
            "{family}: {said}"
        );
    }
}
