//! Issue 40: a CAM job of 25 000 lines, far bigger than the controller's
//! memory, runs from the console as `jogterm run` runs it: opened with
//! `--program`, F6 says the ways and takes the one chosen. A finish whose
//! passes are left to the safe height runs in parts, each cut at a
//! retract; the same raster without a retract between its passes cannot be
//! cut and streams (the stream is not held to the memory: it used to be
//! refused with "the controller stores 2000 commands"). Both end exactly
//! at the job's last point.
//!
//! The simulator runs at `run_e2e::JOB_SCALE` and the profile's line is
//! 921600 baud (the console has no `--baud`; `run_e2e` passes it to `run`):
//! these runs check where 25 000 lines end and
//! where the parts are cut, not how long they take (the scale changes only
//! how soon every reply comes).

use std::fs;
use std::time::Duration;

use crate::console_pty::wait_for;
use crate::editor_e2e::{quit_discarding_the_edits, ready_in_the_editor, spawn_sized};
use crate::run_e2e::{self, JOB_SCALE, WORK_ZERO, finish, finish_end, stands_at};
use crate::sim_process::SimProcess;
use crate::ui_pty::PtyRun;

/// `run_e2e`'s faster machine, on a faster line.
const FAST_LINE: (&str, &str) = (
    "profiles/default.toml",
    "[connection]\nbaud = 921600\n\
     [axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n",
);

/// 125 passes of 200 cuts: 25 254 lines of G-code.
const PASSES: usize = 125;

/// How long a whole job may take on a loaded machine.
const JOB_WAIT: Duration = Duration::from_secs(400);

/// The console at 160x48 with `gcode` opened as `name.nc`, referenced, in
/// the editor.
fn opened(gcode: &str, name: &str) -> (SimProcess, PtyRun) {
    let sim = SimProcess::options("isel")
        .files(&[FAST_LINE])
        .time_scale(JOB_SCALE)
        .start();
    let file = sim.dir.path().join(format!("{name}.nc"));
    fs::write(&file, gcode).expect("write the job");
    assert!(gcode.lines().count() > 25_000);
    let state = sim.dir.path().join("state");
    let link = sim.link.display().to_string();
    let file_arg = file.display().to_string();
    let log = sim.dir.path().join("traffic.log").display().to_string();
    let mut run = spawn_sized(
        &[
            "--port",
            &link,
            "--program",
            &file_arg,
            "--work-zero",
            WORK_ZERO,
            "--log",
            &log,
        ],
        sim.dir.path(),
        &state,
        (48, 160),
    );
    wait_for(&run, "connected");
    let isel = format!("{name}.isel");
    run.wait_for(&isel, JOB_WAIT)
        .unwrap_or_else(|screen| panic!("the import never ended:\n{screen}"));
    ready_in_the_editor(&mut run, &isel);
    (sim, run)
}

/// From the editor to the machine screen, and quit without the program.
fn quit(run: &mut PtyRun) {
    run.type_keys(&[b"\x1bOS"]);
    wait_for(run, "Position");
    quit_discarding_the_edits(run);
}

/// The commands the console's traffic log says were sent: the simulator
/// keeps only the last of what it received, too little for 25 000 lines.
fn sent(sim: &SimProcess) -> Vec<String> {
    let log = fs::read_to_string(sim.dir.path().join("traffic.log")).expect("the traffic log");
    log.lines()
        .filter_map(|l| l.split_once(" >> "))
        .map(|(_, t)| t.trim_end_matches("<CR>").to_owned())
        .collect()
}

/// The programs stored (`@0i` … `9`), each its commands.
fn stored(sent: &[String]) -> Vec<Vec<&str>> {
    let mut programs = Vec::new();
    let mut open: Option<Vec<&str>> = None;
    for line in sent {
        match (line.as_str(), open.as_mut()) {
            ("@0i", _) => open = Some(Vec::new()),
            (line, Some(program)) => {
                program.push(line);
                if line == "9" {
                    programs.extend(open.take());
                }
            }
            _ => {}
        }
    }
    programs
}

/// The finish without its retracts between passes: one descent, then a
/// raster that never leaves the material, so there is nowhere to cut it.
fn raster(passes: usize) -> String {
    finish(passes)
        .lines()
        .enumerate()
        .filter(|(n, l)| !(*n > 5 && (*l == "G0 Z5" || l.starts_with("G1 Z-0.5"))))
        .map(|(n, l)| match l.strip_prefix("G0 X5 ") {
            // The way to the next pass is a cut at the depth, not a rapid.
            Some(rest) if n > 5 => format!("G1 X5 {rest} F3000"),
            _ => l.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn a_25k_line_finish_runs_in_parts_from_the_console_each_cut_at_a_retract() {
    let (mut sim, mut run) = opened(&finish(PASSES), "finish");
    run.type_keys(&[b"\x1b[17~"]);
    let screen = wait_for(&run, "Run finish.nc");
    assert!(screen.contains("the controller stores 2000"), "{screen}");
    assert!(screen.contains("chosen: chunked"), "{screen}");
    run.type_keys(&[b"y"]);
    wait_for(&run, "part 1/");
    let screen = run
        .wait_for("the job ended:", JOB_WAIT)
        .unwrap_or_else(|screen| panic!("the job never ended:\n{screen}"));
    assert!(!screen.contains("RUNNING part"), "{screen}");
    stands_at(&mut sim, finish_end(PASSES));
    let sent = sent(&sim);
    let stored = stored(&sent);
    assert!(stored.len() >= 12, "{} parts", stored.len());
    // The finish's safe height, work Z5: machine 65 mm.
    run_e2e::assert_parts_end_retracted(&stored, "26000", 2000);
    quit(&mut run);
}

#[test]
fn a_25k_line_raster_that_cannot_be_cut_streams_from_the_console_to_its_last_point() {
    let gcode = raster(PASSES);
    let (mut sim, mut run) = opened(&gcode, "raster");
    run.type_keys(&[b"\x1b[17~"]);
    let screen = wait_for(&run, "Run raster.nc");
    assert!(screen.contains("chosen: stream"), "{screen}");
    run.type_keys(&[b"y"]);
    wait_for(&run, "STREAM");
    run.wait_for("the stream ended", JOB_WAIT)
        .unwrap_or_else(|screen| panic!("the stream never ended:\n{screen}"));
    run.type_keys(&[b"x"]);
    // The last cut of the last pass, as the file writes its Z.
    let [x, y, _] = finish_end(PASSES);
    let z: f64 = format!("{:.3}", -0.5 + 0.2 * (200.0f64 * 1.3).sin())
        .parse()
        .expect("a number");
    stands_at(&mut sim, [x, y, z]);
    let sent = sent(&sim);
    assert!(!sent.iter().any(|l| l == "@0i"), "nothing stored");
    let moves = sent.iter().filter(|l| l.starts_with("@0M")).count();
    assert!(moves > 24_000, "{moves} moves streamed");
    quit(&mut run);
}
