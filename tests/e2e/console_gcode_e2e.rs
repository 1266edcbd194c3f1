//! G-code as a first-class file of the console (issue 40): the real
//! binary in a pseudo-terminal against `jogterm sim --pty`. A job that
//! does not fit the soft limits with the saved work offset opens with its
//! errors in the job panel (it used to be refused before the terminal was
//! taken); setting the zero in the console checks it again at once and it
//! converts; `--work-zero` places it for the session; the job panel and the
//! status line read whole at 80x24.

use crate::console_pty;
use crate::editor_e2e;
use crate::sim_process;

use std::fs;

use console_pty::{spawn_on, wait_for};
use sim_process::SimProcess;

/// The default profile with a short reference run (`offsets_e2e`'s).
const PROFILE: (&str, &str) = (
    "profiles/default.toml",
    "base = \"default\"\n[isel]\nreference_speed_hz = 12000\n[sim]\nstart_position = 1.0\nlimit_margin = 0.5\n",
);

/// With the work zero at the reference point (a fresh state), its cut at
/// Z-1 lies 1 mm below the soft limit of Z.
const JOB: &str = "G21 G90\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG1 X20\nG0 Z5\nM30\n";

#[test]
fn a_job_outside_the_soft_limits_opens_with_its_errors_and_converts_once_the_zero_is_set() {
    let sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let job = sim.dir.path().join("part.nc");
    fs::write(&job, JOB).expect("write the job");
    let link = sim.link.display().to_string();
    let job_arg = job.display().to_string();
    let mut run = spawn_on(
        &sim,
        state.path(),
        &["--port", &link, "--program", &job_arg],
    );
    let screen = wait_for(&run, "1 error: does not run");
    assert!(screen.contains("Job part.nc"), "{screen}");
    assert!(
        screen.contains("3:1: G1 Z-1 F100 | Z -1.000 mm is below"),
        "{screen}"
    );

    // To the machine screen, reference, and work Z 0 set 20 mm above here.
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, "Position");
    console_pty::reference(&mut run);
    run.type_keys(&[b"s"]);
    wait_for(&run, "Set the work position here (G54)");
    run.type_text("Z-20");
    run.type_keys(&[b"\r"]);
    wait_for(&run, "checked again for G54: it fits");
    // Back in the editor: the converted program and the panel of the job
    // as it now stands (Z -1 work is machine 19).
    run.type_keys(&[b"e"]);
    let screen = wait_for(&run, "fits memory");
    assert!(screen.contains("part.isel[+]"), "{screen}");
    assert!(screen.contains("Z work -1..5, machine 19..25"), "{screen}");
    assert!(!screen.contains("does not run"), "{screen}");
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, "Position");
    editor_e2e::quit_discarding_the_edits(&mut run);
}

/// Ctrl-O on a `.nc` file imports it (it used to open as isel text, every
/// line an error); `--work-zero` places it for the session; at 80x24 the
/// job panel beside the program says the job's figures and its waits.
#[test]
fn ctrl_o_imports_gcode_and_the_job_panel_reads_at_80x24() {
    let sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = sim.dir.path().join("state");
    let job = sim.dir.path().join("tools.nc");
    fs::write(
        &job,
        "G21 G90\nG0 X10 Y10 Z5\nG1 Z-1 F100\nG0 Z5\nT2 M6\nG1 Z-1 F100\nG0 Z5\nM30\n",
    )
    .expect("write the job");
    let link = sim.link.display().to_string();
    let mut run = editor_e2e::spawn_sized(
        &["--port", &link, "--work-zero", "X0 Y0 Z20"],
        sim.dir.path(),
        &state,
        (24, 80),
    );
    wait_for(&run, "connected");
    run.type_keys(&[b"e"]);
    wait_for(&run, "untitled");
    run.type_keys(&[b"\x0f"]);
    wait_for(&run, "Open a program");
    run.type_text(&job.display().to_string());
    run.type_keys(&[b"\r"]);
    // The cut at Z-1 is inside the soft limits only with --work-zero's Z.
    let screen = wait_for(&run, "Job tools.nc");
    assert!(screen.contains("tools.isel[+]"), "{screen}");
    assert!(screen.contains("fits memory"), "{screen}");
    for needle in ["8 lines of G-code", "tools: T2", "waits for the", "line 5:"] {
        assert!(screen.contains(needle), "`{needle}` missing:\n{screen}");
    }
    // F9 shows the toolpath in its place, and back after the planes.
    run.type_keys(&[b"\x1b[20~"]);
    wait_for(&run, "Toolpath");
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, "Position");
    editor_e2e::quit_discarding_the_edits(&mut run);
}
