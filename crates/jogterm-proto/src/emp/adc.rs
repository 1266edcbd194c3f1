//! The drive's analogue input, a TI ADS1112 (EMP manual "50 : ADC Read" and
//! "20 : Einstellungen – Joystick Parameter"): the mode byte, the joystick ADC
//! parameters and the conversion of a reading to millivolts.

use std::fmt;

use super::error::ValueError;

/// ADCTyp of `20 02` and Typ (PROP) of `50`: the only one documented,
/// "04" = ADS1112 as the internal ADC.
pub const ADC_TYPE_ADS1112: u8 = 0x04;

/// The ADS1112's full scale at gain 1: ±2.048 V (manual: "±2V").
pub const FULL_SCALE_MV: f64 = 2048.0;

/// Input pair, the high nibble of the mode byte. These are the ADS1112's INP1
/// and INP0 bits (config bits 6 and 5); the manual names them by channel, and
/// whether a channel is bipolar or unipolar is a jumper in the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdcInput {
    /// `0x`: AIN0-AIN1, bipolar channel 1.
    Ain0Ain1,
    /// `2x`: AIN2-AIN3, bipolar channel 2 or unipolar channel 3.
    Ain2Ain3,
    /// `4x`: AIN0-AIN3, unipolar channel 1.
    Ain0Ain3,
    /// `6x`: AIN1-AIN3, unipolar channel 2.
    Ain1Ain3,
}

impl AdcInput {
    pub const ALL: [AdcInput; 4] = [
        AdcInput::Ain0Ain1,
        AdcInput::Ain2Ain3,
        AdcInput::Ain0Ain3,
        AdcInput::Ain1Ain3,
    ];

    pub const fn nibble(self) -> u8 {
        match self {
            AdcInput::Ain0Ain1 => 0x0,
            AdcInput::Ain2Ain3 => 0x2,
            AdcInput::Ain0Ain3 => 0x4,
            AdcInput::Ain1Ain3 => 0x6,
        }
    }

    pub fn from_nibble(n: u8) -> Option<AdcInput> {
        AdcInput::ALL.into_iter().find(|i| i.nibble() == n)
    }
}

/// Resolution (and with it the data rate), bits 3-2 of the mode byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdcResolution {
    Bits12,
    Bits14,
    Bits15,
    Bits16,
}

impl AdcResolution {
    pub const ALL: [AdcResolution; 4] = [
        AdcResolution::Bits12,
        AdcResolution::Bits14,
        AdcResolution::Bits15,
        AdcResolution::Bits16,
    ];

    /// The manual's "MinCode": the code of full scale at this resolution.
    pub const fn min_code(self) -> u32 {
        match self {
            AdcResolution::Bits12 => 2048,
            AdcResolution::Bits14 => 8192,
            AdcResolution::Bits15 => 16384,
            AdcResolution::Bits16 => 32768,
        }
    }

    pub const fn bits(self) -> u8 {
        match self {
            AdcResolution::Bits12 => 12,
            AdcResolution::Bits14 => 14,
            AdcResolution::Bits15 => 15,
            AdcResolution::Bits16 => 16,
        }
    }
}

/// The programmable gain ("PGA"), bits 1-0 of the mode byte. The manual:
/// "Andere Verstärkungsfaktoren gibt es nicht."
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Gain {
    X1,
    X2,
    X4,
    X8,
}

impl Gain {
    pub const ALL: [Gain; 4] = [Gain::X1, Gain::X2, Gain::X4, Gain::X8];

    pub const fn factor(self) -> u8 {
        1 << self.index()
    }

    const fn index(self) -> u8 {
        match self {
            Gain::X1 => 0,
            Gain::X2 => 1,
            Gain::X4 => 2,
            Gain::X8 => 3,
        }
    }

    pub fn from_factor(factor: u8) -> Option<Gain> {
        Gain::ALL.into_iter().find(|g| g.factor() == factor)
    }

    /// Full scale in mV at this gain: ±2048, ±1024, ±512, ±256 (the manual
    /// rounds to ±2 V, ±1 V, ±500 mV, ±250 mV).
    pub fn full_scale_mv(self) -> f64 {
        FULL_SCALE_MV / f64::from(self.factor())
    }
}

/// Bipolar or unipolar measurement: a jumper in the drive, and `ADCMode` of
/// the joystick parameters (`00` bipolar, `01` unipolar).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdcPolarity {
    Bipolar,
    Unipolar,
}

impl AdcPolarity {
    pub const fn byte(self) -> u8 {
        match self {
            AdcPolarity::Bipolar => 0x00,
            AdcPolarity::Unipolar => 0x01,
        }
    }

    pub fn from_byte(b: u8) -> Result<AdcPolarity, ValueError> {
        match b {
            0x00 => Ok(AdcPolarity::Bipolar),
            0x01 => Ok(AdcPolarity::Unipolar),
            _ => Err(ValueError::BadByte {
                field: "ADCMode",
                value: b,
                expected: "00 (bipolar) or 01 (unipolar)",
            }),
        }
    }
}

/// The `Mode` byte of `50`: input pair, resolution and gain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AdcMode {
    pub input: AdcInput,
    pub resolution: AdcResolution,
    pub gain: Gain,
}

impl AdcMode {
    pub const fn byte(self) -> u8 {
        let res = match self.resolution {
            AdcResolution::Bits12 => 0,
            AdcResolution::Bits14 => 1,
            AdcResolution::Bits15 => 2,
            AdcResolution::Bits16 => 3,
        };
        self.input.nibble() << 4 | res << 2 | self.gain.index()
    }

    /// Any low nibble is a valid resolution and gain (the manual's table
    /// `x0`-`xF`); the high nibble must name an input pair, since its other
    /// bits would start a single conversion or stop the converter.
    pub fn from_byte(b: u8) -> Result<AdcMode, ValueError> {
        let input = AdcInput::from_nibble(b >> 4).ok_or(ValueError::BadByte {
            field: "ADC mode",
            value: b,
            expected: "high nibble 0 or 2 (bipolar channel 1, 2) or 4, 6, 2 (unipolar 1, 2, 3)",
        })?;
        Ok(AdcMode {
            input,
            resolution: AdcResolution::ALL[usize::from(b >> 2 & 3)],
            gain: Gain::ALL[usize::from(b & 3)],
        })
    }

    /// A reading in millivolts. The code is the ADS1112's two's complement
    /// output (its datasheet; the manual calls it "2-er Komplement"):
    /// mV = 2048 * code / (MinCode * PGA) as the manual's formula. For negative
    /// codes the manual computes with `65535 - DezZahl`, one LSB short of two's
    /// complement (0xFFFF would read 0 instead of -1 LSB); jogterm uses the
    /// datasheet's value (docs/protocols.md, EMP).
    pub fn millivolts(self, code: AdcCode) -> f64 {
        FULL_SCALE_MV * f64::from(code.signed())
            / (f64::from(self.resolution.min_code()) * f64::from(self.gain.factor()))
    }

    /// The range of readings in mV: ±full scale bipolar; unipolar "gelten nur
    /// die positiven Werte".
    pub fn range_mv(self, polarity: AdcPolarity) -> (f64, f64) {
        let fs = self.gain.full_scale_mv();
        match polarity {
            AdcPolarity::Bipolar => (-fs, fs),
            AdcPolarity::Unipolar => (0.0, fs),
        }
    }
}

impl fmt::Display for AdcMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:?} {}-bit x{}",
            self.input,
            self.resolution.bits(),
            self.gain.factor()
        )
    }
}

/// A raw reading as the `51` reply carries it (D1 = LSB, D0 = MSB).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct AdcCode(pub u16);

impl AdcCode {
    pub const fn signed(self) -> i16 {
        self.0 as i16
    }

    /// D1, D0 of the reply: "Die Anlage liefert mit Byte 7 den LSB-Messwert
    /// und mit Byte 8 den MSB-Messwert".
    pub const fn reply_bytes(self) -> [u8; 2] {
        let [msb, lsb] = self.0.to_be_bytes();
        [lsb, msb]
    }

    pub const fn from_reply_bytes(d1: u8, d0: u8) -> AdcCode {
        AdcCode(u16::from_be_bytes([d0, d1]))
    }
}

/// `20 DS 02`: ADC parameters for joystick operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct JoystickParameters {
    /// LOOPCycles: program loops per reading, 1-255. The manual's table ("01" =
    /// 10 ms, "10" = 100 ms, …) and its example (`0C`) disagree on how to read
    /// the byte, so it is passed as a plain count (docs/protocols.md, EMP).
    pub loop_cycles: u8,
    /// ADCMode.
    pub polarity: AdcPolarity,
    /// MULTIPLIER, the gain of the analogue signal (`01` = factor 1).
    pub multiplier: Gain,
    /// HYSTERESE: dead band around zero in mV (`40` = 64 mV).
    pub hysteresis_mv: u8,
}

impl JoystickParameters {
    /// INFO, D3, D2, D1, D0 of the request.
    pub fn bytes(self) -> [u8; 5] {
        [
            self.loop_cycles,
            ADC_TYPE_ADS1112,
            self.polarity.byte(),
            self.multiplier.factor(),
            self.hysteresis_mv,
        ]
    }

    pub fn from_bytes(b: [u8; 5]) -> Result<JoystickParameters, ValueError> {
        let [loop_cycles, adc_type, mode, multiplier, hysteresis_mv] = b;
        if loop_cycles == 0 {
            return Err(ValueError::OutOfRange {
                field: "LOOPCycles",
                value: 0,
                expected: "1..=255 program loops per reading",
            });
        }
        if adc_type != ADC_TYPE_ADS1112 {
            return Err(ValueError::BadByte {
                field: "ADCTyp",
                value: adc_type,
                expected: "04 (ADS1112)",
            });
        }
        Ok(JoystickParameters {
            loop_cycles,
            polarity: AdcPolarity::from_byte(mode)?,
            multiplier: Gain::from_factor(multiplier).ok_or(ValueError::BadByte {
                field: "MULTIPLIER",
                value: multiplier,
                expected: "01, 02, 04 or 08",
            })?,
            hysteresis_mv,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mode_byte_follows_the_manual_table() {
        // x0 = 12-bit x1 … xF = 16-bit x8; 0x/2x bipolar channels 1/2,
        // 4x/6x/2x unipolar channels 1/2/3.
        let m = AdcMode::from_byte(0x00).unwrap();
        assert_eq!(
            (m.input, m.resolution, m.gain),
            (AdcInput::Ain0Ain1, AdcResolution::Bits12, Gain::X1)
        );
        let m = AdcMode::from_byte(0x2D).unwrap();
        assert_eq!(
            (m.input, m.resolution, m.gain),
            (AdcInput::Ain2Ain3, AdcResolution::Bits16, Gain::X2)
        );
        let m = AdcMode::from_byte(0x66).unwrap();
        assert_eq!((m.resolution, m.gain), (AdcResolution::Bits14, Gain::X4));
        let m = AdcMode::from_byte(0x4B).unwrap();
        assert_eq!((m.resolution, m.gain), (AdcResolution::Bits15, Gain::X8));
        for b in 0..=255u8 {
            match AdcMode::from_byte(b) {
                Ok(m) => assert_eq!(m.byte(), b),
                Err(_) => assert!(![0, 2, 4, 6].contains(&(b >> 4))),
            }
        }
    }

    fn mode(resolution: AdcResolution, gain: Gain) -> AdcMode {
        AdcMode {
            input: AdcInput::Ain0Ain1,
            resolution,
            gain,
        }
    }

    #[test]
    fn millivolts_by_resolution_and_gain() {
        use AdcResolution::*;
        // Full scale: ±2 V at factor 1, ±1 V, ±500 mV, ±250 mV (±2048/PGA exactly).
        assert_eq!(mode(Bits16, Gain::X1).millivolts(AdcCode(0x8000)), -2048.0);
        assert_eq!(
            mode(Bits16, Gain::X1).millivolts(AdcCode(0x7FFF)),
            2047.9375
        );
        assert_eq!(mode(Bits16, Gain::X2).millivolts(AdcCode(0x4000)), 512.0);
        assert_eq!(mode(Bits12, Gain::X1).millivolts(AdcCode(0x07FF)), 2047.0);
        assert_eq!(mode(Bits12, Gain::X1).millivolts(AdcCode(0xF800)), -2048.0);
        assert_eq!(mode(Bits12, Gain::X8).millivolts(AdcCode(0x0400)), 128.0);
        assert_eq!(mode(Bits14, Gain::X4).millivolts(AdcCode(0x1000)), 256.0);
        assert_eq!(mode(Bits15, Gain::X1).millivolts(AdcCode(0x2000)), 1024.0);
        // One LSB below zero is -1 LSB (62.5 µV at 16 bit), not 0 as the
        // manual's `65535 - DezZahl` would give.
        assert_eq!(mode(Bits16, Gain::X1).millivolts(AdcCode(0xFFFF)), -0.0625);
        // The manual's positive branch, value for value: 2048 * Dez / (MinCode * PGA).
        for code in [0u16, 1, 100, 1000, 32767] {
            let manual = 2048.0 * f64::from(code) / (32768.0 * 4.0);
            assert_eq!(mode(Bits16, Gain::X4).millivolts(AdcCode(code)), manual);
        }
    }

    #[test]
    fn ranges_by_gain_and_polarity() {
        let m = mode(AdcResolution::Bits16, Gain::X4);
        assert_eq!(m.range_mv(AdcPolarity::Bipolar), (-512.0, 512.0));
        assert_eq!(m.range_mv(AdcPolarity::Unipolar), (0.0, 512.0));
        let fs: Vec<f64> = Gain::ALL.iter().map(|g| g.full_scale_mv()).collect();
        assert_eq!(fs, [2048.0, 1024.0, 512.0, 256.0]);
    }

    #[test]
    fn reply_bytes_are_lsb_then_msb() {
        assert_eq!(AdcCode(0x1234).reply_bytes(), [0x34, 0x12]);
        assert_eq!(AdcCode::from_reply_bytes(0x34, 0x12), AdcCode(0x1234));
    }

    #[test]
    fn joystick_parameters_of_beispiel_5() {
        // LOOPCycles = 0C, ADCTyp = 04, ADCMode = 00, MULTIPLIER = 01, HYSTERese = 40.
        let p = JoystickParameters::from_bytes([0x0C, 0x04, 0x00, 0x01, 0x40]).unwrap();
        assert_eq!(p.polarity, AdcPolarity::Bipolar);
        assert_eq!(p.multiplier, Gain::X1);
        assert_eq!(p.hysteresis_mv, 64);
        assert_eq!(p.bytes(), [0x0C, 0x04, 0x00, 0x01, 0x40]);
        assert!(JoystickParameters::from_bytes([0, 4, 0, 1, 0x40]).is_err());
        assert!(JoystickParameters::from_bytes([1, 5, 0, 1, 0x40]).is_err());
        assert!(JoystickParameters::from_bytes([1, 4, 2, 1, 0x40]).is_err());
        assert!(JoystickParameters::from_bytes([1, 4, 1, 3, 0x40]).is_err());
    }
}
