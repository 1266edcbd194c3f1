//! End to end: `jogterm probe` (`docs/probing.md`) against `jogterm sim
//! --pty` with a probe surface under the tool: the touched point within a
//! step of the surface after a fast pass that overshoots it, the plate
//! applied, the offset saved; each refusal with nothing sent that moves.

use std::process::Output;

use crate::sim_process;
use sim_process::{ISEL_NEAR_REFERENCE, SimProcess, text};

/// Over X 10000, Y 0 this plane is at Z 8100 steps (20.25 mm).
const TILTED: &str = "8000,0.01,-0.005";

fn sim(surface: &str) -> SimProcess {
    let surface = format!("--probe-surface={surface}");
    SimProcess::options("isel")
        .files(&[ISEL_NEAR_REFERENCE])
        .args(&[&surface])
        .time_scale(sim_process::LOGIC_SCALE)
        .start()
}

/// Referenced, standing at X 10000, Y 0 and `z` (steps).
fn referenced_at(sim: &SimProcess, z: i64) {
    let out = sim.run(&[
        "send",
        "@07",
        "@0R7",
        &format!("@0M10000,4000,0,4000,{z},4000,0,4000"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

fn probe(sim: &SimProcess, state: &std::path::Path, args: &[&str]) -> Output {
    let mut all = vec!["probe"];
    all.extend_from_slice(args);
    sim.jogterm(&all)
        .env("JOGTERM_STATE_DIR", state)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run jogterm probe")
}

fn z_now(sim: &SimProcess) -> i64 {
    let out = sim.run(&["send", "@0P"]);
    let stdout = text(&out.stdout);
    stdout
        .lines()
        .find_map(|l| l.split_once(" Z=")?.1.split_once(' ')?.0.parse().ok())
        .unwrap_or_else(|| panic!("no position in {stdout}"))
}

/// The moves the controller received from `before` on: `@0Z`, `@0A`,
/// `@0M` that name steps (not the reference probe's move of none).
fn moves_received(sim: &mut SimProcess, before: usize) -> Vec<String> {
    let received = sim.received();
    received
        .get(before..)
        .unwrap_or_default()
        .split("<CR>")
        .filter(|c| moves(c))
        .map(str::to_owned)
        .collect()
}

fn moves(command: &str) -> bool {
    let numbers = |rest: &str| -> Vec<i64> {
        rest.split(',')
            .filter_map(|n| n.trim().parse().ok())
            .collect()
    };
    if let Some(rest) = command.strip_prefix("@0A") {
        // Pairs of steps and speed.
        numbers(rest).iter().step_by(2).any(|s| *s != 0)
    } else if let Some(rest) = command.strip_prefix("@0Z") {
        // Port, mask, value, speed, then the steps.
        numbers(rest).iter().skip(4).any(|s| *s != 0)
    } else {
        command.starts_with("@0M")
    }
}

#[test]
fn a_z_touch_off_finds_the_surface_within_a_step_and_saves_the_offset() {
    let mut sim = sim(TILTED);
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 12_000);
    let before = sim.received().len();
    let out = probe(&sim, state.path(), &["z", "--plate", "1.5", "--json"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON line");
    let touched = json["touched_machine_mm"]["z"].as_f64().expect("z");
    // Within one step (1/400 mm) of the surface.
    assert!((touched - 20.25).abs() <= 0.0025 + 1e-9, "{json}");
    assert_eq!(json["work_offset"], "G54");
    let zero = json["zero_machine_mm"]["z"].as_f64().expect("zero");
    assert!((zero - (touched - 1.5)).abs() < 1e-9, "{json}");
    // Saved where the console keeps its offsets.
    let saved = json["saved"].as_str().expect("saved path");
    let file = std::fs::read_to_string(saved).expect("offsets file");
    assert!(file.contains("G54"), "{file}");
    // The fast pass overshot the surface (its ramp-down), the slow pass
    // did not; the tool went back up to where it started.
    let moves = moves_received(&mut sim, before);
    assert_eq!(moves.len(), 4, "{moves:?}");
    assert!(moves[0].starts_with("@0Z1,32,32,2000,"), "{moves:?}");
    assert!(moves[1].starts_with("@0Z1,32,0,200,"), "{moves:?}");
    assert!(moves[2].starts_with("@0Z1,32,32,200,"), "{moves:?}");
    assert!(moves[3].starts_with("@0A"), "{moves:?}");
    assert_eq!(z_now(&sim), 12_000);
}

#[test]
fn no_surface_within_the_travel_goes_back_and_fails() {
    // The surface 15 mm below the tool, the travel 10 mm.
    let mut sim = sim("6000");
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 12_000);
    let before = sim.received().len();
    let out = probe(&sim, state.path(), &["z"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert!(
        text(&out.stderr).contains("found no surface within its travel"),
        "{}",
        text(&out.stderr)
    );
    let moves = moves_received(&mut sim, before);
    assert_eq!(moves.len(), 2, "one pass and the way back: {moves:?}");
    assert_eq!(z_now(&sim), 12_000);
}

#[test]
fn refusals_send_nothing_that_moves() {
    // Tripped at the start: the surface above the tool.
    let mut sim = sim("20000");
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 12_000);
    let before = sim.received().len();
    let out = probe(&sim, state.path(), &["z"]);
    let err = text(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("reads touched before the probe moves"),
        "{err}"
    );
    assert!(moves_received(&mut sim, before).is_empty());

    // A travel that leaves the soft limits: 10 mm down from Z 5 mm.
    let mut sim = self::sim("0");
    referenced_at(&sim, 2000);
    let before = sim.received().len();
    let out = probe(&sim, state.path(), &["z"]);
    let err = text(&out.stderr);
    assert!(err.contains("soft limit"), "{err}");
    assert!(moves_received(&mut sim, before).is_empty());

    // Not referenced.
    let mut sim = self::sim(TILTED);
    let before = sim.received().len();
    let out = probe(&sim, state.path(), &["z"]);
    let err = text(&out.stderr);
    assert!(err.contains("not referenced"), "{err}");
    assert!(
        moves_received(&mut sim, before).is_empty(),
        "{}",
        sim.received()
    );
}

#[test]
fn an_edge_is_found_along_x_and_set_as_the_work_zero() {
    // A wall: at Z 12000 the plane is reached at X 10300 (25.75 mm).
    let sim = sim("-400000,40,0");
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 12_000);
    let out = probe(
        &sim,
        state.path(),
        &["edge", "x+", "--offset", "G55", "--json"],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON line");
    let x = json["zero_machine_mm"]["x"].as_f64().expect("x");
    assert!((x - 25.75).abs() <= 0.0025 + 1e-9, "{json}");
    assert_eq!(json["work_offset"], "G55");
}

#[test]
fn a_signal_during_the_fast_pass_stops_the_probe_and_nothing_resumes() {
    use std::time::Duration;
    // Real time: the fast pass of 10 mm at 5 mm/s takes two seconds.
    let mut sim = SimProcess::options("isel")
        .files(&[ISEL_NEAR_REFERENCE])
        .args(&["--probe-surface", "0"])
        .start();
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 12_000);
    let before = sim.received().len();
    let child = sim
        .jogterm(&["probe", "z"])
        .env("JOGTERM_STATE_DIR", state.path())
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm probe");
    sim.wait_received("the fast pass", |r| r.contains("@0Z1,32,32,2000"));
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: a plain kill(2) of our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let out = sim_process::wait_child(child, "jogterm probe");
    let err = text(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("stopped"),
        "{err}"
    );
    let moves = moves_received(&mut sim, before);
    assert_eq!(moves.len(), 1, "the fast pass and no way back: {moves:?}");
    let z = z_now(&sim);
    assert!(z < 12_000 && z > 8000, "stopped on the way down: {z}");
}

/// The simulator's plane [`TILTED`] at machine (x, y) mm, in mm.
fn tilted_mm(x: f64, y: f64) -> f64 {
    (8000.0 + 0.01 * x * 400.0 - 0.005 * y * 400.0) / 400.0
}

#[test]
fn a_grid_on_a_tilted_surface_and_a_job_cut_at_a_constant_depth_below_it() {
    let mut sim = sim(TILTED);
    let state = tempfile::tempdir().expect("state dir");
    // 27.5 mm: the whole surface within the 10 mm travel below.
    referenced_at(&sim, 11_000);
    let before = sim.received().len();
    let map = state.path().join("map.json");
    let map_path = map.display().to_string();
    let out = probe(
        &sim,
        state.path(),
        &[
            "grid",
            "--area",
            "X0 Y0 X20 Y10",
            "--spacing",
            "10",
            "-o",
            &map_path,
            "--json",
        ],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON line");
    let points = json["points"].as_array().expect("points");
    assert_eq!(points.len(), 6, "{json}");
    for p in points {
        let (x, y, z) = (
            p["x"].as_f64().expect("x"),
            p["y"].as_f64().expect("y"),
            p["z"].as_f64().expect("z"),
        );
        // G54 at the reference point: work is machine here.
        assert!((z - tilted_mm(x, y)).abs() <= 0.0025 + 1e-9, "{p}");
    }
    // Two passes and a way back per point, and the moves between them.
    assert!(moves_received(&mut sim, before).len() >= 6 * 4);

    // A job cut 0.2 mm deep through the map follows the surface.
    let job = state.path().join("job.nc");
    std::fs::write(
        &job,
        "G21 G90\nG0 Z25\nG0 X2 Y2\nG1 Z-0.2 F100\nG1 X18 Y8 F300\nG0 Z25\nM30\n",
    )
    .expect("job");
    let program = state.path().join("job.isel");
    let out = std::process::Command::new(sim_process::JOGTERM)
        .arg("import")
        .arg(&job)
        .args(["--height-map", &map_path, "-o"])
        .arg(&program)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .env("JOGTERM_STATE_DIR", state.path())
        .output()
        .expect("run jogterm import");
    assert!(out.status.success(), "{}", text(&out.stderr));
    let program = std::fs::read_to_string(&program).expect("the program");
    let mut cuts = 0;
    for l in program.lines() {
        let Some((command, comment)) = l.split_once(';') else {
            continue;
        };
        if !comment.trim().ends_with("job.nc:5") {
            continue;
        }
        let Some(words) = command.trim().strip_prefix('m') else {
            continue;
        };
        let v: Vec<f64> = words.split(',').filter_map(|w| w.parse().ok()).collect();
        let (x, y, z) = (v[0] / 400.0, v[2] / 400.0, v[4]);
        let expected = ((tilted_mm(x, y) - 0.2) * 400.0).round();
        assert!(
            (z - expected).abs() <= 1.0,
            "Z {z} at X {x} Y {y}, expected {expected}\n{program}"
        );
        cuts += 1;
    }
    // On a plane the pieces along the grid merge back into one straight
    // move, which follows the plane from end to end.
    assert!(cuts >= 1, "the cut of line 5\n{program}");
}

#[test]
fn a_tool_one_millimetre_longer_measures_one_millimetre_higher_on_the_sensor() {
    // The sensor under X 25 (10000 steps), Y 0; the point above it at Z 27.5.
    let profile = (
        "profiles/default.toml",
        "[sim]\nstart_position = 1.0\n[probe]\ntool_sensor = \"X25 Y0 Z27.5\"\n",
    );
    let state = tempfile::tempdir().expect("state dir");
    let measure = |surface: &str, tool: &str| -> serde_json::Value {
        let surface = format!("--probe-surface={surface}");
        let sim = SimProcess::options("isel")
            .files(&[profile])
            .args(&[&surface])
            .time_scale(sim_process::LOGIC_SCALE)
            .start();
        let out = sim
            .configured(&["send", "@07", "@0R7", "@0A0,4000,0,4000,4000,4000,0,4000"])
            .output()
            .expect("send");
        assert!(out.status.success(), "{}", text(&out.stderr));
        let out = sim
            .configured(&["probe", "tool", "--tool", tool, "--json"])
            .env("JOGTERM_STATE_DIR", state.path())
            .output()
            .expect("probe tool");
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
        serde_json::from_str(stdout.trim()).expect("one JSON line")
    };
    // T1 touches the sensor at 20 mm: the reference.
    let t1 = measure("8000", "T1");
    assert_eq!(t1["reference"], "T1", "{t1}");
    assert!(
        (t1["length_mm"].as_f64().expect("length") - 20.0).abs() <= 0.0025,
        "{t1}"
    );
    assert_eq!(t1["offset_mm"].as_f64(), Some(0.0));
    // T2, one millimetre longer, touches at 21 mm.
    let t2 = measure("8400", "T2");
    assert_eq!(t2["reference"], "T1", "{t2}");
    assert!(
        (t2["offset_mm"].as_f64().expect("offset") - 1.0).abs() <= 0.0025 + 1e-9,
        "{t2}"
    );
}

#[test]
fn a_grid_over_a_jobs_own_extents() {
    let sim = sim(TILTED);
    let state = tempfile::tempdir().expect("state dir");
    referenced_at(&sim, 11_000);
    let job = state.path().join("job.nc");
    std::fs::write(
        &job,
        "G21 G90\nG0 Z25\nG0 X2 Y2\nG1 Z-0.2 F100\nG1 X18 Y8 F300\nG0 Z25\nM30\n",
    )
    .expect("job");
    let job = job.display().to_string();
    let out = probe(
        &sim,
        state.path(),
        &["grid", "--of", &job, "--spacing", "10", "--json"],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON line");
    let points = json["points"].as_array().expect("points");
    let xs: Vec<f64> = points.iter().filter_map(|p| p["x"].as_f64()).collect();
    let ys: Vec<f64> = points.iter().filter_map(|p| p["y"].as_f64()).collect();
    // X 2 to 18 at 10 mm: 2, 12, 18; Y 2 to 8: 2, 8.
    assert_eq!(points.len(), 6, "{json}");
    assert_eq!(xs.iter().cloned().fold(f64::INFINITY, f64::min), 2.0);
    assert_eq!(xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max), 18.0);
    assert_eq!(ys.iter().cloned().fold(f64::INFINITY, f64::min), 2.0);
    assert_eq!(ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max), 8.0);
}

/// The isel simulator near its reference point with a work piece
/// `surface`, and the profile jogterm reads beside it
/// ([`SimProcess::configured`]) saying the probe's tip and clearance
/// rather than leaving them to the defaults the expectations rest on.
fn shape_sim(surface: &str, tip: f64) -> SimProcess {
    let profile = format!("[sim]\nstart_position = 1.0\n[probe]\ntip = {tip}\nclearance = 5.0\n");
    let surface = format!("--probe-surface={surface}");
    SimProcess::options("isel")
        .files(&[("profiles/default.toml", &profile)])
        .args(&[&surface])
        .time_scale(sim_process::LOGIC_SCALE)
        .start()
}

/// Referenced, standing at `x`, `y`, `z` (steps).
fn referenced_at_xyz(sim: &SimProcess, [x, y, z]: [i64; 3]) {
    let out = sim.run(&[
        "send",
        "@07",
        "@0R7",
        &format!("@0M{x},4000,{y},4000,{z},4000,0,4000"),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(position(sim), [x, y, z]);
}

/// `jogterm probe …` with the profile of [`shape_sim`]: its JSON line.
fn probe_shape(sim: &SimProcess, state: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["probe"];
    all.extend_from_slice(args);
    let out = sim
        .configured(&all)
        .env("JOGTERM_STATE_DIR", state)
        .output()
        .expect("run jogterm probe");
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    // What was found, for `--nocapture`.
    eprintln!("probe {}: {}", args.join(" "), stdout.trim());
    serde_json::from_str(stdout.trim()).expect("one JSON line")
}

/// X, Y, Z (steps) as `@0P` reports them (`<< 0 X=… Y=… Z=… (steps)`).
fn position(sim: &SimProcess) -> [i64; 3] {
    let out = sim.run(&["send", "@0P"]);
    let stdout = text(&out.stdout);
    let axis = |name: &str| -> Option<i64> {
        stdout.lines().find_map(|l| {
            l.split_once(name)?
                .1
                .split_whitespace()
                .next()?
                .parse()
                .ok()
        })
    };
    match (axis(" X="), axis(" Y="), axis(" Z=")) {
        (Some(x), Some(y), Some(z)) => [x, y, z],
        _ => panic!("no position in {stdout}"),
    }
}

fn mm(json: &serde_json::Value, key: &str, axis: &str) -> f64 {
    json[key][axis]
        .as_f64()
        .unwrap_or_else(|| panic!("{key}.{axis} in {json}"))
}

/// One step of the shipped isel profile (1/400 mm), and a little for the
/// arithmetic in between.
const STEP_MM: f64 = 0.0025 + 1e-9;

/// A block of stock X 30-60 mm, Y 20-50 mm, up to Z 20 mm (400 steps/mm).
const BLOCK: &str = "block:12000,24000,8000,20000,8000";

#[test]
fn a_corner_of_a_block_is_found_within_a_step_and_set_as_the_work_zero() {
    let sim = shape_sim(BLOCK, 0.0);
    let state = tempfile::tempdir().expect("state dir");
    // Outside the corner at the block's smallest X and Y, 3 mm off both
    // faces (less than the 5 mm clearance), 5 mm below its top.
    let start = [10_800, 6800, 6000];
    referenced_at_xyz(&sim, start);
    let json = probe_shape(
        &sim,
        state.path(),
        &["corner", "x+y+", "--offset", "G55", "--json"],
    );
    // A point probe (tip 0) touches with its centre on the faces.
    let (x, y) = (
        mm(&json, "zero_machine_mm", "x"),
        mm(&json, "zero_machine_mm", "y"),
    );
    assert!((x - 30.0).abs() <= STEP_MM, "X face at 30 mm: {json}");
    assert!((y - 20.0).abs() <= STEP_MM, "Y face at 20 mm: {json}");
    assert_eq!(json["work_offset"], "G55");
    let saved = json["saved"].as_str().expect("saved path");
    let file = std::fs::read_to_string(saved).expect("offsets file");
    assert!(file.contains("G55"), "{file}");
    // Back where it started.
    assert_eq!(position(&sim), start);
}

#[test]
fn a_corner_probed_toward_smaller_x_and_y_puts_half_the_tip_beyond_the_touch() {
    // The simulator's probe is a point that touches with its centre on the
    // face; a profile's 1 mm tip says the face lies 0.5 mm further on, in
    // the direction the probe moved.
    let sim = shape_sim(BLOCK, 1.0);
    let state = tempfile::tempdir().expect("state dir");
    // Outside the corner at the block's largest X and Y (60, 50 mm).
    let start = [25_200, 21_200, 6000];
    referenced_at_xyz(&sim, start);
    let json = probe_shape(&sim, state.path(), &["corner", "x-y-", "--json"]);
    let (x, y) = (
        mm(&json, "zero_machine_mm", "x"),
        mm(&json, "zero_machine_mm", "y"),
    );
    assert!((x - (60.0 - 0.5)).abs() <= STEP_MM, "{json}");
    assert!((y - (50.0 - 0.5)).abs() <= STEP_MM, "{json}");
    assert_eq!(json["work_offset"], "G54");
    assert_eq!(position(&sim), start);
}

#[test]
fn the_centre_of_a_bore_is_found_within_a_step_with_its_diameters() {
    // A bore of radius 8 mm around X 40, Y 30 mm in stock up to Z 20 mm.
    let (cx, cy, r) = (40.0, 30.0, 8.0);
    let tip = 0.5;
    let mut sim = shape_sim("bore:16000,12000,3200,8000", tip);
    let state = tempfile::tempdir().expect("state dir");
    // Inside, 1 mm off the centre in X and Y, 5 mm below the top.
    referenced_at_xyz(&sim, [16_400, 12_400, 6000]);
    let shown = sim.device_state();
    assert!(
        shown.contains("probe surface bore:16000,12000,3200,8000 (clear)"),
        "{shown}"
    );
    let json = probe_shape(&sim, state.path(), &["center", "--json"]);
    let (x, y) = (
        mm(&json, "zero_machine_mm", "x"),
        mm(&json, "zero_machine_mm", "y"),
    );
    // The tip cancels out of the centre.
    assert!((x - cx).abs() <= STEP_MM, "centre X: {json}");
    assert!((y - cy).abs() <= STEP_MM, "centre Y: {json}");
    // X is probed 1 mm off the centre in Y: a chord, 2·√(R² − 1²). Y is
    // probed from the centre in X: the diameter. The simulator's point
    // probe touches the wall with its centre, and the command adds the tip
    // (it takes a ball of that diameter to have touched); each touch is
    // good to a step.
    let chord = 2.0 * (r * r - 1.0_f64).sqrt();
    let (dx, dy) = (mm(&json, "diameter_mm", "x"), mm(&json, "diameter_mm", "y"));
    assert!((dx - (chord + tip)).abs() <= 2.0 * STEP_MM, "{dx} {json}");
    assert!((dy - (2.0 * r + tip)).abs() <= 2.0 * STEP_MM, "{dy} {json}");
    // It ends at the centre it found.
    let [px, py, pz] = position(&sim);
    assert!(
        (px - 16_000).abs() <= 1 && (py - 12_000).abs() <= 1,
        "{px} {py}"
    );
    assert_eq!(pz, 6000);
}
