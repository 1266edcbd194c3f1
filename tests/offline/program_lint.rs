//! One test per diagnostic: it fires where it should, nowhere else in that
//! program, and not in a program that differs only where it matters.

use jogterm::axis::AxisSet;
use jogterm::program::{
    AxisLimit, Diagnostic, Fix, Language, LintConfig, Program, Rule, Severity, Span, lint,
};

/// XYZ, soft limits 0..=10000 steps on each axis, 20000 Hz at most, start
/// position unknown.
fn machine() -> LintConfig {
    let mut config = LintConfig::new(AxisSet::XYZ);
    for slot in config.limits.iter_mut().take(3) {
        *slot = Some(AxisLimit {
            max_speed_hz: Some(20000.0),
            ..AxisLimit::steps(0, 10000)
        });
    }
    config
}

fn lint_with(language: Language, text: &str, config: &LintConfig) -> Vec<Diagnostic> {
    lint(&Program::parse(language, text), config)
}

/// The 0-based lines where `rule` fires.
fn lines(diagnostics: &[Diagnostic], rule: Rule) -> Vec<usize> {
    diagnostics
        .iter()
        .filter(|d| d.rule == rule)
        .map(|d| d.span.line)
        .collect()
}

/// `rule` fires exactly at `at` (with `severity`) in `firing` and nowhere in
/// `clean`; returns the firing diagnostics.
#[track_caller]
fn check(
    language: Language,
    config: &LintConfig,
    rule: Rule,
    severity: Severity,
    firing: &str,
    at: &[usize],
    clean: &str,
) -> Vec<Diagnostic> {
    let fired = lint_with(language, firing, config);
    assert_eq!(lines(&fired, rule), at, "{rule} in {firing:?}: {fired:#?}");
    for d in fired.iter().filter(|d| d.rule == rule) {
        assert_eq!(d.severity, severity, "{d:?}");
    }
    let calm = lint_with(language, clean, config);
    assert!(
        lines(&calm, rule).is_empty(),
        "{rule} in {clean:?}: {calm:#?}"
    );
    fired
}

#[track_caller]
fn isel_error(rule: Rule, firing: &str, at: &[usize], clean: &str) -> Vec<Diagnostic> {
    check(
        Language::Isel,
        &machine(),
        rule,
        Severity::Error,
        firing,
        at,
        clean,
    )
}

#[track_caller]
fn isel_warning(rule: Rule, firing: &str, at: &[usize], clean: &str) -> Vec<Diagnostic> {
    check(
        Language::Isel,
        &machine(),
        rule,
        Severity::Warning,
        firing,
        at,
        clean,
    )
}

fn the(diagnostics: &[Diagnostic], rule: Rule) -> Diagnostic {
    diagnostics
        .iter()
        .find(|d| d.rule == rule)
        .cloned()
        .unwrap_or_else(|| panic!("no {rule} in {diagnostics:#?}"))
}

/// The text with a fix applied.
fn apply(text: &str, fix: &Fix) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let line = &mut lines[fix.span.line];
    line.replace_range(fix.span.cols(), &fix.replacement);
    lines.join("\n")
}

#[test]
fn syntax() {
    let d = isel_error(Rule::Syntax, "77\n%5\n9\n", &[1], "77\n55\n9\n");
    assert!(the(&d, Rule::Syntax).message.contains("answers `5`"));
}

#[test]
fn not_storable() {
    isel_error(
        Rule::NotStorable,
        "77\nA5000,900\n@0P\n9\n",
        &[1, 2],
        "77\n9\n",
    );
}

#[test]
fn parameter_count_depends_on_the_axes() {
    // XYZ takes 4 pairs (manual 3.2.2, decision 5).
    let d = isel_error(
        Rule::ParameterCount,
        "77\n05000,900\n9\n",
        &[1],
        "77\n05000,900,0,900,0,900,0,900\n9\n",
    );
    assert!(
        the(&d, Rule::ParameterCount)
            .message
            .contains("4 steps,speed pairs")
    );
    let x_only = LintConfig::new(AxisSet::from_mask(1));
    check(
        Language::Isel,
        &x_only,
        Rule::ParameterCount,
        Severity::Error,
        "71\n05000,900,0,900,0,900,0,900\n9\n",
        &[1],
        "71\n05000,900\n9\n",
    );
}

#[test]
fn number_range_and_bit_numbers_per_command() {
    isel_error(
        Rule::NumberRange,
        "71\nm1x,900,0,900,0,900,0,900\n9\n",
        &[1],
        "71\nm1,900,0,900,0,900,0,900\n9\n",
    );
    // `6` numbers bits 1-8, `o` and `p` 0-7; 128 is the whole byte (decision 11).
    isel_error(
        Rule::NumberRange,
        "60,0,0\n60,9,0\no0,8,0,1\np0,8,1\n9\n",
        &[0, 1, 2, 3],
        "60,1,0\n60,8,0\n60,128,0\no0,0,0,1\no0,7,0,1\no0,128,5,1\np0,0,1\np0,7,1\np0,128,1\n9\n",
    );
    let d = lint_with(Language::Isel, "60,0,0\n9\n", &machine());
    let range = the(&d, Rule::NumberRange);
    assert_eq!(range.span, Span::new(0, 3..4), "the bit parameter");
    assert!(range.message.contains("1-8"), "{}", range.message);
}

#[test]
fn speed() {
    let d = isel_error(
        Rule::Speed,
        "77\n0100,40001,0,900,0,900,0,900\nj10\nJ5000\n9\n",
        &[1, 2, 3],
        "77\n0100,900,0,900,0,900,0,900\nj300\nJ100\n9\n",
    );
    assert_eq!(the(&d, Rule::Speed).span, Span::new(1, 5..10));
}

#[test]
fn axis_not_initialised() {
    isel_error(Rule::Axis, "77\n78\nn8\n9\n", &[1, 2], "77\nn7\n9\n");
    // A set of axes that is no isel configuration.
    let xz = LintConfig::new(AxisSet::from_mask(5));
    let d = lint_with(Language::Isel, "9\n", &xz);
    assert_eq!(lines(&d, Rule::Axis), [0]);
}

#[test]
fn axis_of_the_circle_plane() {
    let xy = LintConfig::new(AxisSet::from_mask(3));
    let circle = "y400,1500,119,-141,141,-1,-1";
    // `e1` (XZ) on the way through line 2 only: the circle may run in XZ.
    check(
        Language::Isel,
        &xy,
        Rule::Axis,
        Severity::Error,
        &format!("f0\no0,0,1,2\ne1\n{circle}\n9\n"),
        &[3],
        &format!("f0\no0,0,1,2\ne0\n{circle}\n9\n"),
    );
    // Every plane of XYZ has its axes.
    isel_error(
        Rule::Axis,
        "f0\ne2\n78\nw32000,600,-1000,-2000,0,1,-1,6000\n9\n",
        &[2],
        "f0\ne2\nw32000,600,-1000,-2000,0,1,-1,6000\n9\n",
    );
}

#[test]
fn forward_loop() {
    isel_error(
        Rule::ForwardLoop,
        "77\n3 2,1\n55\n9\n",
        &[1],
        "77\n55\n3 2,-1\n9\n",
    );
}

#[test]
fn loop_depth() {
    // Loop k (line k) repeats lines 0..k: the one in line 1 is innermost.
    let nested = |depth: usize| {
        let mut text = String::from("55\n");
        for k in 1..=depth {
            text.push_str(&format!("3 1,-{k}\n"));
        }
        text.push_str("9\n");
        text
    };
    isel_error(Rule::LoopDepth, &nested(8), &[1], &nested(7));
}

#[test]
fn loop_overlap() {
    isel_warning(
        Rule::LoopOverlap,
        "55\n55\n3 1,-2\n55\n3 1,-3\n9\n",
        &[4],
        "55\n55\n3 1,-2\n55\n3 1,-4\n9\n",
    );
}

#[test]
fn loop_exit() {
    // The jump in line 1 lands behind the loop of line 3 (lines 1-3).
    let d = isel_error(
        Rule::LoopExit,
        "55\n3 0,3\n55\n3 2,-3\n55\n9\n",
        &[1],
        "55\n3 0,2\n55\n3 2,-3\n55\n9\n",
    );
    assert_eq!(the(&d, Rule::LoopExit).span, Span::new(1, 4..5));
    // Branches too (manual 3.2.5: "Eine Schleife darf nicht durch eine
    // Verzweigung verlassen werden").
    isel_error(
        Rule::LoopExit,
        "55\no0,0,1,-1\n3 2,-1\n9\n",
        &[1],
        "55\no0,0,1,1\n3 2,-1\n9\n",
    );
}

#[test]
fn jump_target() {
    isel_error(
        Rule::JumpTarget,
        "55\n3 0,5\no0,0,1,-3\n233,7\n3 2,-9\n9\n",
        &[1, 2, 3, 4],
        "55\n3 0,1\no0,0,1,-2\n233,2\n3 2,-4\n9\n",
    );
    // Behind the end `9`, even onto a line there.
    let d = isel_error(
        Rule::JumpTarget,
        "55\n3 0,2\n9\n55\n",
        &[1],
        "55\n3 0,1\n9\n",
    );
    assert!(
        the(&d, Rule::JumpTarget)
            .message
            .contains("behind the end `9` of line 3")
    );
}

#[test]
fn endless_jump() {
    isel_warning(Rule::EndlessJump, "55\n3 0,0\n9\n", &[1], "55\n3 0,1\n9\n");
}

#[test]
fn missing_end_with_a_fix() {
    let firing = "77\n55";
    let d = isel_error(Rule::MissingEnd, firing, &[1], "77\n55\n9\n");
    let fix = the(&d, Rule::MissingEnd).fix.expect("a fix");
    let fixed = apply(firing, &fix);
    assert_eq!(fixed, "77\n55\n9");
    assert!(
        lines(
            &lint_with(Language::Isel, &fixed, &machine()),
            Rule::MissingEnd
        )
        .is_empty()
    );
    isel_error(Rule::MissingEnd, "; only a comment\n", &[0], "9\n");
}

#[test]
fn after_end() {
    isel_error(Rule::AfterEnd, "77\n9\n55\n\n9\n", &[2, 4], "77\n55\n9\n");
}

#[test]
fn program_size() {
    let mut small = machine();
    small.capacity = Some(3);
    check(
        Language::Isel,
        &small,
        Rule::ProgramSize,
        Severity::Error,
        "55\n; comments do not count\n55\n55\n55\n9\n",
        &[4],
        "55\n55\n; comments do not count\n55\n9\n",
    );
    // 2000 commands by default (decision 9); the closing `9` is not one of
    // them (`docs/protocols.md`, isel).
    let program = |n: usize| "55\n".repeat(n) + "9\n";
    isel_error(Rule::ProgramSize, &program(2001), &[2000], &program(2000));
}

#[test]
fn table_spelling_with_a_fix() {
    let firing = "77\nM10,900,0,900,0,900,0,900\nF-1\n9";
    let d = isel_warning(
        Rule::TableSpelling,
        firing,
        &[1, 2],
        "77\nm10,900,0,900,0,900,0,900\nf-1\n9",
    );
    let fix = the(&d, Rule::TableSpelling).fix.expect("a fix");
    assert_eq!(
        (fix.span, fix.replacement.as_str()),
        (Span::new(1, 0..1), "m")
    );
    assert!(the(&d, Rule::TableSpelling).message.contains("3.2.16"));
}

#[test]
fn ccw_as_one_with_a_fix() {
    let firing = "f1\ny400,1500,119,-141,141,-1,-1\n9";
    let d = isel_warning(
        Rule::CcwAsOne,
        firing,
        &[0],
        "f-1\ny400,1500,119,-141,141,-1,-1\n9",
    );
    let fix = the(&d, Rule::CcwAsOne).fix.expect("a fix");
    assert!(apply(firing, &fix).starts_with("f-1\n"));
}

#[test]
fn sync_collision() {
    // `0` (48), `D` (68) and `R` (82) are reply codes; `!` (33) is not.
    isel_warning(
        Rule::SyncCollision,
        "148\n168\n182\n9\n",
        &[0, 1, 2],
        "133\n165\n9\n",
    );
}

#[test]
fn circle_direction() {
    isel_warning(
        Rule::CircleDirection,
        "y400,1500,119,-141,141,-1,-1\nw32000,600,-1000,-2000,0,1,-1,6000\n9\n",
        &[0, 1],
        "f-1\ny400,1500,119,-141,141,-1,-1\nw32000,600,-1000,-2000,0,1,-1,6000\n9\n",
    );
    // On the way through the branch of line 0 no `f` is set.
    isel_warning(
        Rule::CircleDirection,
        "o0,0,1,2\nf0\ny400,1500,119,-141,141,-1,-1\n9\n",
        &[2],
        "f-1\no0,0,1,2\nf0\ny400,1500,119,-141,141,-1,-1\n9\n",
    );
}

#[test]
fn soft_limit_after_a_reference_run() {
    let d = isel_error(
        Rule::SoftLimit,
        "77\nm20000,900,0,900,0,900,0,900\n9\n",
        &[1],
        "77\nm5000,900,0,900,0,900,0,900\n9\n",
    );
    let hit = the(&d, Rule::SoftLimit);
    assert_eq!(hit.span, Span::new(1, 1..6), "the X position");
    assert_eq!(
        hit.message,
        "axis X goes to 20000 steps, above its soft limit 10000 steps"
    );
    // Before a reference run (or absolute move) the start is unknown and a
    // relative move is not checked.
    isel_error(
        Rule::SoftLimit,
        "020000,900,0,900,0,900,0,900\n77\n0-1,900,0,900,0,900,0,900\n9\n",
        &[2],
        "020000,900,0,900,0,900,0,900\n9\n",
    );
}

#[test]
fn soft_limit_through_loops_branches_and_arcs() {
    // The fourth round of the loop goes to 12000.
    isel_error(
        Rule::SoftLimit,
        "77\n03000,900,0,900,0,900,0,900\n3 3,-1\n9\n",
        &[1],
        "77\n03000,900,0,900,0,900,0,900\n3 2,-1\n9\n",
    );
    // Only the branch taken in line 1 reaches line 3.
    isel_error(
        Rule::SoftLimit,
        "77\no0,0,1,2\n3 0,2\nm20000,900,0,900,0,900,0,900\n9\n",
        &[3],
        "77\no0,0,1,2\n3 0,2\nm2000,900,0,900,0,900,0,900\n9\n",
    );
    // The arc from 135° to 225° CCW around a centre 141 steps right of
    // X = 50 passes 180°, 59 steps left of its ends: below X = 0. Clockwise
    // it goes the long way round through 90°, 0° and 270° and stays right.
    isel_error(
        Rule::SoftLimit,
        "77\nm50,900,5000,900,0,900,0,900\nf-1\ny400,1500,119,-141,141,-1,-1\n9\n",
        &[3],
        "77\nm50,900,5000,900,0,900,0,900\nf0\ny400,1500,119,-141,141,-1,-1\n9\n",
    );
}

#[test]
fn soft_limit_where_a_port_condition_may_stop_a_move() {
    // The probing move in line 2 ends somewhere between Z 0 and 5000; going
    // up 6000 more may pass 10000.
    isel_warning(
        Rule::SoftLimit,
        "77\n60,128,1\nm0,900,0,900,5000,900,0,900\n0 0,900,0,900,6000,900,0,900\n9\n",
        &[3],
        "77\n60,128,1\nm0,900,0,900,5000,900,0,900\n0 0,900,0,900,4000,900,0,900\n9\n",
    );
}

#[test]
fn soft_limit_from_a_known_start() {
    let mut config = machine();
    config.start = Some([9000, 0, 0, 0]);
    check(
        Language::Isel,
        &config,
        Rule::SoftLimit,
        Severity::Error,
        "02000,900,0,900,0,900,0,900\n9\n",
        &[0],
        "0-2000,900,0,900,0,900,0,900\n9\n",
    );
}

#[test]
fn simulation_bound() {
    let mut config = machine();
    config.budget = 50;
    check(
        Language::Isel,
        &config,
        Rule::SimulationBound,
        Severity::Warning,
        "77\n01,900,0,900,0,900,0,900\n3 100,-1\n9\n",
        &[2],
        "77\n01,900,0,900,0,900,0,900\n3 10,-1\n9\n",
    );
}

#[test]
fn max_speed() {
    isel_warning(
        Rule::MaxSpeed,
        "77\n0100,30000,0,900,0,900,0,900\nd900,900,25000\nf0\ny400,30000,119,-141,141,-1,-1\n9\n",
        &[1, 2, 4],
        "77\n0100,20000,0,30000,0,900,0,900\nd900,900,900\nf0\ny400,20000,119,-141,141,-1,-1\n9\n",
    );
}

/// XY, soft limits 0..=10000 steps, 5000 Hz at most.
fn emcu_machine() -> LintConfig {
    let mut config = machine();
    config.axes = AxisSet::from_mask(3);
    for limit in config.limits.iter_mut().flatten() {
        limit.max_speed_hz = Some(5000.0);
    }
    config
}

#[track_caller]
fn emcu(
    rule: Rule,
    severity: Severity,
    firing: &str,
    at: &[usize],
    clean: &str,
) -> Vec<Diagnostic> {
    check(
        Language::Emcu,
        &emcu_machine(),
        rule,
        severity,
        firing,
        at,
        clean,
    )
}

#[test]
fn emcu_syntax() {
    let d = emcu(
        Rule::Syntax,
        Severity::Error,
        "#E1,800\nL1,q5\n",
        &[1],
        "#E1,800\nL1,y5\n",
    );
    assert_eq!(the(&d, Rule::Syntax).span, Span::new(1, 3..5));
}

#[test]
fn emcu_master_command() {
    emcu(
        Rule::MasterCommand,
        Severity::Error,
        "W250\n@X\n@F\n",
        &[1, 2],
        "W250\n",
    );
}

#[test]
fn emcu_empty_job() {
    emcu(
        Rule::EmptyJob,
        Severity::Error,
        "; nothing yet\n",
        &[0],
        "W250\n",
    );
}

#[test]
fn emcu_axis() {
    emcu(
        Rule::Axis,
        Severity::Error,
        "#E1,800\nL1,z10\n$HZY\n",
        &[1, 2],
        "#E1,800\nL1,y10\n$HYX\n",
    );
}

#[test]
fn emcu_program_size() {
    let job = |n: usize| "W1\n".repeat(n);
    emcu(
        Rule::ProgramSize,
        Severity::Error,
        &job(257),
        &[256],
        &job(256),
    );
}

#[test]
fn emcu_unset_slot() {
    emcu(
        Rule::UnsetSlot,
        Severity::Warning,
        "#E1,800\nL2,x10\n",
        &[1],
        "#E2,800\nL2,x10\n",
    );
}

#[test]
fn emcu_start_above_end() {
    let d = emcu(
        Rule::StartAboveEnd,
        Severity::Warning,
        "#S900\n#E1,800\nL1,x10\n",
        &[2],
        "#S700\n#E1,800\nL1,x10\n",
    );
    assert!(the(&d, Rule::StartAboveEnd).message.contains("line 1"));
}

#[test]
fn emcu_soft_limit_and_max_speed() {
    emcu(
        Rule::SoftLimit,
        Severity::Error,
        "#E1,800\nL1,x20000\n$HX\nL1,x20000\n",
        &[3],
        "#E1,800\nL1,x20000\n$HX\nL1,x2000\n",
    );
    emcu(
        Rule::MaxSpeed,
        Severity::Warning,
        "#E1,6000\nL1,x10\n",
        &[1],
        "#E1,5000\nL1,x10\n",
    );
}

#[test]
fn diagnostics_come_sorted_by_position() {
    let d = lint_with(
        Language::Isel,
        "M1,900,0,900,0,900,0,9000x\n148\n%\n",
        &machine(),
    );
    let positions: Vec<(usize, usize)> = d.iter().map(|d| (d.span.line, d.span.start)).collect();
    let mut sorted = positions.clone();
    sorted.sort();
    assert_eq!(positions, sorted);
    assert!(d.len() >= 3, "{d:#?}");
}

#[test]
fn the_manuals_circle_program_is_clean() {
    let text = "77\nm1000,900,1000,900,0,900,0,900\nf-1\ny400,1500,119,-141,141,-1,-1\n9\n";
    assert_eq!(lint_with(Language::Isel, text, &machine()), vec![]);
}
