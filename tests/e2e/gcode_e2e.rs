//! End to end: G-code from CAM through the real binary. The project's
//! sample files in the styles of three CAM posts and of LinuxCNC
//! (`examples/gcode/`) are imported, uploaded and run on `jogterm sim --pty`,
//! and the simulated machine ends exactly at the G-code's last point in steps
//! (worked out here by hand from the file, not by jogterm); the program the
//! controller received is the one `jogterm import` writes. Bad G-code is an
//! error at FILE:LINE:COL, exit 1, and nothing reaches the controller.
//!
//! These tests check logic, not the wire's timing: they hold no lock and run
//! beside the others, and the jobs that run to their end do so on a
//! simulator [`SCALE`] times faster than real time (`jogterm sim
//! --time-scale`): what they check (the end point in steps, the commands
//! stored or streamed in order, the messages, where a job is cut) does not
//! depend on how long the motion takes. The Ctrl-C of a stream runs at
//! [`STREAM_STOP_SCALE`], slower, so that the rest of the stream after its
//! fifth move takes seconds of wall time, far more than the signal's way.

use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant};

use crate::sim_process::{SimProcess, contains_panic, text};

/// The samples and where each ends, in steps of the default profile (400
/// steps/mm) with G54's zero at machine X50 Y50 Z60 mm.
const WORK_ZERO: &str = "X50 Y50 Z60";

/// How much faster than real time the simulator runs the jobs that run to
/// their end (`SimOptions::time_scale`).
const SCALE: f64 = 20.0;

/// The scale of the stream interrupted by Ctrl-C: the eighty moves left
/// after the fifth take at least 0.2 s each at real time, 16 s in all, so
/// more than 3 s of wall time here; the stop follows the signal within
/// milliseconds.
const STREAM_STOP_SCALE: f64 = 5.0;

fn sample(name: &str) -> String {
    format!("{}/examples/gcode/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn steps(work_mm: [f64; 3]) -> [i64; 3] {
    let zero = [50.0, 50.0, 60.0];
    [0, 1, 2].map(|i| ((work_mm[i] + zero[i]) * 400.0).round() as i64)
}

fn run(sim: &SimProcess, args: &[&str]) -> Output {
    sim.configured(args).output().expect("run jogterm")
}

pub(crate) fn spawn(sim: &SimProcess, args: &[&str]) -> Child {
    sim.configured(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn jogterm")
}

/// The samples cut for ten to seventy-five seconds each at the test
/// profile's speeds at real time; at [`SCALE`] a few seconds, but the bound
/// is the real-time one, for a machine under load.
const RUN_BOUND: Duration = Duration::from_secs(90);

/// A test profile of a faster machine (the default's speeds would make each
/// sample run half a minute): X and Y 60 mm/s, Z 30 mm/s.
const FAST_MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n",
);

pub(crate) fn wait_run(mut child: Child, what: &str) -> Output {
    let end = Instant::now() + RUN_BOUND;
    while matches!(child.try_wait(), Ok(None)) {
        if Instant::now() > end {
            let _ = child.kill();
            let out = child.wait_with_output();
            panic!("{what} did not end within {RUN_BOUND:?}: {out:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("the output")
}

/// The position `upload --start` says the program ended at.
pub(crate) fn ended_at(said: &str) -> [i64; 3] {
    let line = said
        .lines()
        .find_map(|l| l.strip_prefix("the program ended; position (steps): "))
        .unwrap_or_else(|| panic!("no end position in:\n{said}"));
    let values: Vec<i64> = line
        .split(", ")
        .map(|part| part[2..].parse().expect("steps"))
        .collect();
    [values[0], values[1], values[2]]
}

/// The commands of a program file as `jogterm import -o` writes it.
pub(crate) fn commands_of(program: &str) -> Vec<String> {
    program
        .lines()
        .map(|l| l.split(';').next().unwrap_or("").trim().to_owned())
        .filter(|c| !c.is_empty())
        .collect()
}

/// Reference the simulator, import the sample, upload and run it, and
/// check the end point and the stored program on the wire. `during` runs
/// while the program runs (a pause to answer).
fn import_upload_and_run(
    name: &str,
    end_work_mm: [f64; 3],
    during: impl FnOnce(&mut SimProcess),
) -> String {
    let mut sim = SimProcess::options("isel")
        .files(&[FAST_MACHINE])
        .time_scale(SCALE)
        .start();
    let file = sample(name);
    let program = sim.dir.path().join("out.isel");
    let program_path = program.display().to_string();
    let imported = run(
        &sim,
        &[
            "import",
            &file,
            "--work-zero",
            WORK_ZERO,
            "-o",
            &program_path,
        ],
    );
    assert_eq!(
        imported.status.code(),
        Some(0),
        "{}",
        text(&imported.stderr)
    );
    let commands = commands_of(&std::fs::read_to_string(&program).expect("the program"));
    assert_eq!(commands.first().map(String::as_str), Some("77"));
    assert_eq!(commands.get(1).map(String::as_str), Some("z1"));

    let reference = run(&sim, &["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let before = sim.received().len();
    let child = spawn(
        &sim,
        &[
            "upload",
            &file,
            "--work-zero",
            WORK_ZERO,
            "--erase",
            "--start",
        ],
    );
    during(&mut sim);
    let out = wait_run(child, "upload --start");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert_eq!(ended_at(&said), steps(end_work_mm), "{said}");

    // The controller stored exactly the commands `import` wrote, in order.
    let received = sim.received();
    let upload = &received[before..];
    let stored: Vec<&str> = upload
        .split("<CR>")
        .map(|c| c.trim_start_matches("@0i"))
        .collect();
    let mut at = 0;
    for command in &commands {
        let found = stored[at..]
            .iter()
            .position(|c| c == command)
            .unwrap_or_else(|| panic!("`{command}` not stored in order; received: {upload}"));
        at += found + 1;
    }
    said
}

#[test]
fn fusion_360_grbl_style_ends_at_its_last_point() {
    // G2 X20 Y15 I5 J0 (a full circle), then G0 Z15.
    let said = import_upload_and_run("fusion-grbl.nc", [20.0, 15.0, 15.0], |_| {});
    assert!(
        said.contains(
            "fusion-grbl.nc:13:1: warning: the isel controller cannot set a spindle speed"
        ),
        "{said}"
    );
}

#[test]
fn estlcam_style_ends_at_its_last_point() {
    import_upload_and_run("estlcam.nc", [2.0, 2.0, 5.0], |_| {});
}

#[test]
fn linuxcnc_inch_file_with_r_arcs_and_g18_g19_circles_ends_at_its_last_point() {
    // G19 G3 Y1.2 Z0.3 from X1.0 (after the G18 arc), then G0 Z0.5; inches.
    import_upload_and_run("linuxcnc-inch.ngc", [25.4, 30.48, 12.7], |_| {});
}

#[test]
fn freecad_drilling_cycles_wait_at_the_tool_change_for_the_start_key() {
    // Held as an operator holds a key: a press and release at one instant
    // falls between two reads of the port by the waiting `o`.
    freecad_tool_change_ended_by("pulse start 300");
}

/// Issue 37 (16): the simulator's `press start` (its stdin, and `p` on
/// `start` in the console's simulator panel) is a key pressed as a finger
/// presses it, so it ends the wait of an M6 as the real key does. Before,
/// a press was down for no time at all and the program's `o` loop, polling
/// the port, never saw it: the job stood at the tool change for ever.
#[test]
fn a_pressed_start_key_ends_the_tool_change_wait() {
    freecad_tool_change_ended_by("press start");
}

/// M6 T2 comes before any move: the program takes Z alone from the
/// reference point up to the job's safe height (G0 Z10: machine 70 mm,
/// 28000 steps; the profile has no `[tools] change_at`, so the change
/// waits above where the tool stands), stands there until `control` presses
/// the start key, then drills the four holes and ends above the last one
/// (X10 Y25) at G0 Z10.
fn freecad_tool_change_ended_by(control: &str) {
    let said = import_upload_and_run("freecad-path.ngc", [10.0, 25.0, 10.0], |sim| {
        let deadline = Instant::now() + Duration::from_secs(20);
        let running = loop {
            let state = sim.device_state();
            if state.contains("program running") {
                break state;
            }
            assert!(Instant::now() < deadline, "the program never ran: {state}");
            std::thread::sleep(Duration::from_millis(100));
        };
        // Standing at the pause, above the reference point at the safe
        // height: a moment later it has not moved on.
        let up = sim.wait_device("Z up to the safe height", |s| {
            s.starts_with("device: X 0 Y 0 Z 28000 ")
        });
        std::thread::sleep(Duration::from_secs(1));
        let still = sim.device_state();
        assert!(
            still.contains("program running"),
            "{running}\n{up}\n{still}"
        );
        assert!(
            still.starts_with("device: X 0 Y 0 Z 28000 "),
            "no move after the retract before the start key: {still}"
        );
        sim.control(control);
    });
    assert!(said.contains("running the program"), "{said}");
    assert!(
        said.contains("freecad-path.ngc:14:1: the program pauses here: M6: change to tool T2: press the start key"),
        "{said}"
    );
}

/// Bad G-code: the import's error at FILE:LINE:COL, exit 1; `check` and `upload`
/// of the same file the same, with nothing on the wire. What went wrong.
fn refused(sim: &mut SimProcess, name: &str, gcode: &str, expected: &str) -> Option<String> {
    let path = sim.dir.path().join(name);
    std::fs::write(&path, gcode).expect("write the G-code");
    let file = path.display().to_string();
    for command in ["import", "check", "upload"] {
        let out = run(sim, &[command, &file, "--work-zero", WORK_ZERO]);
        // `check` prints its diagnostics on stdout, the others on stderr.
        let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
        if contains_panic(&out.stderr)
            || out.status.code() != Some(1)
            || !said.contains(&format!("{file}:"))
            || !said.contains(expected)
        {
            return Some(format!(
                "{command} {name}: expected exit 1 and `{expected}`, got {:?}:\n{said}",
                out.status.code()
            ));
        }
    }
    None
}

#[test]
fn bad_gcode_is_an_error_at_file_line_col_and_nothing_is_sent() {
    let mut sim = SimProcess::start("isel");
    let cases: &[(&str, &str, &str)] = &[
        ("empty.nc", "", ":1:1: error: the file holds no G-code"),
        (
            "garbage.nc",
            "G21\nG0 X1\n\u{0}\u{1}\u{2}\u{ff}binary\n",
            ":3:1: error: U+0000 cannot stand here",
        ),
        (
            "comp.nc",
            "G21\nG0 X1 Y1\nG41 D1 X2\n",
            ":3:1: error: G41: cutter radius compensation is refused",
        ),
        (
            "g43.nc",
            "G21\nG43 H1 Z5\n",
            ":2:1: error: G43: tool length offsets are refused",
        ),
        (
            "g93.nc",
            "G21 G93\n",
            ":1:5: error: G93: inverse time feed is refused",
        ),
        (
            "g28.nc",
            "G21\nG28 Z0\n",
            ":2:1: error: G28: G28/G30 go to a position this profile does not name",
        ),
        ("oword.nc", "G21\no100 sub\n", ":2:1: error: O-words"),
        (
            "param.nc",
            "G21\nG0 X#1\n",
            ":2:5: error: `#` parameters are refused",
        ),
        (
            "modal.nc",
            "G21\nG0 G1 X5 F100\n",
            ":2:4: error: G1 and G0 (column 1) are of one modal group",
        ),
        (
            "arc.nc",
            "G21 G17\nG0 X10 Y10 Z5\nG2 X20 Y10 I4 J0 F300\n",
            ":3:1: error: the arc's end is not on its circle",
        ),
        (
            "limit.nc",
            "G21\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 Z-61 F100\nG1 Z-70\n",
            ":4:1: error: Z -1.000 mm is below the soft limit 0.000 mm of axis Z",
        ),
        (
            "output.nc",
            "G21\nM64 P42\n",
            ":2:5: error: M64 P42: no output 42 on this machine",
        ),
    ];
    let wrong: Vec<String> = cases
        .iter()
        .filter_map(|(name, gcode, expected)| refused(&mut sim, name, gcode, expected))
        .collect();
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    assert_eq!(sim.received_total(), 0, "nothing reached the controller");
}

#[test]
fn a_file_without_a_unit_is_read_in_the_shipped_profiles_unit_and_the_summary_says_so() {
    let sim = SimProcess::start("isel");
    let path = sim.dir.path().join("mpcnc.nc");
    std::fs::write(&path, "G90\nG0 X1 Y1 Z5\nG1 Z1 F100\nM30\n").expect("write");
    let out = run(&sim, &["import", &path.display().to_string()]);
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(
        said.contains(":2:4: warning: the file sets no unit (G20 or G21): its numbers are read in millimetres, the profile's [gcode] unit"),
        "{said}"
    );
}

#[test]
fn a_program_converted_for_another_work_zero_is_refused_before_anything_is_sent() {
    let mut sim = SimProcess::start("isel");
    let gcode = sim.dir.path().join("small.nc");
    std::fs::write(&gcode, "G21 G90\nG0 X10 Y10 Z10\nG1 X20 F600\nM30\n").expect("write");
    let gcode = gcode.display().to_string();
    let convert = |sim: &SimProcess, out: &str, zero: Option<&str>| {
        let path = sim.dir.path().join(out).display().to_string();
        let mut args = vec!["import", gcode.as_str(), "-o", path.as_str()];
        if let Some(zero) = zero {
            args.extend(["--work-zero", zero]);
        }
        let done = run(sim, &args);
        assert_eq!(done.status.code(), Some(0), "{}", text(&done.stderr));
        path
    };
    // Made for the work zero in force (none stored: machine 0): it stores.
    let current = convert(&sim, "current.isel", None);
    let out = run(&sim, &["upload", &current]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    // Made for G54 at X50 Y50 Z60, which is not where G54 is: refused.
    let before = sim.received_total();
    let moved = convert(&sim, "moved.isel", Some(WORK_ZERO));
    let out = run(&sim, &["upload", &moved, "--erase", "--start"]);
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(
        said.contains("converted from small.nc for work offset G54 with its zero where it no longer is (X 50.000 mm then, 0.000 mm now, Y 50.000 mm then, 0.000 mm now, Z 60.000 mm then, 0.000 mm now)"),
        "{said}"
    );
    assert_eq!(sim.received_total(), before, "nothing sent");
}

#[test]
fn a_command_the_controller_refuses_is_named_by_its_gcode_line() {
    // A controller that stores fewer commands than the profile says: the
    // one that does not fit is refused, and the upload names the G-code
    // line it came from.
    let mut sim = SimProcess::start("isel");
    sim.control("memory 8");
    let file = sample("fusion-grbl.nc");
    let out = run(
        &sim,
        &["upload", &file, "--work-zero", WORK_ZERO, "--erase"],
    );
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    // The 9th command is the `m` of `X40` on line 20, its first word.
    assert!(
        said.contains(&format!("{file}:20:1: the controller refused command 9")),
        "{said}"
    );
}

/// The EMCU profile with faster axes, near machine 0 at power-up (a short
/// reference run), and the spindle's M3/M5 mapped to relay A1 through the
/// `[gcode]` table (the EMCU's outputs have no spindle role).
const FAST_EMCU: (&str, &str) = (
    "profiles/emcu.toml",
    "base = \"emcu\"\n[axes.X]\nmax_speed = 40.0\n[axes.Y]\nmax_speed = 40.0\n[axes.Z]\nmax_speed = 20.0\n[sim]\nstart_position = 1.0\n[gcode]\nm3 = \"output:A1\"\nm5 = \"output:A1\"\n",
);

#[test]
fn estlcam_style_as_an_emcu_job_ends_at_its_last_point() {
    let mut sim = SimProcess::options("emcu")
        .files(&[FAST_EMCU])
        .time_scale(SCALE)
        .start();
    let ready = run(&sim, &["send", "@R", "#S2000", "#R200\\x01", "$HZYX\\x01"]);
    assert!(ready.status.success(), "{}", text(&ready.stderr));
    sim.wait_device("referenced", |s| {
        s.contains("X 0 ") && !s.contains("moving")
    });
    let file = sample("estlcam.nc");
    let child = spawn(
        &sim,
        &["upload", &file, "--work-zero", WORK_ZERO, "--start"],
    );
    let out = wait_run(child, "upload --start");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    // G01 X2 Y2, G00 Z5 with G54 at X50 Y50 Z60, 200 steps/mm.
    let expected = [52.0, 52.0, 65.0].map(|mm: f64| (mm * 200.0).round() as i64);
    assert_eq!(ended_at(&said), expected, "{said}");
    let received = sim.received();
    // The job: the reference run, the spindle on relay A1, absolute vector
    // moves at slot 7, the arcs as chords.
    assert!(received.contains("@F<CR>$HZXY<CR>A1,1<CR>"), "{received}");
    assert!(
        received.contains("L7,X10400,Y10400,Z11900<CR>"),
        "{received}"
    );
    assert!(received.contains("A1,0<01>"), "{received}");
    assert!(received.contains("@J<CR>"), "{received}");
}

/// Twelve square pockets, each entered from and left to Z5: a job of 88
/// commands for a controller that stores 30.
fn pockets() -> String {
    let mut text = String::from("%\n(pockets)\nG21 G90 G17\nG0 Z5\n");
    for i in 0..12 {
        let (x, y) = (10 + (i % 4) * 12, 10 + (i / 4) * 12);
        text.push_str(&format!(
            "G0 X{x} Y{y}\nG1 Z-1 F600\nG1 X{} F1500\nG1 Y{}\nG1 X{x}\nG1 Y{y}\nG0 Z5\n",
            x + 5,
            y + 5
        ));
    }
    text.push_str("M30\n%\n");
    text
}

/// The fast machine's simulator with a program memory of 30 commands, as
/// its profile says too, and the pocket job in its directory; at [`SCALE`].
fn pockets_on_a_small_controller() -> (SimProcess, String) {
    let small_memory = (
        "profiles/default.toml",
        "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n[gcode]\nmemory = 30\n",
    );
    let sim = SimProcess::options("isel")
        .files(&[small_memory])
        .variants(&["memory=30"])
        .time_scale(SCALE)
        .start();
    let file = sim.dir.path().join("pockets.nc");
    std::fs::write(&file, pockets()).expect("write");
    let file = file.display().to_string();
    (sim, file)
}

#[test]
fn a_job_bigger_than_the_memory_runs_in_parts_cut_only_where_the_tool_is_retracted() {
    let (mut sim, file) = pockets_on_a_small_controller();
    // Without --chunked it is refused, and nothing is sent.
    let out = run(
        &sim,
        &["upload", &file, "--work-zero", WORK_ZERO, "--start"],
    );
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains("the converted program has 88 commands and the controller stores 30"),
        "{said}"
    );
    assert_eq!(sim.received_total(), 0);

    let reference = run(&sim, &["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let before = sim.received().len();
    let child = spawn(
        &sim,
        &[
            "upload",
            &file,
            "--work-zero",
            WORK_ZERO,
            "--start",
            "--chunked",
        ],
    );
    let out = wait_run(child, "upload --start --chunked");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("storing and running it in 4 parts"), "{said}");
    assert!(said.contains("part 4/4"), "{said}");
    // The last pocket is at X46 Y34, left to Z5.
    assert_eq!(
        ended_at(said.lines().last().unwrap_or_default()),
        steps([46.0, 34.0, 5.0]),
        "{said}"
    );
    // Every stored part but the last ends, before its `9`, with the rapid
    // up to the safe height Z5 (machine Z65: 26000 steps).
    let received = sim.received();
    // `@0i` also opens the driver's look at what is stored (answered `6`
    // while a program is there, then `@0k`): those hold no commands.
    let stored: Vec<Vec<&str>> = received[before..]
        .split("@0i<CR>")
        .skip(1)
        .map(|program| program.split("<CR>").collect::<Vec<_>>())
        .filter(|commands| commands.first().is_some_and(|c| !c.starts_with('@')))
        .collect();
    assert_eq!(stored.len(), 4, "{received}");
    for (k, part) in stored.iter().enumerate() {
        let end = part.iter().position(|c| *c == "9").expect("a 9");
        let last = part[end - 1];
        let fields: Vec<&str> = last.trim_start_matches('m').split(',').collect();
        assert!(
            last.starts_with('m') && fields.get(4) == Some(&"26000"),
            "part {} ends with `{last}`, not at the safe height",
            k + 1
        );
        assert!(end <= 30, "part {} holds {end} commands", k + 1);
    }
}

#[test]
fn a_job_bigger_than_the_memory_runs_as_a_dnc_stream_and_stores_nothing() {
    let (mut sim, file) = pockets_on_a_small_controller();
    // Unreferenced and not initialised: the stream sets the controller up
    // and its own first command is the reference run (`77` as `@0R7`).
    let child = spawn(
        &sim,
        &["upload", &file, "--work-zero", WORK_ZERO, "--stream"],
    );
    let out = wait_run(child, "upload --stream");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("streaming 88 commands"), "{said}");
    assert!(said.contains("the stream ended"), "{said}");
    // Progress names the G-code lines, to the last (M30) at 100 %.
    assert!(said.contains("pockets.nc:89:1: 100 % after"), "{said}");
    let state = sim.device_state();
    let [x, y, z] = steps([46.0, 34.0, 5.0]);
    assert!(
        state.starts_with(&format!("device: X {x} Y {y} Z {z} ")),
        "{state}"
    );
    let received = sim.received();
    assert!(!received.contains("@0i"), "nothing stored: {received}");
    let reference = received.find("@0R7<CR>").expect("the reference run");
    let three_d = received.find("@0z1<CR>").expect("3D mode");
    assert!(reference < three_d, "{received}");
    // Every `m` of the program (77, z1, 85 moves, 9) as a DNC absolute move.
    assert_eq!(received.matches("@0M").count(), 85, "{received}");
}

#[test]
fn ctrl_c_during_a_stream_stops_the_machine_and_sends_no_further_command() {
    let mut sim = SimProcess::options("isel")
        .files(&[FAST_MACHINE])
        .time_scale(STREAM_STOP_SCALE)
        .start();
    let file = sim.dir.path().join("pockets.nc");
    std::fs::write(&file, pockets()).expect("write");
    let file = file.display().to_string();
    let child = spawn(
        &sim,
        &["upload", &file, "--work-zero", WORK_ZERO, "--stream"],
    );
    // A few pockets in, interrupted as Ctrl-C does.
    sim.wait_received("the fifth move", |r| r.matches("@0M").count() >= 5);
    let pid = libc::pid_t::try_from(child.id()).expect("pid");
    // SAFETY: a plain signal to the child this test started.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let out = wait_run(child, "upload --stream after Ctrl-C");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    let received = sim.received();
    let stop = received.rfind("<FD><FF>").expect("the stop");
    let last_move = received.rfind("@0M").expect("moves");
    assert!(last_move < stop, "nothing after the stop: {received}");
    let moves_at_stop = received.matches("@0M").count();
    assert!(
        moves_at_stop < 85,
        "the stream did not run on: {moves_at_stop}"
    );
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    assert!(!state.contains("program"), "{state}");
}

#[test]
fn import_json_gives_the_figures_of_the_file_worked_out_by_hand() {
    let state = tempfile::tempdir().expect("state dir");
    let out = std::process::Command::new(crate::sim_process::JOGTERM)
        .args([
            "import",
            &sample("fusion-grbl.nc"),
            "--work-zero",
            WORK_ZERO,
            "--json",
        ])
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .env("JOGTERM_STATE_DIR", state.path())
        .output()
        .expect("run jogterm import");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    // In the file's own coordinates: the lead-in at X-2 Y-2, the contour's
    // arcs bulge to X45 and Y30, Z from the cut at -2 to the clearance 15.
    assert_eq!(
        json["extents_mm"],
        serde_json::json!({"x": [-2.0, 45.0], "y": [-2.0, 30.0], "z": [-2.0, 15.0]})
    );
    // Twelve G0/G1 moves, three quarter fillets and a full circle.
    assert_eq!(json["moves"], 12);
    assert_eq!(json["arcs"], 4);
    // From the reference point (machine 0) to the lead-in, 48 mm in X and
    // Y: 67.882; then 75 + 10 + 6 + 2.828 + 40 + 20 + 35 + 25 + 1 + 25 + 17
    // straight, 3 x 7.854 fillets and the 31.416 circle.
    let length = json["length_mm"].as_f64().expect("length");
    assert!((length - 379.688).abs() < 0.01, "{length}");
    assert_eq!(json["fits_memory"], true);
    assert!(json["output_lines"].as_u64().is_some_and(|n| n > 20));
    assert!(json["estimated_s"].as_f64().is_some_and(|s| s > 0.0));
    let warnings = json["warnings"].as_array().expect("warnings");
    assert_eq!(warnings[0]["line"], 13);
    assert_eq!(warnings[0]["col"], 1);
    assert!(
        warnings[0]["message"]
            .as_str()
            .is_some_and(|m| m.contains("spindle speed"))
    );
}
