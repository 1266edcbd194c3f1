//! Feed rate to velocity byte and reload value: the manual's
//! `BerechnungUpDownIV` (EMP manual "Berechnung der Abtastrate mit Vorgabe von
//! Geschwindigkeit/Vorschub").
//!
//! The drive moves `|v|` encoder counts per sample and samples at
//! 12.5 MHz / RelVal, so a feed is a velocity byte and a reload value together:
//! counts/s = |v| * 50 MHz / (Vorteiler * RelVal). Solved for RelVal this is the
//! manual's formula
//! `60 * Systemfrequenz * V / (Encoderauflösung * 4 * Vorteiler * Vorschub * Untersetzung / Spindelsteigung)`,
//! where the 4 is the encoder's quadrature and the Vorteiler the timer
//! prescaler, 4 ([`TIMER_PRESCALER`]).

use super::error::ConversionError;
use super::reload::{ReloadValue, SYSTEM_CLOCK_HZ, TIMER_HZ, TIMER_PRESCALER};
use super::values::{Speed, Velocity};

/// Counts per encoder line: both edges of both tracks ("Quadratur des
/// Encodersignals").
pub const QUADRATURE: u32 = 4;

/// What turns a feed in mm/min into encoder counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mechanics {
    /// Untersetzung: motor turns per spindle turn (14 for 14:1).
    gear_ratio: f64,
    /// Spindelsteigung in mm per spindle turn.
    spindle_pitch_mm: f64,
    /// Encoderauflösung in lines (Inkr/Umdr) per motor turn.
    encoder_lines: u32,
}

impl Mechanics {
    pub fn new(
        gear_ratio: f64,
        spindle_pitch_mm: f64,
        encoder_lines: u32,
    ) -> Result<Mechanics, ConversionError> {
        for (what, value) in [
            ("gear ratio", gear_ratio),
            ("spindle pitch", spindle_pitch_mm),
            ("encoder resolution", f64::from(encoder_lines)),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ConversionError::NotPositive { what, value });
            }
        }
        Ok(Mechanics {
            gear_ratio,
            spindle_pitch_mm,
            encoder_lines,
        })
    }

    pub fn gear_ratio(&self) -> f64 {
        self.gear_ratio
    }

    pub fn spindle_pitch_mm(&self) -> f64 {
        self.spindle_pitch_mm
    }

    pub fn encoder_lines(&self) -> u32 {
        self.encoder_lines
    }

    /// Motor turns per minute: Vorschub * Untersetzung / Spindelsteigung.
    pub fn motor_rpm(&self, feed_mm_min: f64) -> f64 {
        feed_mm_min * self.gear_ratio / self.spindle_pitch_mm
    }

    /// The feed for spindle turns per minute (Beispiel 2 gives speeds in
    /// "Umdr/min" of the spindle: 2 Umdr/min at 5 mm/Umdr is 10 mm/min).
    pub fn feed_for_spindle_rpm(&self, rpm: f64) -> f64 {
        rpm * self.spindle_pitch_mm
    }

    /// Encoder counts per second at a feed.
    pub fn counts_per_second(&self, feed_mm_min: f64) -> f64 {
        self.motor_rpm(feed_mm_min) * f64::from(self.encoder_lines) * f64::from(QUADRATURE) / 60.0
    }

    fn feed_for_counts_per_second(&self, counts: f64) -> f64 {
        counts * 60.0 * self.spindle_pitch_mm
            / (f64::from(self.encoder_lines) * f64::from(QUADRATURE) * self.gear_ratio)
    }
}

/// A velocity byte and the reload value that together give a feed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FeedSetting {
    pub velocity: Velocity,
    pub reload: ReloadValue,
}

impl FeedSetting {
    /// The feed (mm/min, signed) the drive actually runs at with this setting;
    /// truncating the reload value makes it at most 1/RelVal faster than asked.
    pub fn feed_mm_min(&self, mechanics: &Mechanics) -> f64 {
        let counts =
            f64::from(self.velocity.value()) * f64::from(TIMER_HZ) / f64::from(self.reload.value());
        mechanics.feed_for_counts_per_second(counts)
    }
}

/// The reload value ("AbtastFrequ") for a feed at a given velocity byte, as
/// the manual's formula computes it, cut to an integer (Beispiel 4: 10 mm/min
/// with V = 01 at 14:1, 5 mm/Umdr, 1000 Inkr/Umdr is `1A28`).
pub fn reload_for(
    feed_mm_min: f64,
    speed: Speed,
    mechanics: &Mechanics,
) -> Result<ReloadValue, ConversionError> {
    let rpm = mechanics.motor_rpm(feed_mm_min.abs());
    if !(rpm.is_finite() && rpm > 0.0) {
        return Err(ConversionError::ZeroFeed(feed_mm_min));
    }
    let ticks = 60.0 * f64::from(SYSTEM_CLOCK_HZ) * f64::from(speed.value())
        / (f64::from(mechanics.encoder_lines)
            * f64::from(QUADRATURE)
            * f64::from(TIMER_PRESCALER)
            * rpm);
    ReloadValue::from_ticks(ticks)
}

/// `BerechnungUpDownIV`: velocity byte and reload value for a signed feed.
///
/// The manual raises the "Grundfrequenz" from `min_base_frequency`
/// ("MinAbtastRate", 6-54 in its text) until Vorschub * Untersetzung /
/// (Spindelsteigung * Grundfrequenz) is at most 127, takes the integer part as
/// the velocity and computes the reload value for it. Where that integer part
/// is 0 (slow feeds) the manual's code would send V = 0 and RelVal = 0; jogterm
/// uses V = 1 as its examples do (docs/protocols.md, EMP). A negative feed gives
/// the negative velocity byte with the same reload value (Beispiel 2: `FF`).
pub fn feed_setting(
    feed_mm_min: f64,
    mechanics: &Mechanics,
    min_base_frequency: u32,
) -> Result<FeedSetting, ConversionError> {
    if min_base_frequency == 0 {
        return Err(ConversionError::NotPositive {
            what: "minimum base frequency",
            value: 0.0,
        });
    }
    let rpm = mechanics.motor_rpm(feed_mm_min.abs());
    if !(rpm.is_finite() && rpm > 0.0) {
        return Err(ConversionError::ZeroFeed(feed_mm_min));
    }
    // The smallest base frequency >= the minimum with rpm / base <= 127; the
    // manual's loop counts up to it one by one.
    let mut base = f64::from(min_base_frequency).max((rpm / 127.0).ceil());
    while rpm / base > 127.0 {
        base += 1.0;
    }
    // 1..=127 by construction of `base` and the clamp.
    let magnitude = (rpm / base).floor().clamp(1.0, 127.0) as u8;
    let speed = Speed::new(magnitude).unwrap_or(Speed::MIN);
    let reload = reload_for(feed_mm_min, speed, mechanics)?;
    let value = magnitude as i8;
    Ok(FeedSetting {
        velocity: Velocity::new(if feed_mm_min < 0.0 { -value } else { value }),
        reload,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example_mechanics() -> Mechanics {
        // Getriebeuntersetzung = 14:1, Spindelsteigung = 5mm/Umdr,
        // Encoder = 1000 Inkr/Umdr (Beispiel 4; Beispiel 2 without the encoder).
        Mechanics::new(14.0, 5.0, 1000).unwrap()
    }

    #[test]
    fn beispiel_4_reload_values_with_v_01() {
        let m = example_mechanics();
        // "Geschwindigkeit von 10 mm/min berechnen: Abtastrate = 1A28 mit V = 01"
        assert_eq!(reload_for(10.0, Speed::MIN, &m).unwrap().value(), 0x1A28);
        // "Geschwindigkeit von 5 mm/min berechnen: Abtastrate = 3450 mit V = 01"
        assert_eq!(reload_for(5.0, Speed::MIN, &m).unwrap().value(), 0x3450);
    }

    #[test]
    fn beispiel_2_reload_values_for_spindle_turns() {
        let m = example_mechanics();
        let two = m.feed_for_spindle_rpm(2.0);
        let five = m.feed_for_spindle_rpm(5.0);
        assert_eq!(reload_for(two, Speed::MIN, &m).unwrap().value(), 0x1A28);
        assert_eq!(reload_for(five, Speed::MIN, &m).unwrap().value(), 0x0A76);
    }

    #[test]
    fn the_prescaler_the_examples_imply_is_4() {
        // Solve the manual's formula for the Vorteiler from each example and
        // see that only 4 truncates to all three values.
        let m = example_mechanics();
        for (feed, reload) in [(10.0, 0x1A28u16), (5.0, 0x3450), (25.0, 0x0A76)] {
            let exact = 60.0 * 50e6 / (1000.0 * 4.0 * m.motor_rpm(feed));
            // trunc(exact / p) == reload  <=>  exact / (reload + 1) < p <= exact / reload
            let admits =
                |p: f64| exact / (f64::from(reload) + 1.0) < p && p <= exact / f64::from(reload);
            assert!(admits(4.0), "{feed} mm/min");
            assert!(!admits(3.999) && !admits(4.001), "{feed} mm/min");
        }
    }

    #[test]
    fn berechnung_up_down_iv_reproduces_the_examples() {
        let m = example_mechanics();
        // With a minimum base frequency at the top of the manual's 6-54, all
        // three example speeds come out with V = 01 as the manual states.
        let s = feed_setting(10.0, &m, 54).unwrap();
        assert_eq!((s.velocity.byte(), s.reload.value()), (0x01, 0x1A28));
        let s = feed_setting(-10.0, &m, 54).unwrap();
        assert_eq!((s.velocity.byte(), s.reload.value()), (0xFF, 0x1A28));
        let s = feed_setting(5.0, &m, 54).unwrap();
        assert_eq!((s.velocity.byte(), s.reload.value()), (0x01, 0x3450));
        let s = feed_setting(25.0, &m, 54).unwrap();
        assert_eq!((s.velocity.byte(), s.reload.value()), (0x01, 0x0A76));
    }

    #[test]
    fn berechnung_up_down_iv_raises_the_base_frequency_for_fast_feeds() {
        let m = example_mechanics();
        // 10 m/min: 28000 motor turns/min; base 221 is the first with
        // 28000 / base <= 127, V = Int(126.7) = 126,
        // RelVal = Int(60 * 50e6 * 126 / (1000 * 4 * 4 * 28000)) = Int(843.75).
        let s = feed_setting(10_000.0, &m, 6).unwrap();
        assert_eq!((s.velocity.value(), s.reload.value()), (126, 843));
        let actual = s.feed_mm_min(&m);
        assert!((10_000.0..10_000.0 * (1.0 + 1.0 / 843.0)).contains(&actual));
        // A higher velocity byte at a slow feed from a low base frequency.
        let s = feed_setting(100.0, &m, 6).unwrap();
        assert_eq!(s.velocity.value(), 46); // Int(280 / 6)
    }

    #[test]
    fn feeds_the_16_bit_reload_cannot_express_are_refused() {
        let m = example_mechanics();
        assert!(matches!(
            feed_setting(1.0, &m, 54),
            Err(ConversionError::ReloadRange { .. })
        ));
        assert!(matches!(
            feed_setting(0.0, &m, 6),
            Err(ConversionError::ZeroFeed(_))
        ));
        assert!(feed_setting(f64::NAN, &m, 6).is_err());
        assert!(feed_setting(10.0, &m, 0).is_err());
        assert!(Mechanics::new(0.0, 5.0, 1000).is_err());
        assert!(Mechanics::new(14.0, f64::INFINITY, 1000).is_err());
        assert!(Mechanics::new(14.0, 5.0, 0).is_err());
    }
}
