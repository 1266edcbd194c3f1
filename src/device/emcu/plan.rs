//! Turning motion requests into EMCU vector moves (manual 1.5.10): the
//! axes interpolated linearly, the axis with the longest way at the move
//! slot's end speed (`#E<slot>`, decision 3) and the others in proportion,
//! relative (`x`) for steps and jogs, absolute (`X`) for go-to moves in
//! machine coordinates. The EMCU has no zero point of its own: jogterm's
//! work zero is its own offset (`docs/protocols.md`, EMCU).

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Frame, PerAxis, Refusal};
use crate::device::common::AxisLimits;
use crate::device::common::deadline;
use crate::device::common::jog_speed;
use crate::device::common::limits::{capped_speed, invalid, machine_has, moving_axes, soft_limit};
use crate::device::common::vector;
use crate::motion;
use crate::motion::Motion;
use crate::proto::emcu::{Command, EmcuAxis, Move, MoveMode, Speed, Steps};

use super::context::Context;

/// A move ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    /// `#E<slot>,<hz>` when the slot's speed changes, then the `L` move.
    pub commands: Vec<Command>,
    /// The slot speed the move runs at, Hz.
    pub end_hz: u16,
    /// The change per axis.
    pub deltas: PerAxis<i64>,
    /// The speed of each moving axis, Hz: the lead at `end_hz`, the others
    /// in proportion (manual 1.5.10).
    pub speeds: PerAxis<f64>,
    /// How long it takes as planned.
    pub duration: Duration,
}

/// A speed the interface takes: 1..=9999 Hz (`#E`, `docs/protocols.md`).
fn slot_speed(hz: f64) -> u16 {
    hz.clamp(f64::from(Speed::MIN), f64::from(Speed::MAX))
        .round() as u16
}

fn steps(value: i64, what: &str) -> Result<Steps, Refusal> {
    i32::try_from(value)
        .ok()
        .and_then(|v| Steps::new(v).ok())
        .ok_or_else(|| {
            invalid(format!(
                "{what} {value} does not fit an L move ({}..={} steps)",
                Steps::MIN,
                Steps::MAX
            ))
        })
}

/// The end speed of the leading axis: as fast as asked, but so that no
/// other axis, moving in proportion, goes faster than its own speed.
fn vector_speed(deltas: &PerAxis<i64>, hz: &PerAxis<f64>) -> f64 {
    let lead = deltas
        .iter()
        .map(|(_, d)| d.unsigned_abs())
        .max()
        .unwrap_or(0) as f64;
    deltas
        .iter()
        .filter(|(_, d)| *d != 0)
        .filter_map(|(axis, d)| hz.get(axis).map(|v| v * lead / d.unsigned_abs() as f64))
        .fold(f64::MAX, f64::min)
}

/// The batch for a move of `deltas` (relative) or to `targets` (absolute,
/// machine steps) at `end_hz`.
fn planned(
    cx: &Context,
    mode: MoveMode,
    deltas: &PerAxis<i64>,
    targets: &PerAxis<i64>,
    end_hz: f64,
) -> Result<Planned, Refusal> {
    let end_hz = slot_speed(end_hz);
    let values = match mode {
        MoveMode::Relative => deltas,
        MoveMode::Absolute => targets,
    };
    let mut cells = Vec::new();
    for (axis, v) in values.iter() {
        if deltas.get(axis).unwrap_or(0) == 0 && mode == MoveMode::Absolute {
            continue;
        }
        let emcu = EmcuAxis::new(axis).map_err(|e| invalid(e.to_string()))?;
        cells.push((emcu, steps(v, &format!("the {axis} value"))?));
    }
    let slot = cx.settings.move_slot;
    let mv = Move::new(slot, mode, &cells).map_err(|e| invalid(e.to_string()))?;
    let mut commands = Vec::new();
    if cx.slot_hz != Some(end_hz) {
        let speed = Speed::new(end_hz).map_err(|e| invalid(e.to_string()))?;
        commands.push(Command::EndSpeed { slot, speed });
    }
    commands.push(Command::Move(mv));
    let lead = deltas
        .iter()
        .map(|(_, d)| d.unsigned_abs())
        .max()
        .unwrap_or(0);
    let motion = Motion::new(lead, cx.settings.move_ramp(f64::from(end_hz)));
    let speeds = deltas
        .iter()
        .filter(|(_, d)| *d != 0)
        .map(|(axis, d)| {
            (
                axis,
                f64::from(end_hz) * d.unsigned_abs() as f64 / lead as f64,
            )
        })
        .collect();
    Ok(Planned {
        commands,
        end_hz,
        deltas: *deltas,
        speeds,
        duration: motion.end_time(),
    })
}

fn speeds_of(
    cx: &Context,
    axes: AxisSet,
    requested: &PerAxis<f64>,
) -> Result<PerAxis<f64>, Refusal> {
    let mut hz = PerAxis::new();
    for axis in axes.iter() {
        hz.set(
            axis,
            capped_speed(&cx.settings.limits, axis, requested.get(axis))?,
        );
    }
    Ok(hz)
}

/// A relative step of `delta` from `base` (where the steps before it end).
pub fn step(
    cx: &Context,
    base: &PerAxis<i64>,
    delta: &PerAxis<i64>,
    speeds: &PerAxis<f64>,
) -> Result<Planned, Refusal> {
    machine_has(cx.settings.axes, delta.axes())?;
    let moving = moving_axes(delta);
    if moving.is_empty() {
        return Err(invalid("the step moves no axis"));
    }
    cx.motion_allowed(cx.settings.jog.allow_unreferenced)?;
    cx.memory_free()?;
    for axis in moving.iter() {
        if cx.state.referenced.contains(axis) {
            let from = base.get(axis).unwrap_or(0);
            soft_limit(
                &cx.settings.limits,
                axis,
                from.saturating_add(delta.get(axis).unwrap_or(0)),
            )?;
        }
    }
    let deltas: PerAxis<i64> = delta.iter().filter(|(_, d)| *d != 0).collect();
    let hz = speeds_of(cx, moving, speeds)?;
    planned(
        cx,
        MoveMode::Relative,
        &deltas,
        &PerAxis::new(),
        vector_speed(&deltas, &hz),
    )
}

/// A move to `target`: axes left out stay where they are.
pub fn move_to(
    cx: &Context,
    target: &PerAxis<i64>,
    frame: Frame,
    speeds: &PerAxis<f64>,
) -> Result<Planned, Refusal> {
    machine_has(cx.settings.axes, target.axes())?;
    if target.axes().is_empty() {
        return Err(invalid("the target names no axis"));
    }
    let position = cx.position.ok_or(Refusal::NotConnected)?;
    let mut machine = PerAxis::new();
    let mut deltas = PerAxis::new();
    for (axis, t) in target.iter() {
        let m = match frame {
            Frame::Machine => t,
            Frame::Work => t.saturating_add(cx.state.work_zero.get(axis).unwrap_or(0)),
        };
        let d = m.saturating_sub(position.get(axis).unwrap_or(0));
        if d != 0 {
            machine.set(axis, m);
            deltas.set(axis, d);
        }
    }
    if deltas.axes().is_empty() {
        return Err(invalid("the axes are already at the target"));
    }
    cx.motion_allowed(false)?;
    cx.memory_free()?;
    for (axis, m) in machine.iter() {
        soft_limit(&cx.settings.limits, axis, m)?;
    }
    let hz = speeds_of(cx, deltas.axes(), speeds)?;
    planned(
        cx,
        MoveMode::Absolute,
        &deltas,
        &machine,
        vector_speed(&deltas, &hz),
    )
}

/// The fastest jog speed of `axis` that stops within its `jog.max_overrun`
/// when the operator lets go while the jog holds a lease of `lease`: the
/// lease at speed, the `@B`'s way to the wire, then the `#R` ramp down
/// (manual 1.5.7, `motion::speed_cap`).
pub fn overrun_cap(cx: &Context, axis: Axis, lease: Duration) -> f64 {
    cx.settings.limits(axis).map_or(0.0, |l| {
        motion::speed_cap(&cx.settings.braking(), lease, l.max_overrun)
    })
}

/// The lease a renewal asking for `lease` is granted while `planned` runs:
/// no longer than its speeds allow within `jog.max_overrun`.
pub fn granted(cx: &Context, planned: &Planned, lease: Duration) -> Duration {
    let bounds = planned
        .speeds
        .iter()
        .filter_map(|(axis, hz)| cx.settings.limits(axis).map(|l| (hz, l.max_overrun)));
    jog_speed::granted(&cx.settings.braking(), lease, bounds)
}

/// A continuous jog: one relative move towards the soft limits along the
/// speed vector (`common::vector`), each speed capped so that the axis
/// stops within `jog.max_overrun` when the `lease` the jog holds runs out
/// unrenewed ([`overrun_cap`]; `docs/jogging.md`).
pub fn jog(
    cx: &Context,
    axes: &[(Axis, Dir)],
    speeds: &PerAxis<f64>,
    lease: Duration,
) -> Result<Planned, Refusal> {
    let set: AxisSet = axes.iter().map(|(a, _)| *a).collect();
    machine_has(cx.settings.axes, set)?;
    vector::jog_axes(axes)?;
    cx.motion_allowed(cx.settings.jog.allow_unreferenced)?;
    cx.memory_free()?;
    let position = cx.position.ok_or(Refusal::NotConnected)?;
    let legs = vector::legs(
        axes,
        vector::JogFrame {
            position: &position,
            referenced: cx.state.referenced,
            max_travel: i64::from(Steps::MAX),
            limits_of: |axis| cx.settings.limits(axis),
            speed_of: |axis, _: &AxisLimits| {
                // Whole Hz below the cap: the slot speed is rounded.
                let cap = overrun_cap(cx, axis, lease).floor().max(1.0);
                capped_speed(
                    &cx.settings.limits,
                    axis,
                    speeds.get(axis).map(|v| v.min(cap)),
                )
                .map(|hz| f64::from(slot_speed(hz.floor())))
            },
        },
    )?;
    let deltas = vector::travel(&legs);
    let hz: PerAxis<f64> = legs.iter().map(|l| (l.axis, l.hz)).collect();
    let moving: PerAxis<i64> = deltas.iter().filter(|(_, d)| *d != 0).collect();
    if moving.axes().is_empty() {
        return Err(invalid("the jog has no room to move"));
    }
    planned(
        cx,
        MoveMode::Relative,
        &moving,
        &PerAxis::new(),
        vector_speed(&moving, &hz),
    )
}

/// How long a reference run of `axes` may take: each axis searches its
/// switch at the start speed (manual 1.5.8, 1.5.9), one after the other.
pub fn home_deadline(cx: &Context, axes: AxisSet) -> Duration {
    let spans = axes
        .iter()
        .map(|a| cx.settings.limits(a).map_or(0, |l| l.span()));
    deadline::reference(spans, cx.settings.reference_hz())
}

/// How long the axes take to come to rest after `@B` from any speed: the
/// ramp length (manual 1.5.7: start and brake ramp are the same).
pub fn brake_time(cx: &Context) -> Duration {
    Duration::from_millis(u64::from(cx.settings.ramp.get()))
}

/// Why the EMCU does no jog off a limit switch (`Request::LimitJog`,
/// `docs/jogging.md`): jogterm cannot read a limit switch on it. Its status
/// (`@X`, manual 1.5.3) has no limit flag and E1 (1.5.19) cannot be read;
/// what the SMC3000's switches do is the card's, unreported. So jogterm
/// could neither tell which way leads out of a switch nor when it has
/// released, and a jog on a guess might drive deeper in.
pub fn no_limit_jog() -> Refusal {
    invalid(
        "the EMCU reports no limit switches (its @X status has no limit flag, manual 1.5.3): \
         jogterm cannot tell which way leads off a switch nor when it releases. Free the axis \
         by hand with the power off, then reset (ctrl-r) and reference (h)",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lead_axis_runs_as_fast_as_every_axis_allows() {
        let deltas = PerAxis::new().with(Axis::X, 1000).with(Axis::Y, -500);
        let hz = PerAxis::new().with(Axis::X, 800.0).with(Axis::Y, 200.0);
        // Y at 200 Hz covers 500 steps in 2.5 s; X must take as long: 400 Hz.
        assert_eq!(vector_speed(&deltas, &hz), 400.0);
        let hz = PerAxis::new().with(Axis::X, 300.0).with(Axis::Y, 900.0);
        assert_eq!(vector_speed(&deltas, &hz), 300.0);
    }

    #[test]
    fn speeds_and_steps_fit_the_interface() {
        assert_eq!(slot_speed(0.2), 1);
        assert_eq!(slot_speed(12_000.0), 9999);
        assert!(steps(1_000_000, "X").is_err());
        assert_eq!(steps(-999_999, "X").map(|s| s.get()), Ok(-999_999));
    }
}
