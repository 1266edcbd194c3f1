//! A continuous jog as one move towards the soft limits, along the vector of
//! the axes' speeds: every axis travels in proportion to its speed, and the
//! move ends where the first axis reaches its limit. An unreferenced axis
//! (only with `jog.allow_unreferenced`) has no known limits: it may travel
//! the width of its soft-limit range (`docs/device.md`).

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, PerAxis, Refusal};

use super::limits::{AxisLimits, invalid};

/// One axis of a jog.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    pub axis: Axis,
    pub dir: Dir,
    /// Its speed, Hz (as the controller will be given it).
    pub hz: f64,
    /// How far it may travel, steps (at least 1).
    pub room: i64,
}

/// How far `axis` at `position` may travel in `dir`: to its soft limit when
/// referenced, else the span of its limits; at most `max_travel` (what one
/// command of the controller can carry). Refused when it stands at the limit.
pub fn room(
    axis: Axis,
    limits: &AxisLimits,
    position: i64,
    dir: Dir,
    referenced: bool,
    max_travel: i64,
) -> Result<i64, Refusal> {
    let room = if referenced {
        match dir {
            Dir::Plus => limits.max - position,
            Dir::Minus => position - limits.min,
        }
    } else {
        limits.span()
    }
    .clamp(0, max_travel.max(0));
    if room == 0 {
        return Err(Refusal::SoftLimit {
            axis,
            target: position + dir.sign(),
            min: limits.min,
            max: limits.max,
        });
    }
    Ok(room)
}

/// What a jog needs of the machine to plan its legs.
pub struct JogFrame<'a, L, S> {
    pub position: &'a PerAxis<i64>,
    pub referenced: AxisSet,
    /// The most one command of the controller can carry, steps.
    pub max_travel: i64,
    /// The limits of an axis; `None`: the machine has no such axis.
    pub limits_of: L,
    /// The speed an axis runs at (capped as the family must), Hz as the
    /// controller will be given it.
    pub speed_of: S,
}

/// The axes of a jog: at least one, each once.
pub fn jog_axes(axes: &[(Axis, Dir)]) -> Result<AxisSet, Refusal> {
    let set: AxisSet = axes.iter().map(|(a, _)| *a).collect();
    if set.is_empty() {
        return Err(invalid("the jog names no axis"));
    }
    if set.len() != axes.len() {
        return Err(invalid("the jog names an axis twice"));
    }
    Ok(set)
}

/// The legs of a jog of `axes` ([`jog_axes`] checked them) from where the
/// machine stands.
pub fn legs<L, S>(axes: &[(Axis, Dir)], frame: JogFrame<'_, L, S>) -> Result<Vec<Leg>, Refusal>
where
    L: Fn(Axis) -> Option<AxisLimits>,
    S: Fn(Axis, &AxisLimits) -> Result<f64, Refusal>,
{
    axes.iter()
        .map(|&(axis, dir)| {
            let limits = (frame.limits_of)(axis)
                .ok_or_else(|| invalid(format!("the machine has no {axis} axis")))?;
            let hz = (frame.speed_of)(axis, &limits)?;
            let pos = frame.position.get(axis).unwrap_or(0);
            let referenced = frame.referenced.contains(axis);
            let room = room(axis, &limits, pos, dir, referenced, frame.max_travel)?;
            Ok(Leg {
                axis,
                dir,
                hz,
                room,
            })
        })
        .collect()
}

/// The signed travel of each leg: the leg that reaches its limit first
/// bounds the whole vector, the others travel in proportion to their speed.
pub fn travel(legs: &[Leg]) -> PerAxis<i64> {
    let lead = legs
        .iter()
        .filter(|l| l.hz > 0.0)
        .min_by(|a, b| (a.room as f64 / a.hz).total_cmp(&(b.room as f64 / b.hz)));
    let mut out = PerAxis::new();
    let Some(lead) = lead else {
        return out;
    };
    for leg in legs {
        let t = (lead.room as f64 * leg.hz / lead.hz).floor() as i64;
        out.set(leg.axis, leg.dir.sign() * t.min(leg.room));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: AxisLimits = AxisLimits {
        min: 0,
        max: 1000,
        max_hz: 1000.0,
        max_overrun: 100.0,
    };

    #[test]
    fn the_room_is_to_the_limit_or_the_span() {
        assert_eq!(room(Axis::X, &L, 400, Dir::Plus, true, 1 << 20), Ok(600));
        assert_eq!(room(Axis::X, &L, 400, Dir::Minus, true, 1 << 20), Ok(400));
        assert_eq!(room(Axis::X, &L, 400, Dir::Minus, false, 1 << 20), Ok(1000));
        assert_eq!(room(Axis::X, &L, 400, Dir::Plus, true, 250), Ok(250));
        assert_eq!(
            room(Axis::X, &L, 1000, Dir::Plus, true, 1 << 20),
            Err(Refusal::SoftLimit {
                axis: Axis::X,
                target: 1001,
                min: 0,
                max: 1000
            })
        );
    }

    #[test]
    fn the_first_axis_at_its_limit_bounds_the_vector() {
        let legs = [
            Leg {
                axis: Axis::X,
                dir: Dir::Plus,
                hz: 1000.0,
                room: 600,
            },
            Leg {
                axis: Axis::Y,
                dir: Dir::Minus,
                hz: 500.0,
                room: 1000,
            },
        ];
        let t = travel(&legs);
        assert_eq!(t.get(Axis::X), Some(600));
        assert_eq!(t.get(Axis::Y), Some(-300));
        let legs = [
            legs[0],
            Leg {
                room: 100,
                ..legs[1]
            },
        ];
        let t = travel(&legs);
        assert_eq!((t.get(Axis::X), t.get(Axis::Y)), (Some(200), Some(-100)));
    }
}
