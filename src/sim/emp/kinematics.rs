//! Where a simulated servo axis is over time: one trajectory at a time, each a
//! closed-form function of time, and the first moment it reaches a given
//! position (a switch edge). Positions are physical, in encoder counts, as
//! `f64`; speeds in counts per second.
//!
//! Positioning moves use the shared trapezoid of `crate::motion` (`Motion`,
//! `Ramp`); braking to rest uses `Ramp`'s braking distance and time. Velocity
//! set-points are followed at once: the DRS-500 does not ramp them (EMP manual
//! "2A : Move – Servomotor PWM / PV / IV": "Die Beschleunigung A wird bei
//! diesen Geräten nicht verarbeitet").

use std::time::{Duration, Instant};

use crate::motion::{Motion, Ramp};

/// Bisection steps when solving a positioning profile for a position: the
/// profile's duration halves each step, 64 steps reach far below a nanosecond.
const BISECTION_STEPS: u32 = 64;

/// The shortest distance that counts as "before" an edge: a trajectory starting
/// on an edge does not reach it again.
const EDGE_EPSILON: f64 = 1e-9;

/// One piece of motion, valid from its start time until it is replaced.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Trajectory {
    /// Standing (held by the controller or, without current, by the
    /// self-locking spindle).
    Rest { x: f64 },
    /// Constant speed, without end (velocity and torque modes, homing phases).
    Cruise { t0: Instant, x0: f64, v: f64 },
    /// Braking at constant deceleration from `v0` to rest.
    Brake {
        t0: Instant,
        x0: f64,
        v0: f64,
        decel: f64,
    },
    /// A planned positioning move of `motion.profile().distance()` counts in
    /// direction `dir` (+1 or -1), ending at `target`.
    Move {
        t0: Instant,
        x0: f64,
        dir: f64,
        motion: Motion,
        target: f64,
    },
}

fn secs_since(t0: Instant, t: Instant) -> f64 {
    t.saturating_duration_since(t0).as_secs_f64()
}

fn at(t0: Instant, secs: f64) -> Instant {
    // Durations beyond any test or session are clamped rather than panicking
    // on overflow.
    let secs = if secs.is_finite() {
        secs.clamp(0.0, 1e9)
    } else {
        1e9
    };
    t0.checked_add(Duration::from_secs_f64(secs)).unwrap_or(t0)
}

/// The `Ramp` a brake from `speed` at `decel` follows: from rest to rest, no
/// start-stop jump (a servo has none).
fn brake_ramp(speed: f64, decel: f64) -> Ramp {
    Ramp {
        start_hz: 0.0,
        max_hz: speed,
        accel_hz_per_s: decel,
    }
}

impl Trajectory {
    pub(crate) fn rest(x: f64) -> Trajectory {
        Trajectory::Rest { x }
    }

    /// Constant speed `v` from `x0`; a zero speed is rest.
    pub(crate) fn cruise(t0: Instant, x0: f64, v: f64) -> Trajectory {
        if v == 0.0 || !v.is_finite() {
            Trajectory::Rest { x: x0 }
        } else {
            Trajectory::Cruise { t0, x0, v }
        }
    }

    /// Brake from wherever this trajectory is at `t` with `decel`. A brake
    /// already under way that is at least as hard is kept.
    pub(crate) fn braked(&self, t: Instant, decel: f64) -> Trajectory {
        if let Trajectory::Brake { decel: d, .. } = self
            && *d >= decel
        {
            return self.clone();
        }
        let x0 = self.position(t);
        let v0 = self.velocity(t);
        if v0 == 0.0 || decel <= 0.0 || !decel.is_finite() {
            return Trajectory::Rest { x: x0 };
        }
        Trajectory::Brake {
            t0: t,
            x0,
            v0,
            decel,
        }
    }

    /// A positioning move from `x0` to `target` at up to `speed`, accelerating
    /// and braking at `accel`.
    pub(crate) fn move_to(t0: Instant, x0: f64, target: f64, speed: f64, accel: f64) -> Trajectory {
        let distance = (target - x0).abs().round();
        if distance < 1.0 || speed <= 0.0 {
            return Trajectory::Rest { x: target };
        }
        let motion = Motion::new(
            distance as u64,
            Ramp {
                start_hz: 0.0,
                max_hz: speed,
                accel_hz_per_s: accel,
            },
        );
        Trajectory::Move {
            t0,
            x0,
            dir: (target - x0).signum(),
            motion,
            target,
        }
    }

    pub(crate) fn position(&self, t: Instant) -> f64 {
        match *self {
            Trajectory::Rest { x } => x,
            Trajectory::Cruise { t0, x0, v } => x0 + v * secs_since(t0, t),
            Trajectory::Brake { t0, x0, v0, decel } => {
                let speed = v0.abs();
                let tau = secs_since(t0, t).min(speed / decel);
                x0 + v0.signum() * (speed * tau - 0.5 * decel * tau * tau)
            }
            Trajectory::Move {
                t0,
                x0,
                dir,
                ref motion,
                target,
            } => {
                let tau = t.saturating_duration_since(t0);
                if motion.is_done(tau) {
                    target
                } else {
                    x0 + dir * motion.position_at(tau)
                }
            }
        }
    }

    pub(crate) fn velocity(&self, t: Instant) -> f64 {
        match *self {
            Trajectory::Rest { .. } => 0.0,
            Trajectory::Cruise { v, .. } => v,
            Trajectory::Brake { t0, v0, decel, .. } => {
                let speed = (v0.abs() - decel * secs_since(t0, t)).max(0.0);
                v0.signum() * speed
            }
            Trajectory::Move {
                t0,
                dir,
                ref motion,
                ..
            } => dir * motion.speed_at(t.saturating_duration_since(t0)),
        }
    }

    /// When the axis comes to rest by itself; `None` for rest and cruise.
    pub(crate) fn end(&self) -> Option<Instant> {
        match *self {
            Trajectory::Rest { .. } | Trajectory::Cruise { .. } => None,
            Trajectory::Brake { t0, v0, decel, .. } => {
                Some(t0 + brake_ramp(v0.abs(), decel).braking_time(v0.abs()))
            }
            Trajectory::Move { t0, ref motion, .. } => Some(t0 + motion.end_time()),
        }
    }

    /// Where the axis will come to rest (for a cruise: nowhere, `None`).
    pub(crate) fn rest_position(&self) -> Option<f64> {
        match *self {
            Trajectory::Rest { x } => Some(x),
            Trajectory::Cruise { .. } => None,
            Trajectory::Brake { x0, v0, decel, .. } => {
                Some(x0 + v0.signum() * brake_ramp(v0.abs(), decel).braking_distance(v0.abs()))
            }
            Trajectory::Move { target, .. } => Some(target),
        }
    }

    /// The direction of travel: +1, -1, or 0 at rest.
    pub(crate) fn direction(&self) -> f64 {
        match *self {
            Trajectory::Rest { .. } => 0.0,
            Trajectory::Cruise { v, .. } => v.signum(),
            Trajectory::Brake { v0, .. } => v0.signum(),
            Trajectory::Move { dir, .. } => dir,
        }
    }

    /// The first moment this trajectory reaches `edge` coming from before it
    /// in its direction of travel. A trajectory that starts on the edge or
    /// beyond it never reaches it.
    pub(crate) fn reaches(&self, edge: f64) -> Option<Instant> {
        match *self {
            Trajectory::Rest { .. } => None,
            Trajectory::Cruise { t0, x0, v } => {
                let d = (edge - x0) * v.signum();
                (d > EDGE_EPSILON).then(|| at(t0, d / v.abs()))
            }
            Trajectory::Brake { t0, x0, v0, decel } => {
                let d = (edge - x0) * v0.signum();
                let speed = v0.abs();
                let reach = brake_ramp(speed, decel).braking_distance(speed);
                if d <= EDGE_EPSILON || d > reach {
                    return None;
                }
                // d = speed * tau - decel * tau^2 / 2, the earlier root.
                let disc = (speed * speed - 2.0 * decel * d).max(0.0);
                Some(at(t0, (speed - disc.sqrt()) / decel))
            }
            Trajectory::Move {
                t0,
                x0,
                dir,
                ref motion,
                ..
            } => {
                let d = (edge - x0) * dir;
                if d <= EDGE_EPSILON || d > motion.profile().distance() {
                    return None;
                }
                // The profile's position never decreases: bisect for the
                // first moment it covers `d`.
                let (mut lo, mut hi) = (Duration::ZERO, motion.end_time());
                for _ in 0..BISECTION_STEPS {
                    let mid = lo + (hi - lo) / 2;
                    if mid == lo {
                        break;
                    }
                    if motion.position_at(mid) >= d {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                Some(t0 + hi)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    #[test]
    fn cruise_reaches_edges_ahead_only() {
        let t0 = Instant::now();
        let c = Trajectory::cruise(t0, 100.0, -50.0);
        assert_eq!(c.position(t0 + ms(1000)), 50.0);
        assert_eq!(c.reaches(0.0), Some(t0 + ms(2000)));
        assert_eq!(c.reaches(200.0), None);
        assert_eq!(c.reaches(100.0), None, "starts on the edge");
        assert_eq!(Trajectory::cruise(t0, 5.0, 0.0), Trajectory::rest(5.0));
    }

    #[test]
    fn brake_stops_after_the_braking_distance() {
        let t0 = Instant::now();
        let b = Trajectory::cruise(t0, 0.0, 1000.0).braked(t0, 10_000.0);
        // 1000 / 10000 = 0.1 s, 1000^2 / (2 * 10000) = 50 counts.
        assert_eq!(b.end(), Some(t0 + ms(100)));
        assert!((b.position(t0 + ms(500)) - 50.0).abs() < 1e-9);
        assert_eq!(b.rest_position(), Some(50.0));
        assert_eq!(b.velocity(t0 + ms(100)), 0.0);
        let hit = b.reaches(37.5).unwrap();
        // 37.5 = 1000 t - 5000 t^2 -> t = 0.05 s.
        assert!((hit - t0).as_secs_f64() - 0.05 < 1e-9);
        assert_eq!(b.reaches(51.0), None, "beyond the braking distance");
        // A softer brake does not replace a harder one.
        assert_eq!(b.braked(t0 + ms(10), 1.0), b);
    }

    #[test]
    fn moves_reach_their_target_and_every_edge_between() {
        let t0 = Instant::now();
        let m = Trajectory::move_to(t0, 1000.0, 0.0, 500.0, 5_000.0);
        let end = m.end().unwrap();
        assert_eq!(m.position(end), 0.0);
        assert_eq!(m.direction(), -1.0);
        let hit = m.reaches(400.0).unwrap();
        assert!((m.position(hit) - 400.0).abs() < 1e-3);
        assert!(hit < end);
        assert_eq!(m.reaches(-1.0), None);
        // A move of less than one count is no move.
        assert_eq!(
            Trajectory::move_to(t0, 3.2, 3.0, 10.0, 10.0),
            Trajectory::rest(3.0)
        );
    }
}
