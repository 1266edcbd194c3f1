//! Z touch-off in the console (`docs/probing.md`): `P` asks, then probes Z
//! down from where the tool stands (`Request::Probe`); when it touched,
//! the active work offset's Z is set so that work Z 0 is the surface minus
//! the plate (`probe.plate`), and saved as `s` saves it.

use crate::axis::Axis;
use crate::device::api::{Dir, Event, JogId, ProbeEnd, ProbeMove, Request};
use crate::offsets::System;
use crate::probing;

use super::jog::offsets::OffsetsState;
use super::jog::values::JogValues;
use super::msg::Effect;
use super::setup::Setup;
use super::tools::ToolsState;
use super::traffic_log::NoteLevel;

/// Probe ids: apart from the keypad's jogs and limit jogs.
const IDS: u64 = 1 << 62;

/// The probe the console sent and waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Pending {
    id: JogId,
    system: System,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProbeState {
    next: u64,
    pending: Option<Pending>,
}

/// What `P` asks before it probes.
pub struct Question {
    pub title: String,
    pub question: String,
    pub request: Request,
}

/// The touch-off's question, or why there is none: no Z, no probe table
/// that works, or a jog speed override (probes run at their own speeds:
/// an override left on drove the tool into the sensor at bCNC#466).
pub fn question(
    state: &mut ProbeState,
    setup: &Setup,
    values: &JogValues,
    offsets: &OffsetsState,
) -> Result<Question, String> {
    let z = setup
        .axis(Axis::Z)
        .ok_or("the machine has no Z axis to touch off")?;
    if values.override_pct != 100 {
        return Err(format!(
            "the jog speed override is {} %: a probe runs at its own speeds; % sets it back to \
             100 %, then P",
            values.override_pct
        ));
    }
    let probe: ProbeMove = probing::probe_move_of(z, &setup.probe, Axis::Z, Dir::Minus);
    let unit = z.unit.symbol();
    let system = offsets.table.active();
    let question = format!(
        "Z goes down from here until the probe input trips, at most {travel} {unit} at \
         {fast} {unit}/s, backs off and touches again at {slow} {unit}/s, then goes back up \
         to here. {system} Z 0 becomes the surface minus the plate ({plate} {unit}). Space \
         stops it. Probe Z?",
        travel = setup.probe.travel,
        fast = setup.probe.fast_speed.min(z.max_speed),
        slow = setup.probe.slow_speed.min(z.max_speed),
        plate = setup.probe.plate,
    );
    state.next += 1;
    let id = JogId(IDS | state.next);
    state.pending = Some(Pending { id, system });
    Ok(Question {
        title: "Touch off Z".into(),
        question,
        request: Request::Probe { id, probe },
    })
}

/// A device event: the console's probe ended. The note to say, and the
/// save of the offsets when the touch set Z, and of the tool table: the
/// tool in the spindle set work Z, so the next tool measured on the sensor
/// is the reference (as `jogterm probe z` does).
pub fn device_event(
    state: &mut ProbeState,
    setup: &Setup,
    (offsets, tools): (&mut OffsetsState, &mut ToolsState),
    event: &Event,
) -> Option<(NoteLevel, String, Vec<Effect>)> {
    let Event::ProbeEnded { id, end } = event else {
        return None;
    };
    let pending = state.pending.filter(|p| p.id == *id)?;
    state.pending = None;
    let z = setup.axis(Axis::Z)?;
    let what = "the probe of Z-";
    let said = probing::end_text(what, (Axis::Z, z), end);
    let ProbeEnd::Touched { at, .. } = end else {
        return Some((NoteLevel::Danger, said, Vec::new()));
    };
    let touched = at.get(Axis::Z)?;
    let zero = probing::touch_off_zero(z, touched, setup.probe.plate);
    offsets.table.set(pending.system, Axis::Z, zero);
    let mut effects: Vec<Effect> = offsets.save().into_iter().collect();
    effects.extend(tools.touched_off().map(Effect::SaveOffsets));
    let text = format!(
        "{said}; {} Z 0 set to machine Z {:.4} {}",
        pending.system,
        z.to_units(zero),
        z.unit.symbol()
    );
    Some((NoteLevel::Info, text, effects))
}
