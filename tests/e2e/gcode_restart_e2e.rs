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
        "1. reference run of Z, then Y, then X (gcode.reference_first)",
        "2. G0 Z15.000 (the job's safe height) from the reference point, Z alone",
        "3. G0 X0.000 Y0.000 at the safe height, above line 20's start",
        "4. spindle speed S16000",
        "5. spindle on",
        "6. descend: G1 Z-1.000 F600 to line 20's start (the file's last plunge feed, line 18)",
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
    // Down at line 18's plunge feed, F600: 10 mm/s, 4000 steps/s.
    assert_eq!(command(5), "m20000,4000,20000,4000,15600,4000,0,4000");
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

/// A drilled and cut job for the restarts of a tool standing in the part
/// (issue 37): line 8 plunges at F120, lines 9 and 10 cut at F1200; the
/// restart from line 10 starts at X35 Y10 Z-3, its safe height Z5.
const DRILL: &str = "G21 G90 G17\nM3 S9000\nG0 Z5\nG0 X10 Y10\nG1 Z-3 F120\nG0 Z5\nG0 X30 Y10\nG1 Z-3 F120\nG1 X35 F1200\nG1 X40\nG0 Z5\nG0 X60 Y10\nG1 Z-3 F120\nG1 X70 F1200\nG0 Z5\nM30\n";

/// The job's work zero, machine mm.
const DRILL_ZERO: &str = "X50 Y50 Z40";

/// Machine steps of a point of [`DRILL`] at `per_mm` steps a millimetre.
fn drill_steps(per_mm: f64, work: [f64; 3]) -> [i64; 3] {
    let zero = [50.0, 50.0, 40.0];
    [0, 1, 2].map(|i| ((work[i] + zero[i]) * per_mm).round() as i64)
}

/// `jogterm run DRILL --from-line 10` the way `way` (`stored`, `stream`,
/// `chunked`) on `family`'s simulator with `reference_first = false`, the
/// tool standing in the part away from the line's start (X80 Y20 Z-3 of
/// the job): what the controller received from the run on, and what the
/// run said.
fn restart_in_the_part(family: &'static str, way: &str) -> (String, String) {
    let profile = match family {
        "isel" => (
            "profiles/default.toml",
            "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n\
             [gcode]\nreference_first = false\nmemory = 8\n[sim]\nstart_position = 1.0\n",
        ),
        _ => (
            "profiles/emcu.toml",
            "base = \"emcu\"\n[axes.X]\nmax_speed = 40.0\n[axes.Y]\nmax_speed = 40.0\n\
             [axes.Z]\nmax_speed = 20.0\n[gcode]\nreference_first = false\nm3 = \"output:A1\"\n\
             [sim]\nstart_position = 1.0\n",
        ),
    };
    let files = [profile];
    let mut options = SimProcess::options(family)
        .files(&files)
        .time_scale(LOGIC_SCALE);
    if family == "isel" {
        options = options.variants(&["memory=8"]);
    }
    let mut sim = options.start();
    let job = sim.dir.path().join("drill.nc");
    std::fs::write(&job, DRILL).expect("write");
    let job = job.display().to_string();
    // Referenced, then into the part at X80 Y20 Z-3 (work), as a broken
    // tool leaves it.
    let per_mm = if family == "isel" { 400.0 } else { 200.0 };
    let [x, y, z] = drill_steps(per_mm, [80.0, 20.0, -3.0]);
    let into_part: Vec<String> = match family {
        "isel" => vec![
            "@07".into(),
            "@0R7".into(),
            format!("@0M{x},8000,{y},8000,{z},8000,0,8000"),
        ],
        _ => vec![
            "@R".into(),
            "#S2000".into(),
            "#R200\\x01".into(),
            "$HZYX\\x01".into(),
            "#E1,2000".into(),
            format!("L1,X{x},Y{y},Z{z}\\x01"),
        ],
    };
    let args: Vec<&str> = std::iter::once("send")
        .chain(into_part.iter().map(String::as_str))
        .collect();
    let out = sim.configured(&args).output().expect("send");
    assert!(out.status.success(), "{}", text(&out.stderr));
    sim.wait_device("standing", |s| !s.contains("moving"));
    let before = sim.received().len();
    let mut args = vec![
        "run",
        &job,
        "--work-zero",
        DRILL_ZERO,
        "--from-line",
        "10",
        "--yes",
    ];
    let way_arg = format!("--{way}");
    if way != "stored" {
        args.push(&way_arg);
    }
    let out = sim.configured(&args).output().expect("run");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{family} {way}: {said}");
    // The whole job's last point: X70 Y10 Z5.
    let [x, y, z] = drill_steps(per_mm, [70.0, 10.0, 5.0]);
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let at = match family {
        "isel" => format!("device: X {x} Y {y} Z {z} "),
        _ => format!(" Z {z} ["),
    };
    assert!(state.contains(&at), "{family} {way}: not at {at}: {state}");
    (sim.received()[before..].to_string(), said)
}

#[test]
fn an_isel_restart_retracts_z_alone_before_any_x_or_y_and_descends_at_the_plunge_feed() {
    let [_, _, deep] = drill_steps(400.0, [0.0, 0.0, -3.0]);
    let [_, _, safe] = drill_steps(400.0, [0.0, 0.0, 5.0]);
    let [sx, sy, sz] = drill_steps(400.0, [35.0, 10.0, -3.0]);
    for way in ["stored", "stream", "chunked"] {
        let (received, said) = restart_in_the_part("isel", way);
        assert!(
            said.contains(
                "1. retract: Z alone up to Z5.000 (the job's safe height), from wherever the tool stands"
            ),
            "{way}: {said}"
        );
        assert!(!said.contains("reference run"), "{way}: {said}");
        // The first motion of all: a relative move of Z alone, up by the
        // depth of the tool under the safe height, before any program is
        // stored or any absolute move goes out.
        let retract = received
            .find("@0A")
            .unwrap_or_else(|| panic!("{way}: no relative retract: {received}"));
        for other in ["@0M", "@0i", "@0S", "@0y", "@0R"] {
            assert!(
                received.find(other).is_none_or(|k| k > retract),
                "{way}: `{other}` before the retract: {received}"
            );
        }
        let fields: Vec<&str> = received[retract + 3..]
            .split("<CR>")
            .next()
            .unwrap_or("")
            .split(',')
            .collect();
        assert_eq!(
            (fields[0], fields[2], fields[4].parse::<i64>().ok()),
            ("0", "0", Some(safe - deep)),
            "{way}: the retract moves Z alone: {received}"
        );
        // The descent to line 10's start at line 8's plunge feed, F120:
        // 2 mm/s, 800 steps/s, not the F1200 of the cut in force.
        let descent = format!("{sx},800,{sy},800,{sz},800");
        assert!(
            received.contains(&descent),
            "{way}: no descent `{descent}`: {received}"
        );
        assert!(said.contains("descend: G1 Z-3.000 F120"), "{way}: {said}");
        assert!(
            said.contains("(the file's last plunge feed, line 8)"),
            "{way}: {said}"
        );
        if way == "chunked" {
            assert!(said.contains("part 2/"), "{way}: in parts: {said}");
        }
    }
}

#[test]
fn an_emcu_restart_retracts_z_alone_before_any_x_or_y() {
    let [_, _, deep] = drill_steps(200.0, [0.0, 0.0, -3.0]);
    let [_, _, safe] = drill_steps(200.0, [0.0, 0.0, 5.0]);
    for way in ["stored", "stream"] {
        let (received, said) = restart_in_the_part("emcu", way);
        assert!(
            said.contains("1. retract: Z alone up to Z5.000"),
            "{way}: {said}"
        );
        // The first move of all: `L` with z alone, relative, up by the
        // depth under the safe height.
        let first = received
            .split(['\r', '<'])
            .map(|c| c.trim_start_matches("CR>").trim_start_matches("01>"))
            .find(|c| c.starts_with('L'))
            .unwrap_or_else(|| panic!("{way}: no move: {received}"));
        let fields: Vec<&str> = first.split(',').skip(1).collect();
        assert_eq!(
            fields,
            [format!("z{}", safe - deep)],
            "{way}: the first move is Z alone: {received}"
        );
    }
}

/// With the default profile the program's reference run is a step of
/// the entry, and the confirmation lists it.
#[test]
fn the_confirmation_lists_the_reference_run_when_the_program_has_one() {
    let dir = tempfile::tempdir().expect("dir");
    let file = sample("fusion-grbl.nc");
    let out = import(
        &[
            file.as_str(),
            "--work-zero",
            "X50 Y50 Z40",
            "--from-line",
            "20",
        ],
        dir.path(),
    );
    let said = text(&out.stdout);
    assert!(
        said.contains(
            "1. reference run of Z, then Y, then X (gcode.reference_first): the program's moves count from the reference point"
        ),
        "{said}"
    );
}
