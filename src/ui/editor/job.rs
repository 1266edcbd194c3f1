//! A program converted from G-code, as the editor runs it (issue 27,
//! `docs/editor.md` "G-code"): the converted program kept beside the text,
//! since where the job may be cut (the retracts to the safe height) is
//! known only to the import, and the ways of running it
//! (`gcode::ways`); a run in parts under way.

use std::time::Instant;

use crate::config::profile::Profile;
use crate::gcode::output::{Header, Program};
use crate::gcode::ways::{Costs, Ways};
use crate::program::Language;
use crate::program::outputs::JobOutput;

/// What `--program part.nc` imported, beside the text it became.
#[derive(Debug, Clone, PartialEq)]
pub struct Converted {
    /// The G-code file, as the operator named it (for `jogterm run`).
    pub source: String,
    /// The name the program's comments give the file (`part.nc:12`).
    pub header: String,
    pub program: Program,
    pub ways: Ways,
}

/// The converted program and the buffer state that is its text: an edit
/// makes the parts (cut from the converted program) no longer the text.
#[derive(Debug, Clone, PartialEq)]
pub struct Gcode {
    pub converted: Converted,
    pub state: u64,
}

/// One part as it is uploaded: its command lines, and the buffer line each
/// came from (so a refused command marks its line in the text).
#[derive(Debug, Clone, PartialEq)]
pub struct PartUpload {
    pub lines: Vec<String>,
    pub lines_of: Vec<usize>,
}

/// Where a run in parts stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// The part is being stored (after the erase of the one before).
    Uploading,
    /// Stored; `RunProgram` asked, the controller not running it yet.
    Starting,
    Running,
    /// Between two parts, the tool retracted, until F6 again.
    Paused,
}

/// A job run in parts from the editor.
#[derive(Debug, Clone, PartialEq)]
pub struct Chunked {
    pub parts: Vec<PartUpload>,
    /// 0-based, the part under way.
    pub part: usize,
    pub phase: Phase,
    /// Pause once the running part has ended (F6 while it runs).
    pub pause_next: bool,
    pub started: Instant,
    /// Where the axes stood (machine steps, per axis of the setup) when
    /// the job paused: a later part starts with a straight 3D move from
    /// wherever the tool is, so it goes on only from there.
    pub paused_at: Vec<Option<i64>>,
    /// Whether `paused_at` is a position read after the part ended. The
    /// position shown when the part's end is reported is still the
    /// estimate of the last move; the read that follows is where the axes
    /// stand, and the pause is measured from that read.
    pub paused_read: bool,
}

/// The outputs of the editor's job (issue 37, `docs/editor.md` "The job's
/// outputs"): a stop, an error or a lost line must not leave the spindle
/// running with nothing said (`program::outputs`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JobOutputs {
    /// The outputs the job under way switches on: a stored program run
    /// from the text uploaded from here, a job in parts, a check-out or a
    /// stream. Empty when no such job runs or it switches none on.
    pub armed: Vec<JobOutput>,
    /// A job that ended early: its outputs, switched off once the axes
    /// stand, and since when they wait for that.
    pub pending: Option<(Vec<JobOutput>, Instant)>,
    /// The switch-offs sent, by the device's name of their request: a
    /// refusal of one says that output may still be on.
    pub sent: Vec<(String, JobOutput)>,
}

impl Chunked {
    /// `part 2/4`.
    pub fn label(&self) -> String {
        format!("part {}/{}", self.part + 1, self.parts.len())
    }
}

impl Converted {
    /// `program`, converted from the G-code file `source` (its motion
    /// about `motion_s`), with the ways it can run on `profile`'s
    /// controller in `language` (`gcode::ways`).
    pub fn new(
        source: String,
        header: String,
        program: Program,
        motion_s: f64,
        profile: &Profile,
        language: Language,
    ) -> Converted {
        let ways = Ways::of(&program, motion_s, &Costs::of(profile, language));
        Converted {
            source,
            header,
            program,
            ways,
        }
    }

    /// The job cut where the tool stands retracted, each part as it is
    /// uploaded (header, `z1` again, its commands, `9`:
    /// `gcode::output::Program::part`); why it cannot be.
    pub fn part_uploads(&self, language: Language) -> Result<Vec<PartUpload>, String> {
        let program = &self.program;
        let parts = program.parts(program.capacity)?;
        (0..parts.len())
            .map(|k| {
                let part = program.part(&parts, k);
                let text = part.text(&self.header);
                let parsed = crate::program::Program::parse(language, &text);
                let lines = parsed.upload_lines().map_err(|(span, e)| {
                    format!("part {}: line {}: {}", k + 1, span.line + 1, e.message)
                })?;
                // The part's text is its head, its slice of the converted
                // program's lines (the buffer's, one for one) and maybe a
                // `9`: its own lines map to the slice's first and last.
                let range = &parts[k].lines;
                let header_len = program
                    .lines
                    .iter()
                    .take_while(|l| l.command.is_empty() && l.origin.is_none())
                    .count();
                let from = range.start.max(header_len);
                let copied = range.end.saturating_sub(from);
                let tail = usize::from(k + 1 < parts.len());
                let head = part.lines.len().saturating_sub(copied + tail);
                let last = range.end.saturating_sub(1);
                let lines_of = parsed
                    .statements()
                    .map(|(line, _)| match line.checked_sub(head) {
                        Some(i) if i < copied => from + i,
                        Some(_) => last,
                        None => from,
                    })
                    .collect();
                Ok(PartUpload { lines, lines_of })
            })
            .collect()
    }
}

/// Whether `text` is a program converted from G-code (its header says so).
pub fn is_converted(text: &str) -> bool {
    Header::of(text).is_some()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::gcode::ways::Way;

    /// `gcode` imported for the shipped isel profile with a program memory
    /// of `memory` commands, as `--program pockets.nc` opens it.
    pub(crate) fn converted(gcode: &str, memory: usize) -> Converted {
        let dirs = ConfigDirs::builtin_only();
        let mut profile = load_profile("isel", &dirs).expect("shipped profile");
        profile.gcode.memory = Some(memory);
        let import = crate::gcode::import(
            gcode,
            "pockets.nc",
            &profile,
            &crate::offsets::WorkOffsets::default(),
            crate::gcode::Target::Isel,
        )
        .expect("imports");
        Converted::new(
            "/jobs/pockets.nc".into(),
            "pockets.nc".into(),
            import.program,
            import.summary.estimated_s,
            &profile,
            Language::Isel,
        )
    }

    /// `n` square pockets, each entered from and left to Z5, placed for
    /// the shipped isel profile with its work zero at the reference point.
    pub(crate) fn pockets(n: usize) -> String {
        let mut text = String::from("%\nG21 G90 G17\nG0 Z65\n");
        for i in 0..n {
            let (x, y) = (60 + (i % 4) * 12, 60 + (i / 4) * 12);
            text.push_str(&format!(
                "G0 X{x} Y{y}\nG1 Z59 F600\nG1 X{} F1500\nG1 Y{}\nG1 X{x}\nG1 Y{y}\nG0 Z65\n",
                x + 5,
                y + 5
            ));
        }
        text.push_str("M30\n%\n");
        text
    }

    #[test]
    fn each_part_uploads_its_slice_and_marks_lines_of_the_text() {
        let converted = converted(&pockets(12), 30);
        assert_eq!(converted.ways.chosen, Way::Chunked);
        let parts = converted.part_uploads(Language::Isel).expect("parts");
        assert_eq!(parts.len(), 4);
        let text = converted.program.text(&converted.header);
        let lines: Vec<&str> = text.lines().collect();
        for (k, part) in parts.iter().enumerate() {
            assert!(part.lines.len() <= 30, "part {}: {:?}", k + 1, part.lines);
            assert_eq!(part.lines.len(), part.lines_of.len());
            assert_eq!(k > 0, part.lines[0] == "z1", "{:?}", part.lines);
            // Every command but the added ones is on the line it came from.
            for (command, &line) in part.lines.iter().zip(&part.lines_of) {
                if command != "z1" && command != "9" {
                    assert!(lines[line].starts_with(command.as_str()), "{command}");
                }
            }
        }
    }
}
