//! End to end: `jogterm upload` against the real `jogterm sim --pty`: an
//! isel program with a loop and a branch and an EMCU job are checked, stored
//! and run, and the simulated machine ends where the toolpath preview
//! (`program::path`) predicts; an isel program in the way needs `--erase`; a
//! program with errors sends nothing and names its lines; a controller with
//! less memory than the linter assumes (`memory <n>` on the simulator's
//! stdin) refuses the command that does not fit, and the upload names its
//! file line.

use std::path::Path;
use std::process::Output;

use jogterm::axis::AxisSet;
use jogterm::program::path::{Start, path};
use jogterm::program::{Language, Program};

use crate::sim_process;
use sim_process::{LOGIC_SCALE, SimProcess, contains_panic, jogterm};

/// `jogterm` against the simulator, configured from the simulator's
/// directory, with no stdin.
fn run(sim: &SimProcess, args: &[&str]) -> Output {
    sim.configured(args).output().expect("run jogterm")
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

/// On a simulator ten times faster than real time: what it checks (the end
/// position, the replies, the store refusing a second upload) is the same
/// at any speed; at real time the program runs about 25 s.
#[test]
fn a_program_with_a_loop_and_a_branch_ends_where_the_preview_said() {
    let sim = SimProcess::options("isel").time_scale(LOGIC_SCALE).start();
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

/// The link lost in the middle of an upload is a link failure, exit 3 as
/// `--help` says, not the 1 of a refusal (issue 37).
#[test]
fn an_upload_that_loses_the_link_exits_3() {
    let mut sim = SimProcess::start("isel");
    // 400 moves: at 19200 baud the upload takes seconds, long enough to
    // close the line in its middle.
    let mut text = String::from("7 7\n");
    for k in 0..400 {
        text.push_str(&format!("m{},4000,0,4000,0,4000,0,4000\n", 400 + k));
    }
    text.push_str("9\n");
    let file = write_program(&sim, "long.isel", &text);
    let child = sim
        .configured(&["upload", &file, "--erase"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm upload");
    sim.wait_received("a tenth of the program", |r| r.contains("m440,"));
    sim.control("fault close 500");
    let out = child.wait_with_output().expect("upload ends");
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "a link failure: {said}");
    assert!(said.contains("link lost"), "{said}");
    assert!(!contains_panic(&out.stderr), "{said}");
}

#[test]
fn emp_drives_are_refused_before_anything_is_opened() {
    let sim = SimProcess::start("isel");
    let file = write_program(&sim, "job.emcu", "L1,x100\n");
    let out = jogterm(Path::new("/nonexistent/tty"), "emp", &["upload", &file])
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .output()
        .expect("run jogterm");
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("emp drives store no programs"), "{said}");
}

#[test]
fn a_program_of_the_other_family_is_refused_by_its_extension() {
    let sim = SimProcess::start("emcu");
    let file = write_program(&sim, "drill.isel", "7 7\n9\n");
    let out = run(&sim, &["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("an isel program by its extension"), "{said}");
}

/// Issue 37 (13): `--work-zero` places G-code; on an EMCU job (or an isel
/// program) it was accepted and silently ignored. Refused now, before the
/// port is opened: nothing reaches the controller.
#[test]
fn work_zero_on_a_controller_program_is_refused_not_ignored() {
    let mut sim = SimProcess::start("emcu");
    let file = write_program(&sim, "pallet.emcu", "@LX\n");
    let before = sim.received();
    let out = run(&sim, &["upload", &file, "--work-zero", "X10 Y10 Z0"]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("--work-zero places G-code"), "{said}");
    assert_eq!(sim.received(), before, "nothing sent");
}

/// Commands stored (isel `@0i` … `9`) before the one that does not fit.
fn isel_program(moves: usize) -> String {
    let mut text = String::from("; more moves than the controller has room for\n7 7\n");
    for i in 0..moves {
        text.push_str(&format!(
            "0 {},2000,0,2000,0,2000,0,2000 ; move {}\n",
            10 + i,
            i + 1
        ));
    }
    text.push_str("9\n");
    text
}

#[test]
fn an_isel_controller_with_less_memory_refuses_the_command_beyond_it_at_its_file_line() {
    let mut sim = SimProcess::start("isel");
    sim.control("memory 3");
    let file = write_program(&sim, "long.isel", &isel_program(4));
    // The linter assumes the controller's 2000 commands: nothing to fix.
    let check = run(&sim, &["check", &file]);
    assert_eq!(check.status.code(), Some(0), "{}", stderr(&check));
    let out = run(&sim, &["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    // `7 7` and two moves fit; command 4 is the third move, on line 5.
    assert!(
        said.contains("long.isel:5: the controller refused command 4 `012,2000,0,2000,0,2000,0,2000`: 6 The CNC program does not fit into the program memory"),
        "{said}"
    );
    // Issue 37 (13): the same upload fails the same way, --erase or not;
    // before, it advised "upload again with --erase".
    assert!(
        said.contains("the program does not fit: the controller stored 3 of its 6 commands, and uploading it again fails the same way"),
        "{said}"
    );
    assert!(said.contains("`jogterm run FILE --stream`"), "{said}");
    assert!(!said.contains("upload again with --erase"), "{said}");
    assert!(said.contains("upload 0/6"), "{said}");
    assert!(!contains_panic(&out.stderr), "{said}");
    sim.assert_alive();
}

/// Referenced, the counters are 0 (manual 1.5.9). Absolute and relative
/// moves, a wait and an output.
const EMCU_JOB: &str = "\
; a small EMCU job
#E2,1500
L2,X2000,Y1000          ; absolute
W50
L2,x-500,z300           ; relative
A1,1
L2,y250
";

/// On a simulator ten times faster than real time (the reference run from
/// the default start position and the job at its speeds took 16 s): the end
/// position, the counters and the wire are the same at any speed.
#[test]
fn an_emcu_job_is_stored_and_run_and_ends_where_the_preview_said() {
    let mut sim = SimProcess::options("emcu").time_scale(LOGIC_SCALE).start();
    let ready = run(&sim, &["send", "@R", "#S2000", "#R200\\x01", "$HZYX\\x01"]);
    assert!(ready.status.success(), "{}", stderr(&ready));
    sim.wait_device("referenced", |s| {
        s.contains("X 0 ") && !s.contains("moving")
    });
    let file = write_program(&sim, "pallet.emcu", EMCU_JOB);
    let out = run(&sim, &["upload", &file, "--start"]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("6 commands stored"), "{said}");
    assert!(said.contains("upload 6/6 (100 %)"), "{said}");
    assert!(said.contains("lines/s"), "{said}");
    let program = Program::parse(Language::Emcu, EMCU_JOB);
    let end = path(&program, &Start::new(AxisSet::XYZ, [0; 4])).end;
    assert_eq!(end, [1500, 1250, 300, 0]);
    let expected = format!("position (steps): X {}, Y {}, Z {}", end[0], end[1], end[2]);
    assert!(said.contains(&expected), "{expected}\n{said}");
    // The controller's own counters say the same.
    let state = sim.device_state();
    assert!(
        state.starts_with(&format!("device: X {} ", end[0]))
            && state.contains(&format!("Y {} ", end[1]))
            && state.contains(&format!("Z {} ", end[2])),
        "{state}"
    );
    let received = sim.received();
    assert!(received.contains("@F<CR>#E2,1500<CR>"), "{received}");
    assert!(received.contains("L2,y250<01>"), "{received}");
    assert!(received.contains("@J<CR>"), "{received}");

    // `@F` replaces the stored job: another upload needs no --erase, and
    // --erase changes nothing.
    let out = run(&sim, &["upload", &file]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let out = run(&sim, &["upload", &file, "--erase"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

#[test]
fn an_emcu_job_with_errors_sends_nothing_and_names_its_lines() {
    let mut sim = SimProcess::start("emcu");
    let file = write_program(&sim, "bad.emcu", "; head\nL1,X100\n@X\nW0\n");
    let out = run(&sim, &["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("bad.emcu:3:1: error:"), "{said}");
    assert!(said.contains("bad.emcu:4:2: error:"), "{said}");
    assert!(
        said.contains("2 errors to fix first; nothing was sent"),
        "{said}"
    );
    let received = sim.received();
    assert!(!received.contains("@F"), "{received}");
}

#[test]
fn an_emcu_job_beyond_the_interfaces_memory_is_refused_at_its_file_line() {
    let mut sim = SimProcess::start("emcu");
    sim.control("memory 2");
    let file = write_program(&sim, "pallet.emcu", EMCU_JOB);
    let out = run(&sim, &["upload", &file, "--start"]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    // Commands 1 and 2 fit; command 3 `W50` is on line 4.
    assert!(
        said.contains("pallet.emcu:4: the controller refused command 3 `W50`: 0x03 memory full"),
        "{said}"
    );
    assert!(said.contains("discarded the job"), "{said}");
    assert!(!said.contains("running the program"), "{said}");
    let received = sim.received();
    assert!(!received.contains("@J"), "nothing was started: {received}");
    assert!(
        !received.contains("L2,x-500"),
        "the upload stopped at the line: {received}"
    );
    // The session's closing bytes reach the simulator a few byte times
    // after jogterm has ended.
    sim.wait_device("without a job", |state| state.contains("ROM empty"));
    sim.assert_alive();
}

/// A stored program that the controller ends with an error (the E-stop
/// circuit opened while it moves: `9`, manual chapter 5) ends the upload
/// with status 1 and the code said, not "the program ended" with a
/// position: the end's fault is read before the run is taken for done.
#[test]
fn a_program_the_controller_ends_with_an_error_says_its_code() {
    // Near the reference point: the reference run takes two seconds.
    let mut sim = SimProcess::options("isel")
        .files(&[sim_process::near_reference("isel")])
        .start();
    let reference = run(&sim, &["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", stderr(&reference));
    // X 40 mm at 10 mm/s: four seconds of motion.
    let file = write_program(&sim, "long.isel", "m16000,4000,0,4000,0,4000,0,4000\n9\n");
    let child = sim
        .configured(&["upload", &file, "--start"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("jogterm upload --start");
    sim.wait_device("the program's move", |s| s.contains("moving"));
    sim.control("set estop1 open");
    let out = sim_process::wait_child(child, "upload --start");
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(said.contains("the program ended with `9`"), "{said}");
    assert!(!said.contains("the program ended; position"), "{said}");
    assert!(!contains_panic(&out.stderr), "{said}");
}
