//! Typed replies. A reply is CMD+1 of its request, from the same DS, with the
//! status in INFO (`docs/decisions.md` EMP decisions 1 and 2) and data
//! placed as the manual's "Rückgabe" rows show. Several replies look alike
//! (`21` answers three different `20` settings, `2B` every `2A`), so a reply
//! is decoded against the request it answers.
//!
//! Replies are decoded strictly where a field is defined (positions, BCD,
//! output nibbles) and bytes the manual leaves blank are ignored, so a drive
//! that leaves something there is still understood (docs/protocols.md, EMP).

use std::fmt;

use super::adc::AdcCode;
use super::address::DriveAddress;
use super::decoder::Incoming;
use super::error::{ReplyError, RequestError, ValueError};
use super::frame::{FRAME_WIRE_LEN, Frame};
use super::ident::IdentText;
use super::io::{Inputs, Limits, Lines, Outputs};
use super::request::{Command, Request, code};
use super::rtc::{RtcDate, RtcTime};
use super::values::Position;

/// The status byte of a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Info {
    /// `22`: done, ready.
    Ready,
    /// `55`: busy; the same reply code follows with `22` when done.
    Busy,
    /// `EE`: the request was rejected; `0A` tells why.
    Rejected,
}

impl Info {
    pub const fn byte(self) -> u8 {
        match self {
            Info::Ready => 0x22,
            Info::Busy => 0x55,
            Info::Rejected => 0xEE,
        }
    }

    pub const fn from_byte(b: u8) -> Option<Info> {
        match b {
            0x22 => Some(Info::Ready),
            0x55 => Some(Info::Busy),
            0xEE => Some(Info::Rejected),
            _ => None,
        }
    }

    pub const fn meaning(self) -> &'static str {
        match self {
            Info::Ready => "ready: done",
            Info::Busy => "busy: running, a ready reply follows when done",
            Info::Rejected => "rejected: read the error code with 0A",
        }
    }
}

/// The code `0A` reports in D0 (decision 2: `00` = none). The manual lists no
/// codes; the ones named here are jogterm's, used by its simulator
/// (docs/protocols.md, EMP). Any other code is shown as a number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ErrorCode(pub u8);

impl ErrorCode {
    pub const NONE: ErrorCode = ErrorCode(0x00);
    /// Unknown CMD or sub-code.
    pub const UNKNOWN_COMMAND: ErrorCode = ErrorCode(0x01);
    /// A command other than `02` before the drive was switched on (or after `04`).
    pub const NOT_ON: ErrorCode = ErrorCode(0x02);
    /// A field out of range or an unused byte not 00.
    pub const BAD_PARAMETER: ErrorCode = ErrorCode(0x03);
    /// The command does not fit the operating mode (e.g. `2A 01` outside TPWM,
    /// motion with the motor disabled).
    pub const WRONG_MODE: ErrorCode = ErrorCode(0x04);
    /// Motion towards an active limit switch, or a move stopped by one.
    pub const LIMIT_SWITCH: ErrorCode = ErrorCode(0x05);

    pub const fn meaning(self) -> Option<&'static str> {
        match self.0 {
            0x00 => Some("no error"),
            0x01 => Some("unknown command"),
            0x02 => Some("not switched on"),
            0x03 => Some("bad parameter"),
            0x04 => Some("not possible in this operating mode"),
            0x05 => Some("limit switch"),
            _ => None,
        }
    }

    pub const fn is_none(self) -> bool {
        self.0 == 0
    }
}

/// The code a drive (the simulator) reports for a request it cannot decode.
impl From<&RequestError> for ErrorCode {
    fn from(e: &RequestError) -> ErrorCode {
        match e {
            RequestError::NotARequest { .. }
            | RequestError::UnknownCommand { .. }
            | RequestError::UnknownSubCode { .. } => ErrorCode::UNKNOWN_COMMAND,
            RequestError::BadAddress { .. }
            | RequestError::AddressText(_)
            | RequestError::UnusedNotZero { .. }
            | RequestError::BadValue { .. } => ErrorCode::BAD_PARAMETER,
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.meaning() {
            Some(m) => write!(f, "{:02X} ({m})", self.0),
            None => write!(f, "{:02X} (not documented)", self.0),
        }
    }
}

/// The data of a ready or busy reply, one variant per kind of answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ReplyBody {
    /// `03` to `02`.
    On,
    /// `05` to `04`.
    Off,
    /// `09` to `08`.
    Hold,
    /// `0B` to `0A`: the last error in D0.
    LastError(ErrorCode),
    /// `21` to `20 02` and `20 19`.
    Settings,
    /// `21` to `20 05`: the position now set.
    PositionSet(Position),
    /// `23` to `22`: the position when the mode was set.
    MotorEnabled(Position),
    /// `25` to `24`.
    MotorDisabled,
    /// `27` to `26`: the position (with `55` while homing).
    Homing(Position),
    /// `2B` to any `2A`: the position (with `55` while positioning).
    Moved(Position),
    /// `2D` to `2C`.
    Position(Position),
    /// `41` to `40 01`: switches in PROP, I4-I1 in D0.
    Inputs { limits: Limits, inputs: Inputs },
    /// `43` to `42 01`: switches in PROP, the outputs as written in D1, D0.
    Outputs { limits: Limits, outputs: Outputs },
    /// `45` to `44 08`: the byte read, in D0.
    EepromData(u8),
    /// `45` to `44 09` and `44 11`.
    EepromDone,
    /// `51` to `50`: the raw reading (D1 = LSB, D0 = MSB).
    Adc(AdcCode),
    /// `55` to `54 00`: WT HH MM SS in D3..D0.
    Time(RtcTime),
    /// `55` to `54 01`: CC JJ MO TT in D3..D0.
    Date(RtcDate),
    /// `55` to `54 02` and `54 03`.
    RtcDone,
}

impl ReplyBody {
    /// The reply CMD this body goes with.
    pub const fn reply_code(&self) -> u8 {
        let request = match self {
            ReplyBody::On => code::ON,
            ReplyBody::Off => code::OFF,
            ReplyBody::Hold => code::HOLD,
            ReplyBody::LastError(_) => code::LAST_ERROR,
            ReplyBody::Settings | ReplyBody::PositionSet(_) => code::SETTINGS,
            ReplyBody::MotorEnabled(_) => code::MOTOR_ENABLE,
            ReplyBody::MotorDisabled => code::MOTOR_DISABLE,
            ReplyBody::Homing(_) => code::HOME,
            ReplyBody::Moved(_) => code::MOVE,
            ReplyBody::Position(_) => code::READ_POSITION,
            ReplyBody::Inputs { .. } => code::IO_READ,
            ReplyBody::Outputs { .. } => code::IO_WRITE,
            ReplyBody::EepromData(_) | ReplyBody::EepromDone => code::EEPROM,
            ReplyBody::Adc(_) => code::ADC_READ,
            ReplyBody::Time(_) | ReplyBody::Date(_) | ReplyBody::RtcDone => code::RTC,
        };
        request + 1
    }

    /// The position a reply carries, if any.
    pub const fn position(&self) -> Option<Position> {
        match *self {
            ReplyBody::PositionSet(p)
            | ReplyBody::MotorEnabled(p)
            | ReplyBody::Homing(p)
            | ReplyBody::Moved(p)
            | ReplyBody::Position(p) => Some(p),
            _ => None,
        }
    }

    /// PROP, D3..D0 (INFO is the status).
    fn fields(&self) -> (u8, [u8; 4]) {
        const Z: [u8; 4] = [0; 4];
        match *self {
            ReplyBody::On
            | ReplyBody::Off
            | ReplyBody::Hold
            | ReplyBody::Settings
            | ReplyBody::MotorDisabled
            | ReplyBody::EepromDone
            | ReplyBody::RtcDone => (0, Z),
            ReplyBody::LastError(code) => (0, [0, 0, 0, code.0]),
            ReplyBody::PositionSet(p)
            | ReplyBody::MotorEnabled(p)
            | ReplyBody::Homing(p)
            | ReplyBody::Moved(p)
            | ReplyBody::Position(p) => (0, p.to_bytes()),
            ReplyBody::Inputs { limits, inputs } => (limits.byte(), [0, 0, 0, inputs.bits()]),
            ReplyBody::Outputs { limits, outputs } => {
                let [d1, d0] = outputs.output_bytes();
                (limits.byte(), [0, 0, d1, d0])
            }
            ReplyBody::EepromData(b) => (0, [0, 0, 0, b]),
            ReplyBody::Adc(code) => {
                let [d1, d0] = code.reply_bytes();
                (0, [0, 0, d1, d0])
            }
            ReplyBody::Time(t) => (0, t.to_bytes()),
            ReplyBody::Date(d) => (0, d.to_bytes()),
        }
    }

    /// The body of a ready or busy frame answering `command`. `None` for `00`,
    /// which is answered by text.
    fn decode(command: &Command, f: &Frame) -> Result<Option<ReplyBody>, ValueError> {
        let [_, _, d1, d0] = f.data;
        let position = || Position::from_bytes(f.data);
        Ok(Some(match command {
            Command::Identify(_) => return Ok(None),
            Command::On(_) => ReplyBody::On,
            Command::Off => ReplyBody::Off,
            Command::Hold => ReplyBody::Hold,
            Command::LastError => ReplyBody::LastError(ErrorCode(d0)),
            Command::JoystickParameters(_) | Command::SampleRate(_) => ReplyBody::Settings,
            Command::SetPosition(_) => ReplyBody::PositionSet(position()?),
            Command::MotorEnable(_) => ReplyBody::MotorEnabled(position()?),
            Command::MotorDisable => ReplyBody::MotorDisabled,
            // The table shows D3 as 00 and the position in D2..D0; D3 is the
            // sign byte of the 25-bit position like everywhere else.
            Command::Home { .. } => ReplyBody::Homing(position()?),
            Command::Drive { .. }
            | Command::MoveTo { .. }
            | Command::Torque(_)
            | Command::FastStop => ReplyBody::Moved(position()?),
            Command::ReadPosition => ReplyBody::Position(position()?),
            Command::ReadInputs => ReplyBody::Inputs {
                limits: Limits::from_byte(f.prop),
                inputs: Lines::from_bits(d0),
            },
            Command::WriteOutputs(_) => ReplyBody::Outputs {
                limits: Limits::from_byte(f.prop),
                outputs: Lines::from_output_bytes(d1, d0)?,
            },
            Command::EepromRead { .. } => ReplyBody::EepromData(d0),
            Command::EepromWrite { .. } | Command::I2cFrequency(_) => ReplyBody::EepromDone,
            Command::ReadAdc(_) => ReplyBody::Adc(AdcCode::from_reply_bytes(d1, d0)),
            Command::ReadTime => ReplyBody::Time(RtcTime::from_bytes(f.data)?),
            Command::ReadDate => ReplyBody::Date(RtcDate::from_bytes(f.data)?),
            Command::WriteTime(_) | Command::WriteDate(_) => ReplyBody::RtcDone,
        }))
    }
}

impl fmt::Display for ReplyBody {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplyBody::On => f.write_str("switched on"),
            ReplyBody::Off => f.write_str("switched off"),
            ReplyBody::Hold => f.write_str("holding"),
            ReplyBody::LastError(code) => write!(f, "last error {code}"),
            ReplyBody::Settings => f.write_str("setting taken"),
            ReplyBody::PositionSet(p) => write!(f, "position set to {p}"),
            ReplyBody::MotorEnabled(p) => write!(f, "motor enabled at {p}"),
            ReplyBody::MotorDisabled => f.write_str("motor disabled"),
            ReplyBody::Homing(p) => write!(f, "homing, position {p}"),
            ReplyBody::Moved(p) => write!(f, "move, position {p}"),
            ReplyBody::Position(p) => write!(f, "position {p}"),
            ReplyBody::Inputs { limits, inputs } => write!(f, "inputs I4-I1 {inputs}, {limits}"),
            ReplyBody::Outputs { limits, outputs } => {
                write!(f, "outputs O4-O1 {outputs}, {limits}")
            }
            ReplyBody::EepromData(b) => write!(f, "EEPROM byte {b:02X}"),
            ReplyBody::EepromDone => f.write_str("I2C done"),
            ReplyBody::Adc(code) => write!(f, "ADC code {:04X} ({})", code.0, code.signed()),
            ReplyBody::Time(t) => write!(f, "RTC {t}"),
            ReplyBody::Date(d) => write!(f, "RTC {d}"),
            ReplyBody::RtcDone => f.write_str("RTC set"),
        }
    }
}

/// One reply of a drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reply {
    /// INFO `22`.
    Ready { ds: DriveAddress, body: ReplyBody },
    /// INFO `55`.
    Busy { ds: DriveAddress, body: ReplyBody },
    /// INFO `EE` to a request with CMD `cmd`: the reply code is `cmd` + 1. The
    /// data bytes carry nothing and are sent as 00.
    Rejected { ds: DriveAddress, cmd: u8 },
    /// The text answer to `00`.
    Identity(IdentText),
}

impl Reply {
    /// The `EE` answer to a request frame the drive cannot take, for a
    /// simulator. Fails only if the frame's DS is no drive address, to which
    /// no drive would answer.
    pub fn rejecting(request: &Frame) -> Result<Reply, RequestError> {
        Ok(Reply::Rejected {
            ds: DriveAddress::from_byte(request.ds)?,
            cmd: request.cmd & !1,
        })
    }

    pub fn ds(&self) -> Option<DriveAddress> {
        match *self {
            Reply::Ready { ds, .. } | Reply::Busy { ds, .. } | Reply::Rejected { ds, .. } => {
                Some(ds)
            }
            Reply::Identity(_) => None,
        }
    }

    pub fn info(&self) -> Option<Info> {
        match self {
            Reply::Ready { .. } => Some(Info::Ready),
            Reply::Busy { .. } => Some(Info::Busy),
            Reply::Rejected { .. } => Some(Info::Rejected),
            Reply::Identity(_) => None,
        }
    }

    pub fn body(&self) -> Option<&ReplyBody> {
        match self {
            Reply::Ready { body, .. } | Reply::Busy { body, .. } => Some(body),
            _ => None,
        }
    }

    pub fn to_incoming(&self) -> Incoming {
        let frame = |body: &ReplyBody, ds: DriveAddress, info: Info| {
            let (prop, data) = body.fields();
            Frame::new(body.reply_code(), ds.byte(), prop, info.byte(), data)
        };
        match self {
            Reply::Ready { ds, body } => Incoming::Frame(frame(body, *ds, Info::Ready)),
            Reply::Busy { ds, body } => Incoming::Frame(frame(body, *ds, Info::Busy)),
            Reply::Rejected { ds, cmd } => Incoming::Frame(Frame::new(
                cmd | 1,
                ds.byte(),
                0,
                Info::Rejected.byte(),
                [0; 4],
            )),
            Reply::Identity(text) => Incoming::Identity(*text),
        }
    }

    /// The reply as it goes on the wire: 16 characters and EOF.
    pub fn encode(&self) -> [u8; FRAME_WIRE_LEN] {
        self.to_incoming().encode()
    }

    /// Decode `incoming` as the answer to `request`.
    pub fn decode(incoming: &Incoming, request: &Request) -> Result<Reply, ReplyError> {
        let is_identify = matches!(request.command, Command::Identify(_));
        let f = match incoming {
            Incoming::Identity(text) if is_identify => return Ok(Reply::Identity(*text)),
            Incoming::Identity(_) => return Err(ReplyError::UnexpectedText(request.command.cmd())),
            Incoming::Frame(f) => f,
        };
        if f.cmd != request.reply_code() {
            return Err(ReplyError::WrongCode {
                request: request.command.cmd(),
                got: f.cmd,
            });
        }
        if f.ds != request.ds.byte() {
            return Err(ReplyError::WrongDrive {
                expected: request.ds.byte(),
                got: f.ds,
            });
        }
        let info = Info::from_byte(f.info).ok_or(ReplyError::UnknownInfo(f.info))?;
        let ds = request.ds;
        if info == Info::Rejected {
            return Ok(Reply::Rejected {
                ds,
                cmd: request.command.cmd(),
            });
        }
        let body = ReplyBody::decode(&request.command, f)
            .map_err(|source| ReplyError::BadValue { cmd: f.cmd, source })?
            .ok_or(ReplyError::ExpectedText(*f))?;
        Ok(match info {
            Info::Busy => Reply::Busy { ds, body },
            _ => Reply::Ready { ds, body },
        })
    }
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reply::Ready { ds, body } => write!(f, "{ds}: {body}"),
            Reply::Busy { ds, body } => write!(f, "{ds}: busy, {body}"),
            Reply::Rejected { ds, cmd } => {
                write!(f, "{ds}: {cmd:02X} {}", Info::Rejected.meaning())
            }
            Reply::Identity(text) => write!(f, "identity {text}"),
        }
    }
}
