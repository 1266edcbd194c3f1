//! Turning motion requests into isel moves: speeds capped to the axis and
//! the controller, targets checked against the soft limits, pairs laid out
//! for the axis configuration (manual 2.2.2, 2.2.18), and the estimate that
//! goes with the move.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Frame, PerAxis, Refusal};
use crate::device::common::AxisLimits;
use crate::device::common::jog_speed;
use crate::device::common::limits::{self, capped_speed, invalid, machine_has, moving_axes};
use crate::device::common::vector;
use crate::motion::{self, Braking};
use crate::proto::isel::{AxisConfig, Command, MovePair, SPEED_HZ, STEPS};

use super::context::{Cmd, Context};
use super::deadline;
use crate::proto::isel::estimate::{MoveEstimate, RampParams};

/// A move ready to send.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    pub cmd: Cmd,
    pub estimate: MoveEstimate,
    /// The step frequency of each axis the move names (Hz).
    pub speeds: PerAxis<u32>,
}

/// A requested speed as a step frequency the axis and the controller allow:
/// at most the axis's `max_speed`, within 1..=40000 Hz (isel decision 13).
pub fn speed_hz(cx: &Context, axis: Axis, requested: Option<f64>) -> Result<u32, Refusal> {
    let hz = capped_speed(&cx.settings.axes, axis, requested)?;
    let lo = f64::from(*SPEED_HZ.start());
    let hi = f64::from(*SPEED_HZ.end());
    Ok(hz.clamp(lo, hi).round() as u32)
}

/// How the controller brakes with `ramp` (manual 2.2.15, 2.2.16): down to
/// the start-stop frequency at the acceleration, then at once.
pub fn braking(ramp: RampParams) -> Braking {
    Braking::Ramp {
        start_hz: f64::from(ramp.start_stop_hz),
        accel_hz_per_s: f64::from(ramp.accel_hz_per_ms) * 1000.0,
    }
}

/// The fastest jog speed that stops within `max_overrun` steps when the
/// operator lets go while the jog holds a lease of `lease`: the lease at
/// speed, the stop's way to the wire, then the braking ramp
/// (`jog.max_overrun`, `crate::motion::overrun`).
pub fn overrun_cap(ramp: RampParams, lease: Duration, max_overrun: f64) -> f64 {
    motion::speed_cap(&braking(ramp), lease, max_overrun)
}

/// The lease a renewal asking for `lease` is granted while a jog runs at
/// `speeds`: no longer than they allow within every axis's `max_overrun`.
pub fn granted(cx: &Context, speeds: &PerAxis<u32>, lease: Duration) -> Duration {
    let bounds = speeds.iter().filter_map(|(axis, hz)| {
        cx.settings
            .limits(axis)
            .map(|l| (f64::from(hz), l.max_overrun))
    });
    jog_speed::granted(&braking(cx.ramp), lease, bounds)
}

fn check_axes(cx: &Context, axes: AxisSet) -> Result<(), Refusal> {
    machine_has(cx.settings.axis_set(), axes)
}

fn in_range(value: i64, what: &str) -> Result<i32, Refusal> {
    i32::try_from(value)
        .ok()
        .filter(|v| STEPS.contains(v))
        .ok_or_else(|| {
            invalid(format!(
                "{what} {value} does not fit the controller's 24-bit counters"
            ))
        })
}

fn soft_limit(cx: &Context, axis: Axis, target: i64) -> Result<(), Refusal> {
    limits::soft_limit(&cx.settings.axes, axis, target)
}

/// The pairs of a move for `config`: one per axis, and with 3 axes a second
/// Z pair that does not move (manual 2.2.2, `docs/decisions.md` isel 5).
fn pairs(
    config: AxisConfig,
    values: &PerAxis<i32>,
    speeds: &PerAxis<u32>,
    filler: u32,
) -> Vec<MovePair> {
    let pair = |axis: Axis| {
        MovePair::new(
            values.get(axis).unwrap_or(0),
            speeds.get(axis).unwrap_or(filler),
        )
    };
    match config {
        AxisConfig::X => vec![pair(Axis::X)],
        AxisConfig::XY => vec![pair(Axis::X), pair(Axis::Y)],
        AxisConfig::XYZ => vec![
            pair(Axis::X),
            pair(Axis::Y),
            pair(Axis::Z),
            MovePair::new(0, speeds.get(Axis::Z).unwrap_or(filler)),
        ],
        AxisConfig::XYZA => vec![pair(Axis::X), pair(Axis::Y), pair(Axis::Z), pair(Axis::A)],
    }
}

fn relative(
    cx: &Context,
    deltas: &PerAxis<i64>,
    speeds: &PerAxis<u32>,
) -> Result<Planned, Refusal> {
    let start = cx.position.ok_or(Refusal::NotConnected)?;
    let mut values = PerAxis::new();
    for (axis, d) in deltas.iter() {
        values.set(axis, in_range(d, &format!("the {axis} distance"))?);
    }
    let config = cx.settings.config;
    let pairs = pairs(config, &values, speeds, cx.settings.start_stop_hz);
    let estimate = MoveEstimate::relative(config, &pairs, start, cx.ramp, cx.three_d);
    let mut cmd = cx.cmd(Command::MoveRelative(pairs));
    cmd.timeout = Some(deadline::motion(estimate.duration()));
    let moving = deltas
        .iter()
        .filter(|(_, d)| *d != 0)
        .filter_map(|(a, _)| speeds.get(a).map(|hz| (a, hz)))
        .collect();
    Ok(Planned {
        cmd,
        estimate,
        speeds: moving,
    })
}

/// A relative step of `delta` from `base` (the position the step starts
/// from once the steps before it are done).
pub fn step(
    cx: &Context,
    base: &PerAxis<i64>,
    delta: &PerAxis<i64>,
    speeds: &PerAxis<f64>,
) -> Result<Planned, Refusal> {
    let moving = moving_axes(delta);
    check_axes(cx, delta.axes())?;
    if moving.is_empty() {
        return Err(invalid("the step moves no axis"));
    }
    cx.motion_allowed(cx.settings.jog.allow_unreferenced)?;
    let mut hz = PerAxis::new();
    for axis in moving.iter() {
        if cx.state.referenced.contains(axis) {
            let from = base.get(axis).unwrap_or(0);
            soft_limit(cx, axis, from.saturating_add(delta.get(axis).unwrap_or(0)))?;
        }
        hz.set(axis, speed_hz(cx, axis, speeds.get(axis))?);
    }
    relative(cx, delta, &hz)
}

/// An absolute move (`@0M`): the controller's targets are relative to its
/// virtual zero (manual 2.2.19), which `work_zero` tracks; axes left out
/// stay where they are.
pub fn move_to(
    cx: &Context,
    target: &PerAxis<i64>,
    frame: Frame,
    speeds: &PerAxis<f64>,
) -> Result<Planned, Refusal> {
    check_axes(cx, target.axes())?;
    if target.axes().is_empty() {
        return Err(invalid("the target names no axis"));
    }
    let position = cx.position.ok_or(Refusal::NotConnected)?;
    let config = cx.settings.config;
    let unknown: AxisSet = config
        .axes()
        .iter()
        .filter(|a| !cx.zero_known.contains(*a))
        .collect();
    if !unknown.is_empty() {
        return Err(invalid(format!(
            "the controller's zero point of {unknown} was set before jogterm connected and is \
             unknown: set the zero (z) or reference (h) first"
        )));
    }
    let zero = |axis: Axis| cx.state.work_zero.get(axis).unwrap_or(0);
    let mut machine = PerAxis::new();
    for (axis, t) in target.iter() {
        let m = match frame {
            Frame::Machine => t,
            Frame::Work => t.saturating_add(zero(axis)),
        };
        machine.set(axis, m);
    }
    let moving: AxisSet = machine
        .iter()
        .filter(|(a, m)| position.get(*a) != Some(*m))
        .map(|(a, _)| a)
        .collect();
    if moving.is_empty() {
        return Err(invalid("the axes are already at the target"));
    }
    cx.motion_allowed(false)?;
    let mut hz = PerAxis::new();
    let mut values = PerAxis::new();
    for axis in config.axes().iter() {
        let m = machine.get(axis).or(position.get(axis)).unwrap_or(0);
        if moving.contains(axis) {
            soft_limit(cx, axis, m)?;
            hz.set(axis, speed_hz(cx, axis, speeds.get(axis))?);
        }
        values.set(
            axis,
            in_range(m - zero(axis), &format!("the {axis} target"))?,
        );
    }
    let pairs = pairs(config, &values, &hz, cx.settings.start_stop_hz);
    let estimate = MoveEstimate::absolute(
        config,
        &pairs,
        position,
        cx.state.work_zero,
        cx.ramp,
        cx.three_d,
    );
    let mut cmd = cx.cmd(Command::MoveAbsolute(pairs));
    cmd.timeout = Some(deadline::motion(estimate.duration()));
    Ok(Planned {
        cmd,
        estimate,
        speeds: hz,
    })
}

/// One short move of a jog off a limit switch (`limit_op`): `steps` of
/// `axis` at `hz`, relative. Nothing but the axis is checked here: the
/// switch it leaves and the bound are the op's, the rest was checked when
/// it started (`common::limit_jog::check`); the controller is in test mode.
pub fn limit_step(cx: &Context, axis: Axis, steps: i64, hz: u32) -> Result<Planned, Refusal> {
    check_axes(cx, AxisSet::EMPTY.with(axis))?;
    relative(
        cx,
        &PerAxis::new().with(axis, steps),
        &PerAxis::new().with(axis, hz),
    )
}

/// A continuous jog: one long relative move at jog speed towards the soft
/// limits, along the vector of the axes' speeds and ending where the first
/// axis reaches its limit. Unreferenced axes (only with
/// `jog.allow_unreferenced` or test mode) have no known limits: they may
/// travel the width of their soft-limit range (`docs/device.md`).
///
/// No axis runs faster than one `lease` at speed plus braking allows within
/// `jog.max_overrun` ([`overrun_cap`]): the lease is how long the jog runs
/// on if nobody renews it (`docs/jogging.md`).
pub fn jog(
    cx: &Context,
    axes: &[(Axis, Dir)],
    speeds: &PerAxis<f64>,
    lease: Duration,
) -> Result<Planned, Refusal> {
    let set: AxisSet = axes.iter().map(|(a, _)| *a).collect();
    check_axes(cx, set)?;
    vector::jog_axes(axes)?;
    cx.motion_allowed(cx.settings.jog.allow_unreferenced)?;
    let position = cx.position.ok_or(Refusal::NotConnected)?;
    let legs = vector::legs(
        axes,
        vector::JogFrame {
            position: &position,
            referenced: cx.state.referenced,
            max_travel: i64::from(*STEPS.end()),
            limits_of: |axis| cx.settings.limits(axis),
            speed_of: |axis, limits: &AxisLimits| {
                let cap = overrun_cap(cx.ramp, lease, limits.max_overrun).max(1.0);
                speed_hz(cx, axis, speeds.get(axis).map(|v| v.min(cap))).map(f64::from)
            },
        },
    )?;
    let deltas = vector::travel(&legs);
    let mut hz = PerAxis::new();
    for leg in &legs {
        hz.set(leg.axis, leg.hz.round() as u32);
    }
    relative(cx, &deltas, &hz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_overrun_cap_balances_lease_reaction_and_braking() {
        let ramp = RampParams::CONTROLLER_DEFAULT;
        let v = overrun_cap(ramp, Duration::from_millis(150), 1200.0);
        let a = 100_000.0;
        let reaction = motion::STOP_REACTION.as_secs_f64();
        let travel = v * (0.15 + reaction) + (v * v - 300.0 * 300.0) / (2.0 * a);
        assert!((travel - 1200.0).abs() < 1e-3, "{travel}");
        assert!(v > 6_000.0 && v < 6_300.0, "{v}");
        // The grace lease before the first key repeat allows much less.
        let grace = overrun_cap(ramp, Duration::from_millis(750), 1200.0);
        assert!(grace > 1_500.0 && grace < 1_600.0, "{grace}");
    }
}
