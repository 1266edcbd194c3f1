//! End to end: what comes into a G-code import from outside (issue 37),
//! through the real binary. Text never becomes controller commands (a
//! profile name or a file name with line breaks); the work a line asks for
//! is bounded before it is done (turns, dwells, pecks, numbers of 400
//! digits, `/dev/zero`), under a memory limit and a deadline; one error is
//! reported once, without the false ones that followed it, in line order;
//! the program memory is one setting, and a position beyond the
//! controller's counter is refused at its G-code line.

use std::path::Path;
use std::process::{Command, Output, Stdio};

use crate::gcode_e2e::commands_of;
use crate::sim_process::{JOGTERM, LOGIC_SCALE, SimProcess, contains_panic, text, wait_child};

fn run(sim: &SimProcess, args: &[&str]) -> Output {
    sim.configured(args).output().expect("run jogterm")
}

const SMALL: &str = "G21 G90\nG0 X10 Y10 Z10\nG1 X20 F600\nM30\n";

/// The move a name with line breaks would smuggle in: X to 250 mm.
const INJECTED: &str = "m100000,4000,0,4000,0,4000,0,4000";

#[test]
fn a_profile_name_with_line_breaks_is_refused_and_nothing_is_sent() {
    // The simulator plays the default profile; the commands use `mill`.
    let name = format!("name = \"mill\\n77\\nz1\\n{INJECTED}\"\n");
    let mut sim = SimProcess::start_with_files("isel", &[("profiles/mill.toml", &name)]);
    let file = sim.dir.path().join("small.nc");
    std::fs::write(&file, SMALL).expect("write");
    let file = file.display().to_string();
    for command in ["check", "import"] {
        let out = run(&sim, &[command, &file, "--profile", "mill"]);
        let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
        assert_eq!(out.status.code(), Some(2), "{command}: {said}");
        assert!(
            said.contains("a profile name is one line of printable text"),
            "{command}: {said}"
        );
    }
    let out = run(&sim, &["upload", &file, "--start", "--profile", "mill"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert_eq!(sim.received_total(), 0, "nothing reached the controller");
}

/// The G-code's commands stored and run, and nothing else: a file name
/// with line breaks stays inside its comment.
#[test]
fn a_gcode_file_name_with_line_breaks_becomes_no_command() {
    let mut sim = SimProcess::options("isel").time_scale(LOGIC_SCALE).start();
    let plain = sim.dir.path().join("plain.nc");
    let odd = sim
        .dir
        .path()
        .join(format!("part\n77\nz1\n{INJECTED}\n.nc"));
    for path in [&plain, &odd] {
        std::fs::write(path, SMALL).expect("write");
    }
    let program = |gcode: &Path, out: &str| {
        let out = sim.dir.path().join(out);
        let done = run(
            &sim,
            &[
                "import",
                &gcode.display().to_string(),
                "-o",
                &out.display().to_string(),
            ],
        );
        assert_eq!(done.status.code(), Some(0), "{}", text(&done.stderr));
        std::fs::read_to_string(out).expect("the program")
    };
    let expected = commands_of(&program(&plain, "plain.isel"));
    let written = program(&odd, "odd.isel");
    assert_eq!(commands_of(&written), expected, "{written}");
    assert!(written.contains("file=part\\u{a}77\\u{a}z1"), "{written}");

    let out = run(&sim, &["upload", &odd.display().to_string(), "--start"]);
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{said}");
    // X20 Y10 Z10 at 400 steps/mm.
    assert!(
        said.contains("position (steps): X 8000, Y 4000, Z 4000"),
        "{said}"
    );
    let received = sim.received();
    assert!(!received.contains(INJECTED), "{received}");
    assert!(received.contains("@0i<CR>77<CR>z1<CR>m4000,"), "{received}");
}

/// `jogterm import FILE` with at most 2 GB of address space and a deadline:
/// unbounded work fails the test by running out of either.
fn import_bounded(file: &Path) -> Output {
    let child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2000000; exec \"$0\" import \"$1\"")
        .arg(JOGTERM)
        .arg(file)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn jogterm import");
    wait_child(child, "jogterm import")
}

#[test]
fn work_a_line_asks_for_is_bounded_and_refused_at_the_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let nines = "9".repeat(400);
    let cases = [
        (
            "turns.nc",
            "G21 G17 G0 X0 Y0 Z5\nG2 X10 Y0 I5 J0 P100000000 F100\n".to_owned(),
            ":2:17: error: P of an arc is its number of turns: 1 to 1000",
        ),
        (
            "million.nc",
            "G21 G17 G0 X0 Y0 Z5\nG3 X10 Y0 I5 J0 P1000000 F100\n".to_owned(),
            ":2:17: error: P of an arc is its number of turns: 1 to 1000",
        ),
        (
            "dwell.nc",
            format!("G21\nG4 P{nines}\n"),
            ":2:4: error: `P` must be followed by a number of at most 1000000000",
        ),
        (
            "feed.nc",
            format!("G21 G0 X0 Y0 Z5\nG1 X10 F{nines}\n"),
            ":2:8: error: `F` must be followed by a number of at most 1000000000",
        ),
        (
            "radius.nc",
            format!("G21 G0 X0 Y0 Z5\nG2 X10 Y0 R{nines} F100\n"),
            ":2:11: error: `R` must be followed by a number of at most 1000000000",
        ),
        (
            "pecks.nc",
            "G21 G0 X0 Y0 Z5\nG83 X5 Y5 Z-1 R1 Q0.0000001 F100\n".to_owned(),
            ":2:18: error: G83's Q makes more than 1000 pecks",
        ),
    ];
    let mut wrong = Vec::new();
    for (name, gcode, expected) in &cases {
        let path = dir.path().join(name);
        std::fs::write(&path, gcode).expect("write");
        let out = import_bounded(&path);
        let said = text(&out.stderr);
        let want = format!("{}{expected}", path.display());
        if out.status.code() != Some(1) || !said.contains(&want) {
            wrong.push(format!(
                "{name}: expected exit 1 and `{want}`, got {:?}:\n{said}",
                out.status.code()
            ));
        }
    }
    let out = import_bounded(Path::new("/dev/zero"));
    let said = text(&out.stderr);
    if out.status.code() != Some(2) || !said.contains("/dev/zero: more than 67108864 bytes") {
        wrong.push(format!(
            "/dev/zero: expected exit 2 and the size, got {:?}:\n{said}",
            out.status.code()
        ));
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The `error` lines `jogterm import` printed, without the file's path.
fn errors_of(out: &Output, file: &Path) -> Vec<String> {
    let prefix = format!("{}:", file.display());
    text(&out.stderr)
        .lines()
        .filter(|l| l.contains(": error: "))
        .map(|l| l.strip_prefix(&prefix).unwrap_or(l).to_owned())
        .collect()
}

#[test]
fn one_error_is_reported_once_without_false_ones_in_line_order() {
    let dir = tempfile::tempdir().expect("temp dir");
    // No unit: the shipped profile's unit is taken and said once, at the
    // first axis word; the G0 of its line is in force after it, and the
    // arc starts where that line ends: nothing else is said.
    let no_unit = dir.path().join("no-unit.nc");
    std::fs::write(
        &no_unit,
        "(no G20 or G21)\nG0 X0 Y0 Z5\nX10\nG2 X20 Y0 I5 J0 F100\nM30\n",
    )
    .expect("write");
    let out = import_bounded(&no_unit);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        errors_of(&out, &no_unit).is_empty(),
        "{}",
        text(&out.stderr)
    );
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    let warnings: Vec<&str> = said.lines().filter(|l| l.contains(": warning: ")).collect();
    assert_eq!(warnings.len(), 1, "{said}");
    assert!(
        warnings[0].contains(":2:4: warning: the file sets no unit"),
        "{said}"
    );

    // Lines that cannot be read (their F among them): their errors, in
    // line order, and no "feed move before any F" after them.
    let unread = dir.path().join("unread.nc");
    std::fs::write(
        &unread,
        "G21 G0 X0 Y0 Z5\nG1 X10 F100 (unclosed\nG1 X11\nG1 X12 F200 \u{0}\nG1 X13\nG1 X--1 F300\nG1 X14\nM30\n",
    )
    .expect("write");
    let out = import_bounded(&unread);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    let errors = errors_of(&out, &unread);
    let places: Vec<&str> = errors
        .iter()
        .map(|e| e.split(": error: ").next().unwrap_or(""))
        .collect();
    assert_eq!(places, ["2:13", "4:13", "6:4"], "{errors:#?}");
    assert!(errors[0].contains("a comment opened with `(` is not closed"));
    assert!(errors[1].contains("U+0000 cannot stand here"));
    assert!(errors[2].contains("`X` must be followed by a number"));
}

/// 40 commands and the closing `9`.
fn isel_program() -> String {
    let mut text = String::from("77\n");
    for k in 0..39 {
        text.push_str(&format!("m{},2000,0,2000,0,2000,0,2000\n", 100 + k * 10));
    }
    text.push_str("9\n");
    text
}

#[test]
fn the_program_memory_is_one_setting_for_import_check_and_upload() {
    // More than the controller holds: refused by every command alike.
    let dir = tempfile::tempdir().expect("temp dir");
    let profiles = dir.path().join("profiles");
    std::fs::create_dir_all(&profiles).expect("mkdir");
    std::fs::write(profiles.join("default.toml"), "[gcode]\nmemory = 4000\n").expect("write");
    let gcode = dir.path().join("small.nc");
    std::fs::write(&gcode, SMALL).expect("write");
    for command in ["import", "check"] {
        let out = Command::new(JOGTERM)
            .arg(command)
            .arg(&gcode)
            .env("JOGTERM_CONFIG_DIR", dir.path())
            .output()
            .expect("run jogterm");
        let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
        assert_eq!(out.status.code(), Some(2), "{command}: {said}");
        assert!(
            said.contains("4000 commands: a isel controller stores 1 to 2000"),
            "{command}: {said}"
        );
    }

    // A controller that holds 30, as its profile says: `check` counts
    // against 30 as the import does, and the upload sends nothing.
    let small = ("profiles/default.toml", "[gcode]\nmemory = 30\n");
    let mut sim = SimProcess::start_variant("isel", &[small], &["memory=30"]);
    let file = sim.dir.path().join("forty.isel");
    std::fs::write(&file, isel_program()).expect("write");
    let file = file.display().to_string();
    let out = run(&sim, &["check", &file]);
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains(&format!(
            "{file}:31:1: error: the controller stores 30 commands before the end `9`"
        )),
        "{said}"
    );
    let out = run(&sim, &["upload", &file]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert_eq!(sim.received_total(), 0, "nothing reached the controller");
}

#[test]
fn a_position_beyond_the_controllers_counter_is_refused_at_its_gcode_line() {
    let far = ("profiles/default.toml", "[axes.X]\nmax = 50000.0\n");
    let mut sim = SimProcess::start_with_files("isel", &[far]);
    let file = sim.dir.path().join("far.nc");
    std::fs::write(&file, "G21 G90\nG0 X10 Y10 Z10\nG1 X30000 F600\nM30\n").expect("write");
    let file = file.display().to_string();
    for command in ["import", "check", "upload"] {
        let out = run(&sim, &[command, &file]);
        let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
        assert_eq!(out.status.code(), Some(1), "{command}: {said}");
        assert!(
            said.contains(&format!(
                "{file}:3:1: error: X 30000.000 mm is 12000000 steps from the reference point: beyond the isel controller's position counter (-8388608..8388607 steps)"
            )),
            "{command}: {said}"
        );
    }
    assert_eq!(sim.received_total(), 0, "nothing reached the controller");
}
