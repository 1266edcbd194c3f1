//! End to end: a G-code job on a height map (issue 39, `docs/gcode.md`,
//! "Height maps"), through the real binary. The map is written here by
//! hand in the documented format: a tilted plane, the kind of surface a
//! board clamped on a warped table has. `jogterm import --height-map`
//! must cut every point at a constant depth below that surface (checked
//! in the converted isel program's steps, not with jogterm's own
//! arithmetic), refuse a map of another work offset or zero, and name the
//! G-code line of a move the map does not cover; `upload --height-map`
//! runs it on the simulator to the surface's point.

use std::path::Path;
use std::process::Output;
use std::time::{SystemTime, UNIX_EPOCH};

use crate::sim_process::{JOGTERM, SimProcess, contains_panic, text};

/// G54's zero, machine mm, as the map was probed with and the job runs.
const WORK_ZERO: &str = "X50 Y50 Z60";
const ZERO: [f64; 3] = [50.0, 50.0, 60.0];
const STEPS_PER_MM: f64 = 400.0;

/// 2026-12-07T07:00:00Z: 20 454 days from 1970 to 2026-01-01, 340 more to
/// December 7, 7 hours.
const PROBED_AT: &str = "2026-12-07T07:00:00Z";
const PROBED_AT_UNIX: i64 = (20_454 + 340) * 86_400 + 7 * 3600;

/// The probed surface: machine Z at work (x, y), rising 0.6 mm over X's
/// 60 mm and falling 0.3 mm over Y's 50 from `base` at the work zero.
fn surface_from(base: f64, x: f64, y: f64) -> f64 {
    base + 0.01 * x - 0.006 * y
}

/// The surface under a job with G54 at [`ZERO`].
fn surface(x: f64, y: f64) -> f64 {
    surface_from(60.0, x, y)
}

/// A map over work X 0..60, Y 0..50 at 10 mm of the surface from `base`,
/// probed with `work_offset`'s zero at `zero` (machine mm), as `probe grid`
/// writes one: row-major, y outer.
fn map_json(work_offset: &str, zero: [f64; 3], base: f64) -> String {
    let mut points = Vec::new();
    for row in 0..=5 {
        for column in 0..=6 {
            let (x, y) = (f64::from(column) * 10.0, f64::from(row) * 10.0);
            points.push(format!(
                r#"{{"x": {x:.1}, "y": {y:.1}, "z": {:.4}}}"#,
                surface_from(base, x, y)
            ));
        }
    }
    let [zx, zy, zz] = zero;
    format!(
        r#"{{
  "version": 1,
  "probed_at": "{PROBED_AT}",
  "profile": "isel simulator",
  "work_offset": "{work_offset}",
  "work_zero_machine_mm": {{"x": {zx:.1}, "y": {zy:.1}, "z": {zz:.1}}},
  "area": {{"x0": 0.0, "y0": 0.0, "x1": 60.0, "y1": 50.0}},
  "spacing": 10.0,
  "points": [{}]
}}
"#,
        points.join(", ")
    )
}

/// The map of [`surface`], probed with G54 at [`ZERO`].
fn map_at_zero() -> String {
    map_json("G54", ZERO, 60.0)
}

/// An engraving 0.3 mm deep, then a helix down to 0.5 mm and a last line
/// at that depth. Lines 4 to 6 cut at -0.3, 8 at -0.5. The helix' own feed
/// keeps the output from merging its first chord into line 6's last.
const JOB: &str = "G21 G90 G17
G0 X5 Y5 Z5
G1 Z-0.3 F300
G1 X55 Y5 F600
G1 X55 Y35
G3 X35 Y35 I-10 J0
G2 X15 Y35 Z-0.5 I-10 J0 F500
G1 X15 Y10 F600
G0 Z5
G0 X0 Y0
M30
";

fn write(dir: &Path, name: &str, content: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, content).expect("write");
    path.display().to_string()
}

fn import(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(JOGTERM)
        .arg("import")
        .args(args)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .env("JOGTERM_STATE_DIR", dir)
        .output()
        .expect("run jogterm import")
}

/// `import JOB --work-zero … --height-map MAP` and `extra`, refused with
/// `status`: what it said on stderr.
fn refused(dir: &Path, job: &str, map: &str, extra: &[&str], status: i32) -> String {
    let mut args = vec![job, "--work-zero", WORK_ZERO, "--height-map", map];
    args.extend_from_slice(extra);
    let out = import(dir, &args);
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(status), "{said}");
    said
}

/// The isel program's absolute moves (`m x,sx,y,sy,z,sz,…`) as machine
/// steps, each with its G-code line from the `; job.nc:N` comment.
fn moves_of(program: &str) -> Vec<(u32, [i64; 3])> {
    program
        .lines()
        .filter_map(|l| {
            let (command, comment) = l.split_once(';')?;
            let words: Vec<i64> = command
                .trim()
                .strip_prefix('m')?
                .split(',')
                .map(|w| w.parse().expect("a number"))
                .collect();
            let line = comment.trim().strip_prefix("job.nc:")?.parse().ok()?;
            Some((line, [words[0], words[2], words[4]]))
        })
        .collect()
}

/// The surface's Z under a move's end, less `depth`, in steps.
fn cut_steps(at: [i64; 3], depth: f64) -> i64 {
    let x = at[0] as f64 / STEPS_PER_MM - ZERO[0];
    let y = at[1] as f64 / STEPS_PER_MM - ZERO[1];
    ((surface(x, y) - depth) * STEPS_PER_MM).round() as i64
}

#[test]
fn a_job_on_a_height_map_cuts_at_a_constant_depth_below_the_surface() {
    let dir = tempfile::tempdir().expect("dir");
    let job = write(dir.path(), "job.nc", JOB);
    let map = write(dir.path(), "map.json", &map_at_zero());
    let program_path = dir.path().join("job.isel").display().to_string();
    let out = import(
        dir.path(),
        &[
            &job,
            "--work-zero",
            WORK_ZERO,
            "--height-map",
            &map,
            "-o",
            &program_path,
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let program = std::fs::read_to_string(&program_path).expect("the program");
    let moves = moves_of(&program);
    let on_line = |line: u32| moves.iter().filter(move |(l, _)| *l == line);
    // Every cutting move's end at the surface under it less the depth,
    // within a step; the arcs as many moves, none a controller circle.
    for (line, depth) in [(4, 0.3), (5, 0.3), (6, 0.3), (8, 0.5)] {
        let mut n = 0;
        for (_, at) in on_line(line) {
            let expected = cut_steps(*at, depth);
            assert!(
                (at[2] - expected).abs() <= 1,
                "line {line}: Z {} steps at X {} Y {}, the surface less {depth} is {expected}\n{program}",
                at[2],
                at[0],
                at[1]
            );
            n += 1;
        }
        assert!(n >= 1, "no move of line {line}\n{program}");
    }
    assert!(on_line(6).count() > 5, "the arc as segments\n{program}");
    assert!(
        !program
            .lines()
            .any(|l| l.starts_with('y') || l.starts_with('w')),
        "{program}"
    );
    // The helix descends from 0.3 to 0.5 mm below the surface.
    for (_, at) in on_line(7) {
        let (shallow, deep) = (cut_steps(*at, 0.3), cut_steps(*at, 0.5));
        assert!(
            at[2] <= shallow + 1 && at[2] >= deep - 1,
            "{at:?}\n{program}"
        );
    }
    // The plunge ends 0.3 mm below the surface at X5 Y5.
    let plunge = on_line(3)
        .next_back()
        .map(|(_, at)| *at)
        .expect("the plunge");
    assert_eq!(plunge[0], (55.0 * STEPS_PER_MM) as i64);
    assert!((plunge[2] - cut_steps(plunge, 0.3)).abs() <= 1);
    // Rapids 5 mm above Z zero, raised by the highest point of the
    // surface (X60 Y0, 0.6 mm above the zero): 65.6 mm.
    for line in [2, 9, 10] {
        for (_, at) in on_line(line) {
            assert_eq!(
                at[2],
                (65.6 * STEPS_PER_MM).round() as i64,
                "line {line}\n{program}"
            );
        }
    }

    // The summary says a map was applied, its range and its age.
    let out = import(
        dir.path(),
        &[
            &job,
            "--work-zero",
            WORK_ZERO,
            "--height-map",
            &map,
            "--json",
        ],
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    let h = &json["height_map"];
    assert_eq!(h["file"], map.as_str());
    assert_eq!(
        h["correction_mm"],
        serde_json::json!({"min": -0.3, "max": 0.6})
    );
    assert_eq!(h["points"], 42);
    assert_eq!(h["arcs_as_segments"], 2);
    assert_eq!(h["rapids_raised_mm"], 0.6);
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .expect("a clock after 1970")
        .as_secs() as i64;
    let age = h["age_s"].as_i64().expect("age_s");
    assert!((age - (now - PROBED_AT_UNIX)).abs() <= 60, "{age}");
    assert_eq!(json["arcs"], 0, "no arc left for the controller");
    let summary = import(
        dir.path(),
        &[&job, "--work-zero", WORK_ZERO, "--height-map", &map],
    );
    let said = text(&summary.stdout);
    assert!(
        said.contains(&format!(
            "height map {map}: 42 points, correction -0.300 .. +0.600 mm, probed "
        )),
        "{said}"
    );
    // Without the map: no such figures.
    let plain = import(dir.path(), &[&job, "--work-zero", WORK_ZERO, "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&plain.stdout).expect("JSON");
    assert_eq!(json["height_map"], serde_json::Value::Null);
}

#[test]
fn a_map_of_another_work_offset_or_zero_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().expect("dir");
    let job = write(dir.path(), "job.nc", JOB);
    let program = dir.path().join("job.isel");
    let program_path = program.display().to_string();
    for (map, expected) in [
        (
            map_json("G55", ZERO, 60.0),
            "the height map was probed in work offset G55, and the job runs in G54 here",
        ),
        (
            map_json("G54", [50.5, 50.0, 60.0], 60.0),
            "the height map was probed with another G54 zero: X zero at machine 50.0000 mm, the map's at 50.5000 mm (-0.5000 mm)",
        ),
    ] {
        let map = write(dir.path(), "map.json", &map);
        let said = refused(dir.path(), &job, &map, &["-o", &program_path], 1);
        assert!(said.contains(expected), "{said}");
        assert!(!program.exists(), "nothing written");
    }
    // A broken file: its field and what was expected, exit 2.
    let mut bad = map_at_zero();
    bad = bad.replacen(r#""x": 10.0, "y": 0.0"#, r#""x": 12.0, "y": 0.0"#, 1);
    let map = write(dir.path(), "bad.json", &bad);
    let said = refused(dir.path(), &job, &map, &[], 2);
    assert!(
        said.contains(&format!(
            "height map {map}: points[1].x: expected 10 (column 1 of the grid"
        )),
        "{said}"
    );
}

#[test]
fn a_cut_outside_the_maps_area_is_an_error_at_its_gcode_line() {
    let dir = tempfile::tempdir().expect("dir");
    let job = write(
        dir.path(),
        "job.nc",
        "G21 G90\nG0 X5 Y5 Z5\nG1 Z-0.3 F300\nG1 X40 Y20 F600\nG1 X65 Y20\nM30\n",
    );
    let map = write(dir.path(), "map.json", &map_at_zero());
    let said = refused(dir.path(), &job, &map, &[], 1);
    assert!(
        said.contains(&format!(
            "{job}:5:1: error: X 65.000 Y 20.000 (G54 work mm) is outside the height map's area X 0 .. 60, Y 0 .. 50"
        )),
        "{said}"
    );
}

/// A test profile of a faster machine: X and Y 60 mm/s, Z 30 mm/s.
const FAST_MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n",
);

#[test]
fn upload_with_a_height_map_ends_on_the_surface_at_the_jobs_depth() {
    let sim = SimProcess::options("isel")
        .files(&[FAST_MACHINE])
        .time_scale(20.0)
        .start();
    let dir = sim.dir.path();
    // Ends cutting at work X15 Y10, 0.5 mm deep: no rapid after it.
    let job = write(dir, "job.nc", &JOB.replace("G0 Z5\nG0 X0 Y0\n", ""));
    let map = write(dir, "map.json", &map_at_zero());
    let reference = sim.run(&["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let child = crate::gcode_e2e::spawn(
        &sim,
        &[
            "upload",
            &job,
            "--work-zero",
            WORK_ZERO,
            "--height-map",
            &map,
            "--erase",
            "--start",
        ],
    );
    let out = crate::gcode_e2e::wait_run(child, "upload --start");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(
        said.contains(&format!("height map {map}: 42 points")),
        "{said}"
    );
    let expected = [
        ((15.0 + ZERO[0]) * STEPS_PER_MM).round() as i64,
        ((10.0 + ZERO[1]) * STEPS_PER_MM).round() as i64,
        ((surface(15.0, 10.0) - 0.5) * STEPS_PER_MM).round() as i64,
    ];
    assert_eq!(crate::gcode_e2e::ended_at(&said), expected, "{said}");
    // A controller program has no G-code to shift: upload and run refuse.
    let program = write(dir, "p.isel", "77\n9\n");
    let refusals = [
        (
            vec!["upload", &program, "--height-map", &map],
            "--height-map shifts G-code; a controller program runs",
        ),
        (
            vec!["run", &program, "--height-map", &map, "-y"],
            "--height-map shifts G-code onto a surface",
        ),
    ];
    for (args, expected) in refusals {
        let out = sim.run(&args);
        let said = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {said}");
        assert!(said.contains(expected), "{args:?}: {said}");
    }
}

/// The console's `--program job.nc --height-map map.json`: the program in
/// the editor is the one on the surface, with the console's own work
/// offsets (a fresh state: G54 at the reference point, so the map is
/// probed there, its surface 10 mm above it); a map of another offset
/// opens the job with that error in its job panel, nothing to run; a map
/// for a controller program is refused before the terminal is taken.
#[test]
fn the_console_opens_a_gcode_job_on_a_height_map() {
    let (dir, config, state) = crate::editor_e2e::dirs();
    let job = write(dir.path(), "job.nc", JOB);
    let g55 = write(dir.path(), "g55.json", &map_json("G55", [0.0; 3], 10.0));
    let mut run = crate::editor_e2e::spawn_sized(
        &["--program", &job, "--height-map", &g55],
        &config,
        &state,
        (40, 160),
    );
    // The panel's last words, not the message line's "does not run": a
    // screen read while a frame is being written shows the message row
    // before the panels below it (failed so in CI under load).
    let screen = crate::editor_e2e::wait_for(&run, "G55, and the job runs in G54");
    assert!(screen.contains("does not run"), "{screen}");
    // Wrapped in the job panel.
    assert!(
        screen.contains("the height map was probed in work offset")
            && screen.contains("G55, and the job runs in G54"),
        "{screen}"
    );
    run.type_keys(&[b"\x1bOS"]);
    crate::editor_e2e::wait_for(&run, "Position");
    run.type_keys(&[b"q"]);
    assert_eq!(
        run.wait_exit(crate::sim_process::WAIT),
        Some(0),
        "the console ends"
    );
    let program = write(dir.path(), "p.isel", "77\n9\n");
    let out = std::process::Command::new(JOGTERM)
        .args(["--program", &program, "--height-map", &g55])
        .env("JOGTERM_CONFIG_DIR", &config)
        .env("JOGTERM_STATE_DIR", &state)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run the console");
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));

    let map = write(dir.path(), "map.json", &map_json("G54", [0.0; 3], 10.0));
    let mut run = crate::editor_e2e::spawn_sized(
        &["--program", &job, "--height-map", &map],
        &config,
        &state,
        (40, 160),
    );
    crate::editor_e2e::wait_for(&run, "job.isel[+]");
    // The first rapid, Z5 raised by the surface's highest point (10.6 mm
    // above the zero): 15.6 mm, 6240 steps (without the map 2000); the
    // plunge at X5 Y5 to 0.3 mm below the surface there (10.02 mm): 3888.
    let screen = crate::editor_e2e::wait_for(&run, "; job.nc:3");
    let z_of = |line: &str| -> Option<String> {
        let row = screen
            .lines()
            .find(|l| l.contains(&format!("; job.nc:{line}")))?;
        let command = row.split_whitespace().find(|w| w.starts_with('m'))?;
        command.split(',').nth(4).map(str::to_owned)
    };
    assert_eq!(z_of("2").as_deref(), Some("6240"), "{screen}");
    assert_eq!(z_of("3").as_deref(), Some("3888"), "{screen}");
    run.type_keys(&[b"\x1bOS"]);
    crate::editor_e2e::wait_for(&run, "Position");
    crate::editor_e2e::quit_discarding_the_edits(&mut run);
}
