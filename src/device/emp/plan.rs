//! Moves in the drives' terms: which drive runs at which speed (velocity
//! byte and reload value) in which direction, or to which counter value.
//! Soft limits, speed caps and the machine state are checked here, before
//! anything is sent (`docs/device.md`, "Refusals").
//!
//! A velocity jog has no end of its own: the driver watches the polled
//! positions and stops it when the room to the soft limit is down to what
//! the axis covers until the stop has taken hold ([`lookahead`]). A
//! positioning jog (`emp.jog = position`) is one TP move to the soft limit
//! along the speed vector (`common::vector`), like isel's and EMCU's jogs.

use crate::axis::{Axis, AxisSet};
use crate::config::profile::EmpJog;
use crate::device::api::{Dir, Frame, PerAxis, Refusal};
use crate::device::common::jog_speed;
use crate::device::common::limits::{capped_speed, invalid, moving_axes, named_axes, soft_limit};
use crate::device::common::vector::{Leg as VectorLeg, room, travel};
use crate::motion::{self, Braking};
use crate::proto::emp::{Command, DriveAddress, Position, Request};
use std::time::Duration;

use super::context::Context;
use super::settings::BRAKE_TIME;
use super::speed::{DriveSpeed, MIN_HZ};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// `2A 00 v` in IV mode until stopped.
    Velocity,
    /// `2A 01 Vmax target` in TPWM mode.
    Position,
}

/// One drive of a move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    pub axis: Axis,
    pub ds: DriveAddress,
    pub speed: DriveSpeed,
    pub dir: Dir,
    /// The counter value to position to (TP).
    pub target: Option<Position>,
    /// Counts to travel (TP), for the deadline.
    pub distance: u64,
}

impl Leg {
    pub fn hz(&self) -> f64 {
        self.speed.hz()
    }

    /// The TP frame of a positioning leg.
    pub fn move_request(&self) -> Option<Request> {
        self.target.map(|target| {
            Request::new(
                self.ds,
                Command::MoveTo {
                    vmax: self.speed.speed,
                    target,
                },
            )
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub style: Style,
    pub legs: Vec<Leg>,
}

impl Plan {
    pub fn drives(&self) -> Vec<DriveAddress> {
        self.legs.iter().map(|l| l.ds).collect()
    }
}

/// The farthest a TP target may lie from the counter's 0 (25 bits).
const MAX_TRAVEL: i64 = (1 << 24) - 1;

fn speed_of(hz: f64, axis: Axis) -> Result<DriveSpeed, Refusal> {
    DriveSpeed::for_hz(hz).ok_or_else(|| {
        invalid(format!(
            "{axis}: {hz:.0} counts/s is slower than the drive can run ({MIN_HZ:.0} counts/s)"
        ))
    })
}

/// How far an axis travels at `hz` before a stop has taken hold: two poll
/// cycles until the position that crosses the mark is read, the stop frame's
/// round trip, and braking (`BRAKE_TIME`, a linear ramp to rest).
pub fn lookahead(cx: &Context, hz: f64) -> f64 {
    let cycle = cx.settings.timing.round_trip.as_secs_f64() * (cx.drives.len() as f64 + 1.0);
    let reaction = 2.0 * cycle + cx.settings.timing.round_trip.as_secs_f64();
    hz * (reaction + BRAKE_TIME.as_secs_f64() / 2.0)
}

/// How a servo brakes: to rest within `BRAKE_TIME` from any speed.
pub fn braking() -> Braking {
    Braking::FixedTime {
        start_hz: 0.0,
        ramp: BRAKE_TIME,
    }
}

/// The stop frame's way to the drive: a round trip per drive (the stop
/// frames of a jog go out one after the other).
fn stop_way(cx: &Context) -> Duration {
    cx.settings.timing.round_trip * u32::try_from(cx.drives.len()).unwrap_or(u32::MAX)
}

/// The speed the drive's arithmetic may run above the one asked for is at
/// most 1/RelVal (`speed::DriveSpeed::for_hz`), below 1e-4 up to 150 000
/// counts/s: a cap is asked for this much lower, so the speed run keeps it.
const RELOAD_MARGIN: f64 = 1e-4;

/// The fastest jog of `axis` that stops within `jog.max_overrun` when the
/// `lease` it holds runs out unrenewed: the lease, the stop's way to the
/// wire and a round trip per drive at speed, then braking in `BRAKE_TIME`
/// (`motion::speed_cap`).
pub fn overrun_cap(cx: &Context, axis: Axis, lease: Duration) -> f64 {
    cx.settings.limits.get(axis).map_or(0.0, |l| {
        motion::speed_cap(&braking(), lease + stop_way(cx), l.max_overrun) * (1.0 - RELOAD_MARGIN)
    })
}

/// The lease a renewal asking for `lease` is granted while `plan` runs: no
/// longer than its speeds allow within `jog.max_overrun`, the stop frames'
/// round trips included.
pub fn granted(cx: &Context, plan: &Plan, lease: Duration) -> Duration {
    let way = stop_way(cx).as_secs_f64();
    let bounds = plan.legs.iter().filter_map(|leg| {
        cx.settings
            .limits
            .get(leg.axis)
            .map(|l| (leg.hz(), l.max_overrun - leg.hz() * way))
    });
    jog_speed::granted(&braking(), lease, bounds)
}

fn position(counts: i64) -> Result<Position, Refusal> {
    Position::new(counts).map_err(|e| invalid(format!("target {counts}: {e}")))
}

fn ds_of(cx: &Context, axis: Axis) -> Result<DriveAddress, Refusal> {
    cx.settings
        .drive_of(axis)
        .ok_or_else(|| invalid(format!("the machine has no {axis} axis")))
}

/// A continuous jog of `axes`, each no faster than the `lease` it holds
/// allows within `jog.max_overrun` ([`overrun_cap`], `docs/jogging.md`).
pub fn jog(
    cx: &Context,
    axes: &[(Axis, Dir)],
    speeds: &PerAxis<f64>,
    lease: Duration,
) -> Result<Plan, Refusal> {
    let set: AxisSet = axes.iter().map(|(a, _)| *a).collect();
    named_axes(cx.settings.axes, set)?;
    if set.len() != axes.len() {
        return Err(invalid("an axis is named twice"));
    }
    cx.motion_allowed(set, cx.settings.jog.allow_unreferenced)?;
    let here = cx.positions().ok_or(Refusal::NotInitialised)?;
    let style = match cx.settings.jog_style {
        EmpJog::Velocity => Style::Velocity,
        EmpJog::Position => Style::Position,
    };
    let mut legs = Vec::new();
    let mut vector = Vec::new();
    for &(axis, dir) in axes {
        let hz = capped_speed(&cx.settings.limits, axis, speeds.get(axis))?
            .min(overrun_cap(cx, axis, lease));
        let speed = speed_of(hz, axis)?;
        let limits = cx
            .settings
            .limits
            .get(axis)
            .ok_or_else(|| invalid(format!("the machine has no {axis} axis")))?;
        let pos = here.get(axis).unwrap_or(0);
        let referenced = cx.state.referenced.contains(axis);
        let room = room(axis, &limits, pos, dir, referenced, MAX_TRAVEL)?;
        if style == Style::Velocity && referenced && (room as f64) <= lookahead(cx, speed.hz()) {
            return Err(Refusal::SoftLimit {
                axis,
                target: pos + dir.sign() * room,
                min: limits.min,
                max: limits.max,
            });
        }
        vector.push(VectorLeg {
            axis,
            dir,
            hz: speed.hz(),
            room,
        });
        legs.push(Leg {
            axis,
            ds: ds_of(cx, axis)?,
            speed,
            dir,
            target: None,
            distance: 0,
        });
    }
    if style == Style::Position {
        let t = travel(&vector);
        for leg in &mut legs {
            let d = t.get(leg.axis).unwrap_or(0);
            leg.distance = d.unsigned_abs();
            leg.target = Some(position(here.get(leg.axis).unwrap_or(0) + d)?);
        }
        legs.retain(|l| l.distance > 0);
        if legs.is_empty() {
            return Err(invalid("the jog has no room to move"));
        }
    }
    Ok(Plan { style, legs })
}

/// The one TP move of a jog off a limit switch (`limit_op`): `axis`
/// positions `jog.limit_jog_distance` in `dir` from where it stands, at the
/// jog's speed. The drive stops there on its own if the switch never
/// releases, also when the link is gone; and it refuses a move into an
/// active switch itself (`05`, manual introduction: "die Position kann nur
/// in der entgegengesetzten Richtung wieder verlassen werden").
pub fn limit_jog(cx: &Context, axis: Axis, dir: Dir) -> Result<Plan, Refusal> {
    let limit = cx.settings.jog.limit_jog_of(axis)?;
    let here = cx.positions().ok_or(Refusal::NotInitialised)?;
    let pos = here.get(axis).unwrap_or(0);
    let hz = capped_speed(&cx.settings.limits, axis, Some(limit.hz))?;
    Ok(Plan {
        style: Style::Position,
        legs: vec![Leg {
            axis,
            ds: ds_of(cx, axis)?,
            speed: speed_of(hz, axis)?,
            dir,
            target: Some(position(pos + dir.sign() * limit.distance)?),
            distance: limit.distance.unsigned_abs(),
        }],
    })
}

/// TP legs from `from` to `to` for the axes that move.
fn positioning(
    cx: &Context,
    from: &PerAxis<i64>,
    to: &PerAxis<i64>,
    speeds: &PerAxis<f64>,
) -> Result<Plan, Refusal> {
    let mut legs = Vec::new();
    for (axis, target) in to.iter() {
        let start = from.get(axis).unwrap_or(0);
        if target == start {
            continue;
        }
        let hz = capped_speed(&cx.settings.limits, axis, speeds.get(axis))?;
        legs.push(Leg {
            axis,
            ds: ds_of(cx, axis)?,
            speed: speed_of(hz, axis)?,
            dir: if target > start {
                Dir::Plus
            } else {
                Dir::Minus
            },
            target: Some(position(target)?),
            distance: target.abs_diff(start),
        });
    }
    Ok(Plan {
        style: Style::Position,
        legs,
    })
}

/// One TP move of a probe (`probe_op`): `axis` from `from` to `to` at
/// `hz`, at most the axis's top speed. `common::probe::check` has checked
/// the probe's whole travel against the soft limits before it started.
pub fn probe_move(cx: &Context, axis: Axis, from: i64, to: i64, hz: f64) -> Result<Plan, Refusal> {
    positioning(
        cx,
        &PerAxis::new().with(axis, from),
        &PerAxis::new().with(axis, to),
        &PerAxis::new().with(axis, hz),
    )
}

/// Soft limits for referenced axes only: an unreferenced counter does not
/// count from the reference point.
pub fn within_limits(cx: &Context, target: &PerAxis<i64>) -> Result<(), Refusal> {
    for (axis, t) in target.iter() {
        if cx.state.referenced.contains(axis) {
            soft_limit(&cx.settings.limits, axis, t)?;
        }
    }
    Ok(())
}

/// A relative step from `base`.
pub fn step(
    cx: &Context,
    base: &PerAxis<i64>,
    delta: &PerAxis<i64>,
    speeds: &PerAxis<f64>,
) -> Result<Plan, Refusal> {
    let axes = moving_axes(delta);
    named_axes(cx.settings.axes, delta.axes())?;
    cx.motion_allowed(axes, cx.settings.jog.allow_unreferenced)?;
    let target = crate::device::common::limits::shifted(base, delta);
    let target: PerAxis<i64> = target.iter().filter(|(a, _)| axes.contains(*a)).collect();
    within_limits(cx, &target)?;
    positioning(cx, base, &target, speeds)
}

/// A move to `target` (work coordinates are shifted by jogterm's work zero).
pub fn move_to(
    cx: &Context,
    target: &PerAxis<i64>,
    frame: Frame,
    speeds: &PerAxis<f64>,
) -> Result<Plan, Refusal> {
    named_axes(cx.settings.axes, target.axes())?;
    cx.motion_allowed(target.axes(), false)?;
    let here = cx.positions().ok_or(Refusal::NotInitialised)?;
    let machine = match frame {
        Frame::Machine => *target,
        Frame::Work => target.map(|a, t| t + cx.state.work_zero.get(a).unwrap_or(0)),
    };
    within_limits(cx, &machine)?;
    positioning(cx, &here, &machine, speeds)
}
