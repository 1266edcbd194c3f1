//! The machine's axes as a driver checks requests against them: which axes
//! exist, the soft limits, and the highest speed an axis may be given.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{PerAxis, Refusal};

/// One axis in steps and Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimits {
    /// Soft limits in machine steps (from the reference point).
    pub min: i64,
    pub max: i64,
    /// Highest step frequency any move of this axis is given: the profile's
    /// `max_speed`, within what the controller takes.
    pub max_hz: f64,
    /// `jog.max_overrun` in steps.
    pub max_overrun: f64,
}

impl AxisLimits {
    pub fn contains(&self, steps: i64) -> bool {
        (self.min..=self.max).contains(&steps)
    }

    pub fn span(&self) -> i64 {
        self.max.saturating_sub(self.min)
    }
}

pub fn invalid(reason: impl Into<String>) -> Refusal {
    Refusal::Invalid {
        reason: reason.into(),
    }
}

/// Every axis of `axes` is one of the machine's.
pub fn machine_has(machine: AxisSet, axes: AxisSet) -> Result<(), Refusal> {
    match axes.iter().find(|a| !machine.contains(*a)) {
        Some(axis) => Err(invalid(format!(
            "the machine has no {axis} axis (profile axes {machine})"
        ))),
        None => Ok(()),
    }
}

/// The axes of a home or zero request: at least one, all of the machine's.
pub fn named_axes(machine: AxisSet, axes: AxisSet) -> Result<(), Refusal> {
    if axes.is_empty() {
        return Err(invalid("no axis given"));
    }
    machine_has(machine, axes)
}

/// jogterm's own work zero, for a controller that keeps none (EMCU, EMP:
/// `docs/protocols.md`): the position `now` recorded as the zero of `axes`.
pub fn record_work_zero(
    work_zero: &mut PerAxis<i64>,
    machine: AxisSet,
    axes: AxisSet,
    now: Option<PerAxis<i64>>,
) -> Result<(), Refusal> {
    named_axes(machine, axes)?;
    let position = now.ok_or(Refusal::NotInitialised)?;
    for axis in axes.iter() {
        work_zero.set(axis, position.get(axis).unwrap_or(0));
    }
    Ok(())
}

/// `target` (machine steps) lies within the soft limits of `axis`.
pub fn soft_limit(limits: &PerAxis<AxisLimits>, axis: Axis, target: i64) -> Result<(), Refusal> {
    match limits.get(axis) {
        Some(l) if !l.contains(target) => Err(Refusal::SoftLimit {
            axis,
            target,
            min: l.min,
            max: l.max,
        }),
        _ => Ok(()),
    }
}

/// A requested speed, capped at the axis's `max_speed`. The controller's own
/// range is the family's business (it clamps and rounds after this).
pub fn capped_speed(
    limits: &PerAxis<AxisLimits>,
    axis: Axis,
    requested: Option<f64>,
) -> Result<f64, Refusal> {
    let l = limits
        .get(axis)
        .ok_or_else(|| invalid(format!("the machine has no {axis} axis")))?;
    let hz = requested.ok_or_else(|| invalid(format!("no speed given for axis {axis}")))?;
    if !(hz.is_finite() && hz > 0.0) {
        return Err(invalid(format!(
            "the speed of {axis} must be positive, got {hz}"
        )));
    }
    Ok(hz.min(l.max_hz))
}

/// The axes a delta moves (non-zero entries).
pub fn moving_axes(delta: &PerAxis<i64>) -> AxisSet {
    delta
        .iter()
        .filter(|(_, d)| *d != 0)
        .map(|(a, _)| a)
        .collect()
}

/// `base` moved by `delta` (saturating), axis by axis.
pub fn shifted(base: &PerAxis<i64>, delta: &PerAxis<i64>) -> PerAxis<i64> {
    let mut out = *base;
    for (axis, d) in delta.iter() {
        out.set(axis, out.get(axis).unwrap_or(0).saturating_add(d));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> PerAxis<AxisLimits> {
        PerAxis::new().with(
            Axis::X,
            AxisLimits {
                min: 0,
                max: 1000,
                max_hz: 500.0,
                max_overrun: 50.0,
            },
        )
    }

    #[test]
    fn soft_limits_and_axes_are_checked() {
        let l = limits();
        assert!(soft_limit(&l, Axis::X, 1000).is_ok());
        assert_eq!(
            soft_limit(&l, Axis::X, 1001),
            Err(Refusal::SoftLimit {
                axis: Axis::X,
                target: 1001,
                min: 0,
                max: 1000
            })
        );
        let machine = AxisSet::from_mask(0b011);
        assert!(machine_has(machine, AxisSet::from_mask(0b010)).is_ok());
        assert_eq!(
            machine_has(machine, AxisSet::XYZ).unwrap_err().to_string(),
            "the machine has no Z axis (profile axes XY)"
        );
        assert_eq!(
            named_axes(machine, AxisSet::EMPTY).unwrap_err().to_string(),
            "no axis given"
        );
    }

    #[test]
    fn speeds_are_capped_and_must_be_positive() {
        let l = limits();
        assert_eq!(capped_speed(&l, Axis::X, Some(900.0)), Ok(500.0));
        assert_eq!(capped_speed(&l, Axis::X, Some(20.0)), Ok(20.0));
        for bad in [Some(0.0), Some(-1.0), Some(f64::NAN), None] {
            assert!(capped_speed(&l, Axis::X, bad).is_err(), "{bad:?}");
        }
        assert!(capped_speed(&l, Axis::Y, Some(1.0)).is_err());
    }

    #[test]
    fn deltas_shift_positions_and_name_their_axes() {
        let base = PerAxis::new().with(Axis::X, 5).with(Axis::Y, 7);
        let delta = PerAxis::new().with(Axis::X, 10).with(Axis::Y, 0);
        assert_eq!(
            shifted(&base, &delta),
            PerAxis::new().with(Axis::X, 15).with(Axis::Y, 7)
        );
        assert_eq!(moving_axes(&delta), AxisSet::EMPTY.with(Axis::X));
    }
}
