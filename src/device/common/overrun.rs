//! How fast a continuous jog may go: when the operator lets go, the axis
//! runs on for one dead-man timeout at speed and then brakes, and together
//! that must stay within `jog.max_overrun`:
//!
//! ```text
//! v T + braking(v) <= D
//! ```
//!
//! Braking is the family's: isel ramps down at a constant acceleration to
//! its start-stop frequency, EMCU takes its fixed ramp time from any speed,
//! a servo drive brakes at what its motor can do. Each hands in the ramp a
//! move at speed `v` has, and the largest `v` is found by bisection (the
//! distance grows with `v` for every such ramp).

use crate::motion::Ramp;

/// Highest speed ever considered, Hz: far above any controller's.
const CEILING_HZ: f64 = 1e9;

/// The fastest jog speed (Hz) that stops within `max_overrun` steps, with a
/// reaction time of `reaction_s` seconds and `ramp_at(v)` the ramp of a move
/// at `v`. `f64::MAX` when no speed is too fast (no reaction time and no
/// braking distance).
pub fn overrun_cap(reaction_s: f64, max_overrun: f64, ramp_at: impl Fn(f64) -> Ramp) -> f64 {
    let travel = |v: f64| v * reaction_s + ramp_at(v).braking_distance(v);
    if travel(CEILING_HZ) <= max_overrun {
        return f64::MAX;
    }
    let (mut lo, mut hi) = (0.0f64, CEILING_HZ);
    // 200 halvings of 1e9 reach far below f64's resolution near any answer.
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if travel(mid) <= max_overrun {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant_accel(start_hz: f64, accel: f64) -> impl Fn(f64) -> Ramp {
        move |v| Ramp {
            start_hz,
            max_hz: v,
            accel_hz_per_s: accel,
        }
    }

    #[test]
    fn it_balances_reaction_and_braking() {
        let v = overrun_cap(0.15, 1200.0, constant_accel(300.0, 100_000.0));
        let travel = v * 0.15 + (v * v - 300.0 * 300.0) / (2.0 * 100_000.0);
        assert!((travel - 1200.0).abs() < 1e-6, "{travel}");
        // The closed form of the same equation.
        let (a, t, f0, d) = (100_000.0f64, 0.15f64, 300.0f64, 1200.0f64);
        let closed = -a * t + (a * a * t * t + f0 * f0 + 2.0 * a * d).sqrt();
        assert!((v - closed).abs() < 1e-6, "{v} {closed}");
    }

    #[test]
    fn a_fixed_ramp_time_brakes_over_the_mean_speed() {
        // EMCU: 500 ms from any speed down to 200 Hz.
        let ramp = |v: f64| Ramp {
            start_hz: 200.0,
            max_hz: v,
            accel_hz_per_s: if v > 200.0 { (v - 200.0) / 0.5 } else { 0.0 },
        };
        let v = overrun_cap(0.15, 600.0, ramp);
        // v T + (v + s) R / 2 = D  ->  v = (D - s R / 2) / (T + R / 2)
        assert!((v - 550.0 / 0.4).abs() < 1e-6, "{v}");
    }

    #[test]
    fn without_braking_or_reaction_nothing_is_too_fast() {
        assert_eq!(overrun_cap(0.0, 10.0, constant_accel(0.0, 0.0)), f64::MAX);
        let v = overrun_cap(0.1, 10.0, constant_accel(0.0, 0.0));
        assert!((v - 100.0).abs() < 1e-6, "{v}");
    }
}
