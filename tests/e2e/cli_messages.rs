//! Messages of the CLI that said the wrong thing (issue 37, item 13), the
//! real binary: a profile with several errors reports every one at its
//! line; `jogterm import`'s advice for a job bigger than the memory names
//! parts only where the ways `jogterm run` lists can cut it. (A full
//! memory's advice: `cli_upload.rs`.)

use std::path::Path;
use std::process::{Command, Output};

use crate::cli_check::file;
use crate::editor_e2e::pockets;
use crate::sim_process::{JOGTERM, text};

/// `jogterm args…` with its configuration in `dir`, stdin empty.
fn jogterm(dir: &Path, args: &[&str]) -> Output {
    Command::new(JOGTERM)
        .args(args)
        .env("JOGTERM_CONFIG_DIR", dir)
        .env("JOGTERM_STATE_DIR", dir.join("state"))
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run jogterm")
}

/// Before, a broken `machine.axes` was the one error said: the soft limits
/// and the jog's overrun below it waited for the next try.
#[test]
fn a_profile_with_several_errors_reports_each_at_its_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let profile = file(
        dir.path(),
        "several.toml",
        "base = \"isel\"\n[machine]\naxes = \"XQ\"\n[axes.X]\nmin = 10.0\nmax = 5.0\n\
         [jog]\nmax_overrun = -1.0\n",
    );
    let program = file(dir.path(), "p.isel", "7 7\n9\n");
    let out = jogterm(dir.path(), &["check", "--profile", &profile, &program]);
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{said}");
    for (line, what) in [
        (3, "`Q` is not an axis"),
        (6, "min < max"),
        (8, "must be a positive distance"),
    ] {
        assert!(
            said.lines()
                .any(|l| l.contains(&format!("several.toml:{line}:")) && l.contains(what)),
            "`{what}` at line {line}:\n{said}"
        );
    }
}

/// The summary's line about the memory.
fn memory_line(said: &str) -> &str {
    said.lines()
        .find(|l| l.contains("the controller's memory"))
        .unwrap_or_else(|| panic!("no memory line:\n{said}"))
}

/// A job with no retract between two pockets cannot be cut: the advice
/// was "store and run it in parts" right above the ways' "chunked: not
/// possible" (`jogterm run --from-line` prints both). Now it streams it;
/// a job that can be cut is advised its parts, as many as the ways count.
#[test]
fn import_advises_parts_only_where_the_job_can_be_cut() {
    let dir = tempfile::tempdir().expect("tempdir");
    let profile = file(
        dir.path(),
        "small.toml",
        "base = \"isel\"\n[gcode]\nmemory = 10\n",
    );
    let uncut = file(
        dir.path(),
        "uncut.nc",
        &pockets(2).replace("G0 Z8\nG0 X", "G0 X"),
    );
    let out = jogterm(dir.path(), &["import", "--profile", &profile, &uncut]);
    let said = text(&out.stdout);
    assert!(out.status.success(), "{said}{}", text(&out.stderr));
    let advice = memory_line(&said);
    assert!(advice.contains("does NOT fit"), "{advice}");
    assert!(!advice.contains("store and run it in"), "{advice}");
    assert!(advice.contains("cannot run in parts"), "{advice}");
    assert!(advice.contains("--stream"), "{advice}");

    // The restart's summary and the ways below it say the same.
    let out = jogterm(
        dir.path(),
        &["run", "--profile", &profile, &uncut, "--from-line", "6"],
    );
    let said = text(&out.stderr) + &text(&out.stdout);
    let advice = memory_line(&said);
    assert!(said.contains("chunked: not possible"), "{said}");
    assert!(!advice.contains("store and run it in"), "{said}");

    let cut = file(dir.path(), "cut.nc", &pockets(2));
    let out = jogterm(dir.path(), &["import", "--profile", &profile, &cut]);
    let said = text(&out.stdout);
    let advice = memory_line(&said);
    assert!(advice.contains("store and run it in 3 parts"), "{advice}");
}
