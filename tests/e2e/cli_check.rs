//! `jogterm check` through its clap arguments and `run_to`: output format,
//! sorting, summary, exit codes, language and profile selection.

use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use jogterm::cli::{Cli, CliCommand, check};
use jogterm::config::ConfigDirs;

struct Outcome {
    code: ExitCode,
    stdout: String,
    stderr: String,
}

fn run(argv: &[&str]) -> Outcome {
    run_in(argv, &ConfigDirs::builtin_only())
}

fn run_in(argv: &[&str], dirs: &ConfigDirs) -> Outcome {
    let cli = Cli::try_parse_from(std::iter::once("jogterm").chain(argv.iter().copied()))
        .unwrap_or_else(|e| panic!("{argv:?}: {e}"));
    let Some(CliCommand::Check(args)) = &cli.command else {
        panic!("{argv:?} is no check");
    };
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let code =
        check::run_to(&cli.global, args, dirs, &mut out, &mut err).expect("writes to memory");
    Outcome {
        code,
        stdout: String::from_utf8(out).expect("utf-8"),
        stderr: String::from_utf8(err).expect("utf-8"),
    }
}

pub(crate) fn file(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write");
    path.display().to_string()
}

#[test]
fn a_clean_program_exits_0_with_a_summary_only() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = file(
        dir.path(),
        "circle.isel",
        "; the manual's circle\n77\nm1000,900,1000,900,0,900,0,900\nf-1\ny400,1500,119,-141,141,-1,-1\n9\n",
    );
    let o = run(&["check", &path]);
    assert_eq!(o.code, ExitCode::SUCCESS);
    assert_eq!(o.stdout, "");
    assert_eq!(
        o.stderr,
        format!(
            "{path}: 0 errors, 0 warnings in 5 commands (isel, axes XYZ, soft limits of `isel simulator`)\n"
        )
    );
}

#[test]
fn problems_are_printed_compiler_style_sorted_by_position() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = file(
        dir.path(),
        "broken.cnc",
        "77\n\tM1000,900,0,900,0,900,0,900 ; Umlaut: ä\n0 1,900\n148\n",
    );
    let o = run(&["check", &path]);
    assert_eq!(o.code, ExitCode::from(1));
    let expected = [
        format!(
            "{path}:2:2: warning: `M` is the spelling of the manual's command table; its section \
             3.2.16 writes `m` [fix: write `m`]"
        ),
        format!(
            "{path}:3:1: error: `0` with XYZ takes 4 steps,speed pairs (x, y, z1, z2), got 1 \
             (manual 3.2.2; the controller answers `7`)"
        ),
        format!(
            "{path}:4:2: warning: the sync character `0` (48) is also a reply code: while the \
             program runs, the console takes it for the end of the run (manual 3.2.3, chapter 5)"
        ),
        format!(
            "{path}:4:4: error: the program has no end `9`: without it the controller keeps the \
             program invalid and cannot run it (manual 3.2.9) [fix: add a line `9`]"
        ),
    ];
    assert_eq!(o.stdout.lines().collect::<Vec<_>>(), expected);
    assert!(
        o.stderr.contains(": 2 errors, 2 warnings in 4 commands"),
        "{}",
        o.stderr
    );
}

#[test]
fn warnings_alone_exit_0() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = file(dir.path(), "w.isel", "133\n3 0,0\n9\n");
    let o = run(&["check", &path]);
    assert_eq!(o.code, ExitCode::SUCCESS);
    assert_eq!(o.stdout.lines().count(), 1, "{}", o.stdout);
    assert!(o.stdout.contains(":2:5: warning: `3 0,0` jumps to itself"));
}

#[test]
fn soft_limits_come_from_the_profile_in_its_units() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The default profile: X 0-300 mm at 400 steps/mm.
    let path = file(
        dir.path(),
        "far.isel",
        "77\nm130000,900,0,900,0,900,0,900\n9\n",
    );
    let o = run(&["check", &path]);
    assert_eq!(o.code, ExitCode::from(1));
    assert_eq!(
        o.stdout,
        format!(
            "{path}:2:2: error: axis X goes to 130000 steps (325 mm), above its soft limit \
             120000 steps (300 mm)\n"
        )
    );
    // An EMCU profile does not describe an isel machine.
    let o = run(&["check", "--profile", "emcu", &path]);
    assert_eq!(o.code, ExitCode::from(2), "{}", o.stdout);
    assert!(
        o.stderr.contains(
            "(an isel program by its extension): profile `EMCU SMC3000` describes a emcu machine"
        ),
        "{}",
        o.stderr
    );
}

#[test]
fn the_language_comes_from_the_option_then_the_extension_then_the_profile() {
    let dir = tempfile::tempdir().expect("tempdir");
    let job = "#E1,800\nL1,x100\n";
    // `.job` is EMCU, checked for the shipped EMCU machine.
    let o = run(&["check", &file(dir.path(), "a.job", job)]);
    assert_eq!(o.code, ExitCode::SUCCESS, "{}", o.stdout);
    assert!(
        o.stderr
            .contains("(emcu, axes XYZ, soft limits of `EMCU SMC3000`)"),
        "{}",
        o.stderr
    );
    // Without a telling extension the default profile's family (isel)
    // decides, and as isel the text is refused.
    let txt = file(dir.path(), "a.txt", job);
    let o = run(&["check", &txt]);
    assert_eq!(o.code, ExitCode::from(1), "the default profile is isel");
    let o = run(&["check", "--protocol", "emcu", &txt]);
    assert_eq!(o.code, ExitCode::SUCCESS);
    let o = run(&["--profile", "emcu", "check", &txt]);
    assert_eq!(o.code, ExitCode::SUCCESS);
    assert!(
        o.stderr.contains("soft limits of `EMCU SMC3000`"),
        "{}",
        o.stderr
    );
    // --protocol wins over the extension.
    let o = run(&[
        "check",
        "--protocol",
        "isel",
        &file(dir.path(), "b.job", "9\n"),
    ]);
    assert_eq!(o.code, ExitCode::SUCCESS, "{}", o.stdout);
    // EMP drives store no programs.
    for argv in [
        &["check", "--profile", "emp", &txt][..],
        &["check", "--protocol", "emp", &txt],
    ] {
        let o = run(argv);
        assert_eq!(o.code, ExitCode::from(2), "{argv:?}");
        assert!(
            o.stderr.contains("EMP drives store no programs"),
            "{}",
            o.stderr
        );
    }
}

#[test]
fn axes_override_the_profile() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = file(dir.path(), "x.isel", "71\n05000,900\n9\n");
    assert_eq!(run(&["check", &path]).code, ExitCode::from(1));
    let o = run(&["check", "--axes", "1", &path]);
    assert_eq!(o.code, ExitCode::SUCCESS, "{}", o.stdout);
    assert!(o.stderr.contains("axes X,"), "{}", o.stderr);
    let job = file(dir.path(), "z.emcu", "#E1,800\nL1,z5\n");
    let o = run(&["check", "--axes", "2", &job]);
    assert_eq!(o.code, ExitCode::from(1));
    assert!(
        o.stdout.contains("the machine has no axis Z"),
        "{}",
        o.stdout
    );
    let o = run(&["check", "--axes", "4", &job]);
    assert_eq!(o.code, ExitCode::from(2));
    assert!(
        o.stderr.contains("EMCU drives 3 axes at most"),
        "{}",
        o.stderr
    );
}

#[test]
fn unreadable_files_and_unknown_profiles_exit_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("missing.isel").display().to_string();
    let o = run(&["check", &missing]);
    assert_eq!(o.code, ExitCode::from(2));
    assert!(
        o.stderr
            .starts_with(&format!("jogterm check: cannot read {missing}: "))
    );
    assert_eq!(o.stdout, "");
    let o = run(&["check", &dir.path().display().to_string()]);
    assert_eq!(o.code, ExitCode::from(2), "a directory");
    let path = file(dir.path(), "p.isel", "9\n");
    let o = run(&["check", "--profile", "no-such-machine", &path]);
    assert_eq!(o.code, ExitCode::from(2));
    assert!(
        o.stderr.contains("no profile named `no-such-machine`"),
        "{}",
        o.stderr
    );
    // A broken user profile is reported with its file and line.
    let user = tempfile::tempdir().expect("tempdir");
    std::fs::create_dir(user.path().join("profiles")).expect("mkdir");
    std::fs::write(
        user.path().join("profiles/bad.toml"),
        "[axes.X]\nmin = \"low\"\n",
    )
    .expect("write");
    let dirs = ConfigDirs {
        user: Some(user.path().to_path_buf()),
    };
    let o = run_in(&["check", "--profile", "bad", &path], &dirs);
    assert_eq!(o.code, ExitCode::from(2));
    assert!(o.stderr.contains("bad.toml:2:"), "{}", o.stderr);
}

#[test]
fn bad_usage_is_refused_by_the_argument_parser() {
    for argv in [
        &["jogterm", "check"][..],
        &["jogterm", "check", "a.isel", "--axes", "5"],
        &["jogterm", "check", "a.isel", "--protocol", "modbus"],
        &["jogterm", "check", "a.isel", "--frobnicate"],
    ] {
        let e = Cli::try_parse_from(argv).expect_err("refused");
        assert_eq!(e.exit_code(), 2, "{argv:?}");
    }
}

#[test]
fn files_that_are_not_utf8_are_still_checked() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("latin1.isel");
    std::fs::write(&path, b"; Fr\xe4sen\n77\nm1\xe4,900,0,900,0,900,0,900\n9\n").expect("write");
    let o = run(&["check", &path.display().to_string()]);
    assert_eq!(o.code, ExitCode::from(1));
    assert_eq!(o.stdout.lines().count(), 1, "{}", o.stdout);
    assert!(
        o.stdout
            .contains(":3:3: error: unexpected character '\u{fffd}': commands are printable ASCII"),
        "{}",
        o.stdout
    );
}

#[test]
fn arguments_built_without_the_parser_are_checked_too() {
    let dir = tempfile::tempdir().expect("tempdir");
    let args = check::CheckArgs {
        file: dir.path().join("p.isel"),
        axes: Some(9),
        gcode: false,
        work_zero: None,
    };
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let global = jogterm::cli::GlobalArgs::default();
    let code = check::run_to(
        &global,
        &args,
        &ConfigDirs::builtin_only(),
        &mut out,
        &mut err,
    );
    assert_eq!(code.ok(), Some(ExitCode::from(2)));
    assert!(String::from_utf8_lossy(&err).contains("--axes 9"));
}

/// The real binary, with an empty user configuration directory.
fn jogterm(argv: &[&str], config: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_jogterm"))
        .args(argv)
        .env("JOGTERM_CONFIG_DIR", config)
        .output()
        .expect("the binary runs")
}

#[test]
fn the_binary_checks_files_end_to_end() {
    let dir = tempfile::tempdir().expect("tempdir");
    let broken = file(
        dir.path(),
        "broken.isel",
        "77\nM10,900,0,900,0,900,0,900\n0 1,900\n",
    );
    let o = jogterm(&["check", &broken], dir.path());
    assert_eq!(o.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(lines[0].starts_with(&format!("{broken}:2:1: warning: `M` is the spelling")));
    assert!(lines[1].starts_with(&format!("{broken}:3:1: error: `0` with XYZ takes 4")));
    assert!(lines[2].starts_with(&format!("{broken}:3:8: error: the program has no end")));
    assert_eq!(
        String::from_utf8_lossy(&o.stderr),
        format!(
            "{broken}: 2 errors, 1 warning in 3 commands (isel, axes XYZ, soft limits of `isel simulator`)\n"
        )
    );
    let clean = file(dir.path(), "clean.cnc", "77\n9\n");
    let o = jogterm(&["check", &clean, "--axes", "3"], dir.path());
    assert_eq!(o.status.code(), Some(0));
    assert!(o.stdout.is_empty());
    let o = jogterm(
        &["check", &dir.path().join("nope.isel").display().to_string()],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).starts_with("jogterm check: cannot read"));
    let o = jogterm(&["check"], dir.path());
    assert_eq!(o.status.code(), Some(2), "usage");
    let o = jogterm(&["check", &clean, "--profile", "no-such"], dir.path());
    assert_eq!(o.status.code(), Some(2));
}
