//! Step-motor motion as the controllers generate it: a jump to the start-stop
//! frequency, a linear ramp up at constant acceleration, a cruise, and the same
//! ramp down (isel manual 2.2.15/2.2.16; EMCU manual 1.5.5-1.5.7, where the
//! acceleration follows from start speed, end speed and ramp length).
//!
//! Pure arithmetic, no clocks: the simulators use it to move their axes, the
//! device task to estimate where an isel axis is while the controller cannot be
//! asked, and to derive reply timeouts from physics. [`overrun`] bounds how far
//! a jog runs on after its key is let go: the drivers cap their jog speeds and
//! leases with it, the jog keypad shows the caps.

use std::time::Duration;

pub mod overrun;
pub mod standstill;

pub use overrun::{Braking, STOP_REACTION, lease_cap, reaction_speed_cap, speed_cap, travel};

/// The speed profile parameters of a move, in steps per second (Hz) and Hz/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ramp {
    /// Speed the motor starts and stops at without a ramp.
    pub start_hz: f64,
    /// Cruise speed requested for the move.
    pub max_hz: f64,
    /// Acceleration and deceleration, Hz per second (isel gives Hz/ms: multiply by 1000).
    pub accel_hz_per_s: f64,
}

impl Ramp {
    /// The speed the ramp actually starts at: never above the cruise speed.
    fn floor_hz(&self) -> f64 {
        self.start_hz.min(self.max_hz).max(f64::MIN_POSITIVE)
    }

    /// Distance needed to ramp from `from_hz` down to the start-stop speed.
    pub fn braking_distance(&self, from_hz: f64) -> f64 {
        let f0 = self.floor_hz();
        if from_hz <= f0 || self.accel_hz_per_s <= 0.0 {
            return 0.0;
        }
        (from_hz * from_hz - f0 * f0) / (2.0 * self.accel_hz_per_s)
    }

    /// Time needed to ramp from `from_hz` down to the start-stop speed.
    pub fn braking_time(&self, from_hz: f64) -> Duration {
        let f0 = self.floor_hz();
        if from_hz <= f0 || self.accel_hz_per_s <= 0.0 {
            return Duration::ZERO;
        }
        Duration::from_secs_f64((from_hz - f0) / self.accel_hz_per_s)
    }
}

/// A complete point-to-point move of `distance` steps (unsigned; the caller
/// keeps the direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    distance: f64,
    f0: f64,
    accel: f64,
    peak_hz: f64,
    t_ramp: f64,
    t_cruise: f64,
}

impl Profile {
    pub fn new(distance_steps: u64, ramp: Ramp) -> Profile {
        let distance = distance_steps as f64;
        let f0 = ramp.floor_hz();
        let fmax = ramp.max_hz.max(f0);
        let accel = ramp.accel_hz_per_s;
        if distance == 0.0 {
            return Profile {
                distance,
                f0,
                accel,
                peak_hz: 0.0,
                t_ramp: 0.0,
                t_cruise: 0.0,
            };
        }
        if accel <= 0.0 || fmax <= f0 {
            // No ramp possible: the whole move runs at the start-stop speed.
            return Profile {
                distance,
                f0,
                accel,
                peak_hz: f0,
                t_ramp: 0.0,
                t_cruise: distance / f0,
            };
        }
        let ramp_distance = (fmax * fmax - f0 * f0) / (2.0 * accel);
        if 2.0 * ramp_distance <= distance {
            let t_ramp = (fmax - f0) / accel;
            let t_cruise = (distance - 2.0 * ramp_distance) / fmax;
            Profile {
                distance,
                f0,
                accel,
                peak_hz: fmax,
                t_ramp,
                t_cruise,
            }
        } else {
            // Too short to reach the cruise speed: ramp up and straight back down.
            let peak = (f0 * f0 + accel * distance).sqrt();
            Profile {
                distance,
                f0,
                accel,
                peak_hz: peak,
                t_ramp: (peak - f0) / accel,
                t_cruise: 0.0,
            }
        }
    }

    pub fn distance(&self) -> f64 {
        self.distance
    }

    /// Highest speed the move reaches.
    pub fn peak_hz(&self) -> f64 {
        self.peak_hz
    }

    pub fn duration(&self) -> Duration {
        Duration::from_secs_f64(self.total_secs())
    }

    fn total_secs(&self) -> f64 {
        2.0 * self.t_ramp + self.t_cruise
    }

    /// Steps travelled `t` after the start, between 0 and the distance.
    pub fn position_at(&self, t: Duration) -> f64 {
        if self.distance == 0.0 || t.is_zero() {
            return 0.0;
        }
        // Compared as `Duration` so that `position_at(duration())` is exactly the end.
        if t >= self.duration() {
            return self.distance;
        }
        let t = t.as_secs_f64();
        let ramp_distance = self.f0 * self.t_ramp + 0.5 * self.accel * self.t_ramp * self.t_ramp;
        let s = if t < self.t_ramp {
            self.f0 * t + 0.5 * self.accel * t * t
        } else if t < self.t_ramp + self.t_cruise {
            ramp_distance + self.peak_hz * (t - self.t_ramp)
        } else {
            let td = t - self.t_ramp - self.t_cruise;
            ramp_distance + self.peak_hz * self.t_cruise + self.peak_hz * td
                - 0.5 * self.accel * td * td
        };
        s.clamp(0.0, self.distance)
    }

    /// Speed `t` after the start, in Hz; zero before the start and after the end.
    pub fn speed_at(&self, t: Duration) -> f64 {
        if self.distance == 0.0 || t >= self.duration() {
            return 0.0;
        }
        let t = t.as_secs_f64();
        if t < self.t_ramp {
            self.f0 + self.accel * t
        } else if t < self.t_ramp + self.t_cruise {
            self.peak_hz
        } else {
            let td = t - self.t_ramp - self.t_cruise;
            (self.peak_hz - self.accel * td).max(self.f0)
        }
    }
}

/// A move in progress that may be told to ramp down early (isel soft stop 0xFD,
/// EMCU `@B`) or to halt at once (limit switch, E-stop, EMCU `@S`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    profile: Profile,
    ramp: Ramp,
    ending: Ending,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ending {
    AsPlanned,
    /// Ramping down from `hz` at `since`, having covered `at` steps by then.
    Braking {
        since: f64,
        at: f64,
        hz: f64,
    },
    /// Halted without a ramp at `since`, having covered `at` steps.
    Halted {
        since: f64,
        at: f64,
    },
}

impl Motion {
    pub fn new(distance_steps: u64, ramp: Ramp) -> Motion {
        Motion {
            profile: Profile::new(distance_steps, ramp),
            ramp,
            ending: Ending::AsPlanned,
        }
    }

    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Start ramping down at `t` (time since the move started). Has no effect
    /// once a stop is under way.
    pub fn brake(&mut self, t: Duration) {
        if let Ending::AsPlanned = self.ending {
            if t >= self.profile.duration() {
                return;
            }
            let hz = self.profile.speed_at(t);
            self.ending = Ending::Braking {
                since: t.as_secs_f64(),
                at: self.profile.position_at(t),
                hz,
            };
        }
    }

    /// Stop at once at `t`, without a ramp (step loss on real hardware).
    pub fn halt(&mut self, t: Duration) {
        let at = self.position_at(t);
        let since = t.as_secs_f64().min(self.end_secs());
        self.ending = Ending::Halted { since, at };
    }

    fn end_secs(&self) -> f64 {
        match self.ending {
            Ending::AsPlanned => self.profile.total_secs(),
            Ending::Braking { since, hz, .. } => since + self.ramp.braking_time(hz).as_secs_f64(),
            Ending::Halted { since, .. } => since,
        }
    }

    /// When the axis comes to rest, measured from the start of the move.
    pub fn end_time(&self) -> Duration {
        Duration::from_secs_f64(self.end_secs())
    }

    pub fn is_done(&self, t: Duration) -> bool {
        t >= self.end_time()
    }

    /// Whether the move ends short of its planned distance.
    pub fn is_cut_short(&self) -> bool {
        !matches!(self.ending, Ending::AsPlanned)
    }

    /// Steps travelled `t` after the start.
    pub fn position_at(&self, t: Duration) -> f64 {
        let ts = t.as_secs_f64();
        match self.ending {
            Ending::AsPlanned => self.profile.position_at(t),
            Ending::Halted { since, at } => {
                if ts >= since {
                    at
                } else {
                    self.profile.position_at(t)
                }
            }
            Ending::Braking { since, at, hz } => {
                if ts < since {
                    return self.profile.position_at(t);
                }
                let f0 = self.ramp.floor_hz();
                let accel = self.ramp.accel_hz_per_s;
                let t_brake = self.ramp.braking_time(hz).as_secs_f64();
                let td = (ts - since).min(t_brake);
                let travelled = if accel > 0.0 && hz > f0 {
                    hz * td - 0.5 * accel * td * td
                } else {
                    0.0
                };
                at + travelled
            }
        }
    }

    /// Speed `t` after the start.
    pub fn speed_at(&self, t: Duration) -> f64 {
        let ts = t.as_secs_f64();
        match self.ending {
            Ending::AsPlanned => self.profile.speed_at(t),
            Ending::Halted { since, .. } if ts >= since => 0.0,
            Ending::Braking { since, hz, .. } if ts >= since => {
                if ts >= self.end_secs() {
                    0.0
                } else {
                    (hz - self.ramp.accel_hz_per_s * (ts - since)).max(self.ramp.floor_hz())
                }
            }
            _ => self.profile.speed_at(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn isel_defaults(max_hz: f64) -> Ramp {
        // isel defaults: 300 Hz start-stop, 100 Hz/ms.
        Ramp {
            start_hz: 300.0,
            max_hz,
            accel_hz_per_s: 100_000.0,
        }
    }

    fn ms(v: f64) -> Duration {
        Duration::from_secs_f64(v / 1000.0)
    }

    #[test]
    fn trapezoid_reaches_cruise_and_ends_at_the_distance() {
        let p = Profile::new(10_000, isel_defaults(5_300.0));
        // Ramp 300 -> 5300 Hz at 100 Hz/ms takes 50 ms and covers 140 steps.
        assert!((p.position_at(ms(50.0)) - 140.0).abs() < 1e-6);
        assert_eq!(p.peak_hz(), 5_300.0);
        // Cruise covers 10000 - 280 steps at 5300 Hz.
        let expected = 0.1 + (10_000.0 - 280.0) / 5_300.0;
        assert!((p.duration().as_secs_f64() - expected).abs() < 1e-9);
        assert_eq!(p.position_at(p.duration()), 10_000.0);
        assert_eq!(p.speed_at(p.duration()), 0.0);
    }

    #[test]
    fn short_move_is_a_triangle() {
        let p = Profile::new(100, isel_defaults(10_000.0));
        assert!(p.peak_hz() < 10_000.0);
        let half = Duration::from_secs_f64(p.duration().as_secs_f64() / 2.0);
        assert!((p.position_at(half) - 50.0).abs() < 1e-3);
    }

    #[test]
    fn speed_below_start_stop_frequency_runs_without_ramp() {
        let p = Profile::new(200, isel_defaults(100.0));
        assert!((p.duration().as_secs_f64() - 2.0).abs() < 1e-9);
        assert!((p.position_at(ms(1000.0)) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn brake_ramps_down_with_the_braking_distance() {
        let ramp = isel_defaults(5_300.0);
        let mut m = Motion::new(1_000_000, ramp);
        let t = ms(500.0);
        let at = m.position_at(t);
        m.brake(t);
        assert!(m.is_cut_short());
        let end = m.end_time();
        assert!((end.as_secs_f64() - 0.55).abs() < 1e-9);
        assert!((m.position_at(end) - at - ramp.braking_distance(5_300.0)).abs() < 1e-6);
        assert!(m.position_at(end + ms(10.0)) == m.position_at(end));
    }

    #[test]
    fn halt_stops_at_once() {
        let mut m = Motion::new(1_000_000, isel_defaults(5_300.0));
        let at = m.position_at(ms(200.0));
        m.halt(ms(200.0));
        assert_eq!(m.position_at(ms(900.0)), at);
        assert!(m.is_done(ms(200.0)));
        assert_eq!(m.speed_at(ms(300.0)), 0.0);
    }

    #[test]
    fn position_is_monotonic_and_bounded() {
        let p = Profile::new(
            12_345,
            Ramp {
                start_hz: 200.0,
                max_hz: 800.0,
                accel_hz_per_s: 1_200.0,
            },
        );
        let mut last = 0.0;
        let steps = 2_000;
        for i in 0..=steps {
            let t = Duration::from_secs_f64(p.duration().as_secs_f64() * i as f64 / steps as f64);
            let s = p.position_at(t);
            assert!(s + 1e-9 >= last && s <= 12_345.0);
            last = s;
        }
        assert_eq!(last, 12_345.0);
    }
}
