//! A speed in encoder counts per second as the drive takes it: a velocity
//! byte (counts per sample, 1-127) and the sample timer's reload value
//! (`20 DS 19`), since counts/s = |v| * 12.5 MHz / RelVal (EMP manual
//! "Berechnung der Abtastrate", `proto::emp::feed`).
//!
//! jogterm takes the largest velocity byte whose reload value still fits 16
//! bits: the reload value is cut to an integer, so the larger it is, the
//! closer the speed (at most 1/RelVal fast: below 0.004 % up to 24 000
//! counts/s, where v is below 127; docs/protocols.md EMP). The reload value comes from
//! the core's `ReloadValue::for_frequency` for the sample rate hz / v.

use crate::proto::emp::reload::TIMER_HZ;
use crate::proto::emp::{ReloadValue, Speed, Velocity};

/// The slowest speed there is: v = 1 at the longest sample period (65535 ticks).
pub const MIN_HZ: f64 = TIMER_HZ as f64 / 65535.0;

/// The fastest speed the arithmetic allows (v = 127 at one tick); the axis'
/// `max_speed` is always far below.
pub const MAX_HZ: f64 = 127.0 * TIMER_HZ as f64;

/// A speed as velocity byte and reload value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveSpeed {
    pub speed: Speed,
    pub reload: ReloadValue,
}

impl DriveSpeed {
    /// The setting for `hz` counts per second (its magnitude); `None` when it
    /// is not a positive finite speed the drive can run.
    pub fn for_hz(hz: f64) -> Option<DriveSpeed> {
        let hz = hz.abs();
        if !(MIN_HZ..=MAX_HZ).contains(&hz) {
            return None;
        }
        // The sample rate hz / v must stay at or above MIN_HZ (reload <= FFFF).
        let v = (hz / MIN_HZ).floor().clamp(1.0, 127.0);
        let reload = ReloadValue::for_frequency(hz / v).ok()?;
        // 1..=127 by the clamp.
        let speed = Speed::new(v as u8).ok()?;
        Some(DriveSpeed { speed, reload })
    }

    /// The signed velocity byte for a direction.
    pub fn velocity(self, negative: bool) -> Velocity {
        let v = self.speed.value() as i8;
        Velocity::new(if negative { -v } else { v })
    }

    /// The speed the drive will actually run, counts per second.
    pub fn hz(self) -> f64 {
        f64::from(self.speed.value()) * self.reload.frequency_hz()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_jog_speeds_of_the_shipped_profile() {
        // 0.2 mm/s at 11200 counts/mm.
        let s = DriveSpeed::for_hz(2240.0).expect("speed");
        assert_eq!(s.speed.value(), 11);
        assert_eq!(s.reload.value(), 61383);
        assert_eq!(s.velocity(true).byte(), 0xF5);
        let s = DriveSpeed::for_hz(28_000.0).expect("speed");
        assert_eq!(s.speed.value(), 127);
        assert!((s.hz() - 28_000.0).abs() / 28_000.0 < 1e-4);
    }

    #[test]
    fn too_slow_or_not_a_speed_is_none() {
        assert!(DriveSpeed::for_hz(100.0).is_none());
        assert!(DriveSpeed::for_hz(0.0).is_none());
        assert!(DriveSpeed::for_hz(f64::NAN).is_none());
        assert!(DriveSpeed::for_hz(MIN_HZ).is_some());
    }

    proptest! {
        #[test]
        fn every_speed_is_met_closely_and_never_slower(hz in MIN_HZ..2_000_000.0f64) {
            let s = DriveSpeed::for_hz(hz).expect("in range");
            let got = s.hz();
            prop_assert!(got >= hz * (1.0 - 1e-12));
            prop_assert!((got - hz) / hz <= 1.0 / f64::from(s.reload.value()) + 1e-12);
        }
    }
}
