//! Typed requests: every command of the EMP manual, with its bytes placed as
//! the manual's syntax tables and examples show (column order CMD DS PROP INFO
//! D3 D2 D1 D0). Bytes a table leaves blank are sent as 00, as the manual's VB
//! code does, and a request with anything else there is refused
//! (docs/protocols.md, EMP).

use std::fmt;
use std::str::FromStr;

use super::adc::{ADC_TYPE_ADS1112, AdcMode, JoystickParameters};
use super::address::DriveAddress;
use super::error::{RequestError, ValueError};
use super::frame::{FRAME_WIRE_LEN, Frame};
use super::io::Outputs;
use super::mode::{JoystickChannel, OperatingMode, SubMode};
use super::reload::ReloadValue;
use super::rtc::{RtcDate, RtcTime};
use super::values::{Position, Speed, Velocity};

/// CMD bytes of the requests.
pub mod code {
    pub const IDENTIFY: u8 = 0x00;
    pub const ON: u8 = 0x02;
    pub const OFF: u8 = 0x04;
    pub const HOLD: u8 = 0x08;
    pub const LAST_ERROR: u8 = 0x0A;
    pub const SETTINGS: u8 = 0x20;
    pub const MOTOR_ENABLE: u8 = 0x22;
    pub const MOTOR_DISABLE: u8 = 0x24;
    pub const HOME: u8 = 0x26;
    pub const MOVE: u8 = 0x2A;
    pub const READ_POSITION: u8 = 0x2C;
    pub const IO_READ: u8 = 0x40;
    pub const IO_WRITE: u8 = 0x42;
    pub const EEPROM: u8 = 0x44;
    pub const ADC_READ: u8 = 0x50;
    pub const RTC: u8 = 0x54;

    /// Every request CMD the manual documents.
    pub const ALL: [u8; 16] = [
        IDENTIFY,
        ON,
        OFF,
        HOLD,
        LAST_ERROR,
        SETTINGS,
        MOTOR_ENABLE,
        MOTOR_DISABLE,
        HOME,
        MOVE,
        READ_POSITION,
        IO_READ,
        IO_WRITE,
        EEPROM,
        ADC_READ,
        RTC,
    ];
}

/// The I²C bus setting of Beispiel 5 for 15 kHz (`ADCFreq = "26"`); the
/// manual documents no other value (default 96 kHz).
pub const I2C_15_KHZ: u8 = 0x26;

/// The two queries of `00`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IdentityQuery {
    /// `00 DS 00`: program version.
    Version,
    /// `00 DS 01`: device number.
    DeviceNumber,
}

/// The two forms of "on" (`02`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OnScope {
    /// `02 DS 11`: a single drive ("Einzelanlage EIN").
    Single,
    /// `02 DS 00`: a module on a link of several ("Mehrere Baugruppen EIN").
    Link,
}

/// What a request asks, without the drive address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// `00 DS 00|01`.
    Identify(IdentityQuery),
    /// `02 DS 11|00`. Nothing else is accepted before it.
    On(OnScope),
    /// `04 DS`: off, stand-by; no further commands are taken.
    Off,
    /// `08 DS`: stop and actively hold the current position.
    Hold,
    /// `0A DS`: read the last error code.
    LastError,
    /// `20 DS 02 LOOPCycles ADCTyp ADCMode MULTIPLIER HYSTERESE`.
    JoystickParameters(JoystickParameters),
    /// `20 DS 05 01 PosMSB..PosLSB`: set (or with 0 clear) the current
    /// position. The drive switches its controller off; the mode must be set
    /// again.
    SetPosition(Position),
    /// `20 DS 19 00 00 00 MSB LSB`: reload value of the sample timer.
    SampleRate(ReloadValue),
    /// `22 DS Betrieb ADC-Kanal Sub-Betrieb`: motor enable in a mode.
    MotorEnable(OperatingMode),
    /// `24 DS`: motor disable.
    MotorDisable,
    /// `26 DS 00 00 00 Vfast Vslow 00`: homing; answers `55` at once and `22`
    /// on its own when the reference point is reached.
    Home { fast: Speed, slow: Speed },
    /// `2A DS 00 V D3..D0`: in PV/IV/PWM mode turn at the signed velocity
    /// (torque in PWM); `target` is unused there and 0 in the manual's
    /// examples. In TPWM mode the drive positions to `target` at `velocity`
    /// (Beispiel 4: `2A DS 00 01 000186A0`) and answers as `MoveTo` does.
    Drive {
        velocity: Velocity,
        target: Position,
    },
    /// `2A DS 01 Vmax D3..D0`: TP, position to `target` (TPWM mode). Answers
    /// `55` at once and `22` on its own when in position.
    MoveTo { vmax: Speed, target: Position },
    /// `2A DS 02 Vpwm`: constant torque in TPWM mode, signed like PWM.
    Torque(Velocity),
    /// `2A DS 03`: fast stop; the motor is without current afterwards and its
    /// mode must be set again.
    FastStop,
    /// `2C DS`: read the position; allowed at any time, also while moving.
    ReadPosition,
    /// `40 DS 01`: read limit switches and inputs I1-I4.
    ReadInputs,
    /// `42 DS 01 00 00 00 O4O3 O2O1`: write outputs O1-O4.
    WriteOutputs(Outputs),
    /// `44 DS 08 MemoMSB MemoLSB EEPROMAdr`: read one byte of the HMI EEPROM.
    EepromRead { address: u16, device: u8 },
    /// `44 DS 09 MemoMSB MemoLSB EEPROMAdr 00 MemoDat`: write one byte.
    EepromWrite { address: u16, device: u8, data: u8 },
    /// `44 DS 11 00 00 00 ADCFreq 00`: internal I²C bus frequency
    /// ([`I2C_15_KHZ`], Beispiel 5).
    I2cFrequency(u8),
    /// `50 DS 04 00 Mode`: read the ADS1112.
    ReadAdc(AdcMode),
    /// `54 DS 00`: read weekday and time.
    ReadTime,
    /// `54 DS 01`: read the date.
    ReadDate,
    /// `54 DS 02 00 WT HH MM SS`.
    WriteTime(RtcTime),
    /// `54 DS 03 00 CC JJ MO TT`.
    WriteDate(RtcDate),
}

impl Command {
    /// The CMD byte.
    pub const fn cmd(&self) -> u8 {
        match self {
            Command::Identify(_) => code::IDENTIFY,
            Command::On(_) => code::ON,
            Command::Off => code::OFF,
            Command::Hold => code::HOLD,
            Command::LastError => code::LAST_ERROR,
            Command::JoystickParameters(_) | Command::SetPosition(_) | Command::SampleRate(_) => {
                code::SETTINGS
            }
            Command::MotorEnable(_) => code::MOTOR_ENABLE,
            Command::MotorDisable => code::MOTOR_DISABLE,
            Command::Home { .. } => code::HOME,
            Command::Drive { .. }
            | Command::MoveTo { .. }
            | Command::Torque(_)
            | Command::FastStop => code::MOVE,
            Command::ReadPosition => code::READ_POSITION,
            Command::ReadInputs => code::IO_READ,
            Command::WriteOutputs(_) => code::IO_WRITE,
            Command::EepromRead { .. } | Command::EepromWrite { .. } | Command::I2cFrequency(_) => {
                code::EEPROM
            }
            Command::ReadAdc(_) => code::ADC_READ,
            Command::ReadTime
            | Command::ReadDate
            | Command::WriteTime(_)
            | Command::WriteDate(_) => code::RTC,
        }
    }

    /// The CMD byte of the reply: CMD + 1.
    pub const fn reply_code(&self) -> u8 {
        self.cmd() + 1
    }

    /// The stop commands: `08` holds the position, `2A 03` brakes hard.
    pub const fn is_stop(&self) -> bool {
        matches!(self, Command::Hold | Command::FastStop)
    }

    /// Whether this may set the axis in motion (the jog console's "no motion
    /// while state is unknown" and the `send` command's warning use it).
    pub fn may_move(&self) -> bool {
        match self {
            Command::Home { .. } | Command::MoveTo { .. } => true,
            Command::Drive { velocity, .. } | Command::Torque(velocity) => !velocity.is_stop(),
            Command::MotorEnable(mode) => matches!(mode, OperatingMode::Joystick { .. }),
            _ => false,
        }
    }

    /// Whether this ends a running homing or positioning of the same drive:
    /// every command that stops, re-moves or re-configures the axis
    /// (docs/protocols.md, EMP: the ended action sends no completion).
    pub const fn ends_motion(&self) -> bool {
        matches!(
            self,
            Command::Off
                | Command::Hold
                | Command::SetPosition(_)
                | Command::MotorEnable(_)
                | Command::MotorDisable
                | Command::Home { .. }
                | Command::Drive { .. }
                | Command::MoveTo { .. }
                | Command::Torque(_)
                | Command::FastStop
        )
    }

    /// PROP, INFO, D3, D2, D1, D0.
    fn fields(&self) -> (u8, u8, [u8; 4]) {
        const Z: [u8; 4] = [0; 4];
        match *self {
            Command::Identify(IdentityQuery::Version) => (0x00, 0, Z),
            Command::Identify(IdentityQuery::DeviceNumber) => (0x01, 0, Z),
            Command::On(OnScope::Single) => (0x11, 0, Z),
            Command::On(OnScope::Link) => (0x00, 0, Z),
            Command::Off
            | Command::Hold
            | Command::LastError
            | Command::MotorDisable
            | Command::ReadPosition => (0, 0, Z),
            Command::JoystickParameters(p) => {
                let [info, d3, d2, d1, d0] = p.bytes();
                (0x02, info, [d3, d2, d1, d0])
            }
            Command::SetPosition(pos) => (0x05, 0x01, pos.to_bytes()),
            Command::SampleRate(r) => {
                let [msb, lsb] = r.bytes();
                (0x19, 0, [0, 0, msb, lsb])
            }
            Command::MotorEnable(mode) => {
                let [prop, info, d3] = mode.bytes();
                (prop, info, [d3, 0, 0, 0])
            }
            Command::Home { fast, slow } => (0, 0, [0, fast.value(), slow.value(), 0]),
            Command::Drive { velocity, target } => (0x00, velocity.byte(), target.to_bytes()),
            Command::MoveTo { vmax, target } => (0x01, vmax.value(), target.to_bytes()),
            Command::Torque(v) => (0x02, v.byte(), Z),
            Command::FastStop => (0x03, 0, Z),
            Command::ReadInputs => (0x01, 0, Z),
            Command::WriteOutputs(o) => {
                let [d1, d0] = o.output_bytes();
                (0x01, 0, [0, 0, d1, d0])
            }
            Command::EepromRead { address, device } => {
                let [msb, lsb] = address.to_be_bytes();
                (0x08, msb, [lsb, device, 0, 0])
            }
            Command::EepromWrite {
                address,
                device,
                data,
            } => {
                let [msb, lsb] = address.to_be_bytes();
                (0x09, msb, [lsb, device, 0, data])
            }
            Command::I2cFrequency(f) => (0x11, 0, [0, 0, f, 0]),
            Command::ReadAdc(mode) => (ADC_TYPE_ADS1112, 0, [mode.byte(), 0, 0, 0]),
            Command::ReadTime => (0x00, 0, Z),
            Command::ReadDate => (0x01, 0, Z),
            Command::WriteTime(t) => (0x02, 0, t.to_bytes()),
            Command::WriteDate(d) => (0x03, 0, d.to_bytes()),
        }
    }

    fn decode(f: &Frame) -> Result<Command, RequestError> {
        let cmd = f.cmd;
        let [d3, d2, d1, d0] = f.data;
        let bad = |source: ValueError| RequestError::BadValue { cmd, source };
        let sub = || RequestError::UnknownSubCode { cmd, prop: f.prop };
        let unused = |fields: &[(&'static str, u8)]| -> Result<(), RequestError> {
            match fields.iter().find(|(_, v)| *v != 0) {
                Some(&(field, value)) => Err(RequestError::UnusedNotZero { cmd, field, value }),
                None => Ok(()),
            }
        };
        let (info, data) = (
            ("INFO", f.info),
            [("D3", d3), ("D2", d2), ("D1", d1), ("D0", d0)],
        );
        let all_unused = || {
            unused(&[info])?;
            unused(&data)
        };
        if f.is_reply() {
            return Err(RequestError::NotARequest { cmd });
        }
        let command = match cmd {
            code::IDENTIFY => {
                let q = match f.prop {
                    0x00 => IdentityQuery::Version,
                    0x01 => IdentityQuery::DeviceNumber,
                    _ => return Err(sub()),
                };
                all_unused()?;
                Command::Identify(q)
            }
            code::ON => {
                let scope = match f.prop {
                    0x11 => OnScope::Single,
                    0x00 => OnScope::Link,
                    _ => return Err(sub()),
                };
                all_unused()?;
                Command::On(scope)
            }
            code::OFF
            | code::HOLD
            | code::LAST_ERROR
            | code::MOTOR_DISABLE
            | code::READ_POSITION => {
                unused(&[("PROP", f.prop)])?;
                all_unused()?;
                match cmd {
                    code::OFF => Command::Off,
                    code::HOLD => Command::Hold,
                    code::LAST_ERROR => Command::LastError,
                    code::MOTOR_DISABLE => Command::MotorDisable,
                    _ => Command::ReadPosition,
                }
            }
            code::SETTINGS => match f.prop {
                0x02 => Command::JoystickParameters(
                    JoystickParameters::from_bytes([f.info, d3, d2, d1, d0]).map_err(bad)?,
                ),
                0x05 => {
                    // The table's INFO "01" is part of the command.
                    if f.info != 0x01 {
                        return Err(bad(ValueError::BadByte {
                            field: "INFO of 20 05",
                            value: f.info,
                            expected: "01",
                        }));
                    }
                    Command::SetPosition(Position::from_bytes(f.data).map_err(bad)?)
                }
                0x19 => {
                    unused(&[info, data[0], data[1]])?;
                    let reload = u16::from_be_bytes([d1, d0]);
                    Command::SampleRate(ReloadValue::new(reload).map_err(bad)?)
                }
                _ => return Err(sub()),
            },
            code::MOTOR_ENABLE => {
                let mode = match f.prop {
                    0x02 => OperatingMode::Pv,
                    0x03 => OperatingMode::Iv,
                    0x04 => OperatingMode::Pwm,
                    0x05 => OperatingMode::Joystick {
                        channel: JoystickChannel::from_byte(f.info).map_err(bad)?,
                        sub_mode: SubMode::from_byte(d3).map_err(bad)?,
                    },
                    0x06 => OperatingMode::JoystickOff,
                    0x07 => OperatingMode::Tpwm,
                    _ => return Err(sub()),
                };
                if matches!(mode, OperatingMode::Joystick { .. }) {
                    unused(&data[1..])?;
                } else {
                    all_unused()?;
                }
                Command::MotorEnable(mode)
            }
            code::HOME => {
                unused(&[("PROP", f.prop), info, data[0], data[3]])?;
                Command::Home {
                    fast: Speed::new(d2).map_err(bad)?,
                    slow: Speed::new(d1).map_err(bad)?,
                }
            }
            code::MOVE => match f.prop {
                0x00 => Command::Drive {
                    velocity: Velocity::from_byte(f.info),
                    target: Position::from_bytes(f.data).map_err(bad)?,
                },
                0x01 => Command::MoveTo {
                    vmax: Speed::new(f.info).map_err(bad)?,
                    target: Position::from_bytes(f.data).map_err(bad)?,
                },
                0x02 => {
                    unused(&data)?;
                    Command::Torque(Velocity::from_byte(f.info))
                }
                0x03 => {
                    all_unused()?;
                    Command::FastStop
                }
                _ => return Err(sub()),
            },
            code::IO_READ => {
                if f.prop != 0x01 {
                    return Err(sub());
                }
                all_unused()?;
                Command::ReadInputs
            }
            code::IO_WRITE => {
                if f.prop != 0x01 {
                    return Err(sub());
                }
                unused(&[info, data[0], data[1]])?;
                Command::WriteOutputs(Outputs::from_output_bytes(d1, d0).map_err(bad)?)
            }
            code::EEPROM => match f.prop {
                0x08 => {
                    unused(&data[2..])?;
                    Command::EepromRead {
                        address: u16::from_be_bytes([f.info, d3]),
                        device: d2,
                    }
                }
                0x09 => {
                    unused(&[data[2]])?;
                    Command::EepromWrite {
                        address: u16::from_be_bytes([f.info, d3]),
                        device: d2,
                        data: d0,
                    }
                }
                0x11 => {
                    unused(&[info, data[0], data[1], data[3]])?;
                    Command::I2cFrequency(d1)
                }
                _ => return Err(sub()),
            },
            code::ADC_READ => {
                if f.prop != ADC_TYPE_ADS1112 {
                    return Err(bad(ValueError::BadByte {
                        field: "ADC type",
                        value: f.prop,
                        expected: "04 (ADS1112)",
                    }));
                }
                unused(&[info])?;
                unused(&data[1..])?;
                Command::ReadAdc(AdcMode::from_byte(d3).map_err(bad)?)
            }
            code::RTC => match f.prop {
                0x00 | 0x01 => {
                    all_unused()?;
                    if f.prop == 0 {
                        Command::ReadTime
                    } else {
                        Command::ReadDate
                    }
                }
                0x02 => {
                    unused(&[info])?;
                    Command::WriteTime(RtcTime::from_bytes(f.data).map_err(bad)?)
                }
                0x03 => {
                    unused(&[info])?;
                    Command::WriteDate(RtcDate::from_bytes(f.data).map_err(bad)?)
                }
                _ => return Err(sub()),
            },
            _ => return Err(RequestError::UnknownCommand { cmd }),
        };
        Ok(command)
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Command::Identify(IdentityQuery::Version) => f.write_str("read program version"),
            Command::Identify(IdentityQuery::DeviceNumber) => f.write_str("read device number"),
            Command::On(OnScope::Single) => f.write_str("switch on (single drive)"),
            Command::On(OnScope::Link) => f.write_str("switch on (module on a link)"),
            Command::Off => f.write_str("switch off"),
            Command::Hold => f.write_str("stop and hold position"),
            Command::LastError => f.write_str("read last error"),
            Command::JoystickParameters(p) => write!(
                f,
                "joystick ADC parameters: {} loops, {:?}, x{}, hysteresis {} mV",
                p.loop_cycles,
                p.polarity,
                p.multiplier.factor(),
                p.hysteresis_mv
            ),
            Command::SetPosition(p) => write!(f, "set position to {p}"),
            Command::SampleRate(r) => {
                write!(f, "sample rate: reload {r} ({:.1} Hz)", r.frequency_hz())
            }
            Command::MotorEnable(mode) => write!(f, "motor enable, {mode}"),
            Command::MotorDisable => f.write_str("motor disable"),
            Command::Home { fast, slow } => write!(f, "homing, Vfast {fast}, Vslow {slow}"),
            Command::Drive { velocity, target } if *target == Position::ZERO => {
                write!(f, "velocity {velocity}")
            }
            Command::Drive { velocity, target } => {
                write!(f, "velocity {velocity}, target {target} (TPWM)")
            }
            Command::MoveTo { vmax, target } => write!(f, "move to {target} at Vmax {vmax}"),
            Command::Torque(v) => write!(f, "constant torque {v}"),
            Command::FastStop => f.write_str("fast stop"),
            Command::ReadPosition => f.write_str("read position"),
            Command::ReadInputs => f.write_str("read inputs"),
            Command::WriteOutputs(o) => write!(f, "write outputs O4-O1 {o}"),
            Command::EepromRead { address, device } => {
                write!(f, "EEPROM {device:02X}: read {address:04X}")
            }
            Command::EepromWrite {
                address,
                device,
                data,
            } => write!(f, "EEPROM {device:02X}: write {data:02X} to {address:04X}"),
            Command::I2cFrequency(v) if *v == I2C_15_KHZ => f.write_str("I2C bus at 15 kHz"),
            Command::I2cFrequency(v) => write!(f, "I2C bus frequency setting {v:02X}"),
            Command::ReadAdc(mode) => write!(f, "read ADC, {mode}"),
            Command::ReadTime => f.write_str("read RTC time"),
            Command::ReadDate => f.write_str("read RTC date"),
            Command::WriteTime(t) => write!(f, "set RTC time {t}"),
            Command::WriteDate(d) => write!(f, "set RTC date {d}"),
        }
    }
}

/// A command for one drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Request {
    pub ds: DriveAddress,
    pub command: Command,
}

impl Request {
    pub const fn new(ds: DriveAddress, command: Command) -> Request {
        Request { ds, command }
    }

    /// `2A DS 00 V 00000000`: turn at a velocity in PV/IV/PWM mode.
    pub const fn velocity(ds: DriveAddress, velocity: Velocity) -> Request {
        Request::new(
            ds,
            Command::Drive {
                velocity,
                target: Position::ZERO,
            },
        )
    }

    pub fn to_frame(&self) -> Frame {
        let (prop, info, data) = self.command.fields();
        Frame::new(self.command.cmd(), self.ds.byte(), prop, info, data)
    }

    /// The 16 hex characters and EOF.
    pub fn encode(&self) -> [u8; FRAME_WIRE_LEN] {
        self.to_frame().encode()
    }

    /// Validate a frame as a request. Checks the command first, so an unknown
    /// CMD is reported as such whatever its DS.
    pub fn decode(frame: &Frame) -> Result<Request, RequestError> {
        let command = Command::decode(frame)?;
        let ds = DriveAddress::from_byte(frame.ds)?;
        Ok(Request { ds, command })
    }

    pub const fn reply_code(&self) -> u8 {
        self.command.reply_code()
    }
}

impl fmt::Display for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.ds, self.command)
    }
}

/// A request typed as its frame (`2A 11 01 01 00 01 86 A0`, see [`Frame`]'s
/// `FromStr`) and validated, for the `send` command.
impl FromStr for Request {
    type Err = ParseRequestError;

    fn from_str(s: &str) -> Result<Request, ParseRequestError> {
        let frame: Frame = s.parse()?;
        Ok(Request::decode(&frame)?)
    }
}

/// Why typed text is not a request.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParseRequestError {
    #[error(transparent)]
    Frame(#[from] super::error::FrameError),
    #[error(transparent)]
    Request(#[from] RequestError),
}
