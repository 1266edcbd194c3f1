//! A simulator that runs faster (or slower) than the wall clock.
//!
//! The device models and the wire model ([`super::engine::Engine`]) are
//! sans-IO: they are handed the time of every event. The shell normally
//! hands them the wall clock; with a [`TimeScale`] of `S` it hands them
//! *model time*, `origin + (wall - origin) * S`, and waits for the model's
//! next event until the wall-clock instant that maps to it. Everything the
//! model times therefore runs `S` times faster, consistently: motion, ramps,
//! dwells, erase times, the modelled wire in both directions (byte times,
//! a reply's place on the line), injected reply delays and the operator's
//! timed controls (`pulse`, `chatter`, `after`).
//!
//! What stays on the wall clock is what belongs to the world outside the
//! model: the line itself (a client opening the pty, `fault close`'s reopen
//! delay, `show received times`).
//!
//! A scaled simulator is for tests of logic (where a move ends, what went
//! over the wire and in which order, what the console says). It is not the
//! controller's or the line's real timing: a client's own deadlines and
//! position estimates are made for the real machine, so a test of a timing
//! promise (a stop within so many ms, an overrun distance, an estimated
//! position during a move) runs at scale 1 (`docs/simulator.md`, "Time
//! scale"; `docs/testing.md`).

use std::fmt;
use std::str::FromStr;
use std::time::{Duration, Instant};

/// How many seconds of model time pass in one second of wall-clock time.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct TimeScale(f64);

impl TimeScale {
    /// The wall clock itself: what a real controller does.
    pub const REAL: TimeScale = TimeScale(1.0);
    /// The smallest factor taken (a hundred times slower than real).
    pub const MIN: f64 = 0.01;
    /// The largest factor taken. Far beyond it the model's byte times fall
    /// below what the shell's thread can meet (19200 baud at 1000 times is
    /// half a microsecond a byte) and the line would simply run as fast as
    /// the thread does.
    pub const MAX: f64 = 1000.0;

    /// A factor from [`TimeScale::MIN`] to [`TimeScale::MAX`].
    pub fn new(factor: f64) -> Result<Self, String> {
        if factor.is_finite() && (Self::MIN..=Self::MAX).contains(&factor) {
            Ok(Self(factor))
        } else {
            Err(format!(
                "{factor}: a time scale is a factor from {} to {} (1 = real time)",
                Self::MIN,
                Self::MAX
            ))
        }
    }

    pub fn factor(self) -> f64 {
        self.0
    }

    pub fn is_real(self) -> bool {
        self.0 == 1.0
    }
}

impl Default for TimeScale {
    fn default() -> Self {
        Self::REAL
    }
}

impl fmt::Display for TimeScale {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl FromStr for TimeScale {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let factor: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("{s}: a time scale is a number such as 10 or 0.5"))?;
        Self::new(factor)
    }
}

/// The mapping between wall-clock and model instants of one running shell,
/// fixed at `origin` (where both agree).
#[derive(Debug, Clone, Copy)]
pub struct ScaledClock {
    origin: Instant,
    scale: TimeScale,
}

impl ScaledClock {
    pub fn new(origin: Instant, scale: TimeScale) -> Self {
        Self { origin, scale }
    }

    pub fn scale(&self) -> TimeScale {
        self.scale
    }

    /// The model instant at wall-clock `real` (instants before the origin
    /// map to the origin). Never decreases as `real` grows.
    pub fn model(&self, real: Instant) -> Instant {
        if self.scale.is_real() {
            return real;
        }
        let since = real.saturating_duration_since(self.origin);
        self.origin + from_nanos_f64((since.as_nanos() as f64 * self.scale.0).floor())
    }

    /// The first wall-clock instant at which the model has reached `model`:
    /// `self.model(self.real(m)) >= m`, so a thread that sleeps until
    /// `real(m)` finds the model's event due when it wakes.
    pub fn real(&self, model: Instant) -> Instant {
        if self.scale.is_real() {
            return model;
        }
        let since = model.saturating_duration_since(self.origin);
        // One nanosecond more than the quotient covers its rounding.
        self.origin + from_nanos_f64((since.as_nanos() as f64 / self.scale.0).ceil() + 1.0)
    }
}

fn from_nanos_f64(ns: f64) -> Duration {
    // Saturates at u64::MAX nanoseconds (584 years) and at zero.
    Duration::from_nanos(ns.clamp(0.0, u64::MAX as f64) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn real_time_is_the_identity() {
        let t0 = Instant::now();
        let c = ScaledClock::new(t0, TimeScale::REAL);
        for t in [
            t0,
            t0 + ms(1),
            t0 + Duration::from_nanos(7),
            t0 + ms(86_400_000),
        ] {
            assert_eq!(c.model(t), t);
            assert_eq!(c.real(t), t);
        }
    }

    #[test]
    fn model_time_runs_scale_times_as_fast_from_the_origin() {
        let t0 = Instant::now();
        let c = ScaledClock::new(t0, TimeScale::new(10.0).unwrap());
        assert_eq!(c.model(t0), t0);
        assert_eq!(c.model(t0 + ms(100)), t0 + ms(1000));
        assert_eq!(c.model(t0 + ms(1234)), t0 + ms(12_340));
        // A model deadline 8 s away is met 0.8 s of wall time away (plus the
        // rounding nanosecond).
        let back = c.real(t0 + ms(8000)).duration_since(t0);
        assert!(
            back >= ms(800) && back <= ms(800) + Duration::from_nanos(2),
            "{back:?}"
        );
        // Slower than real works the same way.
        let slow = ScaledClock::new(t0, TimeScale::new(0.5).unwrap());
        assert_eq!(slow.model(t0 + ms(100)), t0 + ms(50));
    }

    #[test]
    fn waking_at_the_real_instant_of_a_model_event_finds_it_due() {
        let t0 = Instant::now();
        for factor in [0.01, 0.3, 1.0, 3.0, 7.0, 10.0, 33.3, 1000.0] {
            let c = ScaledClock::new(t0, TimeScale::new(factor).unwrap());
            for ns in [0u64, 1, 2, 3, 520_833, 999_999_999, 3_600_000_000_017] {
                let m = t0 + Duration::from_nanos(ns);
                let r = c.real(m);
                assert!(c.model(r) >= m, "factor {factor}, {ns} ns");
                // And not much later than needed: within two nanoseconds of
                // wall time, plus the float rounding of large spans.
                let exact = ns as f64 / factor;
                let got = r.duration_since(t0).as_nanos() as f64;
                assert!(
                    got - exact <= 2.0 + exact * 1e-12,
                    "factor {factor}, {ns} ns: {got} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn model_time_never_goes_backwards_and_before_the_origin_is_the_origin() {
        let t0 = Instant::now() + ms(10);
        let c = ScaledClock::new(t0, TimeScale::new(3.7).unwrap());
        assert_eq!(c.model(t0 - ms(5)), t0);
        assert_eq!(c.real(t0 - ms(5)), t0 + Duration::from_nanos(1));
        let mut last = c.model(t0);
        for ns in (0..200_000u64).step_by(37) {
            let m = c.model(t0 + Duration::from_nanos(ns));
            assert!(m >= last);
            last = m;
        }
    }

    #[test]
    fn a_scale_is_a_finite_factor_in_range() {
        assert_eq!("10".parse::<TimeScale>(), Ok(TimeScale(10.0)));
        assert_eq!(" 0.5 ".parse::<TimeScale>(), Ok(TimeScale(0.5)));
        assert_eq!("1".parse::<TimeScale>(), Ok(TimeScale::REAL));
        for bad in ["0", "-2", "0.001", "1001", "inf", "NaN", "fast", ""] {
            let err = bad.parse::<TimeScale>().unwrap_err();
            assert!(err.contains("time scale"), "{bad}: {err}");
        }
        assert!(TimeScale::default().is_real());
        assert_eq!(TimeScale::new(20.0).unwrap().to_string(), "20");
    }
}
