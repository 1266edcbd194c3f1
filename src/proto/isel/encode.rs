//! The command encoder: canonical text and bytes of frames and CNC lines.
//!
//! Canonical form (`docs/decisions.md` isel 1 and 10): no space after
//! the command letter, parameters separated by commas, the primary letter of
//! letter pairs (`A` not `a`, `M`, `R`, `S`, `V` not `?`), CCW written `-1`,
//! CNC codes in the spelling of chapter 3's sections. `Display` gives the
//! text without the CR; `encode` adds it. The encoder writes what the value
//! holds and validates nothing: run [`check`](super::check()) first.

use std::fmt::{self, Write as _};

use super::cnc::CncCommand;
use super::command::{
    CircleParams, Command, ControlByte, Frame, HelixParams, InitCommand, MovePair,
};
use super::ports::PortBits;

/// The carriage return that ends every frame and CNC line.
pub const CR: u8 = b'\r';

impl Frame {
    /// The bytes to send: `@`, device digit, command, CR.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.to_string().into_bytes();
        out.push(CR);
        out
    }
}

impl fmt::Display for Frame {
    /// `@0A5000,900`: the frame without its CR.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "@{}{}", self.device, self.command)
    }
}

impl CncCommand {
    /// The bytes of a stored line: code, parameters, CR.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.to_string().into_bytes();
        out.push(CR);
        out
    }
}

impl ControlByte {
    /// The single byte to send; control bytes have no frame.
    pub fn encode(self) -> [u8; 1] {
        [self.byte()]
    }
}

/// Comma-separated parameters.
struct Params(String);

impl Params {
    fn new() -> Params {
        Params(String::new())
    }

    fn push(&mut self, value: impl fmt::Display) -> &mut Params {
        if !self.0.is_empty() {
            self.0.push(',');
        }
        // Writing to a String cannot fail.
        let _ = write!(self.0, "{value}");
        self
    }

    fn pairs(&mut self, pairs: &[MovePair]) -> &mut Params {
        for p in pairs {
            self.push(p.steps).push(p.speed);
        }
        self
    }

    fn circle(&mut self, c: &CircleParams) -> &mut Params {
        self.push(c.arc_length)
            .push(c.speed)
            .push(c.d)
            .push(c.xs)
            .push(c.ys)
            .push(c.rx.value())
            .push(c.ry.value())
    }

    fn helix(&mut self, h: &HelixParams) -> &mut Params {
        self.circle(&h.circle).push(h.s3)
    }

    fn all<T: fmt::Display>(&mut self, values: impl IntoIterator<Item = T>) -> &mut Params {
        for v in values {
            self.push(v);
        }
        self
    }
}

/// The wire value of a bit selection; CNC `6` counts bits from 1
/// (`docs/decisions.md` isel 11).
fn bits_value(bits: PortBits, one_based: bool) -> u16 {
    match bits {
        PortBits::Byte => u16::from(PortBits::BYTE_VALUE),
        PortBits::Bit(n) => u16::from(n) + u16::from(one_based),
    }
}

impl fmt::Display for Command {
    /// The command after `@<dev>`: `A5000,900`, `IU…`, `7`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut p = Params::new();
        let code: String = match self {
            Command::SetAxes(setting) => setting.value().to_string(),
            Command::MoveRelative(pairs) => {
                p.pairs(pairs);
                "A".into()
            }
            Command::ReadPort(port) => {
                p.push(port.number());
                "b".into()
            }
            Command::WritePort { port, value } => {
                p.push(port.number()).push(value);
                "B".into()
            }
            Command::SetReferenceSpeeds(speeds) => {
                p.all(speeds);
                "d".into()
            }
            Command::Diagnose(d) => {
                let [a, b] = d.codes();
                format!("D{}{}", char::from(a), char::from(b))
            }
            Command::SetPlane(plane) => {
                p.push(plane.value());
                "e".into()
            }
            Command::SetCircleDirection(dir) => {
                p.push(dir.value());
                "f".into()
            }
            Command::ClearLimitSwitch(axis) => {
                p.push(axis.mask_bit());
                "F".into()
            }
            Command::SetBrake(on) => {
                p.push(u8::from(*on));
                "g".into()
            }
            Command::SetDeviceNumber(n) => {
                p.push(n);
                "G".into()
            }
            Command::LimitSwitchStatus => "h".into(),
            Command::Status => "H".into(),
            Command::StoreProgram => "i".into(),
            Command::Init(init) => {
                init_params(init, &mut p);
                format!("I{}", init.code())
            }
            Command::SetStartStop(hz) => {
                p.push(hz);
                "j".into()
            }
            Command::SetAcceleration(a) => {
                p.push(a);
                "J".into()
            }
            Command::EraseProgram => "k".into(),
            Command::MoveAbsolute(pairs) => {
                p.pairs(pairs);
                "M".into()
            }
            Command::SetZero(mask) => {
                p.push(mask.mask());
                "n".into()
            }
            Command::SimulateReference(mask) => {
                p.push(mask.mask());
                "N".into()
            }
            Command::ReadPosition => "P".into(),
            Command::Reference(mask) => {
                p.push(mask.mask());
                "R".into()
            }
            Command::Start => "S".into(),
            Command::SetTestMode(on) => {
                p.push(u8::from(*on));
                "T".into()
            }
            Command::ReadUserInfo => "U".into(),
            Command::ReadVersion => "V".into(),
            Command::Helix(h) => {
                p.helix(h);
                "w".into()
            }
            Command::Circle(c) => {
                p.circle(c);
                "y".into()
            }
            Command::Set3dInterpolation(on) => {
                p.push(u8::from(*on));
                "z".into()
            }
            Command::MoveUntilPort(m) => {
                p.push(m.port.number())
                    .push(m.mask)
                    .push(m.value)
                    .push(m.speed)
                    .all(&m.steps);
                "Z".into()
            }
        };
        write!(f, "{code}{}", p.0)
    }
}

fn init_params(init: &InitCommand, p: &mut Params) {
    match init {
        InitCommand::DefaultReferenceSpeeds(v) | InitCommand::ReferenceClearSteps(v) => {
            p.all(v);
        }
        InitCommand::DefaultAcceleration(v) | InitCommand::DefaultStartStop(v) => {
            p.push(v);
        }
        InitCommand::IoOnly(on) | InitCommand::Baud9600(on) => {
            p.push(u8::from(*on));
        }
        InitCommand::LimitSwitches(word) => {
            p.push(word);
        }
        InitCommand::SwapLimitSwitches(m)
        | InitCommand::InvertDirections(m)
        | InitCommand::InvertReferenceDirections(m)
        | InitCommand::RotaryAxes(m) => {
            p.push(m.mask());
        }
        InitCommand::AbortInput(w)
        | InitCommand::HoodInput(w)
        | InitCommand::EmergencyStopInput(w) => {
            p.push(w.port.number()).push(w.mask).push(w.value);
        }
        InitCommand::ErrorOutput(s) => {
            p.push(s.port.number()).push(s.mask).push(s.value);
        }
        // The user info is sent verbatim, commas and all.
        InitCommand::SetUserInfo(text) => p.0.push_str(text),
        InitCommand::LoadFromFlash | InitCommand::WriteToFlash | InitCommand::RestoreDefaults => {}
    }
}

impl fmt::Display for CncCommand {
    /// The stored line without its CR: `05000,900`, `325,-1`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut p = Params::new();
        match self {
            CncCommand::MoveRelative(pairs) | CncCommand::MoveAbsolute(pairs) => {
                p.pairs(pairs);
            }
            CncCommand::SendSync(s) => {
                p.push(s.byte());
            }
            CncCommand::WaitSync { sync, offset } => {
                p.push(sync.byte()).push(offset);
            }
            CncCommand::Loop { count, offset } => {
                p.push(count).push(offset);
            }
            CncCommand::Delay(tenths) => {
                p.push(tenths);
            }
            CncCommand::PortCondition { port, bits, value } => {
                p.push(port.number())
                    .push(bits_value(*bits, true))
                    .push(value);
            }
            CncCommand::Reference(m)
            | CncCommand::SetZero(m)
            | CncCommand::SimulateReference(m) => {
                p.push(m.mask());
            }
            CncCommand::End => {}
            CncCommand::SetReferenceSpeeds(speeds) => {
                p.all(speeds);
            }
            CncCommand::SetPlane(plane) => {
                p.push(plane.value());
            }
            CncCommand::SetCircleDirection(dir) => {
                p.push(dir.value());
            }
            CncCommand::SetBrake(on)
            | CncCommand::SetTestMode(on)
            | CncCommand::Set3dInterpolation(on) => {
                p.push(u8::from(*on));
            }
            CncCommand::SetStartStop(v) | CncCommand::SetAcceleration(v) => {
                p.push(v);
            }
            CncCommand::BranchOnPort {
                port,
                bits,
                value,
                offset,
            } => {
                p.push(port.number())
                    .push(bits_value(*bits, false))
                    .push(value)
                    .push(offset);
            }
            CncCommand::SetPort { port, bits, value } => {
                p.push(port.number())
                    .push(bits_value(*bits, false))
                    .push(value);
            }
            CncCommand::Helix(h) => {
                p.helix(h);
            }
            CncCommand::Circle(c) => {
                p.circle(c);
            }
        }
        write!(f, "{}{}", self.code(), p.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisSet;
    use crate::proto::isel::{
        AxisSetting, CircleDirection, DeviceNumber, InputPort, OutputPort, Sign, SyncChar,
    };

    #[test]
    fn frames_have_no_space_and_end_in_cr() {
        let f = Frame::default_device(Command::MoveRelative(vec![MovePair::new(5000, 900)]));
        assert_eq!(f.encode(), b"@0A5000,900\r");
        let dev3 = DeviceNumber::new(3).map(|d| Frame::new(d, Command::SetAxes(AxisSetting::XYZ)));
        assert_eq!(dev3.map(|f| f.encode()), Some(b"@37\r".to_vec()));
        assert_eq!(
            Frame::default_device(Command::SetCircleDirection(CircleDirection::Ccw)).to_string(),
            "@0f-1"
        );
        assert_eq!(
            Frame::default_device(Command::Reference(AxisSet::XYZ)).to_string(),
            "@0R7"
        );
        assert_eq!(
            Frame::default_device(Command::Init(InitCommand::SetUserInfo("a,b c".into())))
                .to_string(),
            "@0IUa,b c"
        );
        assert_eq!(ControlByte::SoftStop.encode(), [0xFD]);
    }

    #[test]
    fn cnc_lines_have_no_prefix_and_number_bits_per_command() {
        let cond = CncCommand::PortCondition {
            port: InputPort::User,
            bits: PortBits::Bit(0),
            value: 0,
        };
        assert_eq!(cond.encode(), b"60,1,0\r");
        let set = CncCommand::SetPort {
            port: OutputPort::User,
            bits: PortBits::Bit(0),
            value: 1,
        };
        assert_eq!(set.to_string(), "p0,0,1");
        let byte = CncCommand::BranchOnPort {
            port: InputPort::User,
            bits: PortBits::Byte,
            value: 1,
            offset: -1,
        };
        assert_eq!(byte.to_string(), "o0,128,1,-1");
        let sync = SyncChar::new(33).map(CncCommand::SendSync);
        assert_eq!(sync.map(|s| s.to_string()), Some("133".into()));
        let circle = CncCommand::Circle(CircleParams {
            arc_length: 400,
            speed: 1500,
            d: 119,
            xs: -141,
            ys: 141,
            rx: Sign::Minus,
            ry: Sign::Minus,
        });
        assert_eq!(circle.to_string(), "y400,1500,119,-141,141,-1,-1");
    }
}
