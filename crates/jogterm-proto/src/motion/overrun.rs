//! How far an axis runs on after the operator lets go, and the speeds and
//! leases that keep that within the profile's `jog.max_overrun`.
//!
//! Without key release events the console learns that a key was let go only
//! when the next repeat is late: the jog then runs for up to one lease at
//! speed, plus the time the stop takes to reach the wire, plus the braking
//! ramp. So for a jog at `v` with a lease `t`:
//!
//! ```text
//! travel(v, t) = v · (t + STOP_REACTION) + braking(v)   <=   max_overrun
//! ```
//!
//! [`speed_cap`] is the fastest `v` that keeps this for a lease `t`
//! ([`reaction_speed_cap`] for any reaction time: the drivers' own caps),
//! [`lease_cap`] the longest lease a jog already running at `v` may be given.
//! Pure arithmetic: no clocks, no I/O (`docs/jogging.md`, "The overrun
//! bound").

use std::time::Duration;

use super::Ramp;

/// Allowance for the way from "the lease has run out" (or "a key was let
/// go") to the stop byte on the wire: the device task's timer (1 ms
/// granularity), the driver, the paced writer. Measured well below this
/// (`benches/jog.rs`); it is part of every bound, so a late stop still keeps
/// the overrun promise.
pub const STOP_REACTION: Duration = Duration::from_millis(10);

/// How a controller family brakes a move from speed to rest, in steps and
/// steps per second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Braking {
    /// A linear ramp at constant deceleration down to the start-stop speed,
    /// which stops at once (isel manual 2.2.15/2.2.16: `@0j`, `@0J`).
    Ramp { start_hz: f64, accel_hz_per_s: f64 },
    /// A ramp of fixed length from any speed down to the start speed (EMCU
    /// manual 1.5.5-1.5.7: "Aus der Rampenlänge und der Startgeschwindigkeit
    /// errechnet sich die Startrampe und Bremsrampe").
    FixedTime { start_hz: f64, ramp: Duration },
}

impl Braking {
    /// Steps travelled while braking from `v` Hz to rest.
    pub fn distance(&self, v: f64) -> f64 {
        if !(v.is_finite() && v > 0.0) {
            return 0.0;
        }
        match *self {
            Braking::Ramp {
                start_hz,
                accel_hz_per_s,
            } => Ramp {
                start_hz,
                max_hz: v,
                accel_hz_per_s,
            }
            .braking_distance(v),
            Braking::FixedTime { start_hz, ramp } => {
                let f0 = start_hz.max(0.0);
                if v <= f0 {
                    0.0
                } else {
                    (v + f0) / 2.0 * ramp.as_secs_f64()
                }
            }
        }
    }
}

/// Steps an axis jogging at `v` Hz travels when its lease of `lease` runs
/// out unrenewed: the lease at speed, the stop's way to the wire, braking.
pub fn travel(braking: &Braking, v: f64, lease: Duration) -> f64 {
    if !(v.is_finite() && v > 0.0) {
        return 0.0;
    }
    v * (lease + STOP_REACTION).as_secs_f64() + braking.distance(v)
}

/// The fastest speed (Hz) whose [`travel`] over `lease` stays within
/// `max_overrun` steps; 0 when not even a crawl does.
pub fn speed_cap(braking: &Braking, lease: Duration, max_overrun: f64) -> f64 {
    reaction_speed_cap(braking, lease + STOP_REACTION, max_overrun)
}

/// The fastest speed (Hz) that runs on for `reaction` at speed and then
/// brakes within `max_overrun` steps: v · reaction + braking(v) <= bound.
/// 0 when not even a crawl does; `f64::MAX` when nothing is too fast (no
/// reaction time and no braking distance). The distance grows strictly
/// with the speed, so a bisection finds it for any braking model.
pub fn reaction_speed_cap(braking: &Braking, reaction: Duration, max_overrun: f64) -> f64 {
    if !(max_overrun.is_finite() && max_overrun > 0.0) {
        return 0.0;
    }
    let t = reaction.as_secs_f64();
    let run_on = |v: f64| v * t + braking.distance(v);
    // Nothing runs faster than it could travel the whole bound in the
    // reaction time alone; without a reaction time, far above any
    // controller's speed.
    let mut hi = if t > 0.0 { max_overrun / t } else { CEILING_HZ };
    if run_on(hi) <= max_overrun {
        return if t > 0.0 { hi } else { f64::MAX };
    }
    let mut lo = 0.0;
    for _ in 0..100 {
        let mid = (lo + hi) / 2.0;
        if run_on(mid) <= max_overrun {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Highest speed considered when no reaction time bounds it, Hz.
const CEILING_HZ: f64 = 1e9;

/// The longest lease a jog running at `v` Hz may hold so that its
/// [`travel`] stays within `max_overrun`; zero when even an immediate stop
/// would overrun.
pub fn lease_cap(braking: &Braking, v: f64, max_overrun: f64) -> Duration {
    if !(v.is_finite() && v > 0.0) {
        return Duration::MAX;
    }
    let left = max_overrun - braking.distance(v) - v * STOP_REACTION.as_secs_f64();
    if !(left.is_finite() && left > 0.0) {
        return Duration::ZERO;
    }
    Duration::try_from_secs_f64(left / v).unwrap_or(Duration::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const ISEL: Braking = Braking::Ramp {
        start_hz: 300.0,
        accel_hz_per_s: 100_000.0,
    };

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn the_default_isel_profile_caps_the_grace_phase_below_the_repeat_phase() {
        // 400 steps/mm, max_overrun 3 mm = 1200 steps.
        let grace = speed_cap(&ISEL, ms(750), 1200.0);
        let repeats = speed_cap(&ISEL, ms(150), 1200.0);
        assert!((travel(&ISEL, grace, ms(750)) - 1200.0).abs() < 1e-3);
        assert!((travel(&ISEL, repeats, ms(150)) - 1200.0).abs() < 1e-3);
        // About 3.9 mm/s while the first repeat is awaited, 15 mm/s after.
        assert!(grace > 1_500.0 && grace < 1_600.0, "{grace}");
        assert!(repeats > 6_000.0 && repeats < 6_300.0, "{repeats}");
    }

    #[test]
    fn below_the_start_stop_speed_nothing_brakes() {
        // 100 steps in 0.5 s + 10 ms: a crawl under 300 Hz.
        let v = speed_cap(&ISEL, ms(490), 100.0);
        assert!((v - 200.0).abs() < 1e-6, "{v}");
        assert_eq!(ISEL.distance(v), 0.0);
    }

    #[test]
    fn a_fixed_ramp_brakes_in_its_own_time() {
        let emcu = Braking::FixedTime {
            start_hz: 200.0,
            ramp: ms(500),
        };
        assert_eq!(emcu.distance(100.0), 0.0);
        assert!((emcu.distance(1_000.0) - 300.0).abs() < 1e-9);
        let v = speed_cap(&emcu, ms(150), 600.0);
        assert!((travel(&emcu, v, ms(150)) - 600.0).abs() < 1e-3);
    }

    #[test]
    fn the_reaction_cap_is_the_closed_form_for_a_constant_ramp() {
        let v = reaction_speed_cap(&ISEL, ms(150), 1200.0);
        let (a, t, f0, d) = (100_000.0f64, 0.15f64, 300.0f64, 1200.0f64);
        let closed = -a * t + (a * a * t * t + f0 * f0 + 2.0 * a * d).sqrt();
        assert!((v - closed).abs() < 1e-6, "{v} {closed}");
        // EMCU: 500 ms from any speed down to 200 Hz:
        // v T + (v + s) R / 2 = D  ->  v = (D - s R / 2) / (T + R / 2)
        let emcu = Braking::FixedTime {
            start_hz: 200.0,
            ramp: ms(500),
        };
        let v = reaction_speed_cap(&emcu, ms(150), 600.0);
        assert!((v - 550.0 / 0.4).abs() < 1e-6, "{v}");
    }

    #[test]
    fn without_braking_or_reaction_nothing_is_too_fast() {
        let none = Braking::FixedTime {
            start_hz: 0.0,
            ramp: Duration::ZERO,
        };
        assert_eq!(reaction_speed_cap(&none, Duration::ZERO, 10.0), f64::MAX);
        let v = reaction_speed_cap(&none, ms(100), 10.0);
        assert!((v - 100.0).abs() < 1e-6, "{v}");
    }

    #[test]
    fn nonsense_gives_no_speed_and_no_lease() {
        assert_eq!(speed_cap(&ISEL, ms(150), 0.0), 0.0);
        assert_eq!(speed_cap(&ISEL, ms(150), f64::NAN), 0.0);
        assert_eq!(lease_cap(&ISEL, 40_000.0, 10.0), Duration::ZERO);
        assert_eq!(lease_cap(&ISEL, 0.0, 10.0), Duration::MAX);
        assert_eq!(travel(&ISEL, f64::INFINITY, ms(1)), 0.0);
    }

    proptest! {
        #[test]
        fn the_cap_keeps_the_bound_and_the_lease_cap_agrees(
            start in 1.0f64..4_000.0,
            accel in 1_000.0f64..4_000_000.0,
            lease_ms in 50u64..2_000,
            bound in 1.0f64..100_000.0,
        ) {
            let b = Braking::Ramp { start_hz: start, accel_hz_per_s: accel };
            let lease = ms(lease_ms);
            let v = speed_cap(&b, lease, bound);
            prop_assert!(v >= 0.0);
            prop_assert!(travel(&b, v, lease) <= bound + 1e-6);
            // A little faster breaks the bound: the cap is the fastest.
            prop_assert!(travel(&b, v * 1.001 + 1e-3, lease) > bound - 1e-6);
            if v > 0.0 {
                let l = lease_cap(&b, v, bound);
                prop_assert!(l + ms(1) >= lease, "{l:?} < {lease:?}");
                prop_assert!(travel(&b, v, l) <= bound + 1e-6);
            }
        }

        #[test]
        fn travel_grows_with_speed(a in 0.0f64..50_000.0, b in 0.0f64..50_000.0) {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            prop_assert!(travel(&ISEL, lo, ms(150)) <= travel(&ISEL, hi, ms(150)));
        }
    }
}
