//! The check-out's keys, device events and ticks (`docs/editor.md`,
//! "Check-out"): started from the editor after the linter and the DNC form
//! have passed the program, run line by line while the hold key is held,
//! paused when it is let go, ended with the abort key or a stop.

use std::fmt::Write as _;

use crate::axis::Axis;
use crate::device::api::{Activity, CheckoutEnd, Event, LinkState, Request};
use crate::jog::KeyPhase;
use crate::motion::overrun::speed_cap;
use crate::program::Language;
use crate::program::checkout::{
    DncStep, Finish, Plan, config_of, go_to, line_text, pair_axes, unexpressible, with_speeds,
};
use crate::program::checkout_emcu::{self, EmcuPlan, EmcuStep, JobCommand};
use crate::ui::editor::buffer::Cursor;
use crate::ui::editor::checkout::{Checkout, PreLine, RunPlan, RunState, scaled};
use crate::ui::editor::component::Effect;
use crate::ui::editor::dialog::Answer;
use crate::ui::keymap::Action;
use crate::ui::traffic_log::NoteLevel;

use super::Step;

/// What a check-out starts with, for the question and for the start.
pub(super) struct Prepared {
    pub(super) plan: RunPlan,
    pub(super) preamble: Vec<(PreLine, usize)>,
    summary: String,
}

impl Step<'_, '_> {
    /// F10 / Shift-F10 in the editor: check, then ask.
    pub(super) fn checkout_ask(&mut self, from_cursor: bool) {
        let from = from_cursor.then(|| self.e.buffer.cursor().line);
        match self.checkout_prepare(from, false) {
            Ok(p) => {
                let hold = self.key_name(Action::CheckoutHold);
                let text = format!(
                    "{}\n\nThe machine moves only while {hold} is held; let go, it pauses. \
                     Space stops.",
                    p.summary
                );
                self.ask(
                    "Check-out",
                    text,
                    Answer::Checkout { from },
                    Answer::Nothing,
                );
            }
            Err(why) => self.say(NoteLevel::Danger, format!("check-out refused: {why}")),
        }
    }

    fn key_name(&self, action: Action) -> String {
        self.ctx
            .keymap
            .key_for(crate::ui::keymap::Mode::Checkout, action)
            .map_or_else(|| action.to_string(), |k| k.to_string())
    }

    /// The answer was yes: the check-out is on (nothing moves yet).
    pub(super) fn checkout_begin(&mut self, from: Option<usize>) {
        match self.checkout_prepare(from, false) {
            Ok(p) => {
                if let Some(RunState::Paused { rest: Some(_) }) =
                    self.e.checkout.as_ref().map(|c| &c.state)
                {
                    // Started again elsewhere: the paused rest is forgotten
                    // (0xFF, manual 2.2.31).
                    self.out.effects.push(Effect::Device(Request::Raw {
                        line: "\u{ff}".into(),
                    }));
                }
                let c = Checkout::new(p.plan, p.preamble, self.ctx.now);
                let line = c.current_line().map_or(0, |l| l + 1);
                self.e.checkout = Some(c);
                self.outputs_arm();
                self.checkout_follow();
                let hold = self.key_name(Action::CheckoutHold);
                self.say(
                    NoteLevel::Info,
                    format!("check-out at line {line}: hold {hold} to run"),
                );
            }
            Err(why) => self.say(NoteLevel::Danger, format!("check-out refused: {why}")),
        }
    }

    /// `stream`: for a stream of a converted job, whose lines go out in
    /// the DNC form `jogterm run --stream` sends, without the check-out's
    /// refusal of lines that differ there from the stored program.
    pub(super) fn checkout_prepare(
        &mut self,
        from: Option<usize>,
        stream: bool,
    ) -> Result<Prepared, String> {
        let ctx = self.ctx;
        let language = self.e.language();
        if language.protocol() != ctx.setup.protocol {
            return Err(format!(
                "the check-out runs isel CNC programs on an isel controller and EMCU jobs on an \
                 EMCU; this is {} on {} (docs/editor.md, \"What each family can do\")",
                language, ctx.setup.protocol
            ));
        }
        if self.e.upload.busy() {
            return Err("an upload is running".into());
        }
        if !ctx.machine.link_up {
            return Err("not connected to the controller".into());
        }
        if ctx.machine.activity != Activity::Idle {
            return Err("the machine is busy: wait until it stands still".into());
        }
        // The linter's verdict of this very text, soft limits included.
        if let Some(why) = self.first_error() {
            return Err(why);
        }
        let program = self.e.buffer.program();
        let named = match language {
            Language::Isel => unexpressible(program),
            Language::Emcu => checkout_emcu::unexpressible(program),
        };
        if !named.is_empty() && !stream {
            let mut text = String::from("lines without an exact DNC form:");
            for u in &named {
                let _ = write!(text, " line {}: {};", u.line + 1, u.reason);
            }
            if let Some(first) = named.first() {
                self.e.buffer.move_to(Cursor::new(first.line, 0));
                self.scroll_into_view();
            }
            return Err(text.trim_end_matches(';').to_string());
        }
        let name = self.e.name();
        if language == Language::Emcu {
            return self.checkout_prepare_emcu(from);
        }
        let config = config_of(ctx.setup.axis_set())
            .ok_or_else(|| "the machine's axes are no isel axis setting".to_string())?;
        let mut plan = Plan::new(program, config);
        let Some(from) = from else {
            return Ok(Prepared {
                plan: RunPlan::Isel(plan),
                preamble: Vec::new(),
                summary: format!(
                    "Check out {name} from its first line, line by line in DNC form, at {} %.",
                    100
                ),
            });
        };
        if program.index_of(from).is_none() {
            return Err(format!("line {} is no command", from + 1));
        }
        let (_, start) = self.starts();
        let position = start.position;
        let zero = start.zero;
        let skipped = plan.skip_to(from, position, zero)?;
        let units = crate::ui::editor::unit_label(ctx.setup);
        let speed = self.e.teach_speed(ctx.setup).unwrap_or(1.0);
        let mut shown = String::new();
        for axis in pair_axes(config).iter().take(config.axis_count()) {
            let work = skipped.position[axis.index()] - zero[axis.index()];
            let _ = write!(shown, " {axis}{}", self.units_of(*axis, work));
        }
        let go = go_to(config, skipped.position, zero, &|axis| {
            self.axis_hz(axis, speed)
        });
        let settings: Vec<String> = skipped
            .settings
            .iter()
            .map(|(c, l)| format!("{c} (line {})", l + 1))
            .collect();
        let mut preamble: Vec<(PreLine, usize)> = skipped
            .settings
            .into_iter()
            .map(|(c, l)| (PreLine::Isel(c), l))
            .collect();
        preamble.push((PreLine::Isel(go), from));
        let outputs: Vec<String> = skipped
            .outputs
            .iter()
            .map(|(c, l)| format!("{c} (line {})", l + 1))
            .collect();
        let summary = format!(
            "Check out {name} from line {}: {} move{} before it skipped.\n\
             Start position (work):{shown}; the axes go there first (@0M at {speed} {units}/s, \
             held like every line).\n\
             Settings in force there, sent first: {}.\n\
             Outputs the skipped lines set are not sent: {}.\n\
             Moves count from the work zero in force now; absolute and relative moves as written.",
            from + 1,
            skipped.skipped_moves,
            if skipped.skipped_moves == 1 { "" } else { "s" },
            joined_or(&settings, "none (the controller's own)"),
            joined_or(&outputs, "none"),
        );
        Ok(Prepared {
            plan: RunPlan::Isel(plan),
            preamble,
            summary,
        })
    }

    /// An EMCU job's check-out; from source line `from`: the job walked to
    /// it, the settings in force there sent first, then the axes taken to
    /// where the skipped moves would have left them (`docs/editor.md`,
    /// "Run from a line").
    fn checkout_prepare_emcu(&mut self, from: Option<usize>) -> Result<Prepared, String> {
        let ctx = self.ctx;
        let program = self.e.buffer.program();
        let name = self.e.name();
        let mut plan = EmcuPlan::new(program);
        let Some(from) = from else {
            return Ok(Prepared {
                plan: RunPlan::Emcu(plan),
                preamble: Vec::new(),
                summary: format!(
                    "Check out {name} from its first line, each job line sent as a command \
                     (0x01), at 100 %."
                ),
            });
        };
        let (_, start) = self.starts();
        let zero = start.zero;
        let skipped = plan.skip_to(from, start.position)?;
        let units = crate::ui::editor::unit_label(ctx.setup);
        let speed = self.e.teach_speed(ctx.setup).unwrap_or(1.0);
        let axes = ctx.setup.axis_set();
        let hz = axes
            .iter()
            .map(|axis| self.axis_hz(axis, speed))
            .min()
            .unwrap_or(1);
        let go = checkout_emcu::go_to(axes, skipped.position, hz)
            .ok_or_else(|| "the start position is beyond the range of an L move".to_string())?;
        let mut shown = String::new();
        for axis in axes.iter() {
            let i = axis.index();
            let work =
                skipped.position.get(i).copied().unwrap_or(0) - zero.get(i).copied().unwrap_or(0);
            let _ = write!(shown, " {axis}{}", self.units_of(axis, work));
        }
        let listed = |list: &[(JobCommand, usize)]| -> Vec<String> {
            list.iter()
                .map(|(c, l)| format!("{c} (line {})", l + 1))
                .collect()
        };
        let settings = listed(&skipped.settings);
        let outputs = listed(&skipped.outputs);
        // The settings first, so the move to the start runs with the job's
        // ramp and start speed; then the move in its own slot speed, and
        // the job's speed of that slot again after it.
        let mut preamble: Vec<(PreLine, usize)> = skipped
            .settings
            .iter()
            .map(|(c, l)| (PreLine::Emcu(*c), *l))
            .collect();
        preamble.extend(go.iter().map(|c| (PreLine::Emcu(*c), from)));
        preamble.extend(
            skipped
                .settings
                .iter()
                .filter(|(c, _)| {
                    matches!(c, JobCommand::EndSpeed { slot, .. } if *slot == checkout_emcu::GO_TO_SLOT)
                })
                .map(|(c, l)| (PreLine::Emcu(*c), *l)),
        );
        let summary = format!(
            "Check out {name} from line {}: {} move{} before it skipped.\n\
             Start position (work):{shown}; the axes go there first ({} then {}, at {speed} \
             {units}/s, held like every line).\n\
             Settings in force there, sent first: {}.\n\
             Outputs the skipped lines set are not sent: {}.\n\
             Then each job line sent as a command (0x01), at 100 %.",
            from + 1,
            skipped.skipped_moves,
            if skipped.skipped_moves == 1 { "" } else { "s" },
            go[0],
            go[1],
            joined_or(&settings, "none (the controller's own)"),
            joined_or(&outputs, "none"),
        );
        Ok(Prepared {
            plan: RunPlan::Emcu(plan),
            preamble,
            summary,
        })
    }

    fn units_of(&self, axis: Axis, steps: i64) -> String {
        self.ctx
            .setup
            .axes
            .iter()
            .find(|(a, _)| *a == axis)
            .map_or_else(
                || steps.to_string(),
                |(_, p)| crate::ui::position::format_amount(steps as f64 / p.steps_per_unit),
            )
    }

    /// Hz of `axis` for `units_per_second`.
    fn axis_hz(&self, axis: Axis, units_per_second: f64) -> u32 {
        self.ctx
            .setup
            .axes
            .iter()
            .find(|(a, _)| *a == axis)
            .map_or(1, |(_, p)| {
                p.speed_hz(units_per_second).round().max(1.0) as u32
            })
    }

    /// The fastest Hz of `axis` that keeps the overrun bound for the hold's
    /// lease (as a continuous jog's, `docs/jogging.md`).
    fn cap_hz(&self, axis: Axis) -> Option<u32> {
        let jog = &self.ctx.setup.jog;
        let braking = jog.braking?;
        let a = jog.axis(axis)?;
        let hz = speed_cap(&braking, jog.repeat_timeout, a.max_overrun_steps)
            .min(a.max_speed * a.steps_per_unit);
        Some(hz.floor().max(1.0) as u32)
    }

    /// Keep the current line in view and the cursor on it.
    fn checkout_follow(&mut self) {
        if let Some(line) = self.e.checkout.as_ref().and_then(Checkout::buffer_line) {
            self.e.buffer.move_to(Cursor::new(line, 0));
            self.scroll_into_view();
        }
    }

    /// A key of the check-out's mode.
    pub(super) fn checkout_key(&mut self, action: Action, phase: KeyPhase) {
        let ctx = self.ctx;
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        if c.stream.is_some() && matches!(action, Action::CheckoutHold | Action::CheckoutSingle) {
            self.stream_key(action, phase);
            return;
        }
        match action {
            Action::CheckoutHold => match phase {
                KeyPhase::Release => {
                    c.released();
                    if let Some(id) = c.line_id
                        && c.state == RunState::Running
                    {
                        self.out
                            .effects
                            .push(Effect::Device(Request::JogRelease { id }));
                    }
                }
                KeyPhase::Press | KeyPhase::Repeat => {
                    if !c.key(ctx.now, ctx.setup.jog.grace) {
                        return;
                    }
                    match (&c.state, c.line_id) {
                        (RunState::Running, Some(id)) => {
                            let lease = ctx.setup.jog.repeat_timeout;
                            self.out
                                .effects
                                .push(Effect::Device(Request::JogRenew { id, lease }));
                        }
                        (RunState::Stopped { why }, _) => {
                            let why = why.clone();
                            c.latched = true;
                            self.say(
                                NoteLevel::Warning,
                                format!(
                                    "check-out stopped ({why}): Shift-F10 starts again from \
                                     this line, x ends the check-out"
                                ),
                            );
                        }
                        (RunState::Finished, _) => {
                            c.latched = true;
                            self.say(
                                NoteLevel::Info,
                                "the check-out has ended: x leaves it".into(),
                            );
                        }
                        (RunState::Dwelling { .. }, _) => {}
                        _ => self.checkout_next(),
                    }
                }
            },
            Action::CheckoutSingle => {
                c.single = !c.single;
                let text = if c.single {
                    "single step: one line per press"
                } else {
                    "continuous: lines follow while the key is held"
                };
                self.say(NoteLevel::Info, text.into());
            }
            Action::CheckoutSlower | Action::CheckoutFaster => {
                c.change_factor(action == Action::CheckoutFaster);
                let factor = c.factor;
                self.say(
                    NoteLevel::Info,
                    format!("check-out speed {factor} % (from the next line on)"),
                );
            }
            Action::CheckoutAbort => self.checkout_end(),
            Action::CheckoutFromLine => {
                if c.piece.is_some() {
                    self.say(
                        NoteLevel::Warning,
                        "a piece of a job with waits starts from a line only as the whole job: \
                         `jogterm run --from-line`"
                            .into(),
                    );
                    return;
                }
                if c.state == RunState::Running {
                    self.say(
                        NoteLevel::Warning,
                        "a line is running: let the key go first".into(),
                    );
                    return;
                }
                if let Some(line) = c.current_line() {
                    self.e.buffer.move_to(Cursor::new(line, 0));
                }
                self.checkout_ask(true);
            }
            _ => {}
        }
    }

    /// Leave the check-out: whatever runs is stopped, a paused rest is
    /// discarded (0xFF).
    fn checkout_end(&mut self) {
        let Some(c) = self.e.checkout.take() else {
            return;
        };
        // A streamed piece left: its job ends with it.
        if c.piece.is_some()
            && let Some(job) = self.e.chunked.take()
        {
            self.say(
                NoteLevel::Danger,
                format!("the job ends in {}: its stream was left (x)", job.label()),
            );
        }
        // Left before its end: ended early (after its end, nothing is
        // armed any more).
        self.outputs_early();
        match c.state {
            RunState::Running => self.out.effects.push(Effect::Stop),
            RunState::Paused { rest: Some(_) } => {
                // The break (manual 2.2.31): the rest is forgotten.
                self.out.effects.push(Effect::Device(Request::Raw {
                    line: "\u{ff}".into(),
                }));
            }
            _ => {}
        }
        let elapsed = self.ctx.now.saturating_duration_since(c.started).as_secs();
        self.say(
            NoteLevel::Info,
            format!(
                "check-out ended: {} line{} run in {elapsed} s",
                c.lines_done,
                if c.lines_done == 1 { "" } else { "s" }
            ),
        );
    }

    /// Send the next line (or resume the paused one).
    pub(super) fn checkout_next(&mut self) {
        let ctx = self.ctx;
        // A stream's lease is the dead man of a stalled console, not a key
        // let go: it runs at the program's speeds, as `jogterm run --stream`.
        let streaming = self.e.checkout.as_ref().is_some_and(|c| c.stream.is_some());
        let caps: Vec<(Axis, Option<u32>)> = crate::axis::Axis::ALL
            .into_iter()
            .map(|a| (a, if streaming { None } else { self.cap_hz(a) }))
            .collect();
        loop {
            let Some(c) = self.e.checkout.as_mut() else {
                return;
            };
            let factor = c.factor;
            let capped = std::cell::Cell::new(false);
            let speed = |axis: Axis, hz: u32| {
                let cap = caps.iter().find(|(a, _)| *a == axis).and_then(|(_, c)| *c);
                let v = scaled(hz, factor, cap);
                if v < scaled(hz, factor, None) {
                    capped.set(true);
                }
                v
            };
            if let RunState::Paused { rest } = c.state.clone() {
                let Some(text) = c.line_text.clone() else {
                    c.state = RunState::Ready;
                    continue;
                };
                let text = match &c.plan {
                    // An EMCU keeps no rest: what is left of the move,
                    // from where the axes stand.
                    RunPlan::Emcu(p) if p.is_move() && c.preamble.is_empty() => {
                        let start = c.line_start.unwrap_or_default();
                        match p.rest_of_move(start, machine_now(ctx)) {
                            Some(rest) => rest,
                            None => {
                                // Nothing is left: the line is done.
                                c.plan.advance(None);
                                c.at_line = c.plan.line();
                                c.line_text = None;
                                c.state = RunState::Ready;
                                continue;
                            }
                        }
                    }
                    _ => text,
                };
                self.checkout_send(text, rest);
                return;
            }
            // Slot speeds serve every axis: the lowest cap.
            let slot_speed = |hz: u32| {
                let v = caps.iter().map(|(a, _)| speed(*a, hz)).min().unwrap_or(hz);
                v.max(1)
            };
            let (text, line) = if let Some((pre, line)) = c.preamble.first().cloned() {
                match (pre, &c.plan) {
                    (PreLine::Isel(command), RunPlan::Isel(plan)) => {
                        let command = with_speeds(command, plan.config(), &speed);
                        (line_text(ctx.setup.isel_device, &command), line)
                    }
                    (PreLine::Emcu(command), RunPlan::Emcu(_)) => {
                        match checkout_emcu::step_of(command, &slot_speed) {
                            EmcuStep::Send { line: text, .. } => (text, line),
                            EmcuStep::Dwell(_) | EmcuStep::Nothing => {
                                c.preamble.remove(0);
                                continue;
                            }
                        }
                    }
                    _ => {
                        c.preamble.clear();
                        continue;
                    }
                }
            } else {
                let Some(line) = c.plan.line() else {
                    self.checkout_finished();
                    return;
                };
                let step = match &c.plan {
                    RunPlan::Isel(plan) => plan.step(&speed).map(|s| match s {
                        DncStep::Send { command, .. } | DncStep::ReadPort { command } => {
                            EmcuStep::Send {
                                line: line_text(ctx.setup.isel_device, &command),
                                moves: false,
                            }
                        }
                        DncStep::Dwell(d) => EmcuStep::Dwell(d),
                        DncStep::Nothing => EmcuStep::Nothing,
                    }),
                    RunPlan::Emcu(plan) => plan.step(&slot_speed),
                };
                match step {
                    Some(EmcuStep::Send { line: text, .. }) => (text, line),
                    Some(EmcuStep::Dwell(d)) => {
                        c.at_line = Some(line);
                        c.state = RunState::Dwelling { left: d };
                        c.dwell_tick = Some(ctx.now);
                        self.checkout_follow();
                        return;
                    }
                    Some(EmcuStep::Nothing) => {
                        c.plan.advance(None);
                        c.at_line = c.plan.line();
                        continue;
                    }
                    None => {
                        self.checkout_finished();
                        return;
                    }
                }
            };
            c.line_text = Some(text.clone());
            c.at_line = Some(line);
            c.line_start = Some(machine_now(ctx));
            if let Some(s) = c.stream.as_mut() {
                let program = c
                    .piece
                    .as_ref()
                    .map_or(self.e.buffer.program(), |p| &p.program);
                let command = program.index_of(line);
                let running_s = s.running_s(c.started, ctx.now);
                // The model's pace counts from the job's first G-code line.
                // `origins` are by the text's lines, as `line` is.
                let origin = command.and(s.origins.get(line).copied().flatten());
                if let (Some(eta), Some(_)) = (s.eta.as_mut(), origin) {
                    eta.start(line, c.factor, running_s);
                }
                if let Some(origin) = origin {
                    self.job_log_line(origin);
                }
            }
            self.checkout_send(text, None);
            if capped.get() {
                self.say(
                    NoteLevel::Warning,
                    format!(
                        "line {}: speed capped to keep the dead-man bound (jog.max_overrun), \
                         as a continuous jog's",
                        line + 1
                    ),
                );
            }
            self.checkout_follow();
            return;
        }
    }

    /// `text` to the device task as the check-out's line, held by the
    /// repeat timeout's lease; `resume`: the paused line whose rest it
    /// finishes.
    fn checkout_send(&mut self, text: String, resume: Option<crate::device::api::JogId>) {
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        let id = c.new_id();
        c.line_id = Some(id);
        c.state = RunState::Running;
        if let Some(s) = c.stream.as_mut() {
            s.renewed = self.ctx.now;
        }
        // A check-out shows where each line ended; a stream reads that
        // only where its end is not known (the bytes are time in the part).
        let read_back = c.stream.is_none();
        self.out.effects.push(Effect::Device(Request::Checkout {
            id,
            line: text,
            lease: c.lease(self.ctx.setup.jog.repeat_timeout),
            resume,
            read_back,
        }));
    }

    fn checkout_finished(&mut self) {
        if self.e.checkout.as_ref().is_some_and(|c| c.piece.is_some()) {
            self.piece_streamed();
            return;
        }
        self.outputs_ended();
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        c.state = RunState::Finished;
        c.line_id = None;
        let finish = match &c.plan {
            RunPlan::Isel(p) => p.finish().cloned(),
            RunPlan::Emcu(_) => None,
        };
        let why = match finish {
            Some(Finish::LoopStack { line }) => format!(
                "line {}: a loop needs an eighth counter (the controller would answer 6)",
                line + 1
            ),
            Some(Finish::OutOfProgram { line }) => {
                format!("line {}: the jump leads out of the program", line + 1)
            }
            Some(Finish::Broken { line }) => format!("line {} does not parse", line + 1),
            Some(Finish::End) | None => "the program's end".to_string(),
        };
        let elapsed = self.ctx.now.saturating_duration_since(c.started).as_secs();
        let done = c.lines_done;
        let what = if c.stream.is_some() {
            "the stream ended (x leaves it)"
        } else {
            "check-out done"
        };
        self.say(
            NoteLevel::Info,
            format!("{what}: {done} lines in {elapsed} s, at {why}"),
        );
    }

    /// A device event: the line's end, a lost link.
    pub(super) fn checkout_event(&mut self, event: &Event) {
        let ctx = self.ctx;
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        match event {
            Event::Checkout { id, end } if Some(*id) == c.line_id => {
                c.line_id = None;
                let line = c.at_line.map_or(0, |l| l + 1);
                match end {
                    CheckoutEnd::Done { byte } => {
                        c.lines_done += 1;
                        if c.preamble.is_empty() {
                            c.plan.advance(*byte);
                        } else {
                            c.preamble.remove(0);
                        }
                        c.at_line = c.preamble.first().map(|(_, l)| *l).or(c.plan.line());
                        c.line_text = None;
                        c.state = RunState::Ready;
                        if c.single {
                            c.latched = true;
                        }
                        let go_on = c.runs_on(ctx.now, ctx.setup.jog.repeat_timeout);
                        if go_on {
                            self.checkout_next();
                        } else if c.plan.line().is_none() && c.preamble.is_empty() {
                            self.checkout_finished();
                        }
                        self.checkout_follow();
                    }
                    CheckoutEnd::Paused { rest, dead_man } => {
                        c.state = RunState::Paused {
                            rest: rest.then_some(*id),
                        };
                        let streamed = c.stream.is_some();
                        let why = match (*dead_man, streamed) {
                            (true, true) => "the console stopped renewing its lease",
                            (true, false) => "the key's repeats stopped",
                            (false, true) => "paused by F10",
                            (false, false) => "the key was let go",
                        };
                        let at = self.position_text();
                        let then = if streamed {
                            "F10 goes on, x ends the stream"
                        } else {
                            "hold to resume, x ends the check-out"
                        };
                        let kept = self.outputs_paused();
                        self.say(
                            NoteLevel::Warning,
                            format!("PAUSED at line {line} ({why}) at {at}: {then}{kept}"),
                        );
                    }
                    CheckoutEnd::Stopped => {
                        self.checkout_stopped(format!("stopped in line {line}"))
                    }
                    CheckoutEnd::Fault(f) => {
                        self.job_log_end(crate::joblog::How::Error);
                        self.checkout_stopped(format!(
                            "line {line}: the controller answered {} ({}); {}",
                            f.code,
                            f.meaning,
                            f.recovery.instruction()
                        ))
                    }
                    CheckoutEnd::Refused(r) => {
                        self.job_log_end(crate::joblog::How::Error);
                        self.checkout_stopped(format!("line {line} refused: {r}"))
                    }
                    CheckoutEnd::LinkLost => self.checkout_stopped(format!(
                        "the link was lost in line {line}; nothing resumes by itself"
                    )),
                }
            }
            Event::Link(LinkState::Lost { .. } | LinkState::Closed)
                if !matches!(c.state, RunState::Stopped { .. } | RunState::Finished) =>
            {
                let line = c.at_line.map_or(0, |l| l + 1);
                self.checkout_stopped(format!(
                    "the link was lost at line {line}; nothing resumes by itself"
                ));
            }
            _ => {}
        }
    }

    fn checkout_stopped(&mut self, why: String) {
        let mut piece = false;
        if let Some(c) = self.e.checkout.as_mut() {
            c.state = RunState::Stopped { why: why.clone() };
            c.line_id = None;
            c.latched = true;
            piece = c.piece.is_some();
        }
        // A streamed piece's stop ends its job: no later piece follows.
        match self.e.chunked.take().filter(|_| piece) {
            Some(job) => self.say(
                NoteLevel::Danger,
                format!(
                    "the job stopped in {}: {why}; nothing resumes (x leaves the stream)",
                    job.label()
                ),
            ),
            None => self.say(NoteLevel::Danger, format!("check-out: {why}")),
        }
        self.outputs_early();
    }

    /// Where the axes are, in work coordinates.
    fn position_text(&self) -> String {
        let ctx = self.ctx;
        let mut out = Vec::new();
        for (axis, p) in &ctx.setup.axes {
            if let Some(r) = ctx.positions.get(*axis) {
                let zero = ctx.machine.work_zero.get(*axis).unwrap_or(0);
                out.push(format!(
                    "{axis}{}",
                    crate::ui::position::format_amount((r.steps - zero) as f64 / p.steps_per_unit)
                ));
            }
        }
        out.join(" ")
    }

    /// Time passes: a dwell counts down while the key is held.
    pub(super) fn checkout_tick(&mut self) {
        let ctx = self.ctx;
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        let RunState::Dwelling { left } = c.state else {
            return;
        };
        let last = c.dwell_tick.replace(ctx.now).unwrap_or(ctx.now);
        if !c.runs_on(ctx.now, ctx.setup.jog.repeat_timeout) {
            return;
        }
        let left = left.saturating_sub(ctx.now.saturating_duration_since(last));
        if left.is_zero() {
            c.plan.advance(None);
            c.lines_done += 1;
            c.at_line = c.plan.line();
            c.state = RunState::Ready;
            if c.single {
                c.latched = true;
            } else {
                self.checkout_next();
            }
            self.checkout_follow();
        } else {
            c.state = RunState::Dwelling { left };
        }
    }
}

/// `items` joined by commas, or `none` when there are none (the question
/// before a run from a line).
fn joined_or(items: &[String], none: &str) -> String {
    if items.is_empty() {
        none.to_string()
    } else {
        items.join(", ")
    }
}

/// Where the axes stand now, machine steps (an EMCU's counters).
fn machine_now(ctx: &crate::ui::editor::component::Context) -> [i64; 4] {
    let mut at = [0i64; 4];
    for (axis, _) in &ctx.setup.axes {
        if let (Some(r), Some(slot)) = (ctx.positions.get(*axis), at.get_mut(axis.index())) {
            *slot = r.steps;
        }
    }
    at
}
