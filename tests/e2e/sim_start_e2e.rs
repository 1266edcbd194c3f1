//! End to end: the built-in simulator's start key (`docs/simulator.md`,
//! "The start key"), which a job's M0 waits for, pressed without hardware:
//! by `jogterm run --sim-start-key` on the in-process simulator, and by
//! `s` in the console's simulator panel.

use std::io::Write as _;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::sim_process::{JOGTERM, WAIT, text};
use crate::ui_pty::PtyRun;

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
    // Without a press (and no line on its open standard input) the job
    // stands at its M0: still running after 5 s.
    let mut child = run(&dir, &job, &[])
        .stdin(Stdio::piped())
        .spawn()
        .expect("run");
    let stdin = child.stdin.take();
    let (code, said) = finished(child, Duration::from_secs(5));
    drop(stdin);
    assert_eq!(code, None, "the job waits for the start key: {said}");
    assert!(said.contains("M0: program pause"), "{said}");
    // Pressed every second: the job goes on at its M0 and ends. The run
    // killed above broke off: this one says from where, the start.
    let mut child = run(&dir, &job, &["--sim-start-key", "1", "--from-start"])
        .stdin(Stdio::piped())
        .spawn()
        .expect("run");
    let stdin = child.stdin.take();
    let (code, said) = finished(child, Duration::from_secs(30));
    drop(stdin);
    assert_eq!(code, Some(0), "{said}");
    assert!(
        said.contains("the simulator's start key (start key) pressed"),
        "{said}"
    );
    assert!(said.contains("line 4: going on (the start key)"), "{said}");
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
    assert!(said.contains("line 4: going on (the start key)"), "{said}");
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

/// The console on the in-process simulator with the job as its program,
/// run with F6 (confirmed): the console runs it in pieces and waits at its
/// M0 (the piece before erased) until `s` in the simulator panel presses
/// the machine's start key; then the rest runs to its end.
#[test]
fn an_m0_job_in_the_console_is_finished_by_the_sim_panels_start_key() {
    let (dir, job) = setup();
    // Within the soft limits with the work zero at machine 0.
    std::fs::write(
        &job,
        "G21 G90\nG0 Z10\nG0 X10 Y5\nM0\nG1 Z5 F600\nG1 X20\nG0 Z10\nM2\n",
    )
    .expect("write the job");
    let config = dir.path().display().to_string();
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1"),
        ("JOGTERM_CONFIG_DIR", config.as_str()),
        ("JOGTERM_STATE_DIR", config.as_str()),
        ("RUST_BACKTRACE", "0"),
    ];
    let mut run = PtyRun::spawn_sized(
        std::path::Path::new(JOGTERM),
        &["--program", &job],
        &env,
        40,
        200,
    );
    let wait_for = |run: &PtyRun, needle: &str| {
        run.wait_for(needle, WAIT)
            .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
    };
    wait_for(&run, "connected");
    // From the editor to the machine screen; initialise and reference.
    run.type_keys(&[b"\x1b[Z"]);
    wait_for(&run, "i init");
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    run.type_keys(&[b"h"]);
    wait_for(&run, "Reference run");
    run.type_keys(&[b"y"]);
    wait_for(&run, "READY");
    // F6: the console runs the job in pieces and waits at its M0 itself,
    // the piece that ran erased (the start key must not run it again).
    run.type_keys(&[b"\x1b[17~"]);
    wait_for(&run, "Run m0.nc");
    run.type_keys(&[b"y"]);
    wait_for(&run, "WAIT M0 line 4");
    // Tab past the port bits to the simulator panel; s presses the key
    // (again, while the wait is not armed yet: the erase, the position).
    run.type_keys(&[b"\t", b"\t"]);
    wait_for(&run, "s start key");
    let mut ended = false;
    for _ in 0..8 {
        run.type_keys(&[b"s"]);
        if run
            .wait_for("the job ended", Duration::from_secs(3))
            .is_ok()
        {
            ended = true;
            break;
        }
    }
    assert!(ended, "{}", run.screen().screen().contents());
    let screen = wait_for(&run, "READY");
    let x = screen
        .lines()
        .find(|l| l.starts_with("X"))
        .unwrap_or_default()
        .to_owned();
    assert!(x.contains("20.000") && x.contains("8000"), "{screen}");
    // The console's run is in the job log (issue 41 item 4): stored, by
    // the console, done, with the file's content hash `run` would find.
    let out = Command::new(JOGTERM)
        .args(["log", "--json"])
        .env("JOGTERM_STATE_DIR", dir.path())
        .output()
        .expect("jogterm log");
    let log: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the log as JSON");
    let last = &log["runs"][log["runs"].as_array().map_or(0, Vec::len).saturating_sub(1)];
    assert_eq!(last["by"], "console", "{log:#}");
    assert_eq!(last["way"], "stored", "{log:#}");
    assert_eq!(last["how"], "done", "{log:#}");
    assert!(
        last["file"].as_str().is_some_and(|f| f.ends_with("m0.nc")),
        "{log:#}"
    );
}
