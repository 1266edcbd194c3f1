//! The G-code core's view of the machine, filled from a profile: the
//! interpreter's setup and the check's machine. The core crate knows no
//! profile; this is the one place that reads one for it.

use std::collections::BTreeMap;

use crate::axis::Axis;
use crate::config::profile::Profile;
use crate::offsets::{System, WorkOffsets};

use super::check::Machine;
use super::heightmap::Fit;
use super::setup::{Setup, SetupError, outputs_of};
use super::target::Target;
use super::toolpath::Point;

/// The interpreter's setup from a validated profile and the work offsets in
/// force (steps).
pub fn setup_of(profile: &Profile, offsets: &WorkOffsets) -> Result<Setup, Vec<SetupError>> {
    let axes: Vec<Axis> = profile
        .axis_set()
        .iter()
        .filter(|a| *a != Axis::A)
        .collect();
    let mut zeros = [Point::default(); System::COUNT];
    for system in System::ALL {
        let mm = |axis: Axis| {
            profile
                .axis(axis)
                .map_or(0.0, |p| p.to_units(offsets.zero(system, axis)))
        };
        zeros[system.index()] = Point {
            x: mm(Axis::X),
            y: mm(Axis::Y),
            z: mm(Axis::Z),
        };
    }
    let outputs = profile.wiring().map(|w| outputs_of(&w)).unwrap_or_default();
    let mut setup = Setup {
        axes,
        default_units: None,
        zeros,
        active: offsets.active(),
        start: Point::default(),
        outputs,
        codes: BTreeMap::new(),
    };
    setup.apply_table(profile.gcode.unit.as_deref(), &profile.gcode.codes)?;
    Ok(setup)
}

/// The check's machine: soft limits and speeds of X, Y and Z, the rapid
/// speed and the target family's position counter.
pub fn machine_of(profile: &Profile, target: Target) -> Machine {
    let axes = || {
        [Axis::X, Axis::Y, Axis::Z]
            .into_iter()
            .filter_map(|a| profile.axis(a).map(|p| (a, p)))
    };
    Machine {
        axes: axes()
            .map(|(a, p)| (a, p.min, p.max, p.max_speed))
            .collect(),
        rapid_speed: profile.gcode.rapid_speed,
        steps_per_mm: axes().map(|(a, p)| (a, p.steps_per_unit)).collect(),
        counter: target.counter(),
        controller: target.name(),
    }
}

/// What a height map is applied with: the profile's name, one step of X and
/// Y (how far the work zero may lie from the map's), the chord tolerance
/// of arcs and Z's upper soft limit (rapids are raised at most to it).
pub fn fit_of(profile: &Profile) -> Fit {
    let step = |axis: Axis| {
        profile
            .axis(axis)
            .map_or(0.0, |p| 1.0 / p.steps_per_unit.max(f64::MIN_POSITIVE))
    };
    Fit {
        profile: profile.name.clone(),
        step_mm: (step(Axis::X), step(Axis::Y)),
        chord_tolerance: profile.gcode.chord_tolerance,
        z_max: profile.axis(Axis::Z).map(|p| p.max),
    }
}
