//! Work offsets in the console (`docs/jogging.md`, "Work offsets"): the
//! table of G54-G59 the session works in ([`OffsetsState`], in the model),
//! choosing the active one (`O`, [`OffsetsChoice`]), the work zero set
//! where the machine stands (`z`, `Z`) and "set X = 10 here" (`s`,
//! [`set_here`]), and what the controller's own zero has to do with it.
//!
//! One source of truth: jogterm's table, machine steps. The position
//! display, go-to and `G` count from the active system's zero. The isel
//! controller's virtual zero (`@0n`, manual 2.2.19) can only be put where
//! an axis stands, and stored programs' absolute moves count from it: a
//! zero set to 0 here (`z`, `Z`, `s` with `X0`) sends `@0n` of those axes
//! too, so the two agree; where they do not ("X = 10 here", another system
//! chosen, a restart), the position panel says so ([`programs_differ`])
//! and going to the work zero (`G`) and zeroing there (`z`) brings them
//! together. EMCU and EMP have no zero of their own: the driver keeps a
//! copy for its work frame (`Request::SetZero`), jogterm's own moves go in
//! machine coordinates.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{PositionSource, Request};
use crate::jog::Motion;
use crate::offsets::store::{OffsetsFile, SaveJob, Saved, Startup};
use crate::offsets::{System, WorkOffsets};
use crate::proto::Protocol;

use super::super::msg::Effect;
use super::super::position::format_units;
use super::super::traffic_log::NoteLevel;
use super::context::{Context, Note};
use super::goto::Target;
use crate::jog::Gate;
use crate::ui::setup::Setup;

/// The session's work offsets and where they are kept.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OffsetsState {
    pub table: WorkOffsets,
    /// The file they are saved to; `None`: kept for this session only.
    pub file: Option<OffsetsFile>,
    /// The file on disk was refused at start: it is put aside before the
    /// first write, and the position panel marks the active name (`G54!`).
    pub refused: bool,
    /// Why, or anything else said at start (shown in the `O` popup).
    pub note: Option<String>,
}

impl OffsetsState {
    /// What the session starts with: read from `file` (`Startup`), or only
    /// in memory without a state directory.
    pub fn start(startup: Option<(Startup, OffsetsFile)>) -> OffsetsState {
        match startup {
            Some((s, file)) => OffsetsState {
                table: s.offsets,
                file: Some(file),
                refused: s.refused,
                note: s.note,
            },
            None => OffsetsState {
                note: Some(
                    "work offsets are kept for this session only: there is no state directory \
                     (set JOGTERM_STATE_DIR)"
                        .into(),
                ),
                ..OffsetsState::default()
            },
        }
    }

    /// The write of the table as it is now, if it is kept in a file.
    pub fn save(&mut self) -> Option<Effect> {
        let file = self.file.as_ref()?;
        let job: SaveJob = file.job(&self.table, std::mem::take(&mut self.refused));
        Some(Effect::SaveOffsets(job))
    }
}

/// The session starts with `startup` (read from its file; `None` without a
/// state directory); what there is to say about it comes back as a note.
pub fn start(offsets: &mut OffsetsState, startup: Option<(Startup, OffsetsFile)>) -> Option<Note> {
    *offsets = OffsetsState::start(startup);
    let note = offsets.note.clone()?;
    let level = if offsets.refused {
        NoteLevel::Danger
    } else {
        NoteLevel::Warning
    };
    Some((level, note))
}

/// How a write of the offsets file went: said only when it failed.
pub fn saved(what: &str, saved: &Saved) -> Option<Note> {
    saved.as_ref().err().map(|why| {
        (
            NoteLevel::Danger,
            format!("{what} not saved: {why}; the change is lost when jogterm ends"),
        )
    })
}

/// The `O` popup: the six systems, the selected one (cursor), the active
/// one marked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OffsetsChoice {
    pub selected: System,
}

impl OffsetsChoice {
    pub fn new(offsets: &OffsetsState) -> OffsetsChoice {
        OffsetsChoice {
            selected: offsets.table.active(),
        }
    }

    /// Move the cursor by `delta`, within G54-G59.
    pub fn step(&mut self, delta: isize) {
        let i = self.selected.index() as isize + delta;
        let i = i.clamp(0, System::COUNT as isize - 1) as usize;
        self.selected = System::from_index(i).unwrap_or(self.selected);
    }
}

/// Make `system` the active one: saved, and said with its zero.
pub fn activate(offsets: &mut OffsetsState, ctx: &Context, system: System) -> (Vec<Effect>, Note) {
    offsets.table.select(system);
    let mut text = format!(
        "{system} active: work coordinates count from its zero (machine {})",
        zero_words(offsets, ctx.setup, system)
    );
    if let Some(more) = programs_note(offsets, ctx) {
        text.push_str("; ");
        text.push_str(&more);
    }
    let effects = offsets.save().into_iter().collect();
    (effects, (NoteLevel::Info, text))
}

/// `X 102.345 Y 50.000 Z 0.000`: a system's zero in machine units.
pub fn zero_words(offsets: &OffsetsState, setup: &Setup, system: System) -> String {
    setup
        .axes
        .iter()
        .map(|(axis, p)| {
            format!(
                "{axis} {}",
                format_units(p, offsets.table.zero(system, *axis))
            )
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The axes on which stored programs count from another zero than the
/// active system's: isel only (its `@0n` virtual zero, as the driver last
/// knew it), where the driver knows it.
pub fn programs_differ(offsets: &OffsetsState, ctx: &Context) -> AxisSet {
    if ctx.setup.protocol != Protocol::Isel {
        return AxisSet::EMPTY;
    }
    ctx.setup
        .axes
        .iter()
        .map(|(a, _)| *a)
        .filter(|a| {
            ctx.machine
                .work_zero
                .get(*a)
                .is_some_and(|v| v != offsets.table.active_zero(*a))
        })
        .collect()
}

/// What to tell the operator when the controller's zero and the active
/// system's differ.
fn programs_note(offsets: &OffsetsState, ctx: &Context) -> Option<String> {
    let differ = programs_differ(offsets, ctx);
    (!differ.is_empty()).then(|| {
        format!(
            "programs stored in the controller count from its own zero (@0n), which is \
             elsewhere on {differ}: go to the work zero (G) and zero it there (z) to bring it \
             along"
        )
    })
}

/// Why the work zero cannot be set now on `axes`; the machine positions to
/// set it from otherwise. Needs the machine standing (the gate of
/// `Motion::SetZero`), each axis referenced (a zero counted from an
/// unreferenced count is wrong after the reference run, and would be saved
/// so) and its position read, not estimated.
fn positions_for(gate: &Gate, ctx: &Context, axes: AxisSet) -> Result<Vec<(Axis, i64)>, String> {
    gate.check(Motion::SetZero).map_err(|r| r.to_string())?;
    let unreferenced: AxisSet = axes
        .iter()
        .filter(|a| !ctx.machine.referenced.contains(*a))
        .collect();
    if !unreferenced.is_empty() {
        return Err(format!(
            "{unreferenced} not referenced: a work zero counted from there would be wrong after \
             the reference run; reference (h) first"
        ));
    }
    axes.iter()
        .map(|axis| match ctx.positions.get(axis) {
            Some(r) if r.source == PositionSource::Measured => Ok((axis, r.steps)),
            Some(_) => Err(format!(
                "{axis} is moving (its position is estimated): wait until it stands"
            )),
            None => Err(format!("the position of {axis} is not known yet")),
        })
        .collect()
}

/// The work zero of the active system on `axes` where the machine stands
/// (`z`, `Z`): saved, and `SetZero` for the controller (isel `@0n`, so
/// stored programs count from it too).
pub fn zero_here(
    offsets: &mut OffsetsState,
    gate: &Gate,
    ctx: &Context,
    axes: AxisSet,
) -> (Vec<Effect>, Note) {
    let at = match positions_for(gate, ctx, axes) {
        Ok(at) => at,
        Err(why) => {
            return (
                Vec::new(),
                (NoteLevel::Danger, format!("work zero refused: {why}")),
            );
        }
    };
    let system = offsets.table.active();
    for (axis, steps) in at {
        offsets.table.set(system, axis, steps);
    }
    let mut effects: Vec<Effect> = offsets.save().into_iter().collect();
    effects.push(Effect::Request(Request::SetZero { axes }));
    (
        effects,
        (
            NoteLevel::Info,
            format!("{system}: work zero of {axes} set to the current position"),
        ),
    )
}

/// "Set X = 10 here" (`s`): the active system's zero moved so that the
/// machine's position reads the typed values. Axes typed as 0 get the
/// controller's zero too (`SetZero`, isel `@0n`); others cannot (isel's
/// zero goes only where the axis stands) and the note says so.
pub fn set_here(
    offsets: &mut OffsetsState,
    gate: &Gate,
    ctx: &Context,
    target: &Target,
) -> Result<(Vec<Effect>, Note), String> {
    let axes: AxisSet = target.units.iter().map(|(a, _)| *a).collect();
    let at = positions_for(gate, ctx, axes)?;
    let system = offsets.table.active();
    let mut zeros = Vec::new();
    for ((axis, value), (_, steps)) in target.units.iter().zip(&at) {
        let profile = ctx
            .setup
            .axis(*axis)
            .ok_or_else(|| format!("the machine has no {axis} axis"))?;
        let work = profile.to_steps(*value);
        let zero = WorkOffsets::zero_for(*steps, work).ok_or_else(|| {
            format!("{axis}: that puts the work zero beyond any controller's count")
        })?;
        zeros.push((*axis, zero, *value));
    }
    let mut words = Vec::new();
    let mut zeroed = AxisSet::EMPTY;
    for (axis, zero, value) in &zeros {
        offsets.table.set(system, *axis, *zero);
        if *value == 0.0 {
            zeroed = zeroed.with(*axis);
        }
        let at = ctx
            .setup
            .axis(*axis)
            .map(|p| format_units(p, *zero))
            .unwrap_or_default();
        words.push(format!(
            "{axis} = {} (zero at machine {at})",
            super::super::position::format_amount(*value)
        ));
    }
    let mut effects: Vec<Effect> = offsets.save().into_iter().collect();
    if !zeroed.is_empty() {
        effects.push(Effect::Request(Request::SetZero { axes: zeroed }));
    }
    let mut text = format!("{system}: {} here", words.join(", "));
    let elsewhere: AxisSet = axes.iter().filter(|a| !zeroed.contains(*a)).collect();
    if ctx.setup.protocol == Protocol::Isel && !elsewhere.is_empty() {
        text.push_str(&format!(
            "; programs stored in the controller count from its own zero (@0n), which goes \
             only where an axis stands: go to the work zero (G) and zero it there (z) to bring \
             it along on {elsewhere}"
        ));
    }
    Ok((effects, (NoteLevel::Info, text)))
}
