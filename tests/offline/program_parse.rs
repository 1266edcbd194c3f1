//! Parsing programs: every command example of the isel manual's chapter 3
//! (with the corrections of `docs/decisions.md` isel 11) and of the EMCU
//! manual, comments and blank lines, spans, and the map between source lines
//! and the controller's command indices.

use jogterm::axis::AxisSet;
use jogterm::program::{Command, Item, Language, LineKind, LintConfig, Program, Rule, Span, lint};
use jogterm::proto::emcu;
use jogterm::proto::isel::{AxisConfig, CncCommand, MovePair, ReplyCode};

/// Every `Anwendung:` of chapter 3, with the axis configuration it is for.
/// "3 50" (3.2.6) is `550` and "133,-10" (3.2.4) is `233,-10` (decision 11).
const ISEL_EXAMPLES: &[(&str, AxisConfig)] = &[
    ("05000,900", AxisConfig::X),
    ("050,900,20,9000", AxisConfig::XY),
    ("030,800,10,900,4,90,-4,30", AxisConfig::XYZ),
    ("030,800,10,900,4,90,-4,30", AxisConfig::XYZA),
    ("133", AxisConfig::XYZ),
    ("233,-10", AxisConfig::XYZ),
    ("3 25,-1", AxisConfig::XYZ),
    ("3 0,-5", AxisConfig::XYZ),
    ("3 0,5", AxisConfig::XYZ),
    ("3 6,-5", AxisConfig::XYZ),
    ("550", AxisConfig::XYZ),
    ("60,128,1", AxisConfig::XYZ),
    ("60,1,0", AxisConfig::XYZ),
    ("77", AxisConfig::XYZ),
    ("78", AxisConfig::XYZA),
    ("9", AxisConfig::XYZ),
    ("d2500,1000,1200,800", AxisConfig::XYZA),
    ("e1", AxisConfig::XYZ),
    ("e0", AxisConfig::XYZ),
    ("f-1", AxisConfig::XYZ),
    ("f0", AxisConfig::XYZ),
    ("g1", AxisConfig::XYZ),
    ("j300", AxisConfig::XYZ),
    ("J100", AxisConfig::XYZ),
    ("m5000,900", AxisConfig::X),
    ("m50,900,20,9000", AxisConfig::XY),
    ("m30,800,10,900,4,90,0,30", AxisConfig::XYZ),
    ("m30,800,10,900,4,90,4,30", AxisConfig::XYZA),
    ("n7", AxisConfig::XYZ),
    ("n1", AxisConfig::XYZ),
    ("n8", AxisConfig::XYZA),
    ("N7", AxisConfig::XYZ),
    ("N1", AxisConfig::XYZ),
    ("N8", AxisConfig::XYZA),
    ("o0,128,1,-1", AxisConfig::XYZ),
    ("o0,0,1,-1", AxisConfig::XYZ),
    ("o0,0,1,3", AxisConfig::XYZ),
    ("p0,128,1", AxisConfig::XYZ),
    ("p0,0,1", AxisConfig::XYZ),
    ("T1", AxisConfig::XYZ),
    ("T0", AxisConfig::XYZ),
    ("w32000,600,-1000,-2000,0,1,-1,6000", AxisConfig::XYZ),
    ("y400,1500,119,-141,141,-1,-1", AxisConfig::XYZ),
    ("z1", AxisConfig::XYZ),
    ("z0", AxisConfig::XYZ),
];

/// The rules a single line can break on its own.
const LINE_RULES: &[Rule] = &[
    Rule::Syntax,
    Rule::NotStorable,
    Rule::ParameterCount,
    Rule::NumberRange,
    Rule::Speed,
    Rule::Axis,
    Rule::ForwardLoop,
];

#[test]
fn every_isel_chapter_3_example_parses_and_passes_the_line_checks() {
    for (line, axes) in ISEL_EXAMPLES {
        let program = Program::parse(Language::Isel, line);
        let statement = program.lines()[0].statement().expect("a statement");
        assert!(statement.command.is_ok(), "{line}: {:?}", statement.command);
        let problems: Vec<_> = lint(&program, &LintConfig::new(axes.axes()))
            .into_iter()
            .filter(|d| LINE_RULES.contains(&d.rule))
            .collect();
        assert!(problems.is_empty(), "{line} with {axes}: {problems:?}");
    }
}

#[test]
fn the_manuals_typos_are_not_what_they_meant() {
    // As printed, "3 50" is a `3` with one parameter and "133,-10" a `1`
    // with two: the controller refuses both with `7`.
    let program = Program::parse(Language::Isel, "3 50\n133,-10\n");
    let replies: Vec<_> = program
        .statements()
        .map(|(_, s)| s.command.as_ref().err().and_then(|e| e.reply))
        .collect();
    assert_eq!(
        replies,
        [
            Some(ReplyCode::ParameterCount),
            Some(ReplyCode::ParameterCount)
        ]
    );
}

const EMCU_EXAMPLES: &[&str] = &[
    "@R",
    "@V",
    "@X",
    "@LX",
    "@LY",
    "#S150",
    "#E1,800",
    "#R400",
    "$HZXY",
    "$HY",
    "L1,X200,Y500",
    "L1,x500,y1000",
    "L1,X0,Y0,Z0",
    "L1,x15,y25,z35",
    "L1,x-50,y-100",
    "@B",
    "@S",
    "@A",
    "@C",
    "A1,1",
    "A1,0",
    "A2,1",
    "A2,0",
    "W250",
    "@F",
    "@J",
    "&V0",
    "&V1",
];

#[test]
fn every_emcu_example_parses_and_masters_are_flagged_in_a_job() {
    for line in EMCU_EXAMPLES {
        let program = Program::parse(Language::Emcu, line);
        let statement = program.lines()[0].statement().expect("a statement");
        let command = match &statement.command {
            Ok(Command::Emcu(c)) => *c,
            other => panic!("{line}: {other:?}"),
        };
        assert_eq!(command.to_string(), *line);
        let diagnostics = lint(&program, &LintConfig::new(AxisSet::XYZ));
        let flagged = diagnostics.iter().any(|d| d.rule == Rule::MasterCommand);
        assert_eq!(flagged, command.is_master(), "{line}: {diagnostics:?}");
        assert!(
            diagnostics.iter().all(|d| d.rule != Rule::Syntax),
            "{line}: {diagnostics:?}"
        );
    }
}

#[test]
fn emcu_comments_cannot_swallow_hash_commands() {
    let text = "# setup\n#S150 ; slow start\n#E1,800\n#\n;#R400\n  #R400\n";
    let program = Program::parse(Language::Emcu, text);
    let kinds: Vec<&LineKind> = program.lines().iter().map(|l| l.kind()).collect();
    assert!(matches!(kinds[0], LineKind::Comment(_)));
    assert!(matches!(kinds[3], LineKind::Comment(_)));
    assert!(matches!(kinds[4], LineKind::Comment(_)));
    let commands: Vec<String> = program
        .statements()
        .map(|(_, s)| {
            s.command
                .as_ref()
                .map(|c| c.to_string())
                .unwrap_or_default()
        })
        .collect();
    assert_eq!(commands, ["#S150", "#E1,800", "#R400"]);
    assert_eq!(
        program.upload_lines().map_err(|(span, _)| span),
        Ok(vec!["#S150".to_string(), "#E1,800".into(), "#R400".into()])
    );
}

#[test]
fn commands_map_to_lines_and_back_around_comments_and_blanks() {
    let text = "; drill pattern\n\n7 7\n  m100,900,0,900,0,900,0,900 ; start\n# two rows\n\
                0 50,900,0,900,0,900,0,900\n3 3,-1\n\n9\n";
    let program = Program::parse(Language::Isel, text);
    assert_eq!(program.command_count(), 5);
    let lines: Vec<Option<usize>> = (0..6).map(|i| program.line_of(i)).collect();
    assert_eq!(lines, [Some(2), Some(3), Some(5), Some(6), Some(8), None]);
    let indices: Vec<Option<usize>> = (0..10).map(|l| program.index_of(l)).collect();
    assert_eq!(
        indices,
        [
            None,
            None,
            Some(0),
            Some(1),
            None,
            Some(2),
            Some(3),
            None,
            Some(4),
            None
        ]
    );
    // An error the controller reports while storing command 3 is about line 7.
    assert_eq!(program.span_of(3), Some(Span::new(6, 0..6)));
    assert_eq!(
        program.upload_lines().map_err(|(span, _)| span),
        Ok(vec![
            "77".to_string(),
            "m100,900,0,900,0,900,0,900".into(),
            "050,900,0,900,0,900,0,900".into(),
            "33,-1".into(),
            "9".into()
        ])
    );
}

#[test]
fn spans_cover_commands_parameters_and_comments() {
    let program = Program::parse(Language::Isel, "  3 25,-1  ; again\n");
    let statement = program.lines()[0].statement().expect("a statement");
    assert_eq!(statement.code, 2..9);
    assert_eq!(statement.params, vec![4..6, 7..9]);
    assert_eq!(statement.comment, Some(11..18));
    let program = Program::parse(Language::Emcu, "\tL1,x500,y1000;go\n");
    let statement = program.lines()[0].statement().expect("a statement");
    assert_eq!(statement.code, 1..14);
    assert_eq!(statement.params, vec![2..3, 4..8, 9..14]);
    assert_eq!(statement.comment, Some(14..17));
}

#[test]
fn errors_point_into_the_line_and_carry_the_reply_code() {
    let program = Program::parse(Language::Isel, "  m100,9x0\n#no blank\n@0P\n");
    let errors: Vec<_> = program
        .statements()
        .map(|(line, s)| {
            let e = s.command.clone().expect_err("an error");
            (line, e.cols, e.reply)
        })
        .collect();
    assert_eq!(
        errors,
        [
            (0, 7..10, Some(ReplyCode::BadNumber)),
            (1, 0..1, Some(ReplyCode::Syntax)),
            (2, 0..3, Some(ReplyCode::NotStorable)),
        ]
    );
    let message = &program.lines()[1]
        .statement()
        .and_then(|s| s.command.clone().err());
    assert!(
        message
            .as_ref()
            .is_some_and(|e| e.message.contains("`#` and a blank"))
    );
}

#[test]
fn editing_lines_reparses_only_them_and_renumbers() {
    let mut program = Program::parse(
        Language::Isel,
        "77\n; comment\n0 10,900,0,900,0,900,0,900\n9\n",
    );
    let untouched = program.lines()[2].clone();
    program.replace_lines(1..2, "f0\ny400,1500,119,-141,141,-1,-1");
    assert_eq!(program.lines().len(), 5);
    // The line after the edit keeps its text and command, with a new index.
    assert_eq!(program.lines()[3].text(), untouched.text());
    assert_eq!(
        program.lines()[3].statement().map(|s| &s.command),
        untouched.statement().map(|s| &s.command)
    );
    assert_eq!(program.index_of(3), Some(3));
    assert_eq!(program.line_of(4), Some(4));
    assert_eq!(
        program,
        Program::parse(
            Language::Isel,
            "77\nf0\ny400,1500,119,-141,141,-1,-1\n0 10,900,0,900,0,900,0,900\n9\n"
        )
    );
    // Ranges past the end are clamped; an empty text deletes.
    program.replace_lines(3..99, "");
    assert_eq!(program.command_count(), 3);
}

#[test]
fn items_ignore_positions_and_spellings() {
    let a = Program::parse(Language::Isel, "  M30,800 ;x\n\n# c\n");
    let b = Program::parse(Language::Isel, "m30,800 ;x\n\n# c");
    assert_eq!(a.items(), b.items());
    let m = CncCommand::MoveAbsolute(vec![MovePair::new(30, 800)]);
    assert_eq!(
        a.items()[0],
        Item::Command {
            command: Ok(&Command::Isel(m)),
            comment: Some(";x")
        }
    );
    let job = Program::parse(Language::Emcu, "#S0150");
    assert_eq!(
        job.statements().next().map(|(_, s)| s.command.clone()),
        Some(Ok(Command::Emcu(emcu::Command::StartSpeed(
            emcu::Speed::new(150).expect("a speed")
        ))))
    );
}

#[test]
fn jump_targets_for_an_editor() {
    // The manual's examples (3.2.5) at command 5 of a longer program.
    let program = Program::parse(
        Language::Isel,
        "55\n55\n55\n55\n55\n3 25,-1\n3 0,-5\n3 0,5\n3 6,-5\n55\n55\n55\n55\n9\n",
    );
    let targets: Vec<Option<usize>> = (5..9).map(|i| program.jump_target(i)).collect();
    assert_eq!(targets, [Some(4), Some(1), Some(12), Some(3)]);
    assert_eq!(program.jump_target(0), None);
    let outside = Program::parse(Language::Isel, "3 0,-1\n9\n");
    assert_eq!(outside.jump_target(0), None);
    let text = "; c\r\n  77 ;x\n\n9";
    assert_eq!(
        Program::parse(Language::Isel, text).text(),
        "; c\n  77 ;x\n\n9\n"
    );
}
