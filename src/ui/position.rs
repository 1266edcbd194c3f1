//! The last known position of every axis, in steps, and how to show it in
//! machine units (mm or degrees from the profile's steps per unit).

use std::time::Instant;

use crate::axis::Axis;
use crate::config::profile::{AxisProfile, Unit};
use crate::device::api::{PerAxis, PositionSample, PositionSource};

/// One axis as last reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Machine coordinates, steps.
    pub steps: i64,
    pub source: PositionSource,
    pub at: Instant,
}

/// Positions per axis; a sample naming only some axes updates only those
/// (EMCU reads one axis per query).
#[derive(Debug, Clone, PartialEq)]
pub struct Positions {
    readings: PerAxis<Reading>,
}

impl Default for Positions {
    fn default() -> Self {
        Self {
            readings: PerAxis::new(),
        }
    }
}

impl Positions {
    pub fn apply(&mut self, sample: &PositionSample) {
        for (axis, steps) in sample.steps.iter() {
            self.readings.set(
                axis,
                Reading {
                    steps,
                    source: sample.source,
                    at: sample.at,
                },
            );
        }
    }

    pub fn get(&self, axis: Axis) -> Option<Reading> {
        self.readings.get(axis)
    }

    /// Where X, Y and Z stand, machine steps, as far as reported (the
    /// start of a go-to's legs: `ui::legs`).
    pub fn xyz_steps(&self) -> PerAxis<i64> {
        let mut at = PerAxis::new();
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            if let Some(r) = self.get(axis) {
                at.set(axis, r.steps);
            }
        }
        at
    }
}

/// Digits after the point that resolve one step: 400 steps/mm needs 3
/// (0.0025 mm), 100 steps/degree 2. At most 4, so a fine encoder does not
/// blow up the column.
pub fn decimals(profile: &AxisProfile) -> usize {
    let spu = profile.steps_per_unit;
    if !(spu.is_finite() && spu > 1.0) {
        return 0;
    }
    (spu.log10().ceil() as usize).min(4)
}

/// `steps` in the axis' unit, formatted with its resolution.
pub fn format_units(profile: &AxisProfile, steps: i64) -> String {
    let value = profile.to_units(steps);
    let text = format!("{value:.prec$}", prec = decimals(profile));
    // `-0.000` reads like a fault; a value that rounds to zero is zero.
    if text.starts_with('-') && text.trim_start_matches(['-', '0', '.']).is_empty() {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// A distance or speed from the jog lists, in the profile's units.
pub fn format_amount(value: f64) -> String {
    if value.fract() == 0.0 && value.abs() < 1e9 {
        format!("{value:.0}")
    } else {
        let text = format!("{value:.4}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The unit all axes share, for labels that apply to every axis.
pub fn common_unit<'a>(mut axes: impl Iterator<Item = &'a AxisProfile>) -> Option<Unit> {
    let first = axes.next()?.unit;
    axes.all(|p| p.unit == first).then_some(first)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(spu: f64, unit: Unit) -> AxisProfile {
        AxisProfile {
            steps_per_unit: spu,
            unit,
            min: 0.0,
            max: 100.0,
            max_speed: 10.0,
            drive: None,
        }
    }

    #[test]
    fn resolution_follows_steps_per_unit() {
        assert_eq!(decimals(&axis(400.0, Unit::Mm)), 3);
        assert_eq!(decimals(&axis(100.0, Unit::Deg)), 2);
        assert_eq!(decimals(&axis(11200.0, Unit::Mm)), 4);
        assert_eq!(decimals(&axis(1.0, Unit::Steps)), 0);
        assert_eq!(format_units(&axis(400.0, Unit::Mm), 44938), "112.345");
        assert_eq!(format_units(&axis(400.0, Unit::Mm), -1), "-0.003");
        assert_eq!(format_units(&axis(100.0, Unit::Deg), -12345), "-123.45");
        assert_eq!(format_units(&axis(1e6, Unit::Mm), -1), "0.0000");
    }

    #[test]
    fn amounts_drop_useless_zeros() {
        assert_eq!(format_amount(10.0), "10");
        assert_eq!(format_amount(0.01), "0.01");
        assert_eq!(format_amount(2.5), "2.5");
    }

    #[test]
    fn partial_samples_update_only_their_axes() {
        let t = Instant::now();
        let mut p = Positions::default();
        p.apply(&PositionSample {
            at: t,
            steps: PerAxis::new().with(Axis::X, 5).with(Axis::Y, 6),
            source: PositionSource::Measured,
        });
        p.apply(&PositionSample {
            at: t,
            steps: PerAxis::new().with(Axis::Y, 7),
            source: PositionSource::Estimated,
        });
        assert_eq!(p.get(Axis::X).map(|r| r.steps), Some(5));
        assert_eq!(
            p.get(Axis::Y).map(|r| (r.steps, r.source)),
            Some((7, PositionSource::Estimated))
        );
        assert_eq!(p.get(Axis::Z), None);
    }
}
