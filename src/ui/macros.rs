//! Running a profile's macro (`[macros.NAME]`, `config::macros`): its lines
//! go to the device task one at a time as typed raw lines, each after the
//! answer to the one before, so they meet the same refusals as a line typed
//! on the command line (no motion while the state is unknown, an E-stop, a
//! fault). A refusal, a controller error, a lost link or a stop (Space) ends
//! the macro there; the lines after it are not sent.
//!
//! The state is the run (`Model::macro_run`); what a macro reads of the
//! rest of the console comes in a [`Context`], and what it asks for goes
//! back as effects, notes and a question ([`Outcome`]), which `ui::update`
//! applies: the model is not imported here.

use crate::config::macros::Macro;
use crate::device::api::{Activity, Event, LinkState, MachineState, ReplyKind, Request};
use crate::device::describe::describe;

use super::msg::Effect;
use super::outcome::{Confirmation, Note, Outcome, Then};
use super::raw::{self, RawContext};
use super::traffic_log::NoteLevel;

/// What a macro reads of the console, built per call.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The profile's macros.
    pub macros: &'a [Macro],
    pub machine: &'a MachineState,
    /// What the command line checks a line against.
    pub raw: RawContext,
}

/// A macro being run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MacroRun {
    pub name: String,
    pub lines: Vec<String>,
    /// The line sent last (index into `lines`), whose answer is awaited.
    pub current: usize,
    /// Its answer came while the machine was still busy (an EMCU batch
    /// runs on after its acknowledgement): the next line waits for the
    /// machine to stand, or the device task would refuse it as busy.
    pub answered: bool,
}

impl MacroRun {
    fn line(&self) -> &str {
        self.lines.get(self.current).map_or("", String::as_str)
    }

    /// `macro park, line 2 of 3`.
    pub fn place(&self) -> String {
        format!(
            "macro {}, line {} of {}",
            self.name,
            self.current + 1,
            self.lines.len()
        )
    }
}

/// The title of the question before a macro runs.
pub const CONFIRM_TITLE: &str = "Run macro";

/// A macro's key was pressed: ask first when the profile says so (every
/// macro that may move, unless `confirm = false`), else run it.
pub fn key(run: &mut Option<MacroRun>, ctx: &Context, name: &str) -> Outcome {
    let Some(m) = find(ctx, name) else {
        return not_found(name);
    };
    if let Some(refused) = refusal(run, ctx, &m) {
        return Outcome::note(NoteLevel::Warning, refused);
    }
    if !m.confirm {
        return start(run, ctx, name);
    }
    let what = m.description.clone().unwrap_or_else(|| m.lines.join("  "));
    let moves = if m.moves {
        " It moves the machine."
    } else {
        ""
    };
    Outcome {
        confirm: Some(Confirmation {
            title: format!("{CONFIRM_TITLE} {}", m.name),
            question: format!(
                "{what}.{moves} Send its {} lines? Space stops it.",
                m.lines.len()
            ),
            effects: Vec::new(),
            then: Some(Then::Macro(m.name.clone())),
        }),
        ..Outcome::default()
    }
}

fn not_found(name: &str) -> Outcome {
    Outcome::note(
        NoteLevel::Warning,
        format!("no macro `{name}` in the profile"),
    )
}

fn find(ctx: &Context, name: &str) -> Option<Macro> {
    ctx.macros.iter().find(|m| m.name == name).cloned()
}

/// Why the macro cannot start now: one already runs, the machine is busy,
/// or a line does not pass the command line's check for the controller as
/// it is initialised now.
fn refusal(run: &Option<MacroRun>, ctx: &Context, m: &Macro) -> Option<String> {
    if let Some(run) = run {
        return Some(format!(
            "macro {} not started: {} is running (Space stops it)",
            m.name,
            run.place()
        ));
    }
    if ctx.machine.activity != Activity::Idle {
        return Some(format!(
            "macro {} not started: the machine is busy ({:?}); stop it first",
            m.name, ctx.machine.activity
        ));
    }
    m.lines.iter().enumerate().find_map(|(i, line)| {
        raw::validate(&ctx.raw, line).err().map(|e| {
            format!(
                "macro {} not started: line {} `{line}`: {}",
                m.name,
                i + 1,
                e.message
            )
        })
    })
}

/// Start the macro `name`: its first line goes to the device task.
pub fn start(run: &mut Option<MacroRun>, ctx: &Context, name: &str) -> Outcome {
    let Some(m) = find(ctx, name) else {
        return not_found(name);
    };
    if let Some(refused) = refusal(run, ctx, &m) {
        return Outcome::note(NoteLevel::Warning, refused);
    }
    let started = MacroRun {
        name: m.name,
        lines: m.lines,
        current: 0,
        answered: false,
    };
    let note = format!("{}: {}", started.place(), started.line());
    let line = started.line().to_string();
    *run = Some(started);
    Outcome {
        effects: vec![Effect::Request(Request::Raw { line })],
        ..Outcome::note(NoteLevel::Info, note)
    }
}

/// A device event while a macro runs: the answer to its line sends the
/// next (once the machine stands); a refusal, an error or a lost link ends
/// it.
pub fn device_event(slot: &mut Option<MacroRun>, machine: &MachineState, event: &Event) -> Outcome {
    let Some(run) = slot.as_mut() else {
        return Outcome::default();
    };
    let sent = describe(&Request::Raw {
        line: run.line().to_string(),
    });
    let next = match event {
        Event::Reply {
            kind: ReplyKind::Answer,
            ..
        } if !run.answered => {
            run.answered = true;
            machine.activity == Activity::Idle
        }
        Event::State(state) => run.answered && state.activity == Activity::Idle,
        _ => false,
    };
    if next {
        return if run.current + 1 < run.lines.len() {
            run.current += 1;
            run.answered = false;
            let line = run.line().to_string();
            let note = format!("{}: {line}", run.place());
            let effects = vec![Effect::Request(Request::Raw { line })];
            Outcome {
                effects,
                ..Outcome::note(NoteLevel::Info, note)
            }
        } else {
            let done = format!("macro {} done ({} lines)", run.name, run.lines.len());
            *slot = None;
            Outcome::note(NoteLevel::Info, done)
        };
    }
    let why = match event {
        Event::Refused { request, reason } if *request == sent => format!("refused: {reason}"),
        Event::Fault(fault) => format!(
            "the controller answered `{}`: {}",
            fault.code, fault.meaning
        ),
        Event::Link(LinkState::Lost { reason }) => format!("link lost: {reason}"),
        _ => return Outcome::default(),
    };
    let rest = match run.lines.len() - run.current - 1 {
        0 => String::new(),
        1 => "; the last line was not sent".to_string(),
        n => format!("; the {n} lines after it were not sent"),
    };
    let text = format!("{}: {why}{rest}", run.place());
    *slot = None;
    Outcome::note(NoteLevel::Danger, text)
}

/// Everything was stopped: the macro sends nothing more.
pub fn stopped(run: &mut Option<MacroRun>) -> Option<Note> {
    let run = run.take()?;
    let left = run.lines.len() - run.current - 1;
    Some((
        NoteLevel::Warning,
        format!(
            "{} stopped by the operator; {left} more not sent",
            run.place()
        ),
    ))
}
