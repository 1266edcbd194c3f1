//! Running a profile's macro (`[macros.NAME]`, `config::macros`): its lines
//! go to the device task one at a time as typed raw lines, each after the
//! answer to the one before, so they meet the same refusals as a line typed
//! on the command line (no motion while the state is unknown, an E-stop, a
//! fault). A refusal, a controller error, a lost link or a stop (Space) ends
//! the macro there; the lines after it are not sent.

use crate::config::macros::Macro;
use crate::device::api::{Activity, Event, LinkState, ReplyKind, Request};
use crate::device::describe::describe;

use super::model::{Confirmation, Model, Popup};
use super::msg::Effect;
use super::raw;
use super::traffic_log::NoteLevel;

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
pub fn key(model: &mut Model, name: &str) -> (Vec<Effect>, Vec<(NoteLevel, String)>) {
    let Some(m) = find(model, name) else {
        return not_found(name);
    };
    if let Some(refused) = refusal(model, &m) {
        return (Vec::new(), vec![(NoteLevel::Warning, refused)]);
    }
    if !m.confirm {
        return start(model, name);
    }
    let what = m.description.clone().unwrap_or_else(|| m.lines.join("  "));
    let moves = if m.moves {
        " It moves the machine."
    } else {
        ""
    };
    model.popup = Some(Popup::Confirm(Confirmation {
        title: format!("{CONFIRM_TITLE} {}", m.name),
        question: format!(
            "{what}.{moves} Send its {} lines? Space stops it.",
            m.lines.len()
        ),
        effects: Vec::new(),
        run_macro: Some(m.name.clone()),
    }));
    (Vec::new(), Vec::new())
}

fn not_found(name: &str) -> (Vec<Effect>, Vec<(NoteLevel, String)>) {
    (
        Vec::new(),
        vec![(
            NoteLevel::Warning,
            format!("no macro `{name}` in the profile"),
        )],
    )
}

fn find(model: &Model, name: &str) -> Option<Macro> {
    model.setup.macros.iter().find(|m| m.name == name).cloned()
}

/// Why the macro cannot start now: one already runs, the machine is busy,
/// or a line does not pass the command line's check for the controller as
/// it is initialised now.
fn refusal(model: &Model, m: &Macro) -> Option<String> {
    if let Some(run) = &model.macro_run {
        return Some(format!(
            "macro {} not started: {} is running (Space stops it)",
            m.name,
            run.place()
        ));
    }
    if model.machine.activity != Activity::Idle {
        return Some(format!(
            "macro {} not started: the machine is busy ({:?}); stop it first",
            m.name, model.machine.activity
        ));
    }
    let ctx = model.raw_context();
    m.lines.iter().enumerate().find_map(|(i, line)| {
        raw::validate(&ctx, line).err().map(|e| {
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
pub fn start(model: &mut Model, name: &str) -> (Vec<Effect>, Vec<(NoteLevel, String)>) {
    let Some(m) = find(model, name) else {
        return not_found(name);
    };
    if let Some(refused) = refusal(model, &m) {
        return (Vec::new(), vec![(NoteLevel::Warning, refused)]);
    }
    let run = MacroRun {
        name: m.name,
        lines: m.lines,
        current: 0,
        answered: false,
    };
    let note = (NoteLevel::Info, format!("{}: {}", run.place(), run.line()));
    let effect = Effect::Request(Request::Raw {
        line: run.line().to_string(),
    });
    model.macro_run = Some(run);
    (vec![effect], vec![note])
}

/// A device event while a macro runs: the answer to its line sends the
/// next (once the machine stands); a refusal, an error or a lost link ends
/// it.
pub fn device_event(model: &mut Model, event: &Event) -> (Vec<Effect>, Vec<(NoteLevel, String)>) {
    let Some(run) = model.macro_run.as_mut() else {
        return (Vec::new(), Vec::new());
    };
    let sent = describe(&Request::Raw {
        line: run.line().to_string(),
    });
    let ended = |run: &MacroRun, why: String| {
        let left = run.lines.len() - run.current - 1;
        let rest = match left {
            0 => String::new(),
            1 => "; the last line was not sent".to_string(),
            n => format!("; the {n} lines after it were not sent"),
        };
        (NoteLevel::Danger, format!("{}: {why}{rest}", run.place()))
    };
    let next = match event {
        Event::Reply {
            kind: ReplyKind::Answer,
            ..
        } if !run.answered => {
            run.answered = true;
            model.machine.activity == Activity::Idle
        }
        Event::State(state) => run.answered && state.activity == Activity::Idle,
        _ => false,
    };
    if next {
        return if run.current + 1 < run.lines.len() {
            run.current += 1;
            run.answered = false;
            let line = run.line().to_string();
            let note = (NoteLevel::Info, format!("{}: {line}", run.place()));
            (vec![Effect::Request(Request::Raw { line })], vec![note])
        } else {
            let done = format!("macro {} done ({} lines)", run.name, run.lines.len());
            model.macro_run = None;
            (Vec::new(), vec![(NoteLevel::Info, done)])
        };
    }
    match event {
        Event::Refused { request, reason } if *request == sent => {
            let note = ended(run, format!("refused: {reason}"));
            model.macro_run = None;
            (Vec::new(), vec![note])
        }
        Event::Fault(fault) => {
            let note = ended(
                run,
                format!(
                    "the controller answered `{}`: {}",
                    fault.code, fault.meaning
                ),
            );
            model.macro_run = None;
            (Vec::new(), vec![note])
        }
        Event::Link(LinkState::Lost { reason }) => {
            let note = ended(run, format!("link lost: {reason}"));
            model.macro_run = None;
            (Vec::new(), vec![note])
        }
        _ => (Vec::new(), Vec::new()),
    }
}

/// Everything was stopped: the macro sends nothing more.
pub fn stopped(model: &mut Model) -> Option<(NoteLevel, String)> {
    let run = model.macro_run.take()?;
    let left = run.lines.len() - run.current - 1;
    Some((
        NoteLevel::Warning,
        format!(
            "{} stopped by the operator; {left} more not sent",
            run.place()
        ),
    ))
}
