//! The drive's analogue inputs as the ADS1112 sees them (EMP manual "50 : ADC
//! Read"), and how a joystick on one of them becomes a velocity (manual "20 :
//! Einstellungen – Joystick Parameter", "22 : Motor Enable" mode 05).
//!
//! The simulator keeps one voltage per channel as the manual numbers them:
//! channel 1 (bipolar `0x`, unipolar `4x`), channel 2 (bipolar `2x`, unipolar
//! `6x`) and channel 3 (unipolar `2x`). Whether `2x` is bipolar channel 2 or
//! unipolar channel 3 is the drive's jumper ("muss außerdem noch durch einen
//! JUMPER im Gerät manuell umgesteckt werden").

use crate::proto::emp::{
    AdcCode, AdcInput, AdcMode, AdcPolarity, JoystickChannel, JoystickParameters, Velocity,
    adc::FULL_SCALE_MV,
};

/// Channels the operator can set: `adc1` to `adc3`.
pub(crate) const CHANNELS: usize = 3;

/// The largest voltage an operator may apply, mV. The ADS1112 reads at most
/// ±2048 mV; more is clipped by the converter, and this bound keeps the
/// arithmetic finite.
pub(crate) const MAX_INPUT_MV: f64 = 10_000.0;

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Analog {
    mv: [f64; CHANNELS],
    unipolar_jumper: bool,
}

impl Analog {
    pub(crate) fn new(unipolar_jumper: bool) -> Analog {
        Analog {
            mv: [0.0; CHANNELS],
            unipolar_jumper,
        }
    }

    /// Channel 1..=3, in mV; other channels read 0.
    pub(crate) fn millivolts(&self, channel: usize) -> f64 {
        channel
            .checked_sub(1)
            .and_then(|i| self.mv.get(i))
            .copied()
            .unwrap_or(0.0)
    }

    /// Set channel 1..=3; returns `false` for any other channel.
    pub(crate) fn set(&mut self, channel: usize, mv: f64) -> bool {
        let Some(slot) = channel.checked_sub(1).and_then(|i| self.mv.get_mut(i)) else {
            return false;
        };
        *slot = if mv.is_finite() {
            mv.clamp(-MAX_INPUT_MV, MAX_INPUT_MV)
        } else {
            0.0
        };
        true
    }

    fn channel_of(&self, input: AdcInput) -> usize {
        match input {
            AdcInput::Ain0Ain1 | AdcInput::Ain0Ain3 => 1,
            AdcInput::Ain1Ain3 => 2,
            AdcInput::Ain2Ain3 if self.unipolar_jumper => 3,
            AdcInput::Ain2Ain3 => 2,
        }
    }

    /// What `50` reads in `mode`.
    pub(crate) fn read(&self, mode: AdcMode) -> AdcCode {
        let polarity = if self.unipolar_jumper {
            AdcPolarity::Unipolar
        } else {
            AdcPolarity::Bipolar
        };
        code_for(self.millivolts(self.channel_of(mode.input)), mode, polarity)
    }

    pub(crate) fn joystick(&self, channel: JoystickChannel) -> f64 {
        self.millivolts(match channel {
            JoystickChannel::One => 1,
            JoystickChannel::Two => 2,
        })
    }
}

/// The ADS1112's output code for `mv`: the inverse of the manual's
/// mV = 2048 * code / (MinCode * PGA), rounded to the nearest code and clipped
/// at full scale. Unipolar inputs read no negative values ("Im unipolaren
/// Betrieb gelten nur die positiven Werte").
pub(crate) fn code_for(mv: f64, mode: AdcMode, polarity: AdcPolarity) -> AdcCode {
    let min_code = f64::from(mode.resolution.min_code());
    let scale = min_code * f64::from(mode.gain.factor()) / FULL_SCALE_MV;
    let low = match polarity {
        AdcPolarity::Bipolar => -min_code,
        AdcPolarity::Unipolar => 0.0,
    };
    let code = (mv * scale).round().clamp(low, min_code - 1.0);
    // Within ±32768, so it fits an i16; the u16 is its two's complement.
    AdcCode(code as i16 as u16)
}

/// The velocity byte a joystick reading commands: full scale (±2048 mV /
/// MULTIPLIER) is ±127, the dead band of HYSTERESE mV around the centre is 0,
/// linear between. A unipolar joystick's centre is half its full scale.
pub(crate) fn joystick_velocity(mv: f64, params: &JoystickParameters) -> Velocity {
    let full = FULL_SCALE_MV / f64::from(params.multiplier.factor());
    let deflection = match params.polarity {
        AdcPolarity::Bipolar => mv,
        AdcPolarity::Unipolar => mv.clamp(0.0, full) - full / 2.0,
    };
    let reach = match params.polarity {
        AdcPolarity::Bipolar => full,
        AdcPolarity::Unipolar => full / 2.0,
    };
    let dead = f64::from(params.hysteresis_mv);
    let magnitude = deflection.abs().min(reach);
    if magnitude <= dead || reach <= dead {
        return Velocity::STOP;
    }
    let v = (127.0 * (magnitude - dead) / (reach - dead))
        .round()
        .clamp(0.0, 127.0);
    // 0..=127 after the clamp.
    let v = v as i8;
    Velocity::new(if deflection < 0.0 { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::emp::{AdcResolution, Gain};

    fn mode(byte: u8) -> AdcMode {
        AdcMode::from_byte(byte).unwrap()
    }

    #[test]
    fn codes_invert_the_manual_formula() {
        // 16 bit, factor 1: 1234 mV = 19744 = 0x4D20.
        let m = mode(0x0C);
        let c = code_for(1234.0, m, AdcPolarity::Bipolar);
        assert_eq!(c, AdcCode(0x4D20));
        assert_eq!(m.millivolts(c), 1234.0);
        let c = code_for(-1.0, m, AdcPolarity::Bipolar);
        assert_eq!(m.millivolts(c), -1.0);
        // Clipped at full scale, both ends; unipolar reads no negatives.
        assert_eq!(code_for(5000.0, m, AdcPolarity::Bipolar), AdcCode(0x7FFF));
        assert_eq!(code_for(-5000.0, m, AdcPolarity::Bipolar), AdcCode(0x8000));
        assert_eq!(code_for(-5.0, m, AdcPolarity::Unipolar), AdcCode(0));
        // 12 bit, factor 8: full scale 256 mV, 2048 codes.
        let m = mode(0x03);
        assert_eq!((m.resolution, m.gain), (AdcResolution::Bits12, Gain::X8));
        assert_eq!(code_for(128.0, m, AdcPolarity::Bipolar), AdcCode(1024));
    }

    #[test]
    fn channels_follow_the_jumper() {
        let mut a = Analog::new(false);
        assert!(a.set(1, 100.0) && a.set(2, 200.0) && a.set(3, 300.0));
        assert!(!a.set(0, 1.0) && !a.set(4, 1.0));
        let mv = |a: &Analog, b: u8| mode(b).millivolts(a.read(mode(b)));
        assert_eq!(mv(&a, 0x0C), 100.0);
        assert_eq!(mv(&a, 0x2C), 200.0);
        let mut u = Analog::new(true);
        u.set(1, 100.0);
        u.set(2, 200.0);
        u.set(3, 300.0);
        assert_eq!(mv(&u, 0x4C), 100.0);
        assert_eq!(mv(&u, 0x6C), 200.0);
        assert_eq!(mv(&u, 0x2C), 300.0);
        a.set(1, f64::NAN);
        assert_eq!(a.millivolts(1), 0.0);
    }

    #[test]
    fn joystick_dead_band_and_full_scale() {
        // Beispiel 5: bipolar, factor 1, hysteresis 40h = 64 mV.
        let p = JoystickParameters::from_bytes([0x0C, 0x04, 0x00, 0x01, 0x40]).unwrap();
        assert_eq!(joystick_velocity(60.0, &p), Velocity::STOP);
        assert_eq!(joystick_velocity(-64.0, &p), Velocity::STOP);
        assert_eq!(joystick_velocity(2048.0, &p).value(), 127);
        assert_eq!(joystick_velocity(-3000.0, &p).value(), -127);
        assert_eq!(joystick_velocity(1056.0, &p).value(), 64);
        let u = JoystickParameters::from_bytes([1, 4, 1, 2, 0]).unwrap();
        // Unipolar, factor 2: 0..1024 mV, centre 512.
        assert_eq!(joystick_velocity(512.0, &u), Velocity::STOP);
        assert_eq!(joystick_velocity(0.0, &u).value(), -127);
        assert_eq!(joystick_velocity(1024.0, &u).value(), 127);
    }
}
