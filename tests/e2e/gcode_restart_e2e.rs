//! End to end: `jogterm import FILE --from-line N`, the restart of a job
//! after a broken tool or a power cut (`docs/gcode.md`, "Restart from a
//! line"). The confirmation says the modal state and the entry worked out
//! here by hand from the sample; the restart program, stored and run on
//! `jogterm sim --pty`, ends where the whole job ends.
//!
//! Logic, not the wire's timing: no lock, they run beside the others.

use std::process::Output;

use crate::sim_process::{JOGTERM, LOGIC_SCALE, SimProcess, contains_panic, text};

fn sample(name: &str) -> String {
    format!("{}/examples/gcode/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// `jogterm import` with no configuration and a state directory of its own.
fn import(args: &[&str], state: &std::path::Path) -> Output {
    std::process::Command::new(JOGTERM)
        .arg("import")
        .args(args)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .env("JOGTERM_STATE_DIR", state)
        .output()
        .expect("run jogterm import")
}

#[test]
fn import_from_line_confirms_the_modal_state_and_the_entry_and_writes_the_restart() {
    let dir = tempfile::tempdir().expect("dir");
    let file = sample("fusion-grbl.nc");
    let program = dir.path().join("restart.isel");
    let program_path = program.display().to_string();
    let args = [
        file.as_str(),
        "--work-zero",
        "X50 Y50 Z40",
        "--from-line",
        "20",
        "-o",
        &program_path,
    ];
    let out = import(&args, dir.path());
    let said = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    // Line 20 (`X40`) starts where line 19 (`G1 X0 Y0 F2400`) ends, at the
    // cut depth of line 17 (Z-1); the clearance of line 15 is the safe height.
    for expected in [
        "restart from line 20 for profile \"isel simulator\"",
        "skipped lines 1-19; left to run lines 20-33 (14 lines)",
        "modal state applied: G21 mm, G17 XY, G90, G54, F2400, spindle M3 S16000, coolant M9, T1",
        "line 20's start (work G54): X 0.000 Y 0.000 Z -1.000 mm",
        "1. retract: G0 Z15.000 (the job's safe height), from wherever the tool stands",
        "2. G0 X0.000 Y0.000 at the safe height, above line 20's start",
        "3. spindle speed S16000",
        "4. spindle on",
        "5. descend: G1 Z-1.000 F2400 to line 20's start",
        "then line 20 on, from command 7: isel program of 27 commands",
        "written to",
    ] {
        assert!(said.contains(expected), "`{expected}` not in:\n{said}");
    }
    // The program: the reference run, 3D, the entry (machine X50 Y50 Z55 is
    // 20000, 20000, 22000 steps), then line 20 on, each command with its line.
    let written = std::fs::read_to_string(&program).expect("the program");
    let commands: Vec<&str> = written.lines().filter(|l| !l.starts_with(';')).collect();
    let command = |k: usize| commands[k].split(';').next().unwrap_or("").trim();
    assert_eq!(command(0), "77");
    assert_eq!(command(1), "z1");
    assert_eq!(command(2), "m0,6000,0,6000,22000,6000,0,6000");
    assert_eq!(command(3), "m20000,10000,20000,10000,22000,6000,0,10000");
    assert_eq!(command(4), "p2,128,1");
    assert_eq!(command(5), "m20000,6000,20000,6000,15600,6000,0,6000");
    assert!(commands[6].ends_with("; fusion-grbl.nc:20"), "{written}");
    assert!(
        commands[2..6]
            .iter()
            .all(|c| c.contains("; fusion-grbl.nc:20")),
        "{written}"
    );
    assert!(written.contains("; jogterm-gcode restart=line 20\n"));
    let last = commands.len() - 1;
    assert_eq!(command(last), "9");
    assert!(commands[last].ends_with("; fusion-grbl.nc:32"), "{written}");

    // --json: the whole job's figures and the restart's.
    let out = import(
        &[
            file.as_str(),
            "--work-zero",
            "X50 Y50 Z40",
            "--from-line",
            "20",
            "--json",
        ],
        dir.path(),
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let r = &json["restart"];
    assert_eq!(r["line"], 20);
    assert_eq!(r["skipped_lines"], 19);
    assert_eq!(r["modal"]["spindle"], "M3");
    assert_eq!(r["modal"]["feed_mm_min"], 2400.0);
    assert_eq!(r["start_mm"], serde_json::json!([0.0, 0.0, -1.0]));
    assert_eq!(r["safe_z_mm"], 15.0);
    assert_eq!(r["first_command"], 7);
    assert_eq!(
        json["moves"], 12,
        "the whole job's summary as without --from-line"
    );

    // A line before the first move: the reason at FILE:LINE, exit 1,
    // nothing written.
    let refused = dir.path().join("refused.isel");
    let refused_path = refused.display().to_string();
    let out = import(
        &[
            file.as_str(),
            "--work-zero",
            "X50 Y50 Z40",
            "--from-line",
            "12",
            "-o",
            &refused_path,
        ],
        dir.path(),
    );
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains(&format!(
            "{file}:12:1: error: line 12 is at or before the job's first move (line 15)"
        )),
        "{said}"
    );
    assert!(!refused.exists());
    assert!(!contains_panic(&out.stderr), "{said}");
}

/// The position `upload --start` says the program ended at.
fn ended_at(said: &str) -> Vec<i64> {
    let line = said
        .lines()
        .find_map(|l| l.strip_prefix("the program ended; position (steps): "))
        .unwrap_or_else(|| panic!("no end position in:\n{said}"));
    line.split(", ")
        .map(|part| part[2..].parse().expect("steps"))
        .collect()
}

#[test]
fn a_restart_stored_and_run_ends_where_the_whole_job_ends() {
    // A faster machine than the default, standing 1 mm from its reference
    // point, on a simulator at the logic scale: the test checks where the
    // stored restart ends, which no scale changes (`docs/testing.md`,
    // "The time scale").
    let sim = SimProcess::options("isel")
        .files(&[(
            "profiles/default.toml",
            "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n\
             [sim]\nstart_position = 1.0\n",
        )])
        .time_scale(LOGIC_SCALE)
        .start();
    let job = sim.dir.path().join("job.nc");
    std::fs::write(
        &job,
        "G21 G90 G17\nM3 S9000\nG0 X10 Y10 Z20\nG1 Z5 F600\nG1 X30 F1200\nG2 X40 Y20 I0 J10\nG1 Y40\nG0 Z20\nG0 X60 Y40\nG1 Z5 F600\nG1 X80\nG0 Z20\nM5\nM30\n",
    )
    .expect("write");
    let job = job.display().to_string();
    let program = sim.dir.path().join("restart.isel").display().to_string();
    let out = sim
        .configured(&["import", &job, "--from-line", "7", "-o", &program])
        .output()
        .expect("import");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let reference = sim
        .configured(&["send", "@07", "@0R7"])
        .output()
        .expect("reference");
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let out = sim
        .configured(&["upload", &program, "--erase", "--start"])
        .output()
        .expect("upload");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{said}");
    // The whole job's last point: X80 Y40 Z20 at 400 steps/mm.
    assert_eq!(ended_at(&said)[..3], [32000, 16000, 8000], "{said}");
}
