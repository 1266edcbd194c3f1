//! Framing the job in the console (`docs/gcode.md`, "Frame the job"): `F`
//! traces the rectangle of the G-code job open in the editor, at its safe
//! height, at the jog speed, as `jogterm frame` does, so that the operator
//! sees where the job lies on the stock before anything cuts. The plan is
//! `gcode::frame` (the job panel's import computed it with the console's
//! work offsets); each leg is a go-to in machine coordinates, sent when
//! the one before has ended.
//!
//! Nothing moves before the question is answered; the run is armed only by
//! the answer (`Then::Frame`), never by the question, so a jog made after a
//! declined question cannot be taken for a leg. Any stop ends the frame
//! (the router drops it when a stop goes out), as do a fault, a refusal
//! and a lost link: nothing resumes.
//!
//! **Hold-to-run** (`f` held): the same frame without the question, moving
//! only while the key is held, as a jog does. The device task holds the
//! motion (`Request::Hold`, renewed by every key repeat, first for the
//! terminal's delay before its first repeat, then for the repeat timeout):
//! when the repeats stop, because the key was let go or the console
//! stalled, the task stops the machine itself and says so
//! (`Event::HoldLapsed`); a key release the terminal reports stops at once.

use crate::axis::Axis;
use crate::device::api::{Event, Frame as Coordinates, LinkState, Request};
use crate::gcode::frame::{Frame, LegKind};
use crate::gcode::toolpath::Point;
use crate::jog::{Gate, JogSettings, Motion};
use crate::offsets::WorkOffsets;

pub mod plan;

pub use plan::{Leg, Plan};

use super::jog::goto::{self, Target};
use super::legs::{self, Legs};
use super::msg::Effect;
use super::position::Positions;
use super::traffic_log::NoteLevel;

/// A frame being traced: its legs as planned (for what is said of each)
/// and their run.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameRun {
    legs: Vec<Leg>,
    run: Legs,
    /// Hold-to-run: the device task holds the motion while the key is held.
    held: bool,
}

impl FrameRun {
    /// Run while a key is held (`f`), not to its end.
    pub fn held(&self) -> bool {
        self.held
    }
}

/// What `F` reads of the console, built per call.
pub struct Context<'a> {
    /// The G-code job open in the editor: its file and frame (the import's,
    /// or why it has none); `None` without one.
    pub job: Option<(&'a str, &'a Result<Frame, String>)>,
    /// The job is being checked again (the work offset changed): its frame
    /// is not known yet.
    pub checking: bool,
    pub gate: Gate<'a>,
    pub settings: &'a JogSettings,
    pub offsets: &'a WorkOffsets,
    /// The jog speed selected, units per second.
    pub speed: f64,
    pub positions: &'a Positions,
}

/// The question `F` asks, with the plan its answer starts.
pub struct Question {
    pub title: String,
    pub question: String,
    pub plan: Plan,
}

/// `F`: the frame's question, or why there is none.
pub fn question(ctx: &Context) -> Result<Question, String> {
    let Some((file, frame)) = ctx.job else {
        return Err(
            "frame: no G-code job is open: open one in the program editor (Ctrl-O), then F".into(),
        );
    };
    if ctx.checking {
        return Err(format!(
            "frame: {file} is being checked again for the new work offset: F again in a moment"
        ));
    }
    let frame = frame
        .as_ref()
        .map_err(|why| format!("frame: {file}: {why}"))?;
    ctx.gate
        .check(Motion::GoTo)
        .map_err(|r| format!("frame refused: {r}"))?;
    let limits = [Axis::X, Axis::Y, Axis::Z].map(|axis| {
        ctx.settings
            .axis(axis)
            .map_or((f64::NEG_INFINITY, f64::INFINITY), |a| (a.min, a.max))
    });
    if let Some(why) = frame.outside(limits) {
        return Err(format!("frame refused: {why}"));
    }
    let here = here(ctx.settings, ctx.positions)
        .ok_or("frame refused: the controller has not reported where X, Y and Z stand")?;
    let mut legs = Vec::new();
    for leg in frame.legs(here) {
        let units = vec![
            (Axis::X, leg.to.x),
            (Axis::Y, leg.to.y),
            (Axis::Z, leg.to.z),
        ];
        let target = Target {
            machine: true,
            ..Target::plain(units)
        };
        let planned = goto::request(
            &target,
            Coordinates::Machine,
            ctx.settings,
            ctx.offsets,
            ctx.speed,
        )
        .map_err(|e| format!("frame refused: {e}"))?;
        let Request::MoveTo { target, .. } = &planned.request else {
            continue;
        };
        legs.push(Leg {
            kind: leg.kind,
            to: leg.to,
            target: *target,
            request: planned.request.clone(),
        });
    }
    let up = if legs.first().is_some_and(|l| l.kind == LegKind::Up) {
        "Z goes up alone to the safe height first, then "
    } else {
        ""
    };
    let question = format!(
        "{file}: the frame X {} to {}, Y {} to {} (machine) at Z {} (the job's highest Z), at \
         {} per second. {up}X and Y go round the four corners and back to the first. Keep clear \
         of the machine; Space stops it. Trace the frame?",
        num(frame.min_x),
        num(frame.max_x),
        num(frame.min_y),
        num(frame.max_y),
        num(frame.z),
        num(ctx.speed),
    );
    Ok(Question {
        title: "Frame the job".into(),
        question,
        plan: Plan {
            legs,
            from: ctx.positions.xyz_steps(),
        },
    })
}

/// The answer was yes (or the hold key pressed: `hold` is the device
/// task's first lease): the run, and the first leg that moves, the hold
/// before it.
pub fn start(
    run: &mut Option<FrameRun>,
    plan: Plan,
    positions: &Positions,
    hold: Option<std::time::Duration>,
) -> (Vec<Effect>, NoteLevel, String) {
    if positions.xyz_steps() != plan.from {
        *run = None;
        return (
            Vec::new(),
            NoteLevel::Danger,
            "frame not started: the axes moved since the question; F asks again from where they \
             stand"
                .into(),
        );
    }
    let legs = Legs::new(
        plan.legs
            .iter()
            .map(|l| legs::Leg {
                target: l.target,
                request: l.request.clone(),
            })
            .collect(),
    );
    let mut started = FrameRun {
        legs: plan.legs,
        run: legs,
        held: hold.is_some(),
    };
    let sent = started.send_from(0, positions);
    match sent {
        Some((legs, text)) => {
            *run = Some(started);
            let mut effects: Vec<Effect> = hold
                .map(|lease| Effect::Request(Request::Hold { lease }))
                .into_iter()
                .collect();
            effects.extend(legs);
            (effects, NoteLevel::Info, text)
        }
        None => {
            *run = None;
            (
                Vec::new(),
                NoteLevel::Info,
                "frame: the tool stands on the frame already".into(),
            )
        }
    }
}

/// A device event while a frame runs: the next leg when one ended, the
/// end of the frame when the last did or something broke it off.
pub fn device_event(
    run: &mut Option<FrameRun>,
    positions: &Positions,
    event: &Event,
) -> Option<(Vec<Effect>, NoteLevel, String)> {
    let r = run.as_mut()?;
    // The device task's hold ends with the frame, however it ended.
    let ended = |run: &mut Option<FrameRun>, level, text: String| {
        let held = run.as_ref().is_some_and(|r| r.held);
        *run = None;
        let effects = if held {
            vec![Effect::Request(Request::HoldEnd)]
        } else {
            Vec::new()
        };
        Some((effects, level, text))
    };
    match event {
        Event::State(s) if r.run.ended_by(s.activity) => {
            if let Some(f) = &s.fault {
                let text = format!("frame broken off: `{}`: {}", f.code, f.meaning);
                return ended(run, NoteLevel::Danger, text);
            }
            let next = r.run.current() + 1;
            match r.send_from(next, positions) {
                Some((effects, text)) => Some((effects, NoteLevel::Info, text)),
                None => ended(
                    run,
                    NoteLevel::Info,
                    "frame traced: the tool stands above the first corner".into(),
                ),
            }
        }
        Event::Refused { reason, .. } => ended(
            run,
            NoteLevel::Danger,
            format!("frame broken off: {reason}"),
        ),
        Event::HoldLapsed => {
            *run = None;
            Some((
                Vec::new(),
                NoteLevel::Warning,
                "frame stopped: the key was let go (its repeats stopped); nothing resumes, f \
                 again traces it from the first corner"
                    .into(),
            ))
        }
        Event::Link(LinkState::Connected) => None,
        Event::Link(_) => ended(
            run,
            NoteLevel::Danger,
            "frame broken off: the link was lost; nothing resumes".into(),
        ),
        _ => None,
    }
}

impl FrameRun {
    /// The go-to of the first leg from `from` on that moves (a leg that
    /// ends where the tool stands, as the first corner does on a second
    /// frame, would report no motion to end it), and its note.
    fn send_from(&mut self, from: usize, positions: &Positions) -> Option<(Vec<Effect>, String)> {
        let count = self.legs.len();
        let (index, request) = self
            .run
            .send_from(from, |axis| positions.get(axis).map(|r| r.steps))?;
        let leg = self.legs.get(index)?;
        let Point { x, y, z } = leg.to;
        let what = match leg.kind {
            LegKind::Up => "Z up to the safe height".to_string(),
            LegKind::Corner(n) => format!("corner {n}"),
        };
        let text = format!(
            "frame {}/{count}: {what}, X {} Y {} Z {}",
            index + 1,
            num(x),
            num(y),
            num(z)
        );
        Some((vec![Effect::Request(request)], text))
    }
}

/// Where X, Y and Z stand, machine units; `None` unless all three are
/// known.
fn here(settings: &JogSettings, positions: &Positions) -> Option<Point> {
    let at = |axis| {
        let a = settings.axis(axis)?;
        let steps = positions.get(axis)?.steps;
        Some(steps as f64 / a.steps_per_unit)
    };
    Some(Point {
        x: at(Axis::X)?,
        y: at(Axis::Y)?,
        z: at(Axis::Z)?,
    })
}

fn num(v: f64) -> String {
    super::position::format_amount(v)
}
