//! Wiring in the profile, the controller decides (issue 20): `jogterm send`
//! and `poll` on isel controllers wired differently from the manual's table,
//! against the real `jogterm sim --pty --variant …`.
//!
//! - With an unchanged default profile on a controller whose hood inputs
//!   read 0 (no hood circuit), a reference run and a move go; with the hood
//!   wired and open the controller's `H` is what refuses, explained.
//! - Bits carry the profile's names in `send` and `poll --ports`.
//! - A profile with several mistakes gets every one reported, each with its
//!   file, line and column.

use std::path::Path;

use crate::sim_process;
use sim_process::{SimProcess, text};

/// The command of the "done when".
const DONE_WHEN: [&str; 4] = ["send", "@07", "@0R7", "@0A1000,2000,0,2000,0,2000,0,2000"];

/// The simulated axes stand 1 mm from their reference point at power-up.
const NEAR_REFERENCE: (&str, &str) = sim_process::ISEL_NEAR_REFERENCE;

#[test]
fn the_default_profile_moves_an_isel_without_a_hood_circuit() {
    let mut sim = SimProcess::start_variant("isel", &[NEAR_REFERENCE], &["hood-unwired"]);
    let ports = sim.run(&["send", "@0b2"]);
    assert!(
        text(&ports.stdout).contains("<< 0 0x02 (00000010)"),
        "hood bits read 0: {}",
        text(&ports.stdout)
    );
    let out = sim.run(&DONE_WHEN);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    assert!(
        sim.received()
            .contains("@0A1000,2000,0,2000,0,2000,0,2000<CR>"),
        "the move reached the controller"
    );
    let state = sim.device_state();
    assert!(state.starts_with("device: X 1000 "), "{state}");
}

#[test]
fn with_the_hood_wired_and_open_the_controllers_h_refuses() {
    let mut sim = SimProcess::start_with_files("isel", &[NEAR_REFERENCE]);
    sim.control("set hood open");
    let out = sim.run(&DONE_WHEN);
    let stderr = text(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}\n{stderr}",
        text(&out.stdout)
    );
    assert!(
        text(&out.stdout).contains(">> @0R7\n<< H"),
        "{}",
        text(&out.stdout)
    );
    assert!(stderr.contains("answered `H`"), "{stderr}");
    assert!(stderr.contains("hood is open"), "{stderr}");
    assert!(
        stderr.contains("hood closed or setup (in2.6) reads 0"),
        "the hood inputs as read: {stderr}"
    );
    // jogterm sent the reference run: the controller refused it.
    let received = sim.received();
    assert!(received.contains("@0R7<CR>"), "{received}");
    assert!(!received.contains("@0A1000"), "{received}");
}

#[test]
fn a_controller_without_port_2_is_polled_without_it() {
    let sim = SimProcess::start_variant("isel", &[NEAR_REFERENCE], &["no-port2"]);
    let lines = sim.poll_json("5", "0");
    for l in &lines {
        assert!(l["ports"].get("2").is_none(), "{l}");
        assert_eq!(l["ports"]["1"], 3, "{l}");
    }
    let out = sim.run(&DONE_WHEN);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

#[test]
fn send_and_poll_name_the_bits_as_the_profile_does() {
    let mut sim = SimProcess::start_with_files(
        "isel",
        &[(
            "profiles/mill.toml",
            "name = \"mill\"\n\
             [io.\"in3.0\"]\nname = \"X home\"\n\
             [io.\"in0.3\"]\nname = \"tool setter\"\nrole = \"probe\"\n",
        )],
    );
    sim.control("set limit-x1 on");
    sim.control("set in0.3 on");
    let with_profile = |args: &[&str]| {
        sim.jogterm(args)
            .env("JOGTERM_CONFIG_DIR", sim.dir.path())
            .args(["--profile", "mill"])
            .output()
            .expect("jogterm")
    };
    let out = with_profile(&["send", "@0b3", "@0b0"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains("(00000001): X home"), "{stdout}");
    assert!(stdout.contains("(00001000): tool setter"), "{stdout}");
    let out = with_profile(&["poll", "--count", "2", "--ports", "--interval-ms", "0"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    // A probe on a user input: port 0 is read too.
    for line in stdout.lines() {
        assert!(line.contains(" in3=01 "), "{line}");
        assert!(line.contains(" in0=08"), "{line}");
        assert!(line.ends_with("active: tool setter, X home"), "{line}");
    }
}

#[test]
fn a_profile_with_several_errors_reports_every_one_with_its_place() {
    let dir = tempfile::tempdir().expect("dir");
    let path = dir.path().join("broken.toml");
    std::fs::write(
        &path,
        "name = \"broken\"\n\
         [jog]\n\
         speeed = 3\n\
         step = 9\n\
         [axes.Z]\n\
         min = 10.0\n\
         max = 5.0\n\
         [io.\"in0.2\"]\n\
         role = \"limit\"\n",
    )
    .expect("profile");
    let out = sim_process::jogterm(
        Path::new("/nonexistent-port"),
        "isel",
        &["send", "@0P", "--profile", &path.display().to_string()],
    )
    .output()
    .expect("jogterm");
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let located: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("broken.toml:"))
        .collect();
    assert_eq!(located.len(), 4, "{stderr}");
    for (line, needle) in located.iter().zip([":3:", ":4:", ":7:", ":8:"]) {
        assert!(line.contains(needle), "{needle} in {line}");
    }
    assert!(stderr.contains("speeed"), "{stderr}");
    assert!(stderr.contains("min < max"), "{stderr}");
    assert!(stderr.contains("`axis`"), "{stderr}");
}

/// The shipped example of a machine wired differently (`config/isel-rewired.toml`,
/// `docs/profiles.md`) on the simulator of such a machine: no hood circuit,
/// a normally closed tool setter on user input 3, Y's limit switches swapped.
#[test]
fn the_rewired_example_profile_drives_a_machine_wired_so() {
    let mut sim = SimProcess::start_variant("isel", &[NEAR_REFERENCE], &["hood-unwired"]);
    let with_profile = |sim: &SimProcess, args: &[&str]| {
        sim.jogterm(args)
            .args(["--profile", "isel-rewired"])
            .output()
            .expect("jogterm")
    };
    // The tool setter's contact is closed while nothing touches it.
    sim.control("set in0.3 on");
    let out = with_profile(&sim, &DONE_WHEN);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    sim.control("set in0.3 off");
    sim.control("set limit-y1 on");
    let out = with_profile(
        &sim,
        &["poll", "--count", "1", "--ports", "--interval-ms", "0"],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // Touched (0 on a normally closed contact), and Y1 is the max end here.
    assert!(
        stdout.trim_end().ends_with("active: tool setter, Y end"),
        "{stdout}"
    );
    assert!(stdout.contains(" in0=00"), "{stdout}");
}
