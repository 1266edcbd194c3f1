//! The simulated machine's axes: where each carriage physically stands, the
//! controller's step counter, and the two limit switches with hysteresis.
//!
//! Physical positions are in steps of machine coordinates (`config.rs`).
//! The counter is what `@0P` reports: `counter = dir * (phys - origin)`,
//! `origin` being the physical position where the counter reads 0 and `dir`
//! -1 for an axis inverted with `@0ID` (manual 4.2.8).

use super::config::AxisMechanics;
use crate::config::ProbeSurface;

/// Index of the switch on the negative physical side.
pub const NEG: usize = 0;
/// Index of the switch on the positive physical side.
pub const POS: usize = 1;

/// One axis at rest, or the state it had when its current leg started.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AxisState {
    pub layout: Option<AxisMechanics>,
    /// Physical position, steps.
    pub phys: i64,
    origin: i64,
    dir: i64,
    /// Whether the carriage presses the switch of each side, with
    /// hysteresis: set at the trip point, cleared `hysteresis` steps back.
    pub pressed: [bool; 2],
    /// Switch inputs held active by the operator, per input (switch 1, 2),
    /// whatever the carriage does.
    pub forced: [bool; 2],
}

impl AxisState {
    /// Power-up: the counter reads 0 wherever the carriage stands.
    pub fn power_up(layout: Option<AxisMechanics>) -> AxisState {
        let phys = layout.map_or(0, |m| m.start);
        let mut axis = AxisState {
            layout,
            phys,
            origin: phys,
            dir: 1,
            pressed: [false; 2],
            forced: [false; 2],
        };
        axis.pressed = [
            axis.threshold_crossed(NEG, phys as f64, false),
            axis.threshold_crossed(POS, phys as f64, false),
        ];
        axis
    }

    pub fn counter(&self) -> i64 {
        self.dir * (self.phys - self.origin)
    }

    /// Make the counter read `counter` where the carriage stands.
    pub fn set_counter(&mut self, counter: i64) {
        self.origin = self.phys - self.dir * counter;
    }

    /// Invert the direction (or not); the counter keeps its reading.
    pub fn set_inverted(&mut self, inverted: bool) {
        let counter = self.counter();
        self.dir = if inverted { -1 } else { 1 };
        self.set_counter(counter);
    }

    /// +1, or -1 when inverted.
    pub fn dir(&self) -> i64 {
        self.dir
    }

    /// The physical position of a counter reading.
    pub fn phys_of(&self, counter: f64) -> f64 {
        self.origin as f64 + self.dir as f64 * counter
    }

    /// Move the carriage to where the counter reads `counter`.
    pub fn move_to_counter(&mut self, counter: i64) {
        self.phys = self.origin + self.dir * counter;
        self.settle();
    }

    /// Bring the switch states up to the carriage's resting position.
    pub fn settle(&mut self) {
        let phys = self.phys as f64;
        for side in [NEG, POS] {
            let pressed = self.pressed.get(side).copied().unwrap_or(false);
            if self.threshold_crossed(side, phys, pressed)
                && let Some(p) = self.pressed.get_mut(side)
            {
                *p = !pressed;
            }
        }
    }

    /// Whether, at physical position `phys`, the switch of `side` changes
    /// from its state `pressed`: a released switch trips at its position, a
    /// pressed one closes again `hysteresis` steps back. Axes without
    /// mechanics have no switches.
    pub fn threshold_crossed(&self, side: usize, phys: f64, pressed: bool) -> bool {
        let Some(m) = self.layout else {
            return false;
        };
        let h = f64::from(m.hysteresis);
        match (side, pressed) {
            (NEG, false) => phys <= m.switch_neg as f64,
            (NEG, true) => phys >= m.switch_neg as f64 + h,
            (_, false) => phys >= m.switch_pos as f64,
            (_, true) => phys <= m.switch_pos as f64 - h,
        }
    }

    /// The contact of switch input `input` (0 = switch 1, 1 = switch 2):
    /// pressed by the carriage or held by the operator. With `swapped`
    /// (`@0Ie`, manual 4.2.7) input 1 is wired to the positive side.
    pub fn contact(&self, input: usize, swapped: bool) -> bool {
        let side = input ^ usize::from(swapped);
        self.pressed.get(side).copied().unwrap_or(false)
            || self.forced.get(input).copied().unwrap_or(false)
    }
}

/// Where the carriages stand when the counters read `counters`, in steps of
/// machine coordinates; an axis the machine lacks stands at 0.
pub fn physical_point(axes: &[AxisState; 4], counters: [i64; 4]) -> [f64; 4] {
    let mut out = [0.0; 4];
    for ((o, axis), c) in out.iter_mut().zip(axes).zip(counters) {
        if axis.layout.is_some() {
            *o = axis.phys_of(c as f64);
        }
    }
    out
}

/// Whether the probe touches `surface` with the counters at `counters`:
/// Z inside the work piece's material. Whole steps, as the carriage makes
/// them, so a move's trip and the state at rest are the same reading.
pub fn surface_touched(surface: &ProbeSurface, axes: &[AxisState; 4], counters: [i64; 4]) -> bool {
    let [x, y, z, _] = physical_point(axes, counters);
    surface.touches(x, y, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(start: i64) -> AxisState {
        AxisState::power_up(Some(AxisMechanics {
            start,
            switch_neg: -800,
            switch_pos: 10_000,
            hysteresis: 40,
        }))
    }

    #[test]
    fn switches_trip_at_their_position_and_close_with_hysteresis() {
        let mut a = axis(-800);
        assert_eq!(a.pressed, [true, false]);
        a.move_to_counter(20);
        assert_eq!(a.pressed, [true, false], "inside the hysteresis");
        a.move_to_counter(40);
        assert_eq!(a.pressed, [false, false]);
        a.move_to_counter(10_800);
        assert_eq!(a.pressed, [false, true]);
        assert!(a.contact(1, false) && a.contact(0, true));
        assert!(!a.contact(0, false));
    }

    #[test]
    fn the_counter_follows_origin_and_direction() {
        let mut a = axis(1000);
        assert_eq!(a.counter(), 0);
        a.move_to_counter(250);
        assert_eq!(a.phys, 1250);
        a.set_counter(0);
        a.set_inverted(true);
        assert_eq!(a.counter(), 0);
        a.move_to_counter(100);
        assert_eq!(a.phys, 1150);
        assert_eq!(a.phys_of(-100.0), 1350.0);
        let none = AxisState::power_up(None);
        assert!(!none.threshold_crossed(NEG, -1e12, false));
    }
}
