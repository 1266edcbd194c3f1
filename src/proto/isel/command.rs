//! Typed DNC commands (isel manual chapter 2), init commands (chapter 4) and
//! the control bytes (2.2.31).
//!
//! Types hold what the wire can carry: categorical operands (ports, planes,
//! directions, on/off flags, axis settings) are enums, so a [`Command`] can
//! never name port 7; magnitudes (steps, speeds, values) are plain integers
//! whose ranges depend on the manual and the axis configuration and are
//! enforced by [`check`](super::check()).

use crate::axis::{Axis, AxisSet};

use super::axes::AxisSetting;
use super::device::DeviceNumber;
use super::ports::{InputPort, OutputPort};

/// One DNC frame: `@`, device number, command, CR (`docs/decisions.md`
/// isel 1). Encode with [`Frame::encode`], parse with
/// [`parse_frame`](super::parse_frame).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Frame {
    pub device: DeviceNumber,
    pub command: Command,
}

impl Frame {
    pub fn new(device: DeviceNumber, command: Command) -> Frame {
        Frame { device, command }
    }

    /// A frame for the factory default device `@0`.
    pub fn default_device(command: Command) -> Frame {
        Frame::new(DeviceNumber::DEFAULT, command)
    }
}

/// One steps (or position),speed pair of `A`/`M` and CNC `0`/`m`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MovePair {
    /// Relative steps (`A`, `0`) or absolute position (`M`, `m`).
    pub steps: i32,
    /// Step frequency in Hz.
    pub speed: u32,
}

impl MovePair {
    pub const fn new(steps: i32, speed: u32) -> MovePair {
        MovePair { steps, speed }
    }
}

/// The plane circles and helices run in (`@0e`, isel manual 2.2.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Plane {
    #[default]
    XY,
    XZ,
    YZ,
}

impl Plane {
    pub const ALL: [Plane; 3] = [Plane::XY, Plane::XZ, Plane::YZ];

    pub fn value(self) -> u8 {
        self as u8
    }

    pub fn from_value(value: i64) -> Option<Plane> {
        usize::try_from(value)
            .ok()
            .and_then(|v| Plane::ALL.get(v))
            .copied()
    }

    /// Axis 1 and axis 2 of the circle parameters (`Xs`/`Rx` belong to axis 1).
    pub fn axes(self) -> (Axis, Axis) {
        match self {
            Plane::XY => (Axis::X, Axis::Y),
            Plane::XZ => (Axis::X, Axis::Z),
            Plane::YZ => (Axis::Y, Axis::Z),
        }
    }

    /// The axis a helix moves linearly (`S3`, isel manual 2.2.27).
    pub fn third_axis(self) -> Axis {
        match self {
            Plane::XY => Axis::Z,
            Plane::XZ => Axis::Y,
            Plane::YZ => Axis::X,
        }
    }
}

/// Circle direction (`@0f`): `0` clockwise, `-1` counter-clockwise; `1` is
/// also accepted as counter-clockwise (`docs/decisions.md` isel 12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CircleDirection {
    Cw,
    Ccw,
}

impl CircleDirection {
    /// The value the encoder writes.
    pub fn value(self) -> i32 {
        match self {
            CircleDirection::Cw => 0,
            CircleDirection::Ccw => -1,
        }
    }

    pub fn from_value(value: i64) -> Option<CircleDirection> {
        match value {
            0 => Some(CircleDirection::Cw),
            -1 | 1 => Some(CircleDirection::Ccw),
            _ => None,
        }
    }
}

/// A sign parameter (`Rx`, `Ry` of `y`/`w`): `-1` or `1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sign {
    Minus,
    Plus,
}

impl Sign {
    pub fn value(self) -> i32 {
        match self {
            Sign::Minus => -1,
            Sign::Plus => 1,
        }
    }

    pub fn from_value(value: i64) -> Option<Sign> {
        match value {
            -1 => Some(Sign::Minus),
            1 => Some(Sign::Plus),
            _ => None,
        }
    }
}

/// The parameters of a circle `y` (isel manual 2.2.28, 2.3). Compute them
/// with [`circle`](super::circle::circle) rather than by hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CircleParams {
    /// `B`: arc length in steps of both axes together (8 R for a full circle).
    pub arc_length: u32,
    /// `V`: path speed in Hz.
    pub speed: u32,
    /// `D`: start value of the interpolation's difference register.
    pub d: i32,
    /// `Xs`: start point on axis 1, relative to the centre.
    pub xs: i32,
    /// `Ys`: start point on axis 2, relative to the centre.
    pub ys: i32,
    /// `Rx`: direction of axis 1 at the start point.
    pub rx: Sign,
    /// `Ry`: direction of axis 2 at the start point.
    pub ry: Sign,
}

/// The parameters of a helix `w`: a circle plus the steps of the third axis
/// (isel manual 2.2.27).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct HelixParams {
    pub circle: CircleParams,
    /// `S3`: steps of the third axis over the whole arc.
    pub s3: i32,
}

/// The two code characters of `@0D` (isel manual 2.2.6). `Rp` and `Rn` are
/// documented; the manual's example `@0DS0` shows that others exist, so any
/// two ASCII letters or digits are accepted and answered like every
/// diagnosis: `0` and two hex digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Diagnosis([u8; 2]);

impl Diagnosis {
    /// `@0DRp`: the positive limit switches, bit0..3 = X, Y, Z, A.
    pub const POSITIVE_LIMITS: Diagnosis = Diagnosis(*b"Rp");
    /// `@0DRn`: the negative limit switches, bit0..3 = X, Y, Z, A.
    pub const NEGATIVE_LIMITS: Diagnosis = Diagnosis(*b"Rn");

    /// `Some` when both codes are ASCII letters or digits.
    pub fn new(code1: u8, code2: u8) -> Option<Diagnosis> {
        (code1.is_ascii_alphanumeric() && code2.is_ascii_alphanumeric())
            .then_some(Diagnosis([code1, code2]))
    }

    pub fn codes(self) -> [u8; 2] {
        self.0
    }

    /// What the reply byte means, where the manual says.
    pub fn kind(self) -> DiagnosisKind {
        match self {
            Diagnosis::POSITIVE_LIMITS => DiagnosisKind::PositiveLimitSwitches,
            Diagnosis::NEGATIVE_LIMITS => DiagnosisKind::NegativeLimitSwitches,
            _ => DiagnosisKind::Undocumented,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DiagnosisKind {
    /// Reply bits 0..3: positive limit switch of X, Y, Z, A active.
    PositiveLimitSwitches,
    /// Reply bits 0..3: negative limit switch of X, Y, Z, A active.
    NegativeLimitSwitches,
    /// A code the manual does not explain (such as `S0`).
    Undocumented,
}

/// `@0Z`: move relative until an input port matches or the steps are done
/// (isel manual 2.2.30). The move ends when `input & mask == value`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PortMove {
    pub port: InputPort,
    pub mask: u8,
    pub value: u8,
    /// Step frequency in Hz.
    pub speed: u32,
    /// One step count per initialised axis, X first.
    pub steps: Vec<i32>,
}

/// Port, mask and set value of `@0IA`, `@0IH`, `@0IN`: the controller reads
/// the port cyclically in CNC mode and compares `input & mask` with
/// `value & mask`; mask 0 switches the watch off (isel manual 4.2.11–4.2.14).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PortWatch {
    pub port: InputPort,
    pub mask: u8,
    pub value: u8,
}

/// Port, mask and value of `@0Ia`: the error signal output in CNC mode
/// (isel manual 4.2.12). Mask 0 switches it off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct PortSignal {
    pub port: OutputPort,
    pub mask: u8,
    pub value: u8,
}

/// Every DNC command of isel manual chapter 2, with the letter it is sent as.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Command {
    /// `@0<n>`: initialise the axes (2.2.1).
    SetAxes(AxisSetting),
    /// `A` (or `a`): relative move, one pair per axis, 4 pairs with 3 axes (2.2.2).
    MoveRelative(Vec<MovePair>),
    /// `b`: read an input port; answers `0` and two hex digits (2.2.3).
    ReadPort(InputPort),
    /// `B`: write an output port (2.2.4).
    WritePort { port: OutputPort, value: u8 },
    /// `d`: reference speeds, one per initialised axis (2.2.5).
    SetReferenceSpeeds(Vec<u32>),
    /// `D`: diagnosis; answers `0` and two hex digits (2.2.6).
    Diagnose(Diagnosis),
    /// `e`: circle plane (2.2.7).
    SetPlane(Plane),
    /// `f`: circle direction (2.2.8).
    SetCircleDirection(CircleDirection),
    /// `F`: drive one axis out of its limit switch (2.2.9).
    ClearLimitSwitch(Axis),
    /// `g`: brake, `true` = energised, i.e. released (2.2.10).
    SetBrake(bool),
    /// `G`: change the device number (2.2.11).
    SetDeviceNumber(DeviceNumber),
    /// `h`: limit switch status as text lines, then `0` (2.2.12).
    LimitSwitchStatus,
    /// `H`: input status as text lines, then `0` (2.2.12).
    Status,
    /// `i`: start storing a CNC program (2.2.13).
    StoreProgram,
    /// `I…`: the init commands of chapter 4.
    Init(InitCommand),
    /// `j`: start-stop frequency in Hz (2.2.15).
    SetStartStop(u32),
    /// `J`: acceleration in Hz/ms (2.2.16).
    SetAcceleration(u32),
    /// `k`: erase the stored program, answers after about 2 s (2.2.17).
    EraseProgram,
    /// `M` (or `m`): absolute move, pairs as for `A` (2.2.18).
    MoveAbsolute(Vec<MovePair>),
    /// `n`: set the zero point of the masked axes (2.2.19).
    SetZero(AxisSet),
    /// `N`: simulate a reference run of the masked axes (2.2.20).
    SimulateReference(AxisSet),
    /// `P`: read the positions (2.2.21).
    ReadPosition,
    /// `R` (or `r`): reference run, order Z, Y, X, A (2.2.22).
    Reference(AxisSet),
    /// `S` (or `s`): resume a stopped move or run the stored program (2.2.23).
    Start,
    /// `T`: test mode on/off (2.2.24).
    SetTestMode(bool),
    /// `U`: user info as text, no handshake (2.2.25).
    ReadUserInfo,
    /// `V` (or `?`): version as text, no handshake (2.2.26).
    ReadVersion,
    /// `w`: helix (2.2.27).
    Helix(HelixParams),
    /// `y`: circle (2.2.28).
    Circle(CircleParams),
    /// `z`: 3D interpolation on/off (2.2.29).
    Set3dInterpolation(bool),
    /// `Z`: move until a port event (2.2.30).
    MoveUntilPort(PortMove),
}

impl Command {
    /// Whether the controller refuses this with `4` while no axes are
    /// initialised (isel manual chapter 5, code 4): moves, commands whose
    /// parameter count or axis mask depends on the axes, and `i` (2.2.13).
    pub fn needs_axes(&self) -> bool {
        matches!(
            self,
            Command::MoveRelative(_)
                | Command::MoveAbsolute(_)
                | Command::MoveUntilPort(_)
                | Command::SetReferenceSpeeds(_)
                | Command::Reference(_)
                | Command::SetZero(_)
                | Command::SimulateReference(_)
                | Command::ClearLimitSwitch(_)
                | Command::Circle(_)
                | Command::Helix(_)
                | Command::StoreProgram
        )
    }

    /// Whether the controller answers `R` until the axes are referenced
    /// (`docs/decisions.md` isel 4).
    pub fn needs_reference(&self) -> bool {
        matches!(
            self,
            Command::MoveRelative(_)
                | Command::MoveAbsolute(_)
                | Command::MoveUntilPort(_)
                | Command::Circle(_)
                | Command::Helix(_)
        )
    }

    /// Whether the command only reads: it changes nothing on the
    /// controller, so sending it again does what sending it once does.
    pub fn is_read(&self) -> bool {
        matches!(
            self,
            Command::ReadPort(_)
                | Command::Diagnose(_)
                | Command::LimitSwitchStatus
                | Command::Status
                | Command::ReadPosition
                | Command::ReadUserInfo
                | Command::ReadVersion
        )
    }

    /// Whether this command can make an axis move, so the console must treat
    /// the machine as moving until it answers.
    pub fn may_move(&self) -> bool {
        self.needs_reference()
            || matches!(
                self,
                Command::Reference(_) | Command::ClearLimitSwitch(_) | Command::Start
            )
    }
}

/// The init commands of isel manual chapter 4 (`@0I<code>…`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum InitCommand {
    /// `Id`: default reference speeds of X, Y, Z, A in Hz (4.2.1).
    DefaultReferenceSpeeds([u32; 4]),
    /// `IF`: steps to clear the reference switches, X, Y, Z, A (4.2.2).
    ReferenceClearSteps([u32; 4]),
    /// `IJ`: default acceleration in Hz/ms (4.2.3).
    DefaultAcceleration(u32),
    /// `Ij`: default start-stop frequency in Hz (4.2.4).
    DefaultStartStop(u32),
    /// `IO`: IO-only mode on/off (4.2.5).
    IoOnly(bool),
    /// `IE`: limit switch enable and active level word (4.2.6); see
    /// [`LimitSwitchSettings`](super::ports::LimitSwitchSettings).
    LimitSwitches(u16),
    /// `Ie`: swap the limit switches of the masked axes (4.2.7).
    SwapLimitSwitches(AxisSet),
    /// `ID`: invert the direction of the masked axes (4.2.8).
    InvertDirections(AxisSet),
    /// `IR`: invert the reference direction of the masked axes (4.2.9).
    InvertReferenceDirections(AxisSet),
    /// `IT`: the masked axes are rotary, the others linear (4.2.10).
    RotaryAxes(AxisSet),
    /// `IA`: abort input in CNC mode (4.2.11).
    AbortInput(PortWatch),
    /// `Ia`: error signal output in CNC mode (4.2.12).
    ErrorOutput(PortSignal),
    /// `IH`: hood input in CNC mode (4.2.13).
    HoodInput(PortWatch),
    /// `IN`: external E-stop input in CNC mode (4.2.14).
    EmergencyStopInput(PortWatch),
    /// `IC`: 9600 baud after storing and reset (4.2.15).
    Baud9600(bool),
    /// `IU`: user info, at most 32 printable ASCII characters, taken verbatim (4.2.16).
    SetUserInfo(String),
    /// `IL`: load the init values from flash (4.2.17).
    LoadFromFlash,
    /// `IW`: store the init values in flash (4.2.18).
    WriteToFlash,
    /// `IX`: restore the controller's default init values (4.2.19).
    RestoreDefaults,
}

impl InitCommand {
    /// The code letter after `I`.
    pub fn code(&self) -> char {
        match self {
            InitCommand::DefaultReferenceSpeeds(_) => 'd',
            InitCommand::ReferenceClearSteps(_) => 'F',
            InitCommand::DefaultAcceleration(_) => 'J',
            InitCommand::DefaultStartStop(_) => 'j',
            InitCommand::IoOnly(_) => 'O',
            InitCommand::LimitSwitches(_) => 'E',
            InitCommand::SwapLimitSwitches(_) => 'e',
            InitCommand::InvertDirections(_) => 'D',
            InitCommand::InvertReferenceDirections(_) => 'R',
            InitCommand::RotaryAxes(_) => 'T',
            InitCommand::AbortInput(_) => 'A',
            InitCommand::ErrorOutput(_) => 'a',
            InitCommand::HoodInput(_) => 'H',
            InitCommand::EmergencyStopInput(_) => 'N',
            InitCommand::Baud9600(_) => 'C',
            InitCommand::SetUserInfo(_) => 'U',
            InitCommand::LoadFromFlash => 'L',
            InitCommand::WriteToFlash => 'W',
            InitCommand::RestoreDefaults => 'X',
        }
    }
}

/// The three control bytes the controller acts on at once, even between the
/// bytes of a command and during a move (isel manual 2.2.31,
/// `docs/decisions.md` isel 6). None of them has a reply of its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ControlByte {
    /// 0xFD: ramp down without step loss; the move answers `F` and the rest
    /// is kept for `@0S`.
    SoftStop,
    /// 0xFE: software reset; the controller is uninitialised and unreferenced.
    Reset,
    /// 0xFF: ramp down and forget the rest of the move.
    Break,
}

impl ControlByte {
    pub const ALL: [ControlByte; 3] = [
        ControlByte::SoftStop,
        ControlByte::Reset,
        ControlByte::Break,
    ];

    pub fn byte(self) -> u8 {
        match self {
            ControlByte::SoftStop => 0xFD,
            ControlByte::Reset => 0xFE,
            ControlByte::Break => 0xFF,
        }
    }

    pub fn from_byte(byte: u8) -> Option<ControlByte> {
        ControlByte::ALL.into_iter().find(|c| c.byte() == byte)
    }

    pub fn name(self) -> &'static str {
        match self {
            ControlByte::SoftStop => "soft stop",
            ControlByte::Reset => "reset",
            ControlByte::Break => "break",
        }
    }
}
