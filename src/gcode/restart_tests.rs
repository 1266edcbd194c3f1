//! Restarts on small jobs: the modal state the skipped lines leave, the
//! entry's order and heights, the origins, the errors; and over every line
//! of the example files, that a restart ends where the whole job ends.

use super::*;
use crate::axis::Axis;
use crate::config::{ConfigDirs, load_profile};
use crate::gcode::import::import;
use crate::gcode::modal::Spindle;
use crate::gcode::profile::setup_of;
use crate::gcode::setup::Units;
use crate::gcode::toolpath::Plane;
use crate::offsets::System;
use crate::program::path::{Start, path};
use crate::program::{Language, Program as ControllerProgram};

/// The isel profile with a spindle and a coolant output.
fn profile() -> Profile {
    load_profile("isel-rewired", &ConfigDirs::builtin_only()).expect("the isel-rewired profile")
}

/// G54's zero at machine X100 Y100 Z40 mm, G55's at X150 Y100 Z40.
fn offsets(profile: &Profile) -> WorkOffsets {
    let mut o = WorkOffsets::default();
    for (system, x) in [(System::ALL[0], 100.0), (System::ALL[1], 150.0)] {
        for (axis, mm) in [(Axis::X, x), (Axis::Y, 100.0), (Axis::Z, 40.0)] {
            let steps = profile.axis(axis).map_or(0, |p| p.to_steps(mm));
            o.set(system, axis, steps);
        }
    }
    o
}

fn imported(text: &str, profile: &Profile, target: Target) -> Import {
    import(text, "job.nc", profile, &offsets(profile), target)
        .unwrap_or_else(|e| panic!("{text}: {e:?}"))
}

fn restart_at(text: &str, line: u32) -> Result<Restart, RestartError> {
    let profile = profile();
    let job = imported(text, &profile, Target::Isel);
    restart(text, "job.nc", &profile, &offsets(&profile), &job, line)
}

const JOB: &str = "\
G21 G90 G17
G54
S12000 M3
M8
G0 X0 Y0 Z10
G0 Z2
G1 Z-1 F300
G1 X20 F800
G1 Y20
G0 Z10
G0 X40 Y0
G1 Z-1 F300
G3 X50 Y10 I10 J0 F500
(a comment)
G1 X60
M5 M9
M30
";

#[test]
fn the_modal_state_is_what_the_skipped_lines_leave() {
    let setup = setup_of(&profile(), &offsets(&profile())).expect("setup");
    let table: &[(&str, u32, &str)] = &[
        ("G21\nG0 X1\n", 2, "G21 mm"),
        ("G20\nG0 X1\n", 2, "G20 inch"),
        ("G21\nG18\nG0 X1\n", 3, "G18 ZX"),
        ("G21\nG19\nG17\nG0 X1\n", 4, "G17 XY"),
        ("G21 G91\nG0 X1\n", 2, "G91"),
        ("G21\nG55\nG0 X1\n", 3, "G55"),
        ("G21\nG55\nG54\nG0 X1\n", 4, "G54"),
        ("G21\nF800\nG0 X1\n", 3, "F800"),
        ("G20\nF10\nG0 X1\n", 3, "F10"),
        ("G21\nS12000 M3\nG0 X1\n", 3, "spindle M3 S12000"),
        ("G21\nS12000 M3\nM5\nG0 X1\n", 4, "spindle M5 S12000"),
        ("G21\nM4\nG0 X1\n", 3, "spindle M4"),
        ("G21\nM8\nG0 X1\n", 3, "coolant M8"),
        ("G21\nM8\nM9\nG0 X1\n", 4, "coolant M9"),
        ("G21\nT3 M6\nG0 X1\n", 3, "T3"),
        // Line 2's own words are not yet in force before it.
        ("G21\nG20 F10 M8\n", 2, "G21 mm"),
        ("G21\nG20 F10 M8\n", 2, "coolant M9"),
    ];
    for (text, line, word) in table {
        let modal = modal_before(text, &setup, *line);
        assert!(
            modal.words().iter().any(|w| w == word),
            "{text:?} before line {line}: {:?}, not {word}",
            modal.words()
        );
    }
    let modal = modal_before(JOB, &setup, 9);
    assert_eq!(
        modal.text(),
        "G21 mm, G17 XY, G90, G54, F800, spindle M3 S12000, coolant M8"
    );
    assert_eq!(
        (modal.units, modal.plane, modal.spindle, modal.feed),
        (Some(Units::Mm), Plane::Xy, Spindle::Clockwise, Some(800.0))
    );
}

#[test]
fn the_entry_retracts_goes_above_the_start_switches_the_outputs_and_descends_at_feed() {
    let r = restart_at(JOB, 9).expect("restart");
    assert_eq!((r.requested, r.line), (9, 9));
    assert_eq!((r.skipped_lines, r.remaining_lines), (8, 9));
    // Machine mm: G54's zero at X100 Y100 Z40; line 9 starts at X20 Y0 Z-1.
    let start = Point {
        x: 120.0,
        y: 100.0,
        z: 39.0,
    };
    assert_eq!(r.start, start);
    assert_eq!(r.safe_z, 50.0);
    let kinds: Vec<String> = r
        .entry
        .iter()
        .map(|op| match op {
            Op::WorkOffset { system, .. } => format!("offset {system}"),
            Op::Rapid(m) => format!("G0 {} {} {}", m.to.x, m.to.y, m.to.z),
            Op::Line(m) => format!("G1 {} {} {} F{}", m.to.x, m.to.y, m.to.z, m.feed),
            Op::SpindleSpeed { rpm, .. } => format!("S{rpm}"),
            Op::Output(o) => format!("{} {}", o.name, o.on),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "offset G54",
            // From the reference point (the program's `77`): straight up.
            "G0 0 0 50",
            "G0 120 100 50",
            "S12000",
            "spindle true",
            "coolant true",
            // At the plunge feed of line 7, not the cut's F800 in force.
            "G1 120 100 39 F300",
        ]
    );
    assert!(
        r.entry.iter().all(|op| origin_of(op)
            == Origin {
                line: 9,
                col: ENTRY_COL
            }),
        "{:?}",
        r.entry
    );
    assert_eq!(
        r.entry_text(false),
        [
            "reference run of Z, then Y, then X (gcode.reference_first): the program's moves count from the reference point",
            "G0 Z10.000 (the job's safe height) from the reference point, Z alone",
            "G0 X20.000 Y0.000 at the safe height, above line 9's start",
            "spindle speed S12000",
            "spindle on",
            "coolant on",
            "descend: G1 Z-1.000 F300 to line 9's start (the file's last plunge feed, line 7)",
        ]
    );
    // `jogterm run` moves the tool up itself first.
    assert!(
        r.entry_text(true)[0].starts_with(
            "retract: Z alone up to Z10.000 (the job's safe height), from wherever the tool stands"
        ),
        "{:?}",
        r.entry_text(true)
    );
    // The program: header, the restart's mark, 77, z1, retract, rapid,
    // outputs, descent, then line 9 on; every command names a G-code line.
    let commands: Vec<(&str, Option<Origin>)> = r
        .program
        .lines
        .iter()
        .filter(|l| !l.command.is_empty())
        .map(|l| (l.command.as_str(), l.origin))
        .collect();
    let kinds: Vec<char> = commands
        .iter()
        .map(|(c, _)| c.chars().next().unwrap_or(' '))
        .collect();
    assert_eq!(
        &kinds[..8],
        ['7', 'z', 'm', 'm', 'p', 'p', 'm', 'm'],
        "{commands:?}"
    );
    assert_eq!(commands[2].0, "m0,6000,0,6000,20000,6000,0,6000");
    assert!(commands[2..].iter().all(|(_, o)| o.is_some()));
    let own = &r.program.lines[r.cut];
    assert_eq!(own.origin.map(|o| o.line), Some(9));
    assert_ne!(own.origin.map(|o| o.col), Some(ENTRY_COL));
    assert_eq!(own.command, "m48000,5333,48000,5333,15600,5333,0,5333");
    assert!(
        r.program
            .text("job.nc")
            .contains("; jogterm-gcode restart=line 9\n")
    );
    // A chunked run may cut it where the tool is retracted: after the
    // entry's retract, and after line 10's.
    assert!(r.program.parts(2000).is_ok());
}

#[test]
fn a_line_without_commands_restarts_at_the_next_one_with_its_words_applied() {
    let r = restart_at(JOB, 14).expect("restart");
    assert_eq!((r.requested, r.line), (14, 15));
    assert!(
        r.notes[0].contains("line 14 converts to no command"),
        "{:?}",
        r.notes
    );
}

#[test]
fn an_arc_runs_whole_from_its_start() {
    let r = restart_at(JOB, 13).expect("restart");
    assert_eq!(r.start.x, 140.0);
    assert!(r.notes[0].contains("line 13 is an arc"), "{:?}", r.notes);
}

#[test]
fn a_tool_change_among_the_skipped_lines_is_said() {
    let text = JOB.replace("M8\n", "M8\nT2 M6\n");
    let r = restart_at(&text, 10).expect("restart");
    assert_eq!(
        r.notes,
        ["the skipped lines change to tool T2 (line 5): that tool must be in the spindle"]
    );
    assert!(r.modal.text().ends_with("T2"), "{}", r.modal.text());
}

#[test]
fn lines_that_cannot_be_restarted_say_why() {
    let error = |text: &str, line| match restart_at(text, line) {
        Ok(r) => panic!("line {line} restarted: {:?}", r.entry),
        Err(e) => (e.clone(), e.to_string()),
    };
    let (e, text) = error(JOB, 40);
    assert_eq!(
        e,
        RestartError::BeyondFile {
            line: 40,
            lines: 17
        }
    );
    assert_eq!(text, "line 40 is not in the file: it has lines 1 to 17");
    assert!(matches!(error(JOB, 0).0, RestartError::BeyondFile { .. }));
    let (e, text) = error(JOB, 3);
    assert_eq!(e, RestartError::BeforeFirstMove { line: 3, first: 5 });
    assert!(text.contains("run the whole job"), "{text}");
    assert!(matches!(
        error(JOB, 5).0,
        RestartError::BeforeFirstMove { .. }
    ));
    assert_eq!(error(JOB, 16).0, RestartError::NothingLeft { line: 16 });
    let paused = JOB.replace("(a comment)", "M0");
    let (e, text) = error(&paused, 14);
    assert_eq!(
        e,
        RestartError::Pause {
            line: 14,
            what: "M0".into()
        }
    );
    assert!(text.contains("line 14 is a pause (M0)"), "{text}");
}

#[test]
fn the_work_offset_of_the_skipped_lines_is_the_one_entered_in() {
    let text = JOB.replace("G0 X40 Y0", "G55\nG0 X40 Y0");
    let r = restart_at(&text, 13).expect("restart");
    assert!(r.modal.text().contains("G55"), "{}", r.modal.text());
    // G55's zero is at machine X150: line 13 starts at work X40.
    assert_eq!(r.start.x, 190.0);
    assert_eq!(r.zero.x, 150.0);
}

fn example(name: &str) -> String {
    let path = format!("{}/examples/gcode/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Where an isel program ends, in steps, as the program preview runs it.
fn end_of_program(program: &Program, profile: &Profile) -> Vec<i64> {
    let text = program.text("job.nc");
    let parsed = ControllerProgram::parse(Language::Isel, &text);
    path(&parsed, &Start::new(profile.axis_set(), [0; 4])).end[..3].to_vec()
}

/// The last `L` of an EMCU job, in steps.
fn end_of_job(program: &Program) -> Vec<i64> {
    let last = program
        .lines
        .iter()
        .rev()
        .find(|l| l.command.starts_with('L'))
        .expect("a move");
    last.command
        .split(',')
        .skip(1)
        .map(|w| w[1..].parse().expect("steps"))
        .collect()
}

/// The EMCU profile with the spindle on output A1, as the bench maps it
/// (the profile gives no output the spindle role).
fn emcu_profile() -> Profile {
    let mut p = load_profile("emcu", &ConfigDirs::builtin_only()).expect("the emcu profile");
    for m in ["m3", "m5"] {
        p.gcode.codes.insert(m.into(), "output:A1".into());
    }
    p
}

#[test]
fn a_restart_at_any_line_ends_where_the_whole_job_ends() {
    let without_reference = {
        let mut p = profile();
        p.gcode.reference_first = false;
        p
    };
    for name in [
        "fusion-grbl.nc",
        "estlcam.nc",
        "freecad-path.ngc",
        "linuxcnc-inch.ngc",
    ] {
        let text = example(name);
        for (target, profile) in [
            (Target::Isel, profile()),
            (Target::Isel, without_reference.clone()),
            (Target::Emcu, emcu_profile()),
        ] {
            let whole = imported(&text, &profile, target);
            let end = |p: &Program| match target {
                Target::Isel => end_of_program(p, &profile),
                Target::Emcu => end_of_job(p),
            };
            let expected = end(&whole.program);
            let mut restarted = 0;
            for line in 1..=whole.toolpath.lines {
                let r = match restart(&text, name, &profile, &offsets(&profile), &whole, line) {
                    Ok(r) => r,
                    Err(
                        RestartError::BeforeFirstMove { .. }
                        | RestartError::NothingLeft { .. }
                        | RestartError::Pause { .. },
                    ) => continue,
                    Err(e) => panic!("{name}:{line}: {e}"),
                };
                restarted += 1;
                assert_eq!(end(&r.program), expected, "{name} from line {line}");
                // The entry's retract reaches the safe height first.
                let first_move = r.program.lines[..r.cut]
                    .iter()
                    .find(|l| l.command.starts_with(['m', 'L']))
                    .expect("the retract");
                assert_eq!(first_move.origin.map(|o| o.col), Some(ENTRY_COL));
                let z_steps = profile.axis(Axis::Z).map(|p| p.to_steps(r.safe_z));
                let z_word = match target {
                    Target::Isel => first_move.command.split(',').nth(4),
                    Target::Emcu => first_move.command.split(",Z").nth(1),
                };
                assert_eq!(
                    z_word.and_then(|z| z.parse().ok()),
                    z_steps,
                    "{name}:{line}: {}",
                    first_move.command
                );
            }
            assert!(restarted > 5, "{name}: {restarted} restarts");
        }
    }
}

#[test]
fn an_inch_file_is_confirmed_in_inches() {
    let text = example("linuxcnc-inch.ngc");
    let profile = profile();
    let job = imported(&text, &profile, Target::Isel);
    let r = restart(&text, "i.ngc", &profile, &offsets(&profile), &job, 12).expect("restart");
    assert_eq!(
        r.modal.text(),
        "G20 inch, G18 ZX, G90, G54, F60, spindle M5, coolant M9"
    );
    assert_eq!(
        r.entry_text(false),
        [
            "reference run of Z, then Y, then X (gcode.reference_first): the program's moves count from the reference point",
            "G0 Z0.5000 (the job's safe height) from the reference point, Z alone",
            "G0 X0.6000 Y0.8000 at the safe height, above line 12's start",
            "descend: G1 Z0.3000 F60 to line 12's start (the file's last plunge feed, line 6)",
        ]
    );
}

#[test]
fn a_file_that_plunges_nowhere_before_the_line_descends_at_the_profiles_plunge_feed() {
    // The only way down is a ramp in X, Y and Z at once: no plunge.
    let text = "G21 G90 G17\nG0 X0 Y0 Z10\nG1 X10 Y10 Z-1 F800\nG1 X20\nG1 X30\nM30\n";
    let r = restart_at(text, 5).expect("restart");
    assert_eq!(
        (r.descent_feed, r.plunge_line),
        (crate::config::profile::DEFAULT_PLUNGE_FEED, None)
    );
    let last = r.entry_text(true).pop().unwrap_or_default();
    assert!(
        last.starts_with("descend: G1 Z-1.000 F300 to line 5's start (the profile's plunge feed"),
        "{last}"
    );
}
