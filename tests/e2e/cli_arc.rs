//! `jogterm arc` through its clap arguments and `run_to`: the manual's
//! circle example (2.3.6), CNC lines, helices, and clear errors.

use std::process::ExitCode;

use clap::Parser;
use jogterm::cli::{Cli, CliCommand, arc};

fn parse(argv: &[&str]) -> Result<arc::ArcArgs, clap::Error> {
    Cli::try_parse_from(std::iter::once("jogterm").chain(argv.iter().copied())).map(|cli| match cli
        .command
    {
        Some(CliCommand::Arc(args)) => args,
        other => panic!("{argv:?}: {other:?}"),
    })
}

fn run(argv: &[&str]) -> (ExitCode, String, String) {
    let args = parse(argv).unwrap_or_else(|e| panic!("{argv:?}: {e}"));
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let code = arc::run_to(&args, &mut out, &mut err).expect("writes to memory");
    (
        code,
        String::from_utf8(out).expect("utf-8"),
        String::from_utf8(err).expect("utf-8"),
    )
}

const EXAMPLE: &[&str] = &[
    "arc", "--radius", "200", "--start", "135", "--end", "225", "--ccw", "--speed", "1500",
];

#[test]
fn the_manuals_circle_example() {
    let (code, out, err) = run(EXAMPLE);
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(out, "@0f-1\n@0y400,1500,119,-141,141,-1,-1\n");
    assert!(
        err.contains("the arc ends 0,-282 steps from its start"),
        "{err}"
    );
}

#[test]
fn stored_program_lines_with_cnc() {
    let argv: Vec<&str> = EXAMPLE.iter().copied().chain(["--cnc"]).collect();
    let (code, out, _) = run(&argv);
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(out, "f-1\ny400,1500,119,-141,141,-1,-1\n");
}

#[test]
fn helices_clockwise_negative_angles_and_other_devices() {
    let (code, out, err) = run(&[
        "arc",
        "--radius",
        "2000",
        "--start",
        "-180",
        "--end",
        "180",
        "--cw",
        "--speed",
        "600",
        "--helix-steps",
        "-6000",
        "--device",
        "3",
    ]);
    assert_eq!(code, ExitCode::SUCCESS);
    // A full circle from 180°: B = 8 R, start (-2000, 0).
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[0], "@3f0");
    assert!(lines[1].starts_with("@3w16000,600,"), "{out}");
    assert!(lines[1].ends_with(",-2000,0,1,1,-6000"), "{out}");
    assert!(err.contains("-6000 along the third axis"), "{err}");
}

#[test]
fn values_that_describe_no_arc_exit_2_with_a_clear_message() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "arc", "--radius", "0", "--start", "0", "--end", "90", "--cw", "--speed", "100",
            ],
            "jogterm arc: the radius must be at least 1 step\n",
        ),
        (
            &[
                "arc", "--radius", "10", "--start", "0", "--end", "90", "--cw", "--speed", "0",
            ],
            "jogterm arc: the speed must be 1-40000 Hz, got 0\n",
        ),
        (
            &[
                "arc", "--radius", "10", "--start", "0", "--end", "90", "--cw", "--speed", "40001",
            ],
            "jogterm arc: the speed must be 1-40000 Hz, got 40001\n",
        ),
        (
            &[
                "arc", "--radius", "1", "--start", "0", "--end", "0.001", "--ccw", "--speed", "10",
            ],
            "jogterm arc: the arc is shorter than one step (B rounds to 0)\n",
        ),
        (
            &[
                "arc", "--radius", "9000000", "--start", "0", "--end", "90", "--ccw", "--speed",
                "10",
            ],
            "jogterm arc: the radius must be at most 8388607 steps (24-bit start point), got 9000000\n",
        ),
        (
            &[
                "arc", "--radius", "10", "--start", "NaN", "--end", "90", "--ccw", "--speed", "10",
            ],
            "jogterm arc: the start angle must be a finite number of degrees, got NaN\n",
        ),
        (
            &[
                "arc",
                "--radius",
                "10",
                "--start",
                "0",
                "--end",
                "90",
                "--ccw",
                "--speed",
                "10",
                "--helix-steps",
                "9000000",
            ],
            "jogterm arc: the third axis' steps must be 24-bit, got 9000000\n",
        ),
    ];
    for (argv, message) in cases {
        let (code, out, err) = run(argv);
        assert_eq!(code, ExitCode::from(2), "{argv:?}");
        assert_eq!(out, "", "{argv:?}");
        assert_eq!(err, *message, "{argv:?}");
    }
}

#[test]
fn bad_usage_is_refused_by_the_argument_parser() {
    for argv in [
        &[
            "arc", "--radius", "10", "--start", "0", "--end", "90", "--speed", "10",
        ][..],
        &[
            "arc", "--radius", "10", "--start", "0", "--end", "90", "--cw", "--ccw", "--speed", "1",
        ],
        &[
            "arc", "--radius", "-10", "--start", "0", "--end", "90", "--cw", "--speed", "10",
        ],
        &[
            "arc", "--radius", "10", "--start", "x", "--end", "90", "--cw", "--speed", "10",
        ],
        &[
            "arc", "--radius", "10", "--start", "0", "--end", "90", "--cw",
        ],
        &[
            "arc", "--radius", "10", "--start", "0", "--end", "9", "--cw", "--speed", "1",
            "--device", "10",
        ],
    ] {
        let e = parse(argv)
            .err()
            .unwrap_or_else(|| panic!("{argv:?} accepted"));
        assert_eq!(e.exit_code(), 2, "{argv:?}");
    }
}

#[test]
fn arguments_built_without_the_parser_are_checked_too() {
    let mut args = parse(EXAMPLE).expect("the example parses");
    args.device = 12;
    let (mut out, mut err) = (Vec::new(), Vec::new());
    let code = arc::run_to(&args, &mut out, &mut err).expect("writes to memory");
    assert_eq!(code, ExitCode::from(2));
    assert_eq!(
        String::from_utf8_lossy(&err),
        "jogterm arc: the device number is 0-9, got 12\n"
    );
    assert!(out.is_empty());
}

#[test]
fn the_binary_prints_the_manuals_example() {
    let run = |argv: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_jogterm"))
            .args(argv)
            .output()
            .expect("the binary runs")
    };
    let o = run(EXAMPLE);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        "@0f-1\n@0y400,1500,119,-141,141,-1,-1\n"
    );
    let o = run(&[
        "arc", "--radius", "0", "--start", "0", "--end", "90", "--cw", "--speed", "10",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        String::from_utf8_lossy(&o.stderr),
        "jogterm arc: the radius must be at least 1 step\n"
    );
    let o = run(&[
        "arc", "--radius", "10", "--start", "0", "--end", "90", "--speed", "10",
    ]);
    assert_eq!(o.status.code(), Some(2), "no direction");
}
