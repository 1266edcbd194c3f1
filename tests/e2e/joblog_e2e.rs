//! End to end: the job log and the resume after a crash (issue 41 items 4
//! and 5, `docs/gcode.md` "Job log" and "Resume"). `jogterm run` of the
//! slow cut against `jogterm sim --pty` at real time, ended three ways (to
//! its end, by Ctrl-C in the cut, by `kill -9` in the cut), and what `jogterm
//! log` says of each; after the kill, the offer on the next run, the refusal
//! of `--yes` alone, and the restart the offer makes, which ends at the
//! job's last point.
//!
//! Real time (the key and the kill must land in the cut), but no timing
//! promise: no lock.

use std::process::{Child, Output, Stdio};
use std::time::Duration;

use crate::run_e2e::{
    CUT_END_X, CUT_ZERO, SLOW_CUT, cut_controller, cut_steps, spawn_on_a_terminal, stands_at_steps,
    wait_in_the_slow_cut, write,
};
use crate::sim_process::{SimProcess, text};

/// The last line of [`SLOW_CUT`] that has run to its end while its slow
/// cut (line 6, `G1 X22.5 F300`) runs: the plunge, line 5.
const BEFORE_THE_CUT: u64 = 5;

/// [`SLOW_CUT`]'s last point: `G1 Y20` after the cut, then `G0 Z5`.
const END: [f64; 3] = [CUT_END_X, 20.0, 5.0];

fn run_args(file: &str) -> Vec<&str> {
    vec!["run", file, "--work-zero", CUT_ZERO, "--stream", "--yes"]
}

/// `jogterm run` of the slow cut, streamed, spawned without a terminal.
fn spawn_run(sim: &SimProcess, file: &str) -> Child {
    sim.configured(&run_args(file))
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn jogterm run")
}

/// Started, waited for inside its slow cut, then killed with SIGKILL:
/// nothing of jogterm runs after it (no stop, no end record).
fn killed_in_the_cut(sim: &mut SimProcess, file: &str) {
    let mut child = spawn_run(sim, file);
    wait_in_the_slow_cut(sim);
    child.kill().expect("kill -9");
    let _ = child.wait();
    // The controller finishes the move it was given; the operator, like
    // this test, starts again once the machine stands.
    sim.wait_device("standing", |s| !s.contains("moving"));
}

/// `jogterm log --json` of the simulator's state directory.
fn log_json(sim: &SimProcess) -> serde_json::Value {
    let out = sim.configured(&["log", "--json"]).output().expect("log");
    assert!(out.status.success(), "{}", text(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn said(out: &Output) -> String {
    text(&out.stderr)
}

#[test]
fn the_log_holds_a_completed_a_stopped_and_a_killed_run() {
    let mut sim = cut_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    // 1. To its end.
    let out = sim.configured(&run_args(&file)).output().expect("run");
    assert_eq!(out.status.code(), Some(0), "{}", said(&out));
    // 2. Ctrl-C in the cut: stopped by the operator.
    let child = spawn_run(&sim, &file);
    wait_in_the_slow_cut(&mut sim);
    crate::stops_support::interrupt(child, libc::SIGINT, "run");
    // 3. kill -9 in the cut: no end.
    killed_in_the_cut(&mut sim, &file);

    let json = log_json(&sim);
    let runs = json["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 3, "{json:#}");
    let hows: Vec<&str> = runs.iter().map(|r| r["how"].as_str().unwrap()).collect();
    assert_eq!(hows, ["done", "stopped", "crash"], "{json:#}");
    // The whole job's last line, then the plunge before the cut, twice.
    let lines: Vec<u64> = runs
        .iter()
        .map(|r| r["last_line"].as_u64().unwrap())
        .collect();
    assert_eq!(lines, [9, BEFORE_THE_CUT, BEFORE_THE_CUT], "{json:#}");
    let file_path = std::path::absolute(&file).unwrap().display().to_string();
    for r in runs {
        assert_eq!(r["file"], file_path.as_str());
        assert_eq!(r["way"], "stream");
        assert_eq!(r["by"], "run");
        assert_eq!(r["work_offset"], "G54 X0.000 Y0.000 Z5.000 mm");
        assert_eq!(r["port"], sim.link.display().to_string());
        assert!(r["estimated_s"].as_f64().unwrap() > 0.0, "{r:#}");
        assert!(r["actual_s"].as_f64().unwrap() > 0.0, "{r:#}");
    }
    assert_eq!(runs[0]["hash"], runs[2]["hash"]);
    assert!(runs[0]["ended"].is_string() && runs[2]["ended"].is_null());
    // Only the crash is offered for a restart.
    assert_eq!(runs[0]["resume_line"], serde_json::Value::Null);
    assert_eq!(runs[1]["resume_line"], serde_json::Value::Null);
    assert_eq!(runs[2]["resume_line"], BEFORE_THE_CUT);
    assert_eq!(json["notes"], serde_json::json!([]));

    // The table: newest last, within 80 columns.
    let out = sim.configured(&["log", "-n", "2"]).output().expect("log");
    let table = text(&out.stdout);
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 3, "{table}");
    assert!(rows[0].starts_with("started (UTC)"), "{table}");
    assert!(
        rows[1].contains("slow.nc") && rows[1].ends_with("stopped"),
        "{table}"
    );
    assert!(
        rows[2].contains(" 5 ") && rows[2].ends_with("crash"),
        "{table}"
    );
    assert!(rows.iter().all(|r| r.chars().count() <= 80), "{table}");
}

#[test]
fn after_a_kill_the_next_run_offers_the_restart_and_it_ends_at_the_jobs_last_point() {
    let mut sim = cut_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    killed_in_the_cut(&mut sim, &file);

    // --yes alone chooses neither the restart nor the whole job: refused,
    // nothing sent, both commands named.
    let before = sim.received().len();
    let out = sim.configured(&run_args(&file)).output().expect("run");
    let refused = said(&out);
    assert_eq!(out.status.code(), Some(1), "{refused}");
    for expected in [
        "did not end (killed, crashed, or the power went); line 5 was the last to run to its end",
        &format!("jogterm run {file} --from-line 5 --yes (or --resume)"),
        &format!("jogterm run {file} --from-start --yes"),
        "nothing was sent",
    ] {
        assert!(
            refused.contains(expected),
            "`{expected}` not in:\n{refused}"
        );
    }
    assert_eq!(sim.received().len(), before, "nothing went out");

    // On a terminal the offer is a question; yes restarts from line 5
    // through the restart entry, then the start is confirmed as always.
    let mut run = spawn_on_a_terminal(&sim, &file, "stream", CUT_ZERO);
    run.wait_for("instead of the whole job? [y/N]", Duration::from_secs(10))
        .expect("the offer");
    run.type_text("y\r");
    let confirmation = run
        .wait_for("start the job (stream)? [y/N]", Duration::from_secs(10))
        .expect("the start's confirmation");
    assert!(
        confirmation.contains("slow.nc: restart from line 5 for profile"),
        "{confirmation}"
    );
    run.type_text("y\r");
    let code = run.wait_exit(Duration::from_secs(60));
    assert_eq!(code, Some(0), "{}", text(&run.output()));
    stands_at_steps(&mut sim, cut_steps(END));

    // The log: the crash, then the restart from line 5, done at line 9;
    // nothing is offered any more.
    let json = log_json(&sim);
    let runs = json["runs"].as_array().expect("runs");
    assert_eq!(runs.len(), 2, "{json:#}");
    assert_eq!(runs[0]["how"], "crash");
    assert_eq!(runs[1]["how"], "done");
    assert_eq!(runs[1]["from_line"], 5);
    assert_eq!(runs[1]["last_line"], 9);
    let out = sim
        .configured(&[
            "run",
            &file,
            "--work-zero",
            CUT_ZERO,
            "--stream",
            "--yes",
            "--resume",
        ])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1), "{}", said(&out));
    assert!(
        said(&out).contains("--resume: the job log has no run of"),
        "{}",
        said(&out)
    );
}

/// Issue 41 (6): after three whole runs of a job to their end, the next
/// run's estimate says what the last runs on this profile and way took
/// beside the model's figure. The in-process simulator, a short job.
#[test]
fn three_runs_to_their_end_refine_the_next_runs_estimate() {
    let dir = tempfile::tempdir().expect("config and state dir");
    let profiles = dir.path().join("profiles");
    std::fs::create_dir_all(&profiles).expect("profiles dir");
    std::fs::write(
        profiles.join("default.toml"),
        "[sim]\nstart_position = 1.0\n",
    )
    .expect("profile");
    let job = dir.path().join("short.nc");
    std::fs::write(
        &job,
        "G21 G90\nG0 Z5\nG0 X10 Y5\nG1 Z-1 F600\nG1 X20 F900\nG0 Z5\nM2\n",
    )
    .expect("job");
    let job = job.display().to_string();
    let run = || {
        let out = std::process::Command::new(crate::sim_process::JOGTERM)
            .args([
                "--sim",
                "isel",
                "run",
                &job,
                "--work-zero",
                "X50 Y50 Z20",
                "--yes",
            ])
            .env("JOGTERM_CONFIG_DIR", dir.path())
            .env("JOGTERM_STATE_DIR", dir.path())
            .stdin(Stdio::null())
            .output()
            .expect("run");
        assert_eq!(out.status.code(), Some(0), "{}", said(&out));
        said(&out)
    };
    for _ in 0..3 {
        let said = run();
        assert!(!said.contains("from the last"), "{said}");
    }
    let said = run();
    let line = said
        .lines()
        .find(|l| l.contains("by the model, "))
        .unwrap_or_else(|| panic!("no refined estimate:\n{said}"));
    assert!(
        line.contains("from the last 3 jobs on this machine (profile isel simulator, stored)"),
        "{line}"
    );
}
