//! One leg of motion in progress: its geometry in counter coordinates, its
//! trapezoidal timing (`crate::motion`), and the search for the moment a
//! limit switch changes while the carriage travels along it.
//!
//! A leg is parameterised by the fraction `f` of its distance: the speed
//! profile says how far along the leg the axes are at a time, the path says
//! where that is. Lines move every axis in proportion (the controller's
//! linear interpolation, manual 2.2.2); arcs follow the circle of a `y`/`w`
//! command (manual 2.3) with a helix's third axis in proportion.

use std::time::{Duration, Instant};

use crate::motion::{Motion, Ramp};

use super::mechanics::{AxisState, NEG, POS};

/// Axis positions X, Y, Z, A.
pub type Point = [f64; 4];

/// The geometry of a leg, from its start (`f` = 0) to its end (`f` = 1).
#[derive(Debug, Clone, PartialEq)]
pub enum Path {
    Line { from: Point, to: Point },
    Arc(ArcPath),
}

/// A circular arc in the plane of two axes, and a third axis that moves in
/// proportion (a helix).
#[derive(Debug, Clone, PartialEq)]
pub struct ArcPath {
    /// Every axis at the start; axes outside the arc stay there.
    pub from: Point,
    /// Indices of the plane's axis 1 and axis 2.
    pub plane: (usize, usize),
    pub centre: (f64, f64),
    pub radius: f64,
    /// Radians, counter-clockwise from axis 1.
    pub start_angle: f64,
    /// Signed radians: positive is counter-clockwise.
    pub sweep: f64,
    /// The helix axis and its travel over the whole arc.
    pub third: Option<(usize, f64)>,
}

impl Path {
    pub fn at(&self, f: f64) -> Point {
        let f = f.clamp(0.0, 1.0);
        match self {
            Path::Line { from, to } => {
                let mut p = *from;
                for (i, v) in p.iter_mut().enumerate() {
                    *v += (to[i] - from[i]) * f;
                }
                p
            }
            Path::Arc(arc) => arc.at(f),
        }
    }

    /// Every axis moves monotonically along a line, so a switch predicate
    /// along it changes at most once.
    fn is_line(&self) -> bool {
        matches!(self, Path::Line { .. })
    }
}

impl ArcPath {
    pub fn at(&self, f: f64) -> Point {
        let mut p = self.from;
        let angle = self.start_angle + self.sweep * f;
        let (a1, a2) = self.plane;
        if let Some(v) = p.get_mut(a1) {
            *v = self.centre.0 + self.radius * angle.cos();
        }
        if let Some(v) = p.get_mut(a2) {
            *v = self.centre.1 + self.radius * angle.sin();
        }
        if let Some((axis, delta)) = self.third
            && let Some(v) = p.get_mut(axis)
        {
            *v = self.from[axis] + delta * f;
        }
        p
    }

    /// What is left of this arc from fraction `f` on.
    pub fn remainder(&self, f: f64, from: Point) -> ArcPath {
        ArcPath {
            from,
            start_angle: self.start_angle + self.sweep * f,
            sweep: self.sweep * (1.0 - f),
            third: self.third.map(|(axis, delta)| (axis, delta * (1.0 - f))),
            ..self.clone()
        }
    }
}

/// A leg being travelled.
#[derive(Debug, Clone, PartialEq)]
pub struct LegRun {
    pub path: Path,
    /// The counters when the leg completes as planned.
    pub end: [i64; 4],
    /// Steps along the leg the speed profile covers (> 0).
    pub distance: u64,
    pub t0: Instant,
    pub motion: Motion,
}

/// Bisection rounds: fractions to 2^-64, times to the nanosecond.
const BISECTIONS: u32 = 64;

impl LegRun {
    pub fn new(path: Path, end: [i64; 4], distance: u64, ramp: Ramp, t0: Instant) -> LegRun {
        LegRun {
            path,
            end,
            distance: distance.max(1),
            t0,
            motion: Motion::new(distance.max(1), ramp),
        }
    }

    pub fn elapsed(&self, t: Instant) -> Duration {
        t.saturating_duration_since(self.t0)
    }

    pub fn fraction_at(&self, t: Instant) -> f64 {
        self.motion.position_at(self.elapsed(t)) / self.distance as f64
    }

    pub fn position_at(&self, t: Instant) -> Point {
        self.path.at(self.fraction_at(t))
    }

    /// When the carriage comes to rest on this leg.
    pub fn end_time(&self) -> Instant {
        self.t0 + self.motion.end_time()
    }

    /// Where the counters stand once the leg is over: the planned end, or,
    /// for a leg cut short, the step each axis had reached.
    pub fn final_counters(&self) -> [i64; 4] {
        if self.motion.is_cut_short() {
            self.position_at(self.end_time()).map(|v| v.round() as i64)
        } else {
            self.end
        }
    }

    /// The first moment at or after `from` when the leg has covered the
    /// fraction `f`.
    pub fn time_of_fraction(&self, f: f64, from: Instant) -> Instant {
        let target = f * self.distance as f64;
        let mut lo = self.elapsed(from);
        let mut hi = self.motion.end_time().max(lo);
        if self.motion.position_at(lo) >= target {
            return self.t0 + lo;
        }
        for _ in 0..BISECTIONS {
            if hi.saturating_sub(lo) <= Duration::from_nanos(1) {
                break;
            }
            let mid = lo + (hi - lo) / 2;
            if self.motion.position_at(mid) >= target {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        self.t0 + hi
    }

    /// The first switch that changes after `from` on this leg, with the
    /// fraction where it does: `(fraction, axis, side)`.
    pub fn next_switch_change(
        &self,
        axes: &[AxisState; 4],
        from: Instant,
    ) -> Option<(f64, usize, usize)> {
        let fa = self.fraction_at(from);
        let fb = self.fraction_at(self.end_time());
        let mut best: Option<(f64, usize, usize)> = None;
        for (i, axis) in axes.iter().enumerate() {
            if axis.layout.is_none() {
                continue;
            }
            for side in [NEG, POS] {
                let pressed = axis.pressed.get(side).copied().unwrap_or(false);
                let crossed = |f: f64| {
                    let counter = self.path.at(f).get(i).copied().unwrap_or(0.0);
                    axis.threshold_crossed(side, axis.phys_of(counter), pressed)
                };
                let found = if crossed(fa) {
                    Some(fa)
                } else if fb > fa {
                    self.first_crossing(fa, fb, &crossed)
                } else {
                    None
                };
                if let Some(f) = found
                    && best.is_none_or(|(b, _, _)| f < b)
                {
                    best = Some((f, i, side));
                }
            }
        }
        best
    }

    /// The smallest fraction in (`fa`, `fb`] where `crossed` holds, given
    /// that it does not at `fa`.
    fn first_crossing(&self, fa: f64, fb: f64, crossed: &dyn Fn(f64) -> bool) -> Option<f64> {
        // Lines: monotonic, one look at the end. Arcs: about one sample per
        // step of travel, so no switch is entered and left unseen.
        let samples = if self.path.is_line() {
            1
        } else {
            (((fb - fa) * self.distance as f64).ceil() as usize).clamp(8, 20_000)
        };
        let mut lo = fa;
        for k in 1..=samples {
            let hi = fa + (fb - fa) * k as f64 / samples as f64;
            if crossed(hi) {
                return Some(bisect(lo, hi, crossed));
            }
            lo = hi;
        }
        None
    }
}

/// Narrow `(lo, hi]` down to the first fraction where `crossed` holds.
fn bisect(mut lo: f64, mut hi: f64, crossed: &dyn Fn(f64) -> bool) -> f64 {
    for _ in 0..BISECTIONS {
        let mid = lo + (hi - lo) / 2.0;
        if mid <= lo || mid >= hi {
            break;
        }
        if crossed(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::isel::config::AxisMechanics;

    fn ramp(max_hz: f64) -> Ramp {
        Ramp {
            start_hz: 300.0,
            max_hz,
            accel_hz_per_s: 100_000.0,
        }
    }

    fn axes() -> [AxisState; 4] {
        let m = AxisMechanics {
            start: 0,
            switch_neg: -800,
            switch_pos: 4000,
            hysteresis: 40,
        };
        [
            AxisState::power_up(Some(m)),
            AxisState::power_up(Some(m)),
            AxisState::power_up(None),
            AxisState::power_up(None),
        ]
    }

    #[test]
    fn a_line_finds_the_switch_where_it_is() {
        let t0 = Instant::now();
        let run = LegRun::new(
            Path::Line {
                from: [0.0; 4],
                to: [10_000.0, 5_000.0, 0.0, 0.0],
            },
            [10_000, 5_000, 0, 0],
            10_000,
            ramp(2000.0),
            t0,
        );
        let (f, axis, side) = run.next_switch_change(&axes(), t0).expect("switch");
        assert_eq!((axis, side), (0, POS));
        assert!((f - 0.4).abs() < 1e-12);
        let t = run.time_of_fraction(f, t0);
        let at = run.position_at(t);
        assert!((at[0] - 4000.0).abs() < 1e-3, "{at:?}");
        assert!((at[1] - 2000.0).abs() < 1e-3);
    }

    #[test]
    fn an_arc_finds_the_switch_it_touches() {
        let t0 = Instant::now();
        // Full circle of radius 1000 around (0, 0) starting at (1000, 0):
        // it reaches x = -800 (switch 1 of X) at 143.13 degrees.
        let arc = ArcPath {
            from: [1000.0, 0.0, 0.0, 0.0],
            plane: (0, 1),
            centre: (0.0, 0.0),
            radius: 1000.0,
            start_angle: 0.0,
            sweep: std::f64::consts::TAU,
            third: None,
        };
        let run = LegRun::new(Path::Arc(arc), [1000, 0, 0, 0], 8000, ramp(2000.0), t0);
        let mut a = axes();
        a[0].phys = 1000;
        a[0].set_counter(1000);
        let (f, axis, side) = run.next_switch_change(&a, t0).expect("switch");
        assert_eq!((axis, side), (0, NEG));
        let angle = f * 360.0;
        assert!((angle - 143.130).abs() < 0.01, "{angle}");
    }

    #[test]
    fn a_leg_cut_short_ends_on_the_step_it_reached() {
        let t0 = Instant::now();
        let mut run = LegRun::new(
            Path::Line {
                from: [0.0; 4],
                to: [1000.0, 0.0, 0.0, 0.0],
            },
            [1000, 0, 0, 0],
            1000,
            ramp(300.0),
            t0,
        );
        assert_eq!(run.final_counters(), [1000, 0, 0, 0]);
        run.motion.halt(Duration::from_millis(1000));
        assert_eq!(run.final_counters(), [300, 0, 0, 0]);
        assert_eq!(run.end_time(), t0 + Duration::from_secs(1));
    }
}
