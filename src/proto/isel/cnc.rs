//! Typed CNC (stored program) commands, isel manual chapter 3, with the
//! command letters of `docs/decisions.md` isel 10. A CNC line is sent
//! after `@0i` without the `@<dev>` prefix and answered with `0` or an error.

/// Commands a controller's program memory holds before the closing `9`
/// (`docs/protocols.md`, isel 9: more answer `6`). A controller may hold
/// fewer (a profile's `[gcode] memory`), none more.
pub const PROGRAM_CAPACITY: usize = 2000;

use std::fmt;

use crate::axis::AxisSet;

use super::command::{CircleDirection, CircleParams, Command, HelixParams, MovePair, Plane};
use super::ports::{InputPort, OutputPort, PortBits};
use super::reply::ReplyCode;

/// A synchronisation character of CNC `1` and `2`: ASCII 33–126
/// (isel manual 3.2.3). The value is private, so it always is one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SyncChar(u8);

impl SyncChar {
    pub const fn new(byte: u8) -> Option<SyncChar> {
        if byte >= 33 && byte <= 126 {
            Some(SyncChar(byte))
        } else {
            None
        }
    }

    pub const fn byte(self) -> u8 {
        self.0
    }

    /// Whether this character is also a reply code the controller uses
    /// (`0`–`9`, `D`, `F`, `G`, `H`, `R`). While `@0S` runs a program, such a
    /// byte is read as the end of the run, not as a sync character, so a
    /// program should not send it (`docs/protocols.md`, isel).
    pub fn collides_with_reply_code(self) -> bool {
        ReplyCode::from_byte(self.0).is_some_and(ReplyCode::is_used)
    }
}

impl fmt::Display for SyncChar {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", char::from(self.0))
    }
}

/// Every storable command of isel manual chapter 3.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum CncCommand {
    /// `0`: relative move, pairs as for `@0A` (3.2.2).
    MoveRelative(Vec<MovePair>),
    /// `1`: send a sync character to the host (3.2.3).
    SendSync(SyncChar),
    /// `2`: wait for a sync character from the host; on the right one jump by
    /// `offset`, on any other go on with the next command (3.2.4).
    WaitSync { sync: SyncChar, offset: i16 },
    /// `3`: with `count` > 0 run the `-offset` commands before this one
    /// `count` more times; with `count` 0 jump by `offset` (3.2.5,
    /// `docs/decisions.md` isel 11).
    Loop { count: u16, offset: i16 },
    /// `5`: wait `tenths` tenths of a second (3.2.6).
    Delay(u16),
    /// `6`: the next move ends when the port (bit) equals `value` (3.2.7).
    PortCondition {
        port: InputPort,
        bits: PortBits,
        value: u8,
    },
    /// `7`: reference run of the masked axes (3.2.8).
    Reference(AxisSet),
    /// `9`: end of the program (3.2.9).
    End,
    /// `d`: reference speeds, one per initialised axis (3.2.10).
    SetReferenceSpeeds(Vec<u32>),
    /// `e`: circle plane (3.2.11).
    SetPlane(Plane),
    /// `f`: circle direction (3.2.12).
    SetCircleDirection(CircleDirection),
    /// `g`: brake, `true` = energised (released) (3.2.13).
    SetBrake(bool),
    /// `j`: start-stop frequency in Hz (3.2.14).
    SetStartStop(u32),
    /// `J`: acceleration in Hz/ms (3.2.15).
    SetAcceleration(u32),
    /// `m`: absolute move (3.2.16).
    MoveAbsolute(Vec<MovePair>),
    /// `n`: set the zero point of the masked axes (3.2.17).
    SetZero(AxisSet),
    /// `N`: simulate a reference run of the masked axes (3.2.18).
    SimulateReference(AxisSet),
    /// `o`: if the port (bit) equals `value`, jump by `offset` (3.2.19).
    BranchOnPort {
        port: InputPort,
        bits: PortBits,
        value: u8,
        offset: i16,
    },
    /// `p`: set an output port or one of its bits (3.2.20).
    SetPort {
        port: OutputPort,
        bits: PortBits,
        value: u8,
    },
    /// `T`: test mode on/off (3.2.21).
    SetTestMode(bool),
    /// `w`: helix (3.2.22).
    Helix(HelixParams),
    /// `y`: circle (3.2.23).
    Circle(CircleParams),
    /// `z`: 3D interpolation on/off (3.2.24).
    Set3dInterpolation(bool),
}

impl CncCommand {
    /// The command letter of chapter 3's sections (`docs/decisions.md`
    /// isel 10); the encoder writes this one.
    pub fn code(&self) -> char {
        match self {
            CncCommand::MoveRelative(_) => '0',
            CncCommand::SendSync(_) => '1',
            CncCommand::WaitSync { .. } => '2',
            CncCommand::Loop { .. } => '3',
            CncCommand::Delay(_) => '5',
            CncCommand::PortCondition { .. } => '6',
            CncCommand::Reference(_) => '7',
            CncCommand::End => '9',
            CncCommand::SetReferenceSpeeds(_) => 'd',
            CncCommand::SetPlane(_) => 'e',
            CncCommand::SetCircleDirection(_) => 'f',
            CncCommand::SetBrake(_) => 'g',
            CncCommand::SetStartStop(_) => 'j',
            CncCommand::SetAcceleration(_) => 'J',
            CncCommand::MoveAbsolute(_) => 'm',
            CncCommand::SetZero(_) => 'n',
            CncCommand::SimulateReference(_) => 'N',
            CncCommand::BranchOnPort { .. } => 'o',
            CncCommand::SetPort { .. } => 'p',
            CncCommand::SetTestMode(_) => 'T',
            CncCommand::Helix(_) => 'w',
            CncCommand::Circle(_) => 'y',
            CncCommand::Set3dInterpolation(_) => 'z',
        }
    }

    /// The jump offset this command carries, relative to its own index
    /// (`docs/decisions.md` isel 11), for a program linter.
    pub fn jump_offset(&self) -> Option<i16> {
        match self {
            CncCommand::WaitSync { offset, .. }
            | CncCommand::Loop { offset, .. }
            | CncCommand::BranchOnPort { offset, .. } => Some(*offset),
            _ => None,
        }
    }

    /// The DNC command with the same effect, for the commands that have one
    /// (a simulator runs stored programs through its DNC code this way).
    /// `None` for the program-flow commands `1 2 3 5 6 9 o p`.
    pub fn as_dnc(&self) -> Option<Command> {
        Some(match self {
            CncCommand::MoveRelative(p) => Command::MoveRelative(p.clone()),
            CncCommand::Reference(m) => Command::Reference(*m),
            CncCommand::SetReferenceSpeeds(s) => Command::SetReferenceSpeeds(s.clone()),
            CncCommand::SetPlane(p) => Command::SetPlane(*p),
            CncCommand::SetCircleDirection(d) => Command::SetCircleDirection(*d),
            CncCommand::SetBrake(b) => Command::SetBrake(*b),
            CncCommand::SetStartStop(f) => Command::SetStartStop(*f),
            CncCommand::SetAcceleration(a) => Command::SetAcceleration(*a),
            CncCommand::MoveAbsolute(p) => Command::MoveAbsolute(p.clone()),
            CncCommand::SetZero(m) => Command::SetZero(*m),
            CncCommand::SimulateReference(m) => Command::SimulateReference(*m),
            CncCommand::SetTestMode(t) => Command::SetTestMode(*t),
            CncCommand::Helix(h) => Command::Helix(*h),
            CncCommand::Circle(c) => Command::Circle(*c),
            CncCommand::Set3dInterpolation(z) => Command::Set3dInterpolation(*z),
            CncCommand::SendSync(_)
            | CncCommand::WaitSync { .. }
            | CncCommand::Loop { .. }
            | CncCommand::Delay(_)
            | CncCommand::PortCondition { .. }
            | CncCommand::End
            | CncCommand::BranchOnPort { .. }
            | CncCommand::SetPort { .. } => return None,
        })
    }
}

/// The CNC code a letter written in a stored line stands for, and whether it
/// is the upper-case spelling of chapter 1's table rather than the section's
/// (`docs/decisions.md` isel 10).
pub(crate) fn cnc_code(byte: u8) -> Option<(u8, bool)> {
    match byte {
        b'0' | b'1' | b'2' | b'3' | b'5' | b'6' | b'7' | b'9' | b'd' | b'e' | b'f' | b'g'
        | b'j' | b'J' | b'm' | b'n' | b'N' | b'o' | b'p' | b'T' | b'w' | b'y' | b'z' => {
            Some((byte, false))
        }
        b'F' | b'M' | b'O' | b'P' | b'W' | b'Y' | b'Z' => Some((byte.to_ascii_lowercase(), true)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sync_chars_are_printable_and_collisions_are_known() {
        assert_eq!(SyncChar::new(32), None);
        assert_eq!(SyncChar::new(127), None);
        assert_eq!(SyncChar::new(33).map(|s| s.to_string()), Some("!".into()));
        let colliding: String = (33..=126u8)
            .filter_map(SyncChar::new)
            .filter(|s| s.collides_with_reply_code())
            .map(|s| char::from(s.byte()))
            .collect();
        assert_eq!(colliding, "0123456789DFGHR");
    }

    #[test]
    fn upper_case_spellings_map_to_the_sections() {
        assert_eq!(cnc_code(b'M'), Some((b'm', true)));
        assert_eq!(cnc_code(b'Z'), Some((b'z', true)));
        assert_eq!(cnc_code(b'J'), Some((b'J', false)));
        assert_eq!(cnc_code(b'N'), Some((b'N', false)));
        assert_eq!(cnc_code(b'G'), None);
        assert_eq!(cnc_code(b'4'), None);
    }
}
