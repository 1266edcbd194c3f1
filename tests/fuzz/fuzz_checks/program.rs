//! The program languages (isel CNC programs, EMCU jobs): parser, linter,
//! formatter, path preview and the editor's incremental re-parse.

use std::ops::Range;

use jogterm::axis::AxisSet;
use jogterm::program::{Language, LintConfig, Program, Start, format, lint, path_with};
use jogterm::proto::Protocol;

use super::sim::profile;
use super::{Choices, split_head};

/// Commands the soft-limit run and the path preview execute at most: enough
/// for loops and branches to matter, few enough that every input is quick.
pub const BUDGET: usize = 20_000;

/// The first byte picks the language and the machine; the rest is the
/// program text (invalid UTF-8 replaced, as an editor reading a file would).
pub fn program(data: &[u8]) {
    let (head, body) = split_head(data);
    let language = Language::ALL[usize::from(head & 1)];
    let text = String::from_utf8_lossy(body);
    let mut choices = Choices::new(data);
    let program = Program::parse(language, &text);
    check_structure(&program);

    let config = lint_config(language, head >> 1);
    let diagnostics = lint(&program, &config);
    for d in &diagnostics {
        let _ = (d.rule.name(), &d.message);
        assert!(
            slices(&program, d.span.line, d.span.cols()),
            "diagnostic span {:?} does not slice its line: {d:?}",
            d.span
        );
        if let Some(fix) = &d.fix {
            assert!(slices(&program, fix.span.line, fix.span.cols()), "{fix:?}");
        }
    }

    let axes = config.axes;
    let path = path_with(&program, &Start::at_zero(axes), BUDGET);
    assert!(
        path.executed <= BUDGET + 1,
        "{} commands run",
        path.executed
    );
    for s in &path.segments {
        assert!(s.line < program.lines().len() && s.index < program.command_count());
    }

    // The source text an editor saves reads back as the same lines.
    let saved = Program::parse(language, &program.text());
    assert_eq!(saved, program, "text() does not read back");

    // What the formatter writes reads back as the same program, and is its
    // own format.
    let formatted = format(&program);
    let again = Program::parse(language, &formatted);
    assert_eq!(
        again.items(),
        program.items(),
        "formatting changed the program"
    );
    assert_eq!(format(&again), formatted, "format is not idempotent");

    // The upload's canonical lines are the same commands.
    if let Ok(lines) = program.upload_lines() {
        let uploaded = Program::parse(language, &lines.join("\n"));
        assert_eq!(uploaded.command_count(), program.command_count());
        let ours = program.statements().map(|(_, s)| s.command.as_ref().ok());
        let theirs = uploaded.statements().map(|(_, s)| s.command.as_ref().ok());
        assert!(ours.eq(theirs), "the upload lines are other commands");
    }

    // An editor's edit re-parses only the lines it touches, and gets what a
    // whole parse of the edited text gets.
    let n = program.lines().len();
    let start = choices.below(n as u64 + 1) as usize;
    let end = start + choices.below((n - start) as u64 + 1) as usize;
    let cut = choices.below(body.len() as u64 + 1) as usize;
    let replacement = String::from_utf8_lossy(body.get(cut..).unwrap_or_default());
    let mut edited = program.clone();
    edited.replace_lines(start..end, &replacement);
    check_structure(&edited);
    let mut lines: Vec<String> = program
        .lines()
        .iter()
        .map(|l| l.text().to_owned())
        .collect();
    let new: Vec<String> = jogterm::program::source::lines(&replacement)
        .map(str::to_owned)
        .collect();
    lines.splice(start..end, new);
    let fresh = Program::parse(language, &source_text(&lines));
    assert_eq!(
        edited.items(),
        fresh.items(),
        "replace_lines({start}..{end})"
    );
    assert_eq!(edited.command_count(), fresh.command_count());
}

/// Lines joined so that `source::lines` gives them back: each ended by LF,
/// and by CR LF when it ends with a CR itself (one CR before an LF is part
/// of the line end).
fn source_text(lines: &[String]) -> String {
    let mut out = String::new();
    for line in lines {
        out.push_str(line);
        if line.ends_with('\r') {
            out.push('\r');
        }
        out.push('\n');
    }
    out
}

fn lint_config(language: Language, pick: u8) -> LintConfig {
    let mut config = match pick & 3 {
        0 => LintConfig::new(match language {
            Language::Isel => AxisSet::XYZ,
            Language::Emcu => AxisSet::XYZ,
        }),
        1 => LintConfig::new(AxisSet::from_mask(pick >> 2 & 0xF)),
        _ => LintConfig::from_profile(profile(match language {
            Language::Isel => Protocol::Isel,
            Language::Emcu => Protocol::Emcu,
        })),
    };
    config.budget = BUDGET;
    if pick & 3 == 3 {
        // The console knows where the machine stands; a small memory.
        config.start = Some([0; 4]);
        config.capacity = Some(usize::from(pick >> 2) + 1);
    }
    config
}

/// Whether `cols` is a range of whole characters of source line `line`.
fn slices(program: &Program, line: usize, cols: Range<usize>) -> bool {
    match program.line(line) {
        Some(l) => l.text().get(cols).is_some(),
        // A whole-program diagnostic (an empty program, a missing end) may
        // sit on the line after the last one, without width.
        None => line <= program.lines().len() && cols.is_empty(),
    }
}

/// Every span of every line slices it; command indices and lines agree.
fn check_structure(program: &Program) {
    for (i, line) in program.lines().iter().enumerate() {
        let text = line.text();
        let ok = |r: &Range<usize>| text.get(r.clone()).is_some();
        if let Some(s) = line.statement() {
            assert!(ok(&s.code), "line {i}: code {:?} in {text:?}", s.code);
            assert!(s.comment.as_ref().is_none_or(ok), "line {i}: comment");
            assert!(s.params.iter().all(ok), "line {i}: params {:?}", s.params);
            assert!(s.notes.iter().all(|n| ok(&n.cols)), "line {i}: notes");
            if let Err(e) = &s.command {
                assert!(ok(&e.cols), "line {i}: error {e:?} in {text:?}");
            }
            assert_eq!(program.line_of(s.index), Some(i));
            assert_eq!(program.index_of(i), Some(s.index));
        }
    }
    for index in 0..program.command_count() {
        if let Some(target) = program.jump_target(index) {
            assert!(target < program.command_count());
        }
    }
}
