//! End to end: the built-in simulator's start key (`docs/simulator.md`,
//! "The start key"), which a job's M0 waits for, pressed without hardware:
//! by `jogterm run --sim-start-key` on the in-process simulator.

use std::io::Write as _;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::sim_process::{JOGTERM, text};

/// A job that pauses (M0) above its first point, then cuts one line.
const M0_JOB: &str = "G21 G90\nG0 Z5\nG0 X10 Y5\nM0\nG1 Z-1 F600\nG1 X20\nG0 Z5\nM2\n";

/// A configuration directory whose simulated axes stand 1 mm from their
/// reference point (a short reference run), and the job in it.
fn setup() -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().expect("config dir");
    let profiles = dir.path().join("profiles");
    std::fs::create_dir_all(&profiles).expect("profiles dir");
    std::fs::write(
        profiles.join("default.toml"),
        "[sim]\nstart_position = 1.0\n",
    )
    .expect("write the profile");
    let job = dir.path().join("m0.nc");
    std::fs::write(&job, M0_JOB).expect("write the job");
    let job = job.display().to_string();
    (dir, job)
}

fn run(dir: &tempfile::TempDir, job: &str, extra: &[&str]) -> Command {
    let mut c = Command::new(JOGTERM);
    c.args([
        "--sim",
        "isel",
        "run",
        job,
        "--work-zero",
        "X50 Y50 Z20",
        "--yes",
    ])
    .args(extra)
    .env("JOGTERM_CONFIG_DIR", dir.path())
    .env("JOGTERM_STATE_DIR", dir.path())
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    c
}

/// Wait for the child's end within `limit`; its output (killed if late).
fn finished(mut child: std::process::Child, limit: Duration) -> (Option<i32>, String) {
    let end = Instant::now() + limit;
    loop {
        if let Ok(Some(_)) = child.try_wait() {
            break;
        }
        if Instant::now() > end {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("the run's output");
    (out.status.code(), text(&out.stderr))
}

#[test]
fn an_m0_job_on_the_in_process_simulator_is_finished_by_the_sim_start_key() {
    let (dir, job) = setup();
    // Without a press the job stands at its M0: still running after 5 s.
    let child = run(&dir, &job, &[])
        .stdin(Stdio::null())
        .spawn()
        .expect("run");
    let (code, said) = finished(child, Duration::from_secs(5));
    assert_eq!(code, None, "the job waits for the start key: {said}");
    assert!(said.contains("M0: program pause"), "{said}");
    // Pressed every second: the job goes on at its M0 and ends.
    let child = run(&dir, &job, &["--sim-start-key", "1"])
        .stdin(Stdio::null())
        .spawn()
        .expect("run");
    let (code, said) = finished(child, Duration::from_secs(30));
    assert_eq!(code, Some(0), "{said}");
    assert!(
        said.contains("the simulator's start key (start key) pressed"),
        "{said}"
    );
}

#[test]
fn a_line_on_stdin_presses_the_sim_start_key() {
    let (dir, job) = setup();
    let mut child = run(&dir, &job, &["--sim-start-key", "stdin"])
        .stdin(Stdio::piped())
        .spawn()
        .expect("run");
    let mut stdin = child.stdin.take().expect("stdin");
    // A line a second until the job ends: a press before the job stands at
    // its pause is taken by nothing, the one after ends the wait.
    let end = Instant::now() + Duration::from_secs(30);
    while child.try_wait().ok().flatten().is_none() && Instant::now() < end {
        let _ = writeln!(stdin);
        std::thread::sleep(Duration::from_secs(1));
    }
    drop(stdin);
    let (code, said) = finished(child, Duration::from_secs(5));
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("start key (start key) pressed"), "{said}");
    // On a real port: refused before anything is sent.
    let out = Command::new(JOGTERM)
        .args(["run", &job, "--port", "/dev/null", "--protocol", "isel"])
        .args([
            "--yes",
            "--sim-start-key",
            "1",
            "--work-zero",
            "X50 Y50 Z20",
        ])
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::null())
        .output()
        .expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("use --sim"), "{said}");
}
