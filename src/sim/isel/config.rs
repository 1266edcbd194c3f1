//! What the simulated iMC-S8 and its machine are built from: a plain config
//! struct for tests, or a machine profile so that the simulated machine
//! matches the one the console is set up for.
//!
//! Physical layout (`docs/simulator.md`, isel): positions are in steps of
//! machine coordinates, i.e. the counter reading after a reference run with
//! the simulator's built-in `@0IF` steps. Switch 1 sits `limit_margin` below
//! the soft minimum, switch 2 `limit_margin` above the soft maximum. A
//! reference run drives into switch 1, steps out until it closes again
//! (`hysteresis` steps past its trip point) and then travels the `@0IF`
//! steps (manual 4.2.2); the built-in `@0IF` value is chosen so that this
//! lands exactly on machine 0.

use std::time::Duration;

use thiserror::Error;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::config::profile::Unit;
use crate::config::{ProbeSurface, SimVariant};
use crate::proto::isel::{DeviceNumber, InputPort, PortWatch, REFERENCE_CLEAR_STEPS};

use super::flash::{Flash, InitValues};

/// Commands the program memory holds (`docs/decisions.md` isel 9).
pub const PROGRAM_CAPACITY: usize = crate::proto::isel::PROGRAM_CAPACITY;
/// How long `@0k` takes to erase the flash (manual 2.2.17: "etwa 2 Sekunden").
pub const ERASE_TIME: Duration = Duration::from_secs(2);
/// Time a stored command that neither moves nor waits takes to run
/// (`docs/protocols.md`, isel): a program of jumps alone still lets time pass.
pub const PROGRAM_STEP: Duration = Duration::from_millis(1);
/// Switch hysteresis in units of the axis (0.1 mm, 0.1°), at least one step.
pub const HYSTERESIS_UNITS: f64 = 0.1;

/// The mechanics of one axis, in physical steps (machine coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisMechanics {
    /// Where the axis stands at power-up.
    pub start: i64,
    /// Limit switch on the negative side: pressed at and below this position.
    pub switch_neg: i64,
    /// Limit switch on the positive side: pressed at and above this position.
    pub switch_pos: i64,
    /// A pressed switch closes again only this many steps back out of it
    /// (manual 2.2.5: the controller needs a switching hysteresis).
    pub hysteresis: u32,
}

impl AxisMechanics {
    /// The `@0IF` steps that put machine 0 at physical 0 after a reference
    /// run into the negative switch, clamped to what `@0IF` holds.
    pub fn clear_steps(&self) -> u32 {
        let steps = -self.switch_neg - i64::from(self.hysteresis);
        steps.clamp(
            i64::from(*REFERENCE_CLEAR_STEPS.start()),
            i64::from(*REFERENCE_CLEAR_STEPS.end()),
        ) as u32
    }
}

/// Everything an [`IselSim`](super::IselSim) is built from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IselSimConfig {
    /// The device number at power-up (`@0G` changes it until the next one).
    pub device: DeviceNumber,
    /// The machine's axes X, Y, Z, A; `None` for an axis without mechanics
    /// (its outputs drive nothing and it has no switches).
    pub axes: [Option<AxisMechanics>; 4],
    /// The built-in init values `@0IX` restores.
    pub factory: InitValues,
    /// The flash at power-up.
    pub flash: Flash,
    pub program_capacity: usize,
    pub erase_time: Duration,
    pub program_step: Duration,
    /// A hood circuit on port 2 (bit 5 hood closed and automatic, bit 6
    /// hood closed or setup, bit 7 key switch), supervised by the factory
    /// `@0IH` watch [`HOOD_WATCH`]; without one (variant `hood-unwired`)
    /// those bits read 0 and nothing supervises a hood (manual 4.2.13).
    pub hood_circuit: bool,
    /// Input port 2 exists; without it (variant `no-port2`) `@0b2` answers
    /// `1` and there is no hood circuit.
    pub port2: bool,
    /// `@0P` reports positions from the virtual zero of `@0n` (variant
    /// `work-positions`) instead of from the reference point (manual 2.2.19).
    pub work_positions: bool,
    /// A work piece under the probe (variant `probe-surface`): port 1 bit 5
    /// follows it while it is set, whatever the `probe` control says.
    pub probe_surface: Option<ProbeSurface>,
}

/// The factory hood supervision of a controller with a hood circuit: port 2
/// bit 6 ("hood closed or setup") must read 1, else motion answers `H`
/// (manual 2.2.3, 4.2.13, chapter 5). `@0IH` with mask 0 switches it off.
pub const HOOD_WATCH: PortWatch = PortWatch {
    port: InputPort::Status2,
    mask: 0x40,
    value: 0x40,
};

/// A profile the simulator cannot be built from.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SimConfigError {
    #[error("the profile has no axes")]
    NoAxes,
    #[error("axis {axis}: {message}")]
    Axis { axis: Axis, message: String },
}

impl IselSimConfig {
    /// A controller for the given mechanics with factory settings: clearing
    /// steps that put machine 0 at physical 0, no rotary axes.
    pub fn new(axes: [Option<AxisMechanics>; 4]) -> IselSimConfig {
        IselSimConfig::with_rotary(axes, AxisSet::EMPTY)
    }

    fn with_rotary(axes: [Option<AxisMechanics>; 4], rotary: AxisSet) -> IselSimConfig {
        let clear = axes.map(|a| a.map_or(0, |m| m.clear_steps()));
        let mut factory = InitValues::factory(clear, rotary);
        factory.hood_input = HOOD_WATCH;
        IselSimConfig {
            device: DeviceNumber::DEFAULT,
            axes,
            flash: Flash::new(factory.clone()),
            factory,
            program_capacity: PROGRAM_CAPACITY,
            erase_time: ERASE_TIME,
            program_step: PROGRAM_STEP,
            hood_circuit: true,
            port2: true,
            work_positions: false,
            probe_surface: None,
        }
    }

    /// A controller that differs from the default one as `variant` says
    /// (`config::variant`, `docs/simulator.md`). `memory=` is applied by
    /// `sim::registry` for every family.
    pub fn with_variant(mut self, variant: SimVariant) -> IselSimConfig {
        match variant {
            SimVariant::HoodUnwired => self.without_hood(),
            SimVariant::NoPort2 => {
                self.port2 = false;
                self.without_hood();
            }
            SimVariant::WorkPositions => self.work_positions = true,
            SimVariant::ProbeSurface(s) => self.probe_surface = Some(s),
            // Another family's (refused when the profile is checked), or
            // applied by the registry.
            SimVariant::Memory(_) | SimVariant::EmpRejects0aBeforeOn => {}
        }
        self
    }

    fn without_hood(&mut self) {
        self.hood_circuit = false;
        let off = PortWatch {
            port: InputPort::User,
            mask: 0,
            value: 0,
        };
        self.factory.hood_input = off;
        self.flash.init.hood_input = off;
    }

    /// The simulated machine a profile describes: its axes, soft limits,
    /// `[sim] limit_margin` and `start_position`, its `[isel] device`.
    /// Axes measured in degrees are rotary (`@0IT`).
    pub fn from_profile(profile: &Profile) -> Result<IselSimConfig, SimConfigError> {
        if profile.axes.is_empty() {
            return Err(SimConfigError::NoAxes);
        }
        let mut axes = [None; 4];
        let mut rotary = AxisSet::EMPTY;
        for (axis, p) in &profile.axes {
            let fail = |message: &str| SimConfigError::Axis {
                axis: *axis,
                message: message.into(),
            };
            let finite = [
                p.steps_per_unit,
                p.min,
                p.max,
                profile.sim.limit_margin,
                profile.sim.start_position,
            ]
            .iter()
            .all(|v| v.is_finite());
            if !finite || p.steps_per_unit <= 0.0 || p.min >= p.max {
                return Err(fail("needs positive steps per unit and min < max"));
            }
            if profile.sim.limit_margin < 0.0 {
                return Err(fail("the limit margin must not be negative"));
            }
            let steps = |units: f64| (units * p.steps_per_unit).round() as i64;
            let margin = steps(profile.sim.limit_margin);
            let hysteresis = steps(HYSTERESIS_UNITS).clamp(1, i64::from(u16::MAX)) as u32;
            if let Some(slot) = axes.get_mut(axis.index()) {
                *slot = Some(AxisMechanics {
                    start: steps(profile.sim.start_position),
                    switch_neg: p.min_steps() - margin,
                    switch_pos: p.max_steps() + margin,
                    hysteresis,
                });
            }
            if p.unit == Unit::Deg {
                rotary = rotary.with(*axis);
            }
        }
        let mut config = IselSimConfig::with_rotary(axes, rotary);
        config.device = DeviceNumber::new(profile.isel.device).unwrap_or_default();
        Ok(profile
            .sim
            .variants
            .iter()
            .fold(config, |c, v| c.with_variant(*v)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_default_profile_puts_the_switches_at_the_soft_limits_plus_the_margin() {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let config = IselSimConfig::from_profile(&profile).expect("config");
        // 400 steps/mm, X 0..300 mm, margin 2 mm, start 40 mm.
        let x = config.axes[0].expect("X");
        assert_eq!(
            x,
            AxisMechanics {
                start: 16_000,
                switch_neg: -800,
                switch_pos: 120_800,
                hysteresis: 40,
            }
        );
        // Switch at -800, closes again at -760, 760 steps on: machine 0.
        assert_eq!(x.clear_steps(), 760);
        assert_eq!(config.factory.clear_steps, [760, 760, 760, 0]);
        assert!(
            config.axes[3].is_none(),
            "the default machine has no A axis"
        );
        assert_eq!(config.flash.init, config.factory);
    }

    #[test]
    fn clearing_steps_clamp_to_the_range_of_at_if() {
        let m = |neg| AxisMechanics {
            start: 0,
            switch_neg: neg,
            switch_pos: 1000,
            hysteresis: 10,
        };
        assert_eq!(m(5).clear_steps(), 0);
        assert_eq!(m(-200).clear_steps(), 190);
        assert_eq!(m(-1_000_000).clear_steps(), 65_535);
    }
}
