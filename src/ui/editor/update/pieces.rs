//! A converted G-code job with tool changes and pauses (M6, M0, M1) run
//! from the editor (issue 40, `docs/editor.md` "Tool changes and pauses"):
//! cut at its waits and driven by the same sans-IO
//! `gcode::toolchange::Sequence` as `jogterm run`. Each piece is converted
//! when its turn comes (`gcode::waits::convert_piece`: the moves to the
//! change position with the spindle off, and back) and stored, in parts
//! where it does not fit, by the run in parts of `update::job`, or, where
//! it has no retract to cut at, streamed by the check-out's stream
//! (`update::stream`, the piece's own text in `Checkout::piece`); between two
//! pieces the job waits for the operator: the status line and the message
//! line say what for and that F6 goes on, Space ends the job. On isel the
//! piece that ran is erased first (`@0k`): the iMC runs a stored program
//! when its start key is pressed. With a tool sensor (`probe.tool_sensor`)
//! the new tool is measured after F6 at a tool change (`update::measure`)
//! and every Z after it shifts by its length; without one it must have the
//! old one's length.

use crate::gcode::toolchange::{Sequence, Step as Next};
use crate::gcode::ways::Way;
use crate::program::Language;
use crate::program::checkout::{Plan, config_of};
use crate::program::checkout_emcu::EmcuPlan;
use crate::ui::editor::checkout::{Checkout, RunPlan, Stream};
use crate::ui::editor::component::Effect;
use crate::ui::editor::dialog::Answer;
use crate::ui::editor::job::{AtWait, Phase, PieceRun, PieceStream, Pieces, WAIT_ARMED, wait_text};
use crate::ui::traffic_log::NoteLevel;

use super::Step;
use super::job::{erase_request, standing};

/// What the console says of measuring at a tool change without a sensor.
const NO_MEASURE: &str = "no tool sensor (probe.tool_sensor): the new tool must have the old \
    one's length (or Space ends the job: touch off Z and restart it from its line)";

/// The same with one: every step the measure moves.
const MEASURE: &str = "after F6 Z goes up alone, then X and Y over and Z down to the tool sensor \
    (probe.tool_sensor), Z probes it and the tool comes back the same way; every Z after the \
    change shifts by the new tool's length";

impl Step<'_, '_> {
    /// F6 on a converted job with waits: the waits, how the job runs
    /// them, and the question.
    pub(super) fn pieces_ask(&mut self) {
        let Some(g) = self.e.gcode.as_ref() else {
            return;
        };
        let c = &g.converted;
        let Some(w) = c.waits.as_ref() else {
            return;
        };
        let plan = &w.plan;
        let mut text = format!(
            "{}: {} tool changes and pauses: the console runs it in {} pieces, each stored (in \
             parts where it does not fit, streamed where it cannot be cut), and waits at each \
             for you:\n",
            c.header,
            plan.waits.len(),
            plan.segments()
        );
        for line in crate::gcode::waits::waits_text(plan) {
            text.push_str(&format!("  {line}\n"));
        }
        let profile = &self.ctx.setup.profile;
        let language = self.e.language();
        let ways: Vec<String> = (0..plan.segments())
            .map(|k| match c.piece_run(k, (0.0, 0.0), profile, language) {
                Ok(PieceRun::Stored(parts, _)) if parts.len() > 1 => {
                    format!("piece {}: in {} parts", k + 1, parts.len())
                }
                Ok(PieceRun::Stored(..)) => format!("piece {}: stored", k + 1),
                Ok(PieceRun::Stream(p)) => format!(
                    "piece {}: streamed ({} commands, no retract to cut at)",
                    k + 1,
                    p.commands
                ),
                Err(why) => format!("piece {}: {why}", k + 1),
            })
            .collect();
        text.push_str(&format!("  {}\n", ways.join("; ")));
        let sensor = self.ctx.setup.profile.probe.tool_sensor.is_some();
        text.push_str(if sensor { MEASURE } else { NO_MEASURE });
        text.push_str(".\nRun it? The machine moves; at each wait F6 goes on, Space ends the job.");
        let title = format!("Run {}", c.header);
        self.ask(&title, text, Answer::RunPieces, Answer::Nothing);
    }

    /// Yes to the job with waits: every piece converted and checked once
    /// (a piece that does not convert or cannot be cut refuses the job
    /// before anything moves), then piece 1.
    pub(super) fn pieces_begin(&mut self) {
        let ctx = self.ctx;
        let language = self.e.language();
        if let Some(why) = self.job_refused() {
            self.say(NoteLevel::Danger, format!("run refused: {why}"));
            return;
        }
        let Some(g) = self.e.gcode.as_ref() else {
            return;
        };
        let c = &g.converted;
        let Some(w) = c.waits.as_ref() else {
            return;
        };
        let profile = &ctx.setup.profile;
        // A tool sensor measures each new tool into the tool table: both
        // must be usable before anything moves.
        let sensor = match profile.probe.tool_sensor_point() {
            Some(Ok(_)) => match ctx.tools.refused() {
                Some(why) => {
                    self.say(NoteLevel::Danger, format!("run refused: {why}"));
                    return;
                }
                None => true,
            },
            Some(Err(why)) => {
                self.say(
                    NoteLevel::Danger,
                    format!("run refused: probe.tool_sensor: {why}"),
                );
                return;
            }
            None => false,
        };
        let mut first = None;
        let mut model_s = Some(Vec::new());
        // The job log's way: the most a piece needs.
        let mut way = Way::Stored;
        for k in 0..w.plan.segments() {
            match c.piece_run(k, (0.0, 0.0), profile, language) {
                Ok(run) => {
                    model_s = model_s.zip(run.model_s()).map(|(mut m, s)| {
                        m.push(s);
                        m
                    });
                    way = match (&run, way) {
                        (PieceRun::Stream(_), _) | (_, Way::Stream) => Way::Stream,
                        (PieceRun::Stored(parts, _), _) if parts.len() > 1 => Way::Chunked,
                        (PieceRun::Stored(..), way) => way,
                    };
                    if first.is_none() {
                        first = Some(run);
                    }
                }
                Err(why) => {
                    self.say(NoteLevel::Danger, format!("run refused: {why}"));
                    return;
                }
            }
        }
        let Some(run) = first else {
            return;
        };
        // The import shifted the job by the offset of the tool in the
        // spindle already: the sequence's shifts are what a measured tool
        // changes after it (`Sequence::measured` takes the difference).
        let sequence = Sequence::new(w.plan.clone(), sensor, 0.0);
        let pieces = Pieces {
            sequence,
            header: w.header.clone(),
            piece: 0,
            wait: None,
            measure: None,
            probes: 0,
            model_s,
        };
        self.chunked_start(Vec::new(), Some(Box::new(pieces)), way);
        self.piece_start(run);
    }

    /// The piece under way begins as it runs: its first part stored, or
    /// its stream.
    fn piece_start(&mut self, run: PieceRun) {
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        c.part = 0;
        match run {
            PieceRun::Stored(parts, part_s) => {
                c.eta = (!part_s.is_empty()).then(|| crate::gcode::eta::PartsEta::new(part_s));
                c.parts = parts;
                self.chunked_upload();
            }
            PieceRun::Stream(piece) => {
                c.eta = None;
                c.parts = Vec::new();
                self.piece_stream(piece);
            }
        }
    }

    /// A piece with no retract to cut at streamed as a whole job that
    /// cannot be cut is (`update::stream`), its own text as the plan.
    fn piece_stream(&mut self, piece: Box<PieceStream>) {
        let ctx = self.ctx;
        let plan = match self.e.language() {
            Language::Isel => match config_of(ctx.setup.axis_set()) {
                Some(config) => RunPlan::Isel(Plan::new(&piece.program, config)),
                None => {
                    self.job_log_end(crate::joblog::How::Error);
                    self.chunked_end(
                        "the machine's axes are no isel axis setting: the job ends here".into(),
                    );
                    return;
                }
            },
            Language::Emcu => RunPlan::Emcu(EmcuPlan::new(&piece.program)),
        };
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        c.phase = Phase::Streaming;
        let label = c.label();
        let mut stream = Checkout::new(plan, Vec::new(), ctx.now);
        stream.stream = Some(Stream::new(
            piece.origins.clone(),
            Some(piece.eta.clone()),
            ctx.now,
        ));
        let text = format!(
            "{label}: streaming {} commands (no retract to cut at within the memory): F10 \
             pauses and goes on, Space stops",
            piece.commands
        );
        stream.piece = Some(piece);
        self.e.checkout = Some(stream);
        self.say(NoteLevel::Info, text);
        self.checkout_next();
    }

    /// A streamed piece's last line ended: its last G-code line has run,
    /// and the wait after it (or the job's end) follows as after a stored
    /// piece.
    pub(super) fn piece_streamed(&mut self) {
        self.e.checkout = None;
        if let Some(Some(line)) = self.e.job_logged {
            self.job_log_done(line);
        }
        self.piece_ended();
    }

    /// The last part of a piece ended: the wait after it, or the job's end.
    pub(super) fn piece_ended(&mut self) {
        let now = self.ctx.now;
        let isel = self.ctx.setup.protocol == crate::proto::Protocol::Isel;
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        let Some(p) = c.pieces.as_mut() else {
            return;
        };
        p.sequence.done();
        match p.sequence.step() {
            Next::Confirm { index } => {
                let plan = p.sequence.plan();
                let Some(wait) = plan.waits.get(index) else {
                    return;
                };
                let at = plan.waits_at(index, p.sequence.shift()).unwrap_or(wait.at);
                let sensor = self.ctx.setup.profile.probe.tool_sensor.is_some();
                let place = if wait.is_tool_change() {
                    format!(
                        "the spindle off, the tool at machine X {:.3} Y {:.3} Z {:.3}; {}",
                        at.x,
                        at.y,
                        at.z,
                        if sensor { MEASURE } else { NO_MEASURE }
                    )
                } else {
                    "the tool where the program left it".to_owned()
                };
                let wired = self.ctx.setup.profile.wiring().is_ok_and(|w| {
                    w.bits().iter().any(|b| {
                        b.role == crate::wiring::Role::Start
                            && b.kind == crate::wiring::BitKind::Input
                            && b.wired
                    })
                });
                let start_key = if wired { " (or the start key)" } else { "" };
                let text = format!(
                    "{} ended: line {}: {}: {place}: F6{start_key} goes on, Space ends the job",
                    p.label(),
                    wait.origin.line,
                    wait.what()
                );
                p.wait = Some(AtWait {
                    index,
                    since: now,
                    erasing: isel,
                    start_released: false,
                });
                c.phase = Phase::Waiting;
                c.pause_next = false;
                c.paused_at = standing(self.ctx);
                c.paused_read = false;
                let kept = self.outputs_paused();
                if isel {
                    self.out.effects.push(Effect::Device(erase_request()));
                }
                self.say(NoteLevel::Warning, format!("WAIT {text}{kept}"));
            }
            Next::Done => {
                let secs = now.saturating_duration_since(c.started).as_secs_f64();
                let text = format!(
                    "the job ended: {} pieces in {secs:.1} s",
                    p.sequence.plan().segments()
                );
                self.e.chunked = None;
                self.outputs_ended();
                self.say(NoteLevel::Info, text);
            }
            other => {
                let text = format!("the job ends: {other:?} is not the console's to do");
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(text);
            }
        }
    }

    /// The erase before the wait answered: F6 may go on.
    pub(super) fn wait_erased(&mut self) {
        let Some(p) = self.e.chunked.as_mut().and_then(|c| c.pieces.as_mut()) else {
            return;
        };
        let Some(at) = p.wait.as_mut().filter(|w| w.erasing) else {
            return;
        };
        at.erasing = false;
        let text = p
            .current_wait()
            .map(|w| format!("the piece that ran is erased: {}", wait_text(w, false)));
        if let Some(text) = text {
            self.say(NoteLevel::Info, text);
        }
    }

    /// F6 at a wait: the operator confirms; the new tool is measured
    /// where there is a tool sensor, and the next piece is converted for
    /// the tool in the spindle and stored.
    pub(super) fn wait_key(&mut self) {
        let now = self.ctx.now;
        let here = standing(self.ctx);
        let machine = self.ctx.machine;
        let axes = self.ctx.setup.axis_set();
        // The next piece has no reference run: it goes on only from a
        // machine in the state the piece before left it.
        let unready = if !machine.link_up {
            Some("the controller is not connected")
        } else if machine.activity != crate::device::api::Activity::Idle {
            Some("the machine must stand still")
        } else if !axes.iter().all(|a| machine.referenced.contains(a)) {
            Some("the axes are no longer referenced")
        } else {
            None
        };
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        let Some(p) = c.pieces.as_mut() else {
            return;
        };
        let Some(at) = p.wait.as_ref() else {
            return;
        };
        let refused = if let Some(why) = unready {
            Some((
                NoteLevel::Danger,
                format!("{why}: the job cannot go on from here; Space ends it"),
            ))
        } else if at.erasing {
            Some((
                NoteLevel::Info,
                "the piece that ran is being erased (@0k, about 2 s): F6 again in a moment".into(),
            ))
        } else if now.saturating_duration_since(at.since) < WAIT_ARMED {
            Some((
                NoteLevel::Info,
                "the wait has just begun: F6 again to go on".into(),
            ))
        } else if !c.paused_read {
            Some((
                NoteLevel::Info,
                "the position at the wait is being read: F6 again in a moment".into(),
            ))
        } else if c.paused_at != here {
            Some((
                NoteLevel::Danger,
                "the axes moved since the wait: the next piece begins with a straight move from \
                 where the tool stands; put them back where the job waits, or Space ends the job"
                    .into(),
            ))
        } else {
            None
        };
        if let Some((level, text)) = refused {
            self.say(level, text);
            return;
        }
        let line = p.current_wait().map_or(0, |w| w.origin.line);
        p.sequence.confirmed();
        p.wait = None;
        self.pieces_go_on(line);
    }

    /// After a confirmed wait (and the measure of a new tool): what the
    /// sequence does next, the next piece converted for the tool in the
    /// spindle and stored, or the measure of the new tool.
    pub(super) fn pieces_go_on(&mut self, line: u32) {
        let profile = std::sync::Arc::clone(&self.ctx.setup.profile);
        let language = self.e.language();
        let Some(p) = self.e.chunked.as_mut().and_then(|c| c.pieces.as_mut()) else {
            return;
        };
        match p.sequence.step() {
            Next::Run {
                index,
                dz_before,
                dz,
            } => {
                let run = self.e.gcode.as_ref().map(|g| {
                    g.converted
                        .piece_run(index, (dz_before, dz), &profile, language)
                });
                let Some(c) = self.e.chunked.as_mut() else {
                    return;
                };
                match run {
                    Some(Ok(run)) => {
                        if let Some(p) = c.pieces.as_mut() {
                            p.piece = index;
                        }
                        let shift = if dz == 0.0 {
                            String::new()
                        } else {
                            format!(", every Z {dz:+.3} mm for the tool measured")
                        };
                        let label = c.pieces.as_ref().map(|p| p.label()).unwrap_or_default();
                        let text = format!("line {line}: going on with {label}{shift}");
                        self.say(NoteLevel::Info, text);
                        self.piece_start(run);
                    }
                    Some(Err(why)) => {
                        self.job_log_end(crate::joblog::How::Error);
                        self.chunked_end(format!("{why}: the job ends here"));
                    }
                    None => {
                        self.job_log_end(crate::joblog::How::Error);
                        self.chunked_end("the converted job is gone: the job ends here".into());
                    }
                }
            }
            Next::Measure { tool, .. } => self.measure_begin(tool),
            other => {
                let text = format!("the job ends: {other:?} is not the console's to do");
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(text);
            }
        }
    }
}
