//! The jog off a limit switch (`L`) with the real `jogterm` binary in an
//! 80x24 pseudo-terminal against `jogterm sim --pty`, the switch held
//! active through the simulator's input controls: isel (test mode, short
//! moves, `@0T0` after) and EMP (one positioning, stopped on release), the
//! switch released while it runs (the jog ends by itself and the reference
//! run is asked for), and a switch that stays active (the bound).

use crate::sim_process;
use crate::ui_pty;

use std::path::Path;
use std::time::Duration;

use sim_process::{JOGTERM, SimProcess, WAIT};
use ui_pty::PtyRun;

fn spawn(args: &[&str], config: &Path) -> PtyRun {
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        ("RUST_BACKTRACE", "0".to_string()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    PtyRun::spawn(Path::new(JOGTERM), args, &env)
}

fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

fn quit(run: &mut PtyRun) {
    run.type_keys(&[b"q"]);
    let code = run.wait_exit(WAIT);
    assert_eq!(code, Some(0), "{}", run.screen().screen().contents());
}

/// An isel console with limit X1 held on at the simulator, initialised
/// (`i`), its question (`L`) confirmed.
fn isel_jogging_off_x1(sim: &mut SimProcess, config: &Path) -> PtyRun {
    let mut run = spawn(&["--port", &sim.link.display().to_string()], config);
    wait_for(&run, "○X1");
    sim.control("set limit-x1 on");
    wait_for(&run, "●X1");
    run.type_keys(&[b"i"]);
    // `@07` (the axes), not the probe: the probe went out at connect too,
    // and an `L` written right behind the `i` is read with it, a burst
    // that does nothing (`docs/jogging.md`, "Pastes and bursts").
    sim.wait_received("the initialisation", |r| r.contains("@07<CR>"));
    // The console learns of the initialisation from the device task's next
    // state: on a loaded machine `L` may still be refused once.
    let mut screen = String::new();
    for _ in 0..10 {
        run.type_keys(&[b"L"]);
        match run.wait_for("Jog X off its limit switch", Duration::from_secs(2)) {
            Ok(s) => {
                screen = s;
                break;
            }
            Err(s) => assert!(s.contains("not initialised"), "{s}"),
        }
    }
    assert!(
        screen.contains("X stands in its min limit switch limit X1"),
        "{screen}"
    );
    run.type_keys(&[b"\r"]);
    wait_for(&run, "off limit X1: X+ at most 2 mm");
    run
}

#[test]
fn isel_the_axis_leaves_its_switch_test_mode_goes_off_and_a_reference_is_asked_for() {
    let config = tempfile::tempdir().expect("tempdir");
    // 1 mm from the reference point (the switch is the operator's control
    // here): the closing reference run is only the way to READY.
    let mut sim = SimProcess::start_with_files("isel", &[sim_process::ISEL_NEAR_REFERENCE]);
    let mut run = isel_jogging_off_x1(&mut sim, config.path());
    let state = sim.wait_device("in test mode", |s| s.contains("test mode"));
    assert!(state.contains("test mode"), "{state}");
    // A few short moves, then the switch lets go.
    sim.wait_received("two short moves", |r| {
        r.matches("@0A20,200,0,300,0,300,0,300<CR>").count() >= 2
    });
    sim.control("set limit-x1 off");
    let screen = wait_for(&run, "Reference run");
    assert!(
        screen.contains("X is off its limit switch limit X1 after 40 steps"),
        "{screen}"
    );
    let received = sim.received();
    let t1 = received.find("@0T1<CR>").expect("test mode on");
    let t0 = received.rfind("@0T0<CR>").expect("test mode off");
    assert!(t1 < t0, "{received}");
    // Between them only X moves, only in X+ and 20 steps at a time.
    let between = &received[t1..t0];
    for part in between.split("@0A").skip(1) {
        assert!(part.starts_with("20,200,0,300,0,300,0,300"), "{between}");
    }
    let state = sim.device_state();
    assert!(!state.contains("test mode"), "{state}");
    // The reference question is the `h` one: yes runs it.
    run.type_keys(&[b"\r"]);
    sim.wait_received("the reference run", |r| r.contains("@0R7<CR>"));
    wait_for(&run, "READY");
    quit(&mut run);
}

#[test]
fn isel_a_switch_that_stays_active_stops_the_jog_at_the_bound() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut sim = SimProcess::start("isel");
    let mut run = isel_jogging_off_x1(&mut sim, config.path());
    // 2 mm at 400 steps/mm: 40 moves of 20 steps.
    let screen = run
        .wait_for("still reads active", WAIT)
        .unwrap_or_else(|s| panic!("{s}\nreceived: {}", sim.received()));
    assert!(!screen.contains("Reference run"), "{screen}");
    let received = sim.received();
    let moves = received.matches("@0A20,200,0,300,0,300,0,300<CR>").count();
    assert_eq!(moves, 40, "{received}");
    let state = sim.device_state();
    assert!(!state.contains("test mode"), "{state}");
    quit(&mut run);
}

#[test]
fn isel_space_stops_it_and_nothing_moves_afterwards() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut sim = SimProcess::start("isel");
    let mut run = isel_jogging_off_x1(&mut sim, config.path());
    sim.wait_received("a short move", |r| r.contains("@0A20,200"));
    run.type_keys(&[b" "]);
    wait_for(&run, "off its limit switch stopped");
    let received = sim.received();
    assert!(received.contains("<FD><FF>"), "{received}");
    let moves = received.matches("@0A20,200").count();
    std::thread::sleep(Duration::from_millis(800));
    let later = sim.received();
    assert_eq!(later.matches("@0A20,200").count(), moves, "{later}");
    assert!(later.rfind("@0T0<CR>") > later.rfind("<FD><FF>"), "{later}");
    quit(&mut run);
}

/// EMP with limit X min wired to input I1 (`[io]`), held on at the
/// simulator: one positioning away from it, stopped once I1 lets go.
#[test]
fn emp_the_drive_positions_off_its_switch_and_stops_once_it_releases() {
    let profile =
        "base = \"emp\"\n[io.\"11.I1\"]\nrole = \"limit\"\naxis = \"X\"\nside = \"min\"\n";
    let mut sim = SimProcess::start_with_files("emp", &[("profiles/emp.toml", profile)]);
    let link = sim.link.display().to_string();
    let config = sim.dir.path().to_path_buf();
    let mut run = spawn(&["--protocol", "emp", "--port", &link], &config);
    wait_for(&run, "state read back");
    run.type_keys(&[b"i"]);
    sim.wait_device("switched on", |s| !s.contains("off"));
    sim.control("set i1 on");
    std::thread::sleep(Duration::from_millis(800));
    run.type_keys(&[b"L"]);
    let screen = wait_for(&run, "Jog X off its limit switch");
    assert!(screen.contains("min limit switch"), "{screen}");
    run.type_keys(&[b"\r"]);
    sim.wait_received("the positioning", |r| r.contains("2A1101"));
    std::thread::sleep(Duration::from_millis(500));
    sim.control("set i1 off");
    wait_for(&run, "Reference run");
    let received = sim.received();
    let from = received.find("2A1101").unwrap_or(0);
    assert!(received[from..].contains("081100"), "stopped: {received}");
    run.type_keys(&[b"n"]);
    wait_for(&run, "Reference run: cancelled");
    quit(&mut run);
}
