//! A program converted from G-code, as the editor runs it (issue 27,
//! `docs/editor.md` "G-code"): the converted program kept beside the text,
//! since where the job may be cut (the retracts to the safe height) is
//! known only to the import, and the ways of running it
//! (`gcode::ways`); a run in parts under way.

use std::time::Instant;

use crate::config::profile::Profile;
use crate::gcode::output::{Header, Program};
use crate::gcode::toolchange::{Plan, Sequence, Wait, WaitKind};
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
    /// The job's tool changes and pauses (M6, M0, M1), where it has any:
    /// F6 then runs it in pieces and waits between them itself
    /// (`update::job`, `docs/editor.md` "Tool changes and pauses").
    pub waits: Option<Box<JobWaits>>,
}

/// What a job with waits needs to run in pieces: the job cut at its waits
/// (`gcode::toolchange::Plan`) and the header each piece is converted
/// with.
#[derive(Debug, Clone, PartialEq)]
pub struct JobWaits {
    pub plan: Plan,
    /// The tool offset the import shifted every Z by (the tool in the
    /// spindle, `ui::tools`): a tool measured at a change shifts the
    /// pieces after it by its offset less this.
    pub dz0: f64,
    /// The toolpath the plan was made of: its pieces are ranges of it.
    pub path: std::sync::Arc<crate::gcode::toolpath::Toolpath>,
    pub header: Header,
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

/// How a piece of a job with waits runs.
#[derive(Debug, Clone, PartialEq)]
pub enum PieceRun {
    /// Stored whole, or in parts where it does not fit; each part's
    /// seconds by the model (`Ways::part_s`; none where the model cut it
    /// otherwise).
    Stored(Vec<PartUpload>, Vec<f64>),
    /// Bigger than the memory with no retract to cut at: streamed.
    Stream(Box<PieceStream>),
}

impl PieceRun {
    /// The piece's seconds by the model, waits not counted; `None` where
    /// the model has none (stored parts it cut otherwise).
    pub fn model_s(&self) -> Option<f64> {
        match self {
            PieceRun::Stored(_, part_s) if part_s.is_empty() => None,
            PieceRun::Stored(_, part_s) => Some(part_s.iter().sum()),
            PieceRun::Stream(piece) => piece.eta.left_s(0, 0.0),
        }
    }
}

/// A piece streamed: its converted text as the check-out's stream runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct PieceStream {
    pub program: crate::program::Program,
    pub commands: usize,
    /// The G-code line of each line of the piece's text.
    pub origins: Vec<Option<u32>>,
    /// The buffer's line of each line of the piece's text (by its G-code
    /// line), where the editor shows the stream.
    pub lines_of: Vec<usize>,
    /// The model of the piece's time left, by its text's lines: the
    /// status line's ETA, as a whole job's stream has.
    pub eta: crate::gcode::eta::Eta,
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
    /// A job with waits at one of them (M6, M0, M1): the tool at the
    /// change position with the spindle off (M6) or where the program left
    /// it, until the operator confirms with F6 (`Pieces::wait`).
    Waiting,
    /// At a tool change, after F6: the new tool goes to the tool sensor,
    /// is measured and comes back (`Pieces::measure`).
    Measuring,
    /// A piece of a job with waits streamed by the check-out's stream
    /// (`Editor::checkout`), until its last line has ended.
    Streaming,
}

/// A job with waits run in pieces (`docs/editor.md`, "Tool changes and
/// pauses"): the same [`Sequence`] `jogterm run` drives, each piece
/// converted when its turn comes and stored (in parts where it does not
/// fit).
#[derive(Debug, Clone, PartialEq)]
pub struct Pieces {
    pub sequence: Sequence,
    pub header: Header,
    /// 0-based, the piece under way.
    pub piece: usize,
    /// The wait under way while the job waits (`Phase::Waiting`).
    pub wait: Option<AtWait>,
    /// The measure of the new tool under way (`Phase::Measuring`).
    pub measure: Option<Measuring>,
    /// The probes sent so far: each measure's probe id is the next.
    pub probes: u64,
    /// Each piece's seconds by the model, as converted before the job
    /// began (a measured tool shifts Z, not the time): the time left of
    /// the pieces after the one under way. `None` where a piece has no
    /// model: then the job says no time left rather than too little.
    pub model_s: Option<Vec<f64>>,
}

/// The new tool measured on the tool sensor (`probe.tool_sensor`), as
/// `jogterm run` measures it: to the sensor, the probe, back to the change
/// position.
#[derive(Debug, Clone, PartialEq)]
pub struct Measuring {
    /// The tool's name as the job's `T` word gives it (`T2`).
    pub tool: String,
    pub stage: MeasureStage,
}

#[derive(Debug, Clone, PartialEq)]
pub enum MeasureStage {
    /// Up, over and down to the point above the sensor.
    ToSensor(crate::ui::legs::Legs),
    /// The probe of Z down onto the sensor (its id), which ends where it
    /// began.
    Probing(crate::device::api::JogId),
    /// Up, over and down to the change position again.
    Back(crate::ui::legs::Legs),
}

/// The wait the job stands at.
#[derive(Debug, Clone, PartialEq)]
pub struct AtWait {
    /// 0-based, into the plan's waits.
    pub index: usize,
    pub since: Instant,
    /// isel: the piece that ran is being erased (`@0k`): the iMC runs a
    /// stored program when its start key is pressed, and a press with the
    /// operator's hands at the spindle would run it again. F6 waits for it.
    pub erasing: bool,
    /// The machine's start key (the profile's wired input of role `start`)
    /// has been seen released since the wait began: its next press goes on
    /// as F6 does. A key held down since before the wait confirms nothing.
    pub start_released: bool,
}

/// F6 confirms a wait only this long after it began: a key pressed before
/// the wait (to pause a part, say) confirms nothing.
pub const WAIT_ARMED: std::time::Duration = std::time::Duration::from_millis(500);

impl Pieces {
    /// The wait under way, as the plan has it.
    pub fn current_wait(&self) -> Option<&Wait> {
        let at = self.wait.as_ref()?;
        self.sequence.plan().waits.get(at.index)
    }

    /// The model's seconds of the pieces after the one under way, and
    /// how many waits come before their end (whose time is the
    /// operator's, not guessed).
    pub fn after(&self) -> (Option<f64>, usize) {
        let later = self
            .model_s
            .as_ref()
            .map(|m| m.iter().skip(self.piece + 1).sum());
        let waits = self
            .sequence
            .plan()
            .segments()
            .saturating_sub(self.piece + 1);
        (later, waits)
    }

    /// `piece 2/3`.
    pub fn label(&self) -> String {
        format!(
            "piece {}/{}",
            self.piece + 1,
            self.sequence.plan().segments()
        )
    }
}

/// A wait in a few words for the status line: `T2 flat end mill, D=3.175`,
/// `M6 (no T)`, `M0 line 120`, `M1 line 120`.
pub fn wait_short(w: &Wait) -> String {
    match &w.kind {
        WaitKind::ToolChange {
            info: Some(info), ..
        } => info.label(),
        WaitKind::ToolChange { tool: Some(t), .. } => format!("T{t}"),
        WaitKind::ToolChange { tool: None, .. } => format!("M6 line {}", w.origin.line),
        WaitKind::Program => format!("M0 line {}", w.origin.line),
        WaitKind::Optional => format!("M1 line {}", w.origin.line),
    }
}

/// What the message line says while the job waits: what for and what
/// ends it, `WAIT T2 flat end mill, D=3.175: F6 goes on, Space ends`.
pub fn wait_text(w: &Wait, erasing: bool) -> String {
    if erasing {
        format!(
            "WAIT {}: erasing the stored piece (@0k), then F6 goes on; Space ends",
            wait_short(w)
        )
    } else {
        format!("WAIT {}: F6 goes on, Space ends", wait_short(w))
    }
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
    /// A job with waits: its pieces and the wait under way.
    pub pieces: Option<Box<Pieces>>,
    /// When the part under way began to be stored (after a pause before
    /// it): its time so far, for the time left.
    pub part_began: Instant,
    /// The model's time left where the job is the converted G-code as
    /// converted (`gcode::eta::PartsEta`).
    pub eta: Option<crate::gcode::eta::PartsEta>,
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
    /// The model's time left (`gcode::eta::PartsEta`): while a part is
    /// stored or runs, and at a pause before the next.
    pub fn time_left(&self, now: Instant) -> Option<std::time::Duration> {
        let in_part = match self.phase {
            Phase::Uploading | Phase::Starting | Phase::Running => {
                now.saturating_duration_since(self.part_began).as_secs_f64()
            }
            Phase::Paused => 0.0,
            Phase::Streaming | Phase::Waiting | Phase::Measuring => return None,
        };
        let left = self.eta.as_ref()?.left_s(self.part, in_part)?;
        let later = match &self.pieces {
            Some(p) => p.after().0?,
            None => 0.0,
        };
        Some(std::time::Duration::from_secs_f64(left + later))
    }

    /// ` +2 waits` where waits come before the job's end: the time left
    /// does not count them.
    pub fn waits_ahead(&self) -> String {
        match self.pieces.as_ref().map(|p| p.after().1) {
            Some(1) => " +1 wait".into(),
            Some(n) if n > 1 => format!(" +{n} waits"),
            _ => String::new(),
        }
    }

    /// `part 2/4`; a job with waits `piece 2/3` (`piece 2/3 part 1/2`
    /// where the piece runs in parts).
    pub fn label(&self) -> String {
        let part = format!("part {}/{}", self.part + 1, self.parts.len());
        match &self.pieces {
            Some(p) if self.parts.len() > 1 => format!("{} {part}", p.label()),
            Some(p) => p.label(),
            None => part,
        }
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
            waits: None,
        }
    }

    /// With the job's waits, where it has any (`import.plan`, made of
    /// `path`, `import.toolpath`), and the header its pieces are converted
    /// with.
    pub fn with_waits(
        mut self,
        plan: &Plan,
        path: &crate::gcode::toolpath::Toolpath,
        header: Header,
    ) -> Converted {
        if !plan.waits.is_empty() {
            self.waits = Some(Box::new(JobWaits {
                plan: plan.clone(),
                dz0: 0.0,
                path: std::sync::Arc::new(path.clone()),
                header,
            }));
        }
        self
    }

    /// The import shifted every Z by `dz0` for the tool in the spindle.
    pub fn with_tool_shift(mut self, dz0: f64) -> Converted {
        if let Some(w) = self.waits.as_mut() {
            w.dz0 = dz0;
        }
        self
    }

    /// Piece `k` of a job with waits (every Z `dz` higher, the piece before
    /// `dz_before`) converted for `profile` (checked against the soft limits
    /// again), and how it runs: stored, in parts cut at the retracts where
    /// it does not fit (each part as it is uploaded, its commands marked at
    /// the buffer's lines with the same G-code line), or streamed where it
    /// has no retract to cut at, as `jogterm run` chooses for a whole job.
    pub fn piece_run(
        &self,
        k: usize,
        shifts: (f64, f64),
        profile: &Profile,
        language: Language,
    ) -> Result<PieceRun, String> {
        let Some(w) = self.waits.as_ref() else {
            return Err("the job has no waits".into());
        };
        let target = match language {
            Language::Isel => crate::gcode::Target::Isel,
            Language::Emcu => crate::gcode::Target::Emcu,
        };
        let piece = crate::gcode::waits::convert_piece(
            &w.plan, &w.path, k, shifts, profile, target, &w.header,
        )
        .map_err(|errors| {
            let first = errors
                .first()
                .map(|e| format!("line {}: {}", e.origin.line, e.message))
                .unwrap_or_default();
            format!("piece {} does not convert: {first}", k + 1)
        })?;
        // The piece's lines to the buffer's (the whole program's) by the
        // G-code line they came from.
        let mut at_line = std::collections::HashMap::new();
        for (i, l) in self.program.lines.iter().enumerate() {
            if let Some(o) = l.origin {
                at_line.entry(o.line).or_insert(i);
            }
        }
        // A line the conversion added (the way to and from the change) is
        // shown at the G-code line before it, or, before any, the first
        // after it: where the piece begins.
        let mut buffer_lines: Vec<Option<usize>> = piece
            .lines
            .iter()
            .map(|p| p.origin.and_then(|o| at_line.get(&o.line).copied()))
            .collect();
        let mut last = buffer_lines.iter().flatten().next().copied();
        for b in &mut buffer_lines {
            match b {
                Some(line) => last = Some(*line),
                None => *b = last,
            }
        }
        let to_buffer = |l: usize| buffer_lines.get(l).copied().flatten().unwrap_or(0);
        if !piece.fits() && piece.parts(piece.capacity).is_err() {
            let text = piece.text(&self.header);
            let program = crate::program::Program::parse(language, &text);
            program.upload_lines().map_err(|(span, e)| {
                format!(
                    "piece {}: line {}{}: {}",
                    k + 1,
                    span.line + 1,
                    gcode_at(&piece, &self.header, span.line),
                    e.message
                )
            })?;
            return Ok(PieceRun::Stream(Box::new(PieceStream {
                commands: program.command_count(),
                origins: piece
                    .lines
                    .iter()
                    .map(|l| l.origin.map(|o| o.line))
                    .collect(),
                lines_of: (0..piece.lines.len()).map(to_buffer).collect(),
                eta: crate::gcode::eta::Eta::new(
                    std::sync::Arc::new(Ways::of(&piece, 0.0, &Costs::of(profile, language))),
                    piece.lines.len(),
                ),
                program,
            })));
        }
        let mut uploads = uploads_of(&piece, &self.header, language)
            .map_err(|why| format!("piece {}: {why}", k + 1))?;
        for u in &mut uploads {
            for l in &mut u.lines_of {
                *l = to_buffer(*l);
            }
        }
        let ways = Ways::of(&piece, 0.0, &Costs::of(profile, language));
        let part_s = match &ways.stored {
            Some(whole) if uploads.len() == 1 => vec![whole.total_s],
            _ if ways.part_s.len() == uploads.len() => ways.part_s,
            _ => Vec::new(),
        };
        Ok(PieceRun::Stored(uploads, part_s))
    }

    /// The job cut where the tool stands retracted, each part as it is
    /// uploaded (header, `z1` again, its commands, `9`:
    /// `gcode::output::Program::part`); why it cannot be.
    pub fn part_uploads(&self, language: Language) -> Result<Vec<PartUpload>, String> {
        parts_of(&self.program, &self.header, language)
    }
}

/// ` (part.nc:12:5)`: the G-code place line `line` of `program`'s text
/// came from, where it came from one.
fn gcode_at(program: &Program, file: &str, line: usize) -> String {
    program
        .lines
        .get(line)
        .and_then(|l| l.origin)
        .map(|o| format!(" ({file}:{}:{})", o.line, o.col))
        .unwrap_or_default()
}

/// `program` as it is uploaded: whole where it fits, else in parts
/// ([`parts_of`]); `lines_of` index `program.lines`.
fn uploads_of(
    program: &Program,
    header: &str,
    language: Language,
) -> Result<Vec<PartUpload>, String> {
    if !program.fits() {
        return parts_of(program, header, language);
    }
    let text = program.text(header);
    let parsed = crate::program::Program::parse(language, &text);
    let lines = parsed.upload_lines().map_err(|(span, e)| {
        let at = gcode_at(program, header, span.line);
        format!("line {}{at}: {}", span.line + 1, e.message)
    })?;
    let lines_of = parsed.statements().map(|(line, _)| line).collect();
    Ok(vec![PartUpload { lines, lines_of }])
}

/// `program` cut where the tool stands retracted, each part as it is
/// uploaded (header, `z1` again, its commands, `9`:
/// `gcode::output::Program::part`); `lines_of` index `program.lines`.
fn parts_of(
    program: &Program,
    header: &str,
    language: Language,
) -> Result<Vec<PartUpload>, String> {
    let parts = program.parts(program.capacity)?;
    (0..parts.len())
        .map(|k| {
            let part = program.part(&parts, k);
            let text = part.text(header);
            let parsed = crate::program::Program::parse(language, &text);
            let lines = parsed.upload_lines().map_err(|(span, e)| {
                let at = gcode_at(&part, header, span.line);
                format!("part {}: line {}{at}: {}", k + 1, span.line + 1, e.message)
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
            import.program.clone(),
            import.summary.estimated_s,
            &profile,
            Language::Isel,
        )
        .with_waits(
            &import.plan,
            &import.toolpath,
            Header {
                file: "pockets.nc".into(),
                profile: profile.name.clone(),
                system: import.summary.system.to_string(),
                zero: import.summary.zero,
            },
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
    fn a_refused_line_of_the_converted_text_names_its_gcode_place() {
        let c = converted(&pockets(2), 2000);
        let line = c
            .program
            .lines
            .iter()
            .position(|l| l.origin.is_some())
            .expect("a G-code line");
        let origin = c.program.lines[line].origin.expect("its origin");
        assert_eq!(
            gcode_at(&c.program, "pockets.nc", line),
            format!(" (pockets.nc:{}:{})", origin.line, origin.col)
        );
        // The header's comments came from no G-code line.
        assert_eq!(gcode_at(&c.program, "pockets.nc", 0), "");
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
