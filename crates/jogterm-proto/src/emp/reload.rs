//! The reload value of the drive's sample timer, sent with `20 DS 19` (EMP
//! manual "20 : Einstellungen – Abtastrate" and "Berechnung der Abtastrate").

use std::fmt;
use std::time::Duration;

use super::error::{ConversionError, ValueError};

/// The drive's system clock (manual: "Die Systemfrequenz beträgt 50 MHz").
pub const SYSTEM_CLOCK_HZ: u32 = 50_000_000;

/// The prescaler between system clock and sample timer: the "4" of
/// RelVal = TimeOutPeriod * Systemfrequenz / 4, and the "Vorteiler" of
/// `BerechnungUpDownIV`, which Beispiel 2 and 4 (`1A28`, `3450`, `0A76`) only
/// reproduce with 4.
pub const TIMER_PRESCALER: u32 = 4;

/// Timer ticks per second: 12.5 MHz, one tick every 80 ns.
pub const TIMER_HZ: u32 = SYSTEM_CLOCK_HZ / TIMER_PRESCALER;

const TICK_NS: u64 = 1_000_000_000 / TIMER_HZ as u64;

/// Timer ticks per sample, 1-65535 (MSB, LSB in D1, D0; 0 would stop the
/// controller's sampling, so it is refused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ReloadValue(u16);

impl ReloadValue {
    pub fn new(value: u16) -> Result<ReloadValue, ValueError> {
        if value == 0 {
            return Err(ValueError::OutOfRange {
                field: "reload value",
                value: 0,
                expected: "0001..=FFFF",
            });
        }
        Ok(ReloadValue(value))
    }

    /// The reload value for a sample frequency (decision 6:
    /// RelVal = (1 / f) * 50 MHz / 4), cut to an integer as the manual's table
    /// does in its hex column (3 kHz -> 0x1046; its decimal column rounds to
    /// 4.167) and as Beispiel 2 and 4 need (`3450`, `0A76`).
    pub fn for_frequency(hz: f64) -> Result<ReloadValue, ConversionError> {
        if !(hz.is_finite() && hz > 0.0) {
            return Err(ConversionError::NotPositive {
                what: "sample frequency",
                value: hz,
            });
        }
        ReloadValue::from_ticks(f64::from(TIMER_HZ) / hz)
    }

    /// Truncate a computed tick count to a reload value, refusing what 16 bits
    /// cannot hold.
    pub(crate) fn from_ticks(ticks: f64) -> Result<ReloadValue, ConversionError> {
        let whole = ticks.trunc();
        if !(1.0..=f64::from(u16::MAX)).contains(&whole) {
            return Err(ConversionError::ReloadRange { value: ticks });
        }
        // In 1..=65535 after the check above.
        Ok(ReloadValue(whole as u16))
    }

    pub const fn value(self) -> u16 {
        self.0
    }

    /// D1, D0 of `20 DS 19`.
    pub const fn bytes(self) -> [u8; 2] {
        self.0.to_be_bytes()
    }

    /// The sample period: 80 ns per tick.
    pub fn period(self) -> Duration {
        Duration::from_nanos(u64::from(self.0) * TICK_NS)
    }

    pub fn frequency_hz(self) -> f64 {
        f64::from(TIMER_HZ) / f64::from(self.0)
    }
}

impl fmt::Display for ReloadValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reload_table_of_the_manual() {
        // Frequenz, RelVal_dez, RelVal_hex.
        let table: [(f64, u32, u16); 8] = [
            (250.0, 50_000, 0xC350),
            (400.0, 31_250, 0x7A12),
            (500.0, 25_000, 0x61A8),
            (1_000.0, 12_500, 0x30D4),
            (2_000.0, 6_250, 0x186A),
            (3_000.0, 4_167, 0x1046),
            (4_000.0, 3_125, 0x0C35),
            (6_000.0, 2_083, 0x0823),
        ];
        for (hz, dec, hex) in table {
            let r = ReloadValue::for_frequency(hz).unwrap();
            assert_eq!(r.value(), hex, "{hz} Hz");
            // The decimal column is the exact quotient rounded for display.
            assert_eq!((f64::from(TIMER_HZ) / hz).round() as u32, dec, "{hz} Hz");
        }
        assert_eq!(
            ReloadValue::for_frequency(250.0).unwrap().bytes(),
            [0xC3, 0x50]
        );
    }

    #[test]
    fn sample_periods_of_the_20_19_remark() {
        // "0xffff = 5 ms, 0x3600 = 1 ms, 0x1800 = 0,5 ms", rounded as written.
        let ms = |v: u16| ReloadValue::new(v).unwrap().period().as_secs_f64() * 1000.0;
        assert_eq!(ms(0xFFFF).round(), 5.0);
        assert_eq!(ms(0x3600).round(), 1.0);
        assert_eq!((ms(0x1800) * 10.0).round() / 10.0, 0.5);
        assert_eq!(
            ReloadValue::new(0xFFFF).unwrap().period(),
            Duration::from_nanos(5_242_800)
        );
        assert_eq!(ReloadValue::new(0xC350).unwrap().frequency_hz(), 250.0);
    }

    #[test]
    fn out_of_range_frequencies_and_zero_are_refused() {
        assert!(ReloadValue::new(0).is_err());
        // Below 12.5 MHz / 65535 = 190.7 Hz the value needs more than 16 bits.
        assert!(ReloadValue::for_frequency(190.0).is_err());
        assert_eq!(ReloadValue::for_frequency(190.8).unwrap().value(), 65_513);
        assert!(ReloadValue::for_frequency(13e6).is_err());
        assert!(ReloadValue::for_frequency(0.0).is_err());
        assert!(ReloadValue::for_frequency(f64::NAN).is_err());
        assert!(ReloadValue::for_frequency(-250.0).is_err());
    }
}
