//! The simulated machine behind the interface: where each carriage can
//! physically go and where it stands at power-up. Positions are in steps of
//! machine coordinates, the reference switch of every axis at 0.

use thiserror::Error;

use crate::axis::Axis;
use crate::config::Profile;
use crate::proto::emcu::EmcuAxis;

/// Hard end stops of one axis: the carriage cannot go below `low` or above
/// `high`; a move driven further loses its steps there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EndStops {
    pub low: i64,
    pub high: i64,
}

impl EndStops {
    /// Both stops, whichever order they are given in.
    pub fn new(a: i64, b: i64) -> EndStops {
        EndStops {
            low: a.min(b),
            high: a.max(b),
        }
    }

    pub fn clamp(&self, position: i64) -> i64 {
        position.clamp(self.low, self.high)
    }
}

/// One axis of the simulated machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisTravel {
    /// `None`: no end stops (a channel the profile gives no axis; the SMC3000
    /// still counts its steps).
    pub end_stops: Option<EndStops>,
    /// Machine position at power-up (clamped into the end stops).
    pub start: i64,
}

impl AxisTravel {
    /// Where the carriage stands at power-up.
    pub fn start_position(&self) -> i64 {
        self.end_stops.map_or(self.start, |s| s.clamp(self.start))
    }
}

/// Everything the device model needs to know about the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmcuSimConfig {
    /// X, Y, Z in this order.
    pub axes: [AxisTravel; 3],
}

/// A profile that cannot be simulated on an EMCU.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SimConfigError {
    #[error("the EMCU drives X, Y and Z only, but the profile lists axis {0}")]
    NotEmcuAxis(Axis),
}

impl Default for EmcuSimConfig {
    /// Three axes of the shipped `emcu` profile's X: 200 steps/mm, soft limits
    /// 0..300 mm, end stops 2 mm beyond them, standing at 40 mm.
    fn default() -> Self {
        let axis = AxisTravel {
            end_stops: Some(EndStops::new(-400, 60_400)),
            start: 8_000,
        };
        EmcuSimConfig { axes: [axis; 3] }
    }
}

impl EmcuSimConfig {
    /// The machine a profile describes: end stops `sim.limit_margin` beyond
    /// each soft limit, carriages at `sim.start_position`. Channels the
    /// profile gives no axis have no end stops and stand at 0.
    pub fn from_profile(profile: &Profile) -> Result<EmcuSimConfig, SimConfigError> {
        let mut axes = [AxisTravel {
            end_stops: None,
            start: 0,
        }; 3];
        for (axis, p) in &profile.axes {
            let emcu = EmcuAxis::new(*axis).map_err(|_| SimConfigError::NotEmcuAxis(*axis))?;
            let margin = profile.sim.limit_margin;
            if let Some(cell) = axes.get_mut(emcu.index()) {
                *cell = AxisTravel {
                    end_stops: Some(EndStops::new(
                        p.to_steps(p.min - margin),
                        p.to_steps(p.max + margin),
                    )),
                    start: p.to_steps(profile.sim.start_position),
                };
            }
        }
        Ok(EmcuSimConfig { axes })
    }

    pub fn axis(&self, axis: EmcuAxis) -> Option<&AxisTravel> {
        self.axes.get(axis.index())
    }
}
