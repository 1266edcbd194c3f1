//! End to end: `jogterm import FILE --from-line N`, the restart of a job
//! after a broken tool or a power cut (`docs/gcode.md`, "Restart from a
//! line"). The confirmation says the modal state and the entry worked out
//! here by hand from the sample; the restart program, stored and run on
//! `jogterm sim --pty`, ends where the whole job ends. `jogterm run FILE
//! --from-line N` with the tool left in the part (issue 37): the retract,
//! Z alone, is the first motion on the wire, for every way and family, and
//! the confirmation lists every step of the entry.
//!
//! Logic, not the wire's timing: no lock, they run beside the others.

use std::process::Output;

use crate::faults_support::wire::isel_messages;
use crate::sim_process::{JOGTERM, LOGIC_SCALE, SimProcess, contains_panic, text};
use crate::stops_support::{assert_stands, interrupt, wait_moving};

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

/// Steps a millimetre of the restart machines below: isel 400, EMCU 200.
fn per_mm(family: &str) -> f64 {
    if family == "isel" { 400.0 } else { 200.0 }
}

/// `jogterm run DRILL --from-line 10 --yes` against `sim`, the way `way`
/// (`stored`: the default; `stream`, `chunked`), bounded: a run that
/// hangs fails the test.
fn run_drill(sim: &SimProcess, way: &str) -> Output {
    let job = sim.dir.path().join("drill.nc");
    std::fs::write(&job, DRILL).expect("write");
    let job = job.display().to_string();
    let way_arg = format!("--{way}");
    let mut args = vec![
        "run",
        &job,
        "--work-zero",
        DRILL_ZERO,
        "--from-line",
        "10",
        "--yes",
    ];
    if way != "stored" {
        args.push(&way_arg);
    }
    let child = sim
        .configured(&args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm run");
    crate::sim_process::wait_child(child, "jogterm run --from-line")
}

/// `jogterm run DRILL --from-line 10 --yes` the way `way` (`stored`,
/// `stream`, `chunked`) on `family`'s simulator, referenced, the tool
/// standing in the part away from the line's start (X80 Y20 Z-3 of the
/// job), as a broken tool leaves it; with or without the program's own
/// reference run (`gcode.reference_first`). The run ends at the whole
/// job's last point. What the controller received from the run on, as
/// commands (`<CR>` and, EMCU, `<01>` ends each; isel's stop bytes left
/// off), and what the run said.
/// `family`'s simulator, referenced, the tool standing in the part away
/// from the drill job's line 10 (X80 Y20 Z-3 of the job), as a broken tool
/// leaves it; with or without the program's own reference run
/// (`gcode.reference_first`), Z at `z_speed` mm/s (else the test's 30 or
/// 20).
fn tool_in_the_part(
    family: &'static str,
    reference_first: bool,
    z_speed: Option<f64>,
) -> SimProcess {
    // EMCU: the start speed is the reference run's too (manual 1.5.8):
    // the shipped 200 Hz would take 250 s from X80 Y20.
    let z = z_speed.unwrap_or(if family == "isel" { 30.0 } else { 20.0 });
    let profile = match family {
        // A program memory of 8 commands: the rest of the job, without a
        // reference run, fits whole and also runs in parts (`--chunked`).
        "isel" => (
            "profiles/default.toml",
            format!(
                "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = {z:.1}\n\
                 [gcode]\nreference_first = {reference_first}\n{}[sim]\nstart_position = 1.0\n",
                if reference_first { "" } else { "memory = 8\n" }
            ),
        ),
        _ => (
            "profiles/emcu.toml",
            format!(
                "base = \"emcu\"\n[axes.X]\nmax_speed = 40.0\n[axes.Y]\nmax_speed = 40.0\n\
                 [axes.Z]\nmax_speed = {z:.1}\n[gcode]\nreference_first = {reference_first}\n\
                 m3 = \"output:A1\"\n[emcu]\nstart_speed_hz = 2000\n[sim]\nstart_position = 1.0\n"
            ),
        ),
    };
    let files = [(profile.0, profile.1.as_str())];
    let mut options = SimProcess::options(family)
        .files(&files)
        .time_scale(LOGIC_SCALE);
    if family == "isel" && !reference_first {
        options = options.variants(&["memory=8"]);
    }
    let mut sim = options.start();
    let per_mm = per_mm(family);
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
    sim
}

fn restart_in_the_part(
    family: &'static str,
    way: &str,
    reference_first: bool,
) -> (Vec<String>, String) {
    let mut sim = tool_in_the_part(family, reference_first, None);
    let per_mm = per_mm(family);
    let before = sim.received().len();
    let out = run_drill(&sim, way);
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{family} {way}: {said}");
    // The whole job's last point: X70 Y10 Z5.
    let [x, y, z] = drill_steps(per_mm, [70.0, 10.0, 5.0]);
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    // isel `device: X 28000 Y …`, EMCU `device: X 24000 [machine 24026] …`.
    for (axis, steps) in [("X", x), ("Y", y), ("Z", z)] {
        assert!(
            state.contains(&format!("{axis} {steps} ")),
            "{family} {way}: not at {axis} {steps}: {state}"
        );
    }
    let commands = sim.received()[before..]
        .split("<CR>")
        .flat_map(|c| c.split_inclusive("<01>"))
        .map(|c| c.replace("<FD>", "").replace("<FF>", ""))
        .filter(|c| !c.is_empty())
        .collect();
    (commands, said)
}

/// The index and the text of the first command that sets an axis in
/// motion: isel a move with a distance (`@0A` of zeros is the reference
/// probe), an absolute move, a reference run or a program's start; EMCU a
/// move or a reference run run at once (not stored by `@F`), or the stored
/// job's start.
fn first_motion(family: &str, commands: &[String]) -> (usize, String) {
    let moves = |c: &str| match family {
        "isel" => {
            c.strip_prefix("@0A").is_some_and(|pairs| {
                pairs
                    .split(',')
                    .step_by(2)
                    .any(|d| d.parse::<i64>() != Ok(0))
            }) || ["@0M", "@0R", "@0S", "@0y", "@0w"]
                .iter()
                .any(|p| c.starts_with(p))
        }
        _ => {
            c.starts_with("@J")
                || (c.ends_with("<01>") && (c.starts_with('L') || c.starts_with("$H")))
        }
    };
    let mut storing = false;
    for (k, c) in commands.iter().enumerate() {
        // EMCU: `@F` stores what follows up to the first line ended by 0x01.
        if family == "emcu" && c == "@F" {
            storing = true;
            continue;
        }
        if storing {
            storing = !c.ends_with("<01>");
            continue;
        }
        if moves(c) {
            return (k, c.clone());
        }
    }
    panic!("{family}: nothing moved: {commands:?}");
}

/// The retract of a restart in the part: the first motion of all is a
/// relative move of Z alone, up from Z-3 to the safe height Z5, sent
/// before anything is stored or streamed; its index.
fn assert_retract_first(family: &str, way: &str, commands: &[String]) -> usize {
    let up = {
        let [_, _, deep] = drill_steps(per_mm(family), [0.0, 0.0, -3.0]);
        let [_, _, safe] = drill_steps(per_mm(family), [0.0, 0.0, 5.0]);
        safe - deep
    };
    let (k, first) = first_motion(family, commands);
    match family {
        "isel" => {
            // `@0A` and the distances of X, Y, Z and the second Z pair.
            let distances: Vec<&str> = first
                .strip_prefix("@0A")
                .map(|pairs| pairs.split(',').step_by(2).collect())
                .unwrap_or_default();
            assert_eq!(
                distances,
                ["0", "0", up.to_string().as_str(), "0"],
                "{way}: the first motion is not Z alone up {up} steps: {first} in {commands:?}"
            );
        }
        _ => {
            let f: Vec<&str> = first.trim_end_matches("<01>").split(',').collect();
            assert!(
                f.len() == 2 && f[0].starts_with('L') && f[1] == format!("z{up}"),
                "{way}: the first motion is not Z alone up {up} steps: {first} in {commands:?}"
            );
        }
    }
    let stored_or_streamed = commands
        .iter()
        .position(|c| ["@0i", "@F", "@0M", "L"].iter().any(|p| c.starts_with(p)) && *c != first)
        .unwrap_or_else(|| panic!("{way}: no program: {commands:?}"));
    assert!(
        k < stored_or_streamed,
        "{way}: `{}` before the retract: {commands:?}",
        commands[stored_or_streamed]
    );
    k
}

/// The entry as the confirmation lists it, "N. step" lines in order.
fn entry_lines(said: &str) -> Vec<String> {
    said.lines()
        .skip_while(|l| !l.contains("entry, in this order:"))
        .skip(1)
        .take_while(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| l.trim().to_string())
        .collect()
}

#[test]
fn an_isel_restart_retracts_z_alone_before_any_x_or_y_and_descends_at_the_plunge_feed() {
    let [sx, sy, sz] = drill_steps(400.0, [35.0, 10.0, -3.0]);
    let [_, _, safe] = drill_steps(400.0, [0.0, 0.0, 5.0]);
    for way in ["stored", "stream", "chunked"] {
        let (commands, said) = restart_in_the_part("isel", way, false);
        let entry = entry_lines(&said);
        assert_eq!(
            entry,
            [
                "1. retract: Z alone up to Z5.000 (the job's safe height), from wherever the tool stands, before anything else moves (jogterm, before the program)",
                "2. G0 X35.000 Y10.000 at the safe height, above line 10's start",
                "3. spindle speed S9000",
                "4. spindle on",
                "5. descend: G1 Z-3.000 F120 to line 10's start (the file's last plunge feed, line 8)",
            ],
            "{way}: {said}"
        );
        let retract = assert_retract_first("isel", way, &commands);
        // Then above the start at the safe height: the tool stands there
        // already in Z, so X and Y alone move.
        let moves: Vec<&String> = commands[retract + 1..]
            .iter()
            .filter(|c| c.starts_with('m') || c.starts_with("@0M"))
            .collect();
        let above = format!("{sx},12000,{sy},12000,{safe},");
        assert!(
            moves.first().is_some_and(|m| m.contains(&above)),
            "{way}: not above the start next: {moves:?}"
        );
        // The descent to line 10's start at line 8's plunge feed, F120:
        // 2 mm/s, 800 steps/s, not the F1200 of the cut in force.
        let descent = format!("{sx},800,{sy},800,{sz},800,0,800");
        assert!(
            moves.get(1).is_some_and(|m| m.ends_with(&descent)),
            "{way}: no descent `{descent}` next: {moves:?}"
        );
        if way == "chunked" {
            assert!(said.contains("part 2/"), "{way}: in parts: {said}");
            // Each part says the model's time left of the job.
            for k in ["part 1/", "part 2/"] {
                assert!(
                    said.lines().any(|l| l.starts_with(k)
                        && l.contains(", about ")
                        && l.ends_with(" left")),
                    "{way}: {k} with the time left: {said}"
                );
            }
        }
    }
}

#[test]
fn an_emcu_restart_retracts_z_alone_before_any_x_or_y_and_descends_at_the_plunge_feed() {
    let [sx, sy, sz] = drill_steps(200.0, [35.0, 10.0, -3.0]);
    for way in ["stored", "stream"] {
        let (commands, said) = restart_in_the_part("emcu", way, false);
        let entry = entry_lines(&said);
        assert!(
            entry.first().is_some_and(|l| l
                .starts_with("1. retract: Z alone up to Z5.000 (the job's safe height), from wherever the tool stands")),
            "{way}: {said}"
        );
        assert!(
            entry.last().is_some_and(|l| l
                == "5. descend: G1 Z-3.000 F120 to line 10's start (the file's last plunge feed, line 8)"),
            "{way}: {said}"
        );
        let retract = assert_retract_first("emcu", way, &commands);
        // The descent at F120: 2 mm/s, 400 steps/s in slot 7's end speed.
        let descent = format!("L7,X{sx},Y{sy},Z{sz}");
        let at = commands[retract..]
            .iter()
            .position(|c| c.trim_end_matches("<01>") == descent)
            .unwrap_or_else(|| panic!("{way}: no descent {descent}: {commands:?}"));
        let speed = commands[retract..retract + at]
            .iter()
            .rev()
            .find(|c| c.starts_with("#E7,"));
        assert_eq!(
            speed.map(|c| c.trim_end_matches("<01>")),
            Some("#E7,400"),
            "{way}: {commands:?}"
        );
    }
}

/// With the program's own reference run (the default profile's
/// `reference_first`) the confirmation lists it among the entry's steps,
/// in the order they run, with the plunge feed of the descent; the
/// retract, Z alone, still comes first, then the program's reference run,
/// then Z alone up from the reference point.
#[test]
fn a_restart_with_a_reference_run_lists_every_step_and_still_retracts_first() {
    for family in ["isel", "emcu"] {
        let (commands, said) = restart_in_the_part(family, "stored", true);
        let (reference, order, spindle) = match family {
            "isel" => ("77", "Z, then Y, then X", "spindle on"),
            _ => ("$HZXY", "Z, then X, then Y", "A1 (K1) on"),
        };
        assert_eq!(
            entry_lines(&said),
            [
                "1. retract: Z alone up to Z5.000 (the job's safe height), from wherever the tool stands, before anything else moves (jogterm, before the program)".to_string(),
                format!("2. reference run of {order} (gcode.reference_first): the program's moves count from the reference point"),
                "3. G0 Z5.000 (the job's safe height) from the reference point, Z alone".into(),
                "4. G0 X35.000 Y10.000 at the safe height, above line 10's start".into(),
                "5. spindle speed S9000".into(),
                format!("6. {spindle}"),
                "7. descend: G1 Z-3.000 F120 to line 10's start (the file's last plunge feed, line 8)".into(),
            ],
            "{family}: {said}"
        );
        // Said before anything moved: the run's own lines come after it.
        let up = {
            let [_, _, deep] = drill_steps(per_mm(family), [0.0, 0.0, -3.0]);
            let [_, _, safe] = drill_steps(per_mm(family), [0.0, 0.0, 5.0]);
            safe - deep
        };
        let listed = said.find("entry, in this order:").expect("the entry");
        let moved = said
            .find(&format!("retract: Z alone up {up} steps"))
            .unwrap_or_else(|| panic!("{family}: {said}"));
        assert!(listed < moved, "{family}: {said}");
        let retract = assert_retract_first(family, "stored", &commands);
        let stored: Vec<&str> = commands[retract..]
            .iter()
            .map(|c| c.trim_end_matches("<01>"))
            .skip_while(|c| !matches!(*c, "@0i" | "@F"))
            .collect();
        let referencing = stored.iter().position(|c| *c == reference);
        let first_move = stored
            .iter()
            .position(|c| c.starts_with('m') || c.starts_with('L'));
        assert!(
            referencing.zip(first_move).is_some_and(|(r, m)| r < m),
            "{family}: the reference run first in the program: {stored:?}"
        );
        // Then Z alone up from the reference point, X and Y 0.
        let [_, _, safe] = drill_steps(per_mm(family), [0.0, 0.0, 5.0]);
        let xyz: Vec<i64> = first_move
            .map(|m| stored[m])
            .unwrap_or_default()
            .trim_start_matches(['m', 'L', '7'])
            .split(',')
            .map(|f| f.trim_start_matches(['X', 'Y', 'Z']))
            .filter_map(|f| f.parse().ok())
            .collect();
        let at = match family {
            "isel" => [xyz.first(), xyz.get(2), xyz.get(4)],
            _ => [xyz.first(), xyz.get(1), xyz.get(2)],
        };
        assert_eq!(
            at,
            [Some(&0), Some(&0), Some(&safe)],
            "{family}: {stored:?}"
        );
    }
}

/// With Z not referenced where the tool stands is unknown, and without a
/// reference run in the program nothing would take the tool out of the
/// part before the program's first move: the run is refused before
/// anything moves or is stored.
#[test]
fn a_restart_with_z_not_referenced_and_no_reference_run_moves_nothing() {
    let mut sim = SimProcess::options("isel")
        .files(&[(
            "profiles/default.toml",
            "[gcode]\nreference_first = false\n[sim]\nstart_position = 1.0\n",
        )])
        .time_scale(LOGIC_SCALE)
        .start();
    let before = sim.received().len();
    let out = run_drill(&sim, "stored");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains("Z is not referenced: where the tool stands is unknown"),
        "{said}"
    );
    assert!(said.contains("@0R7"), "the way to reference: {said}");
    let received = sim.received()[before..].to_string();
    for never in ["@0i", "@0M", "@0S", "@0R"] {
        assert!(!received.contains(never), "`{never}`: {received}");
    }
}

/// The retract is motion of its own, before the job: Ctrl-C while Z goes
/// up stops it there (0xFD 0xFF right after the retract's `@0A`), the run
/// ends with status 1 and nothing more moves or is stored. Z runs slowly
/// (0.25 mm/s, 3.2 s for the 8 mm at the time scale) so that the signal
/// lands while it climbs.
#[test]
fn ctrl_c_during_the_retract_stops_z_and_nothing_more_moves() {
    let mut sim = tool_in_the_part("isel", false, Some(0.25));
    let before = sim.received().len();
    let job = sim.dir.path().join("drill.nc");
    std::fs::write(&job, DRILL).expect("write");
    let job = job.display().to_string();
    let child = sim
        .configured(&[
            "run",
            &job,
            "--work-zero",
            DRILL_ZERO,
            "--from-line",
            "10",
            "--yes",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm run");
    wait_moving(&mut sim, "the retract under way");
    interrupt(child, libc::SIGINT, "run");
    let state = assert_stands(&mut sim);
    let commands = isel_messages(&sim.received()[before..]);
    let retract = commands
        .iter()
        .rposition(|c| c.starts_with("@0A"))
        .unwrap_or_else(|| panic!("no retract: {commands:?}"));
    assert_eq!(
        commands.get(retract + 1..retract + 3),
        Some(&["<FD>".to_string(), "<FF>".to_string()][..]),
        "the stop right after the retract: {commands:?}"
    );
    let moved_after: Vec<&String> = commands[retract..]
        .iter()
        .filter(|c| {
            ["@0A", "@0M", "@0S", "@0i", "@0R"]
                .iter()
                .any(|m| c.starts_with(m))
        })
        .collect();
    assert_eq!(moved_after.len(), 1, "only the retract: {commands:?}");
    // Z stopped on its way: above where the tool stood, below the safe height.
    let [_, _, in_part] = drill_steps(per_mm("isel"), [80.0, 20.0, -3.0]);
    let [_, _, safe] = drill_steps(per_mm("isel"), [0.0, 0.0, 5.0]);
    let z: i64 = state
        .split_whitespace()
        .skip_while(|w| *w != "Z")
        .nth(1)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no Z in {state}"));
    assert!(
        in_part < z && z < safe,
        "Z {z} between {in_part} and {safe}: {state}"
    );
    sim.assert_alive();
}
