//! End to end: `jogterm upload` against the real `jogterm sim --protocol
//! isel --pty`: a program with a loop and a branch is checked, stored and
//! run, and the simulated machine ends where the toolpath preview
//! (`program::path`) predicts; a program in the way needs `--erase`; a
//! program with errors sends nothing and names its lines.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};

use jogterm::axis::AxisSet;
use jogterm::program::path::{Start, path};
use jogterm::program::{Language, Program};

/// A simulator process; killed when dropped. Its stdin stays open (a closed
/// stdin would end it).
struct Sim {
    child: Child,
    link: PathBuf,
    dir: tempfile::TempDir,
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Sim {
    fn start() -> Sim {
        let dir = tempfile::tempdir().expect("temp dir");
        let link = dir.path().join("isel");
        let mut child = Command::new(env!("CARGO_BIN_EXE_jogterm"))
            .args(["sim", "--protocol", "isel", "--pty", "--link"])
            .arg(&link)
            .env("JOGTERM_CONFIG_DIR", dir.path())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn the simulator");
        let stdout = child.stdout.take().expect("stdout");
        let mut lines = BufReader::new(stdout);
        let mut first = String::new();
        lines.read_line(&mut first).expect("the simulator's path");
        assert_eq!(PathBuf::from(first.trim()), link);
        std::thread::spawn(move || {
            let mut line = String::new();
            while lines.read_line(&mut line).is_ok_and(|n| n > 0) {
                line.clear();
            }
        });
        Sim { child, link, dir }
    }

    fn jogterm(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_jogterm"))
            .args(args)
            .args([
                "--port",
                &self.link.display().to_string(),
                "--protocol",
                "isel",
            ])
            .env("JOGTERM_CONFIG_DIR", self.dir.path())
            .stdin(Stdio::null())
            .output()
            .expect("run jogterm")
    }

    fn file(&self, name: &str, text: &str) -> String {
        let path = self.dir.path().join(name);
        std::fs::write(&path, text).expect("write the program");
        path.display().to_string()
    }
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
    let sim = Sim::start();
    let reference = sim.jogterm(&["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", stderr(&reference));
    let file = sim.file("loop.isel", LOOP_AND_BRANCH);
    let out = sim.jogterm(&["upload", &file, "--start"]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("10 commands stored"), "{said}");
    assert!(said.contains("upload 10/10 (100 %)"), "{said}");
    let end = predicted_end(LOOP_AND_BRANCH);
    assert_eq!(end, [3200, 1800, 400, 0]);
    let expected = format!("position (steps): X {}, Y {}, Z {}", end[0], end[1], end[2]);
    assert!(said.contains(&expected), "{expected}\n{said}");

    // Stored now: another upload stops unless it may erase.
    let out = sim.jogterm(&["upload", &file]);
    let said = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(said.contains("a program is already stored"), "{said}");
    let out = sim.jogterm(&["upload", &file, "--erase"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

#[test]
fn a_program_with_errors_sends_nothing_and_names_its_lines() {
    let sim = Sim::start();
    let file = sim.file("bad.isel", "; head\n7 7\nm8000,8000\nq\n9\n");
    let out = sim.jogterm(&["upload", &file]);
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
    let sim = Sim::start();
    let out = sim.jogterm(&["upload", "/nonexistent/x.isel"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let file = sim.file("ok.isel", "7 7\n9\n");
    let out = Command::new(env!("CARGO_BIN_EXE_jogterm"))
        .args([
            "upload",
            &file,
            "--port",
            "/nonexistent/tty",
            "--protocol",
            "isel",
        ])
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .output()
        .expect("run jogterm");
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
}
