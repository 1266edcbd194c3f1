//! What the console's job panel says of a G-code file opened in the editor
//! (issue 40): the figures of the import, the ways of running it, every
//! wait with its line, and the diagnostics at their lines with the line's
//! text, kept on screen instead of pushed through the message line. Built
//! once per import (and again when the work offset changes), drawn by
//! `view::job_panel`. Pure: no I/O, no terminal.

use crate::gcode::Import;
use crate::gcode::toolpath::{Diagnostic, Op, Pause, Severity};
use crate::gcode::ways::{Way, Ways, duration};

/// A diagnostic of the G-code at its line, with that line's text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AtLine {
    pub line: u32,
    pub col: u32,
    pub message: String,
    /// The G-code line as the file has it (trimmed), so the panel shows
    /// what is wrong where without the file beside it.
    pub text: String,
}

/// The figures of a job that imported.
#[derive(Debug, Clone, PartialEq)]
pub struct Figures {
    pub moves: usize,
    pub arcs: usize,
    pub length_mm: f64,
    /// The active work offset and its zero in machine mm.
    pub system: String,
    pub zero: [f64; 3],
    /// Per axis X, Y, Z: the range in work coordinates, if the file moves it.
    pub extents: [Option<(f64, f64)>; 3],
    /// The tools the job changes to, in order (`M6 Tn`).
    pub tools: Vec<u32>,
    /// The tool in the spindle and the offset every Z was shifted by.
    pub tool_offset: Option<(String, f64)>,
    /// Where the job waits for the operator (M0, M1, M6): line and what.
    pub waits: Vec<(u32, String)>,
    pub commands: usize,
    pub capacity: usize,
    pub fits: bool,
    /// `way time`, the chosen one first.
    pub ways: Vec<String>,
    /// The rectangle `F` traces (`ui::frame`), machine units, or why the
    /// job has none.
    pub frame: Result<crate::gcode::frame::Frame, String>,
}

/// How a line of the panel reads: the view gives each its style.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tone {
    Text,
    Good,
    /// A wait for the operator, a warning.
    Warning,
    /// An error: the job does not run.
    Danger,
}

/// Everything the job panel shows.
#[derive(Debug, Clone, PartialEq)]
pub struct JobReport {
    /// The G-code file as the operator named it.
    pub file: String,
    pub lines: usize,
    /// `None` when the file did not import: its errors say why.
    pub figures: Option<Figures>,
    pub errors: Vec<AtLine>,
    pub warnings: Vec<AtLine>,
}

fn at_line(d: &Diagnostic, source: &str) -> AtLine {
    let text = usize::try_from(d.origin.line)
        .ok()
        .and_then(|n| n.checked_sub(1))
        .and_then(|n| source.lines().nth(n))
        .unwrap_or("")
        .trim()
        .to_owned();
    AtLine {
        line: d.origin.line,
        col: d.origin.col,
        message: d.message.clone(),
        text,
    }
}

fn ways_of(ways: &Ways) -> Vec<String> {
    let mut out = Vec::new();
    let mut add = |way: Way, text: String| {
        if way == ways.chosen {
            out.insert(0, format!("{text} (chosen)"));
        } else {
            out.push(text);
        }
    };
    if let Some(s) = &ways.stored {
        add(Way::Stored, format!("stored {}", duration(s.total_s)));
    }
    if ways.stored.is_none()
        && let Ok(c) = &ways.chunked
    {
        add(
            Way::Chunked,
            format!("{} parts {}", c.parts, duration(c.total_s)),
        );
    }
    add(
        Way::Stream,
        format!("stream {}", duration(ways.stream.total_s)),
    );
    out
}

/// Why the job has no frame, in the console's words (it has no `--z`).
fn frame_error(e: crate::gcode::frame::FrameError) -> String {
    match e {
        crate::gcode::frame::FrameError::NoHeight => {
            "the job names no Z: there is no safe height to trace the frame at (jogterm frame --z \
             gives one)"
                .into()
        }
        other => other.to_string(),
    }
}

impl JobReport {
    /// The report of `source` (the file `file`) that imported as `import`,
    /// with the ways it can run.
    pub fn imported(file: &str, source: &str, import: &Import, ways: &Ways) -> JobReport {
        let s = &import.summary;
        let mut tools = Vec::new();
        for op in &import.toolpath.ops {
            if let Op::Pause(Pause::ToolChange { tool: Some(t), .. }) = op
                && !tools.contains(t)
            {
                tools.push(*t);
            }
        }
        let program = &import.program;
        JobReport {
            file: file.to_owned(),
            lines: source.lines().count(),
            figures: Some(Figures {
                moves: s.moves,
                arcs: s.arcs,
                length_mm: s.length_mm,
                system: s.system.to_string(),
                zero: [s.zero.x, s.zero.y, s.zero.z],
                extents: [0, 1, 2].map(|axis| s.extents.range(axis)),
                tools,
                tool_offset: import.tool.as_ref().map(|t| (t.tool.clone(), t.offset_mm)),
                // What the console's F6 waits for (`update::pieces`), not
                // the stored program's start key.
                waits: import
                    .plan
                    .waits
                    .iter()
                    .map(|w| (w.origin.line, w.what()))
                    .collect(),
                commands: program.commands,
                capacity: program.capacity,
                fits: program.fits(),
                ways: ways_of(ways),
                frame: crate::gcode::frame::of(&import.toolpath, None).map_err(frame_error),
            }),
            errors: Vec::new(),
            warnings: import.warnings.iter().map(|d| at_line(d, source)).collect(),
        }
    }

    /// The report of `source` that did not import: its diagnostics.
    pub fn refused(file: &str, source: &str, diagnostics: &[Diagnostic]) -> JobReport {
        let (errors, warnings): (Vec<_>, Vec<_>) = diagnostics
            .iter()
            .partition(|d| d.severity == Severity::Error);
        JobReport {
            file: file.to_owned(),
            lines: source.lines().count(),
            figures: None,
            errors: errors.into_iter().map(|d| at_line(d, source)).collect(),
            warnings: warnings.into_iter().map(|d| at_line(d, source)).collect(),
        }
    }

    /// The panel's text, one entry a line with its tone; the view wraps
    /// them.
    pub fn lines(&self) -> Vec<(Tone, String)> {
        let mut out = Vec::new();
        let mut add = |tone: Tone, text: String| out.push((tone, text));
        add(Tone::Text, format!("{} lines of G-code", self.lines));
        if let Some(f) = &self.figures {
            add(
                Tone::Text,
                format!("{} moves, {} arcs, {:.1} mm", f.moves, f.arcs, f.length_mm),
            );
            add(
                Tone::Text,
                format!(
                    "{} zero X{} Y{} Z{} (machine)",
                    f.system,
                    num(f.zero[0]),
                    num(f.zero[1]),
                    num(f.zero[2])
                ),
            );
            for (k, name) in ["X", "Y", "Z"].into_iter().enumerate() {
                if let Some((min, max)) = f.extents[k] {
                    let zero = f.zero[k];
                    add(
                        Tone::Text,
                        format!(
                            "{name} work {}..{}, machine {}..{}",
                            num(min),
                            num(max),
                            num(min + zero),
                            num(max + zero)
                        ),
                    );
                }
            }
            if !f.tools.is_empty() {
                let tools: Vec<String> = f.tools.iter().map(|t| format!("T{t}")).collect();
                add(Tone::Text, format!("tools: {}", tools.join(" ")));
            }
            if let Some((tool, offset)) = &f.tool_offset {
                add(
                    Tone::Warning,
                    format!("every Z {offset:+.3} mm: {tool}'s length (tool table)"),
                );
            }
            if f.fits {
                add(
                    Tone::Good,
                    format!("fits memory: {} of {}", f.commands, f.capacity),
                );
            } else {
                add(
                    Tone::Text,
                    format!(
                        "memory {}, job {}: in parts or streamed",
                        f.capacity, f.commands
                    ),
                );
            }
            for way in &f.ways {
                add(Tone::Text, way.clone());
            }
            if f.waits.is_empty() {
                add(Tone::Text, "no waits for the operator".into());
            } else {
                add(
                    Tone::Warning,
                    format!("{} waits for the operator:", f.waits.len()),
                );
                for (line, what) in &f.waits {
                    add(Tone::Warning, format!(" line {line}: {what}"));
                }
            }
        }
        if !self.errors.is_empty() {
            add(
                Tone::Danger,
                format!(
                    "{} error{}: does not run",
                    self.errors.len(),
                    if self.errors.len() == 1 { "" } else { "s" }
                ),
            );
            for e in &self.errors {
                add(Tone::Danger, said(e));
            }
        }
        if !self.warnings.is_empty() {
            add(
                Tone::Warning,
                format!(
                    "{} warning{}:",
                    self.warnings.len(),
                    if self.warnings.len() == 1 { "" } else { "s" }
                ),
            );
            for w in &self.warnings {
                add(Tone::Warning, said(w));
            }
        }
        out
    }
}

/// A length in mm as the panel says it: at most three decimals, none
/// that are zero (`20`, `-1.5`, `0.125`).
fn num(v: f64) -> String {
    let text = format!("{v:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    match text {
        "-0" => "0".to_owned(),
        t => t.to_owned(),
    }
}

fn said(d: &AtLine) -> String {
    if d.text.is_empty() {
        format!(" {}:{}: {}", d.line, d.col, d.message)
    } else {
        format!(" {}:{}: {} | {}", d.line, d.col, d.text, d.message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::gcode::ways::Costs;
    use crate::offsets::WorkOffsets;
    use crate::program::Language;

    fn import(text: &str) -> Result<(Import, Ways), Vec<Diagnostic>> {
        let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
        let import = crate::gcode::import(
            text,
            "job.nc",
            &profile,
            &WorkOffsets::default(),
            crate::gcode::Target::Isel,
        )?;
        let ways = Ways::of(
            &import.program,
            import.summary.estimated_s,
            &Costs::of(&profile, Language::Isel),
        );
        Ok((import, ways))
    }

    #[test]
    fn a_job_that_imports_says_its_figures_tools_waits_and_ways() {
        let text = "G21 G90\nG0 X10 Y20 Z5\nG1 Z1 F100\nT2 M6\nG1 X30\nM0\nM30\n";
        let (i, ways) = import(text).expect("imports");
        let r = JobReport::imported("job.nc", text, &i, &ways);
        let f = r.figures.as_ref().expect("figures");
        assert_eq!(f.tools, vec![2]);
        assert_eq!(f.waits.iter().map(|w| w.0).collect::<Vec<_>>(), [4, 6]);
        assert_eq!(f.extents[0], Some((10.0, 30.0)));
        assert!(f.fits);
        assert!(f.ways[0].starts_with("stored ") && f.ways[0].ends_with("(chosen)"));
        let lines: Vec<String> = r.lines().into_iter().map(|(_, l)| l).collect();
        assert_eq!(lines[0], "7 lines of G-code");
        assert!(
            lines.iter().any(|l| l == "X work 10..30, machine 10..30"),
            "{lines:?}"
        );
        assert!(
            lines.iter().any(|l| l == "G54 zero X0 Y0 Z0 (machine)"),
            "{lines:?}"
        );
        assert_eq!(
            (num(-0.0001), num(19.5), num(0.125)),
            ("0".into(), "19.5".into(), "0.125".into())
        );
        assert!(lines.iter().any(|l| l == "2 waits for the operator:"));
        assert!(lines.iter().any(|l| l.starts_with(" line 4: ")));
    }

    #[test]
    fn a_job_that_is_refused_shows_each_error_with_its_line_text() {
        let text = "G21\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 Z-70\n";
        let errors = import(text).expect_err("refused");
        let r = JobReport::refused("job.nc", text, &errors);
        assert!(r.figures.is_none());
        let first = &r.errors[0];
        assert_eq!((first.line, first.text.as_str()), (3, "G1 Z-1 F100"));
        let lines = r.lines();
        assert!(
            lines
                .iter()
                .any(|(tone, l)| *tone == Tone::Danger && l.ends_with(": does not run")),
            "{lines:?}"
        );
        assert!(
            lines
                .iter()
                .any(|(_, l)| l.starts_with(" 3:1: G1 Z-1 F100 | Z -1.000 mm is below")),
            "{lines:?}"
        );
    }
}
