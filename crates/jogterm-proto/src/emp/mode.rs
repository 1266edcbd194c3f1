//! Operating modes set with `22` Motor Enable (EMP manual "22 : Motor Enable").

use std::fmt;

use super::error::ValueError;

/// The speed profile a joystick drives ("Unter-Betriebsart").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SubMode {
    /// `02` PV: proportional velocity ("starke Drehmomentsteuerung").
    Pv,
    /// `03` IV: integrated velocity, constant speed.
    Iv,
    /// `04` PWM: constant torque ("leichte Drehmomentsteuerung").
    Pwm,
}

impl SubMode {
    pub const ALL: [SubMode; 3] = [SubMode::Pv, SubMode::Iv, SubMode::Pwm];

    pub const fn byte(self) -> u8 {
        match self {
            SubMode::Pv => 0x02,
            SubMode::Iv => 0x03,
            SubMode::Pwm => 0x04,
        }
    }

    pub fn from_byte(b: u8) -> Result<SubMode, ValueError> {
        SubMode::ALL
            .into_iter()
            .find(|m| m.byte() == b)
            .ok_or(ValueError::BadByte {
                field: "sub-mode",
                value: b,
                expected: "02 (PV), 03 (IV) or 04 (PWM)",
            })
    }
}

/// The analogue channel a joystick is read from: bipolar channel 1 (`01`) or
/// 2 (`02`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JoystickChannel {
    One,
    Two,
}

impl JoystickChannel {
    pub const fn byte(self) -> u8 {
        match self {
            JoystickChannel::One => 0x01,
            JoystickChannel::Two => 0x02,
        }
    }

    pub fn from_byte(b: u8) -> Result<JoystickChannel, ValueError> {
        match b {
            0x01 => Ok(JoystickChannel::One),
            0x02 => Ok(JoystickChannel::Two),
            _ => Err(ValueError::BadByte {
                field: "ADC channel",
                value: b,
                expected: "01 or 02 (bipolar channel 1 or 2)",
            }),
        }
    }
}

/// "Betrieb" (PROP of `22`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OperatingMode {
    /// `02` proportional velocity.
    Pv,
    /// `03` integrated velocity.
    Iv,
    /// `04` PWM, constant torque.
    Pwm,
    /// `05` joystick on: speed from ADC `channel`, driven as `sub_mode`.
    Joystick {
        channel: JoystickChannel,
        sub_mode: SubMode,
    },
    /// `06` joystick off.
    JoystickOff,
    /// `07` TPWM: positioning and constant torque.
    Tpwm,
}

impl OperatingMode {
    pub const fn code(self) -> u8 {
        match self {
            OperatingMode::Pv => 0x02,
            OperatingMode::Iv => 0x03,
            OperatingMode::Pwm => 0x04,
            OperatingMode::Joystick { .. } => 0x05,
            OperatingMode::JoystickOff => 0x06,
            OperatingMode::Tpwm => 0x07,
        }
    }

    /// PROP, INFO, D3 of the request.
    pub const fn bytes(self) -> [u8; 3] {
        match self {
            OperatingMode::Joystick { channel, sub_mode } => {
                [self.code(), channel.byte(), sub_mode.byte()]
            }
            _ => [self.code(), 0, 0],
        }
    }

    pub fn is_velocity_mode(self) -> bool {
        matches!(
            self,
            OperatingMode::Pv | OperatingMode::Iv | OperatingMode::Pwm
        )
    }
}

impl fmt::Display for OperatingMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OperatingMode::Pv => f.write_str("PV"),
            OperatingMode::Iv => f.write_str("IV"),
            OperatingMode::Pwm => f.write_str("PWM"),
            OperatingMode::Joystick { channel, sub_mode } => {
                write!(f, "joystick on channel {} as {sub_mode:?}", channel.byte())
            }
            OperatingMode::JoystickOff => f.write_str("joystick off"),
            OperatingMode::Tpwm => f.write_str("TPWM"),
        }
    }
}
