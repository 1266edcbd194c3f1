//! Typed EMCU commands and their encoder (manual 1.5). Master commands (`@…`)
//! run at once, also while the axes move; all others are buffered in the data
//! memory and run when a command ends with 0x01 or the memory is full
//! (manual 1.4.2, `docs/decisions.md` EMCU decision 1).

use std::fmt;

use thiserror::Error;

use crate::axis::{Axis, AxisSet};

use super::values::{EmcuAxis, Output, RampMillis, Slot, Speed, Steps, ValueError, WaitMillis};

/// Ends a buffered command and starts the data memory (manual 1.4.2).
pub const RUN_BUFFER: u8 = 0x01;
/// Ends every command and acknowledges every command (manual 1.4.2).
pub const CR: u8 = b'\r';
/// Longest command line jogterm accepts, terminator not counted. The longest
/// valid command, `L1,X-999999,Y-999999,Z-999999`, has 29 bytes.
pub const MAX_COMMAND_LINE: usize = 32;

/// When the interface acts on a command (manual 1.4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Class {
    /// `@…`: executed at once, never stored, allowed while a buffer or job runs.
    Master,
    /// Stored in the data memory (or in ROM during an `@F` transfer) and run
    /// later; may not be sent while a buffer or job runs.
    Buffered,
}

/// The byte that ends a command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Terminator {
    /// CR: store a buffered command (or run a master command).
    Cr,
    /// 0x01 instead of CR: store a buffered command and run the data memory
    /// (during an `@F` transfer: store it as the last command of the job).
    RunBuffer,
}

impl Terminator {
    pub fn byte(self) -> u8 {
        match self {
            Terminator::Cr => CR,
            Terminator::RunBuffer => RUN_BUFFER,
        }
    }

    pub fn from_byte(byte: u8) -> Option<Terminator> {
        match byte {
            CR => Some(Terminator::Cr),
            RUN_BUFFER => Some(Terminator::RunBuffer),
            _ => None,
        }
    }
}

/// Whether the axes of an `L` move name target positions or distances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MoveMode {
    /// Upper-case axis letters: positions relative to the zero point.
    Absolute,
    /// Lower-case axis letters: distances from the current position.
    Relative,
}

/// The axes of a `$H` reference run, in the order they run (manual 1.5.9:
/// "Die Reihenfolge der Achsenbewegung ergibt sich aus der Reihenfolge der
/// Achsendefinition"). One to three distinct axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ReferenceOrder {
    /// The first `len` cells are the order; the rest stay X so that equal
    /// orders compare equal.
    axes: [EmcuAxis; 3],
    len: usize,
}

impl ReferenceOrder {
    pub fn new(axes: &[EmcuAxis]) -> Result<ReferenceOrder, ValueError> {
        if axes.is_empty() {
            return Err(ValueError::NoAxes);
        }
        let mut seen = AxisSet::EMPTY;
        let mut order = ReferenceOrder {
            axes: [EmcuAxis::X; 3],
            len: 0,
        };
        for axis in axes {
            if seen.contains(axis.axis()) {
                return Err(ValueError::RepeatedAxis(axis.axis()));
            }
            seen = seen.with(axis.axis());
            // Three distinct EMCU axes at most, so a cell is always free.
            if let Some(cell) = order.axes.get_mut(order.len) {
                *cell = *axis;
                order.len += 1;
            }
        }
        Ok(order)
    }

    /// From shared axes; refuses `A` as well as repeats.
    pub fn from_axes(axes: &[Axis]) -> Result<ReferenceOrder, ValueError> {
        let axes = axes
            .iter()
            .map(|a| EmcuAxis::new(*a))
            .collect::<Result<Vec<_>, _>>()?;
        ReferenceOrder::new(&axes)
    }

    /// The axes in the order they are referenced.
    pub fn axes(&self) -> &[EmcuAxis] {
        self.axes.get(..self.len).unwrap_or_default()
    }

    pub fn set(&self) -> AxisSet {
        self.axes().iter().map(|a| a.axis()).collect()
    }
}

/// An `L` vector move: one to three axes, linearly interpolated, at the end
/// speed of a slot (manual 1.5.10, decision 3).
///
/// All axes of one move share the mode (`docs/protocols.md`, EMCU): the
/// manual's examples never mix cases, and a controller that took the mode
/// from the first letter would send a mixed move somewhere else.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Move {
    slot: Slot,
    mode: MoveMode,
    steps: [Option<Steps>; 3],
}

impl Move {
    pub fn new(
        slot: Slot,
        mode: MoveMode,
        targets: &[(EmcuAxis, Steps)],
    ) -> Result<Move, ValueError> {
        if targets.is_empty() {
            return Err(ValueError::NoAxes);
        }
        let mut steps = [None; 3];
        for (axis, value) in targets {
            let cell = steps
                .get_mut(axis.index())
                .ok_or(ValueError::NotEmcuAxis(axis.axis()))?;
            if cell.is_some() {
                return Err(ValueError::RepeatedAxis(axis.axis()));
            }
            *cell = Some(*value);
        }
        Ok(Move { slot, mode, steps })
    }

    /// A move of one axis.
    pub fn single(slot: Slot, mode: MoveMode, axis: EmcuAxis, steps: Steps) -> Move {
        let mut cells = [None; 3];
        if let Some(cell) = cells.get_mut(axis.index()) {
            *cell = Some(steps);
        }
        Move {
            slot,
            mode,
            steps: cells,
        }
    }

    pub fn slot(&self) -> Slot {
        self.slot
    }

    pub fn mode(&self) -> MoveMode {
        self.mode
    }

    /// The target (absolute) or distance (relative) of one axis, if it moves.
    pub fn steps(&self, axis: EmcuAxis) -> Option<Steps> {
        self.steps.get(axis.index()).copied().flatten()
    }

    /// The axes and their steps in X, Y, Z order (the order the encoder
    /// writes; the parser accepts any order).
    pub fn targets(&self) -> impl Iterator<Item = (EmcuAxis, Steps)> + '_ {
        EmcuAxis::ALL
            .into_iter()
            .filter_map(|axis| self.steps(axis).map(|s| (axis, s)))
    }

    pub fn axes(&self) -> AxisSet {
        self.targets().map(|(a, _)| a.axis()).collect()
    }
}

/// Every command of the EMCU manual, chapter 1.5.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// `@R` reset: stops at once, clears the data memory, positions become
    /// zero; a reference run is needed afterwards (1.5.1).
    Reset,
    /// `@V` version query (1.5.2).
    Version,
    /// `@X` status query (1.5.3).
    Status,
    /// `@LX`, `@LY`, `@LZ` position query (1.5.4).
    Position(EmcuAxis),
    /// `#S<hz>` start speed, also the reference speed (1.5.5, 1.5.8).
    StartSpeed(Speed),
    /// `#E<slot>,<hz>` end speed of a slot (1.5.6, decision 3).
    EndSpeed { slot: Slot, speed: Speed },
    /// `#R<ms>` ramp length (1.5.7).
    Ramp(RampMillis),
    /// `$H<axes>` reference run, axes in the given order (1.5.9).
    Reference(ReferenceOrder),
    /// `L<slot>,<axis><steps>[,…]` vector move (1.5.10).
    Move(Move),
    /// `@B` halt all axes with ramp, the job ends, positions kept (1.5.11).
    Halt,
    /// `@S` stop at once without ramp: positions lost, memory cleared (1.5.12,
    /// decision 5).
    Stop,
    /// `@A` pause: ramp down and wait for `@C` (1.5.13).
    Pause,
    /// `@C` end the pause and go on (1.5.14).
    Resume,
    /// `A<n>,<0|1>` switch output n (1.5.15).
    SetOutput { output: Output, on: bool },
    /// `W<ms>` wait (1.5.16).
    Wait(WaitMillis),
    /// `@F` store the following buffered commands in ROM (1.5.17, decision 2).
    StoreJob,
    /// `@J` run the job stored in ROM (1.5.18).
    RunJob,
    /// `&V<0|1>` make the following moves wait for input E1 (1.5.19).
    LinkE1(bool),
}

/// A command that cannot be put on the wire as asked.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum EncodeError {
    #[error(
        "`{0}` is a master command: it runs at once and cannot be ended with 0x01 (run buffer)"
    )]
    RunBufferOnMaster(String),
}

impl Command {
    pub fn class(&self) -> Class {
        match self {
            Command::Reset
            | Command::Version
            | Command::Status
            | Command::Position(_)
            | Command::Halt
            | Command::Stop
            | Command::Pause
            | Command::Resume
            | Command::StoreJob
            | Command::RunJob => Class::Master,
            Command::StartSpeed(_)
            | Command::EndSpeed { .. }
            | Command::Ramp(_)
            | Command::Reference(_)
            | Command::Move(_)
            | Command::SetOutput { .. }
            | Command::Wait(_)
            | Command::LinkE1(_) => Class::Buffered,
        }
    }

    pub fn is_master(&self) -> bool {
        self.class() == Class::Master
    }

    /// Whether the command may be stored in the data memory or a ROM job:
    /// exactly the buffered ones (manual 1.4.2, decision 2).
    pub fn is_storable(&self) -> bool {
        self.class() == Class::Buffered
    }

    /// Whether the interface answers with data rather than a bare CR.
    pub fn is_query(&self) -> bool {
        matches!(
            self,
            Command::Version | Command::Status | Command::Position(_)
        )
    }

    /// Whether running the command can move an axis: a buffered move or
    /// reference run, or a master command that restarts stored motion.
    pub fn may_move(&self) -> bool {
        matches!(
            self,
            Command::Move(_) | Command::Reference(_) | Command::Resume | Command::RunJob
        )
    }

    /// The bytes of the command line, ended by `end`. Only buffered commands
    /// may end with [`Terminator::RunBuffer`].
    pub fn encode(&self, end: Terminator) -> Result<Vec<u8>, EncodeError> {
        if end == Terminator::RunBuffer && self.is_master() {
            return Err(EncodeError::RunBufferOnMaster(self.to_string()));
        }
        let mut bytes = self.to_string().into_bytes();
        bytes.push(end.byte());
        Ok(bytes)
    }
}

fn bit(on: bool) -> char {
    if on { '1' } else { '0' }
}

impl fmt::Display for Command {
    /// The command line as text, without its terminator (`L1,x500,y1000`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Command::Reset => f.write_str("@R"),
            Command::Version => f.write_str("@V"),
            Command::Status => f.write_str("@X"),
            Command::Position(axis) => write!(f, "@L{}", char::from(axis.upper())),
            Command::StartSpeed(hz) => write!(f, "#S{hz}"),
            Command::EndSpeed { slot, speed } => write!(f, "#E{slot},{speed}"),
            Command::Ramp(ms) => write!(f, "#R{ms}"),
            Command::Reference(order) => {
                f.write_str("$H")?;
                order
                    .axes()
                    .iter()
                    .try_for_each(|a| write!(f, "{}", char::from(a.upper())))
            }
            Command::Move(mv) => {
                write!(f, "L{}", mv.slot())?;
                mv.targets().try_for_each(|(axis, steps)| {
                    let letter = match mv.mode() {
                        MoveMode::Absolute => axis.upper(),
                        MoveMode::Relative => axis.lower(),
                    };
                    write!(f, ",{}{steps}", char::from(letter))
                })
            }
            Command::Halt => f.write_str("@B"),
            Command::Stop => f.write_str("@S"),
            Command::Pause => f.write_str("@A"),
            Command::Resume => f.write_str("@C"),
            Command::SetOutput { output, on } => write!(f, "A{output},{}", bit(*on)),
            Command::Wait(ms) => write!(f, "W{ms}"),
            Command::StoreJob => f.write_str("@F"),
            Command::RunJob => f.write_str("@J"),
            Command::LinkE1(on) => write!(f, "&V{}", bit(*on)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(v: i32) -> Steps {
        Steps::new(v).unwrap()
    }

    #[test]
    fn moves_are_written_in_xyz_order_with_the_mode_as_letter_case() {
        let mv = Move::new(
            Slot::FIRST,
            MoveMode::Relative,
            &[(EmcuAxis::Y, steps(-100)), (EmcuAxis::X, steps(-50))],
        )
        .unwrap();
        assert_eq!(Command::Move(mv).to_string(), "L1,x-50,y-100");
        assert_eq!(mv.axes(), AxisSet::from_iter([Axis::X, Axis::Y]));
    }

    #[test]
    fn moves_refuse_repeated_and_missing_axes() {
        let repeated = Move::new(
            Slot::FIRST,
            MoveMode::Absolute,
            &[(EmcuAxis::X, steps(1)), (EmcuAxis::X, steps(2))],
        );
        assert_eq!(repeated, Err(ValueError::RepeatedAxis(Axis::X)));
        assert_eq!(
            Move::new(Slot::FIRST, MoveMode::Absolute, &[]),
            Err(ValueError::NoAxes)
        );
    }

    #[test]
    fn reference_order_is_kept_and_checked() {
        let order = ReferenceOrder::from_axes(&[Axis::Z, Axis::X, Axis::Y]).unwrap();
        assert_eq!(Command::Reference(order).to_string(), "$HZXY");
        assert_eq!(
            ReferenceOrder::from_axes(&[Axis::Y, Axis::Y]),
            Err(ValueError::RepeatedAxis(Axis::Y))
        );
        assert_eq!(
            ReferenceOrder::from_axes(&[Axis::A]),
            Err(ValueError::NotEmcuAxis(Axis::A))
        );
        assert_eq!(ReferenceOrder::new(&[]), Err(ValueError::NoAxes));
    }

    #[test]
    fn the_terminator_is_chosen_by_the_caller() {
        let wait = Command::Wait(WaitMillis::new(250).unwrap());
        assert_eq!(wait.encode(Terminator::Cr).unwrap(), b"W250\r");
        assert_eq!(wait.encode(Terminator::RunBuffer).unwrap(), b"W250\x01");
        assert_eq!(Command::Status.encode(Terminator::Cr).unwrap(), b"@X\r");
        assert_eq!(
            Command::Status.encode(Terminator::RunBuffer),
            Err(EncodeError::RunBufferOnMaster("@X".into()))
        );
    }
}
