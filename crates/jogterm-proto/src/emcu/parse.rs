//! Text parser: one command line (without its terminator) to a typed
//! [`Command`]. The interface never reports a bad command (decision 4: it
//! acknowledges with CR and sets the error flag of `@X`), so this parser is the
//! only place a mistake can be caught: the console refuses to send what it
//! refuses, and the simulator sets its error flag for it. Rules and ranges:
//! `docs/protocols.md`, EMCU.

use std::fmt;
use std::str::FromStr;

use thiserror::Error;

use crate::axis::AxisSet;
use crate::text::readable;

use super::command::{Command, Move, MoveMode, ReferenceOrder};
use super::values::{
    Bounded, EmcuAxis, Output, RampMillis, Slot, Speed, Steps, ValueError, WaitMillis,
};

/// What stood where something else was expected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Found {
    EndOfLine,
    Byte(u8),
}

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Found::EndOfLine => f.write_str("the end of the line"),
            Found::Byte(b) => write!(f, "`{}`", readable(&[*b])),
        }
    }
}

/// Why a line is not a valid EMCU command.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ParseErrorKind {
    #[error("empty line: expected a command such as `@X` or `L1,x100`")]
    Empty,
    #[error(
        "unknown command `{0}`: EMCU commands are @R @V @X @LX @LY @LZ @B @S @A @C @F @J \
         #S #E #R $H L A W &V"
    )]
    UnknownCommand(String),
    #[error("`{found}`: commands are upper case, did you mean `{upper}`?")]
    LowerCaseCommand { found: String, upper: String },
    #[error("expected {expected}, found {found}")]
    Expected {
        expected: &'static str,
        found: Found,
    },
    #[error("{what} takes no sign `{sign}`{hint}")]
    SignNotAllowed {
        what: &'static str,
        sign: char,
        hint: &'static str,
    },
    #[error("{what} has at most {max} digits")]
    TooManyDigits { what: &'static str, max: usize },
    #[error(transparent)]
    Value(#[from] ValueError),
    #[error(
        "axis `{found}` mixes absolute (X Y Z) and relative (x y z) axes in one move: \
         write two moves"
    )]
    MixedMoveModes { found: char },
    #[error("a master command (`@…`) cannot be ended with 0x01 (run buffer)")]
    RunBufferOnMaster,
    #[error("line of {len} bytes is longer than any EMCU command (at most {max})")]
    TooLong { len: usize, max: usize },
}

/// A refused command line: what is wrong and at which byte (0-based; the
/// display counts columns from 1).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("column {}: {kind}", .offset + 1)]
pub struct ParseError {
    pub offset: usize,
    pub kind: ParseErrorKind,
}

impl ParseError {
    pub fn new(offset: usize, kind: ParseErrorKind) -> ParseError {
        ParseError { offset, kind }
    }
}

/// Parses one command line given as text (no terminator, no whitespace).
pub fn parse_line(line: &str) -> Result<Command, ParseError> {
    parse_bytes(line.as_bytes())
}

/// Parses one command line given as the bytes that arrived (no terminator).
pub fn parse_bytes(line: &[u8]) -> Result<Command, ParseError> {
    let mut p = Cursor { line, at: 0 };
    let command = p.command()?;
    p.end()?;
    Ok(command)
}

impl FromStr for Command {
    type Err = ParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_line(s)
    }
}

/// Master command letters after `@` (manual 1.5).
const MASTER_LETTERS: &[u8] = b"RVXLBSACFJ";

struct Cursor<'a> {
    line: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<u8> {
        self.line.get(self.at).copied()
    }

    fn found(&self) -> Found {
        self.peek().map_or(Found::EndOfLine, Found::Byte)
    }

    fn error(&self, kind: ParseErrorKind) -> ParseError {
        ParseError::new(self.at, kind)
    }

    fn expected(&self, expected: &'static str) -> ParseError {
        self.error(ParseErrorKind::Expected {
            expected,
            found: self.found(),
        })
    }

    fn bump(&mut self) -> Option<u8> {
        let b = self.peek()?;
        self.at += 1;
        Some(b)
    }

    fn eat(&mut self, byte: u8, expected: &'static str) -> Result<(), ParseError> {
        if self.peek() == Some(byte) {
            self.at += 1;
            Ok(())
        } else {
            Err(self.expected(expected))
        }
    }

    fn end(&self) -> Result<(), ParseError> {
        match self.peek() {
            None => Ok(()),
            Some(_) => Err(self.expected("the end of the command")),
        }
    }

    /// The command token (`@X`, `#S`, `L`) that was not understood, for the
    /// error message; lower-case spellings of real commands get a hint.
    fn unknown(&self, start: usize, len: usize) -> ParseError {
        let end = (start + len).min(self.line.len());
        let token = self.line.get(start..end).unwrap_or_default();
        let upper = token.to_ascii_uppercase();
        let kind = if upper != token && is_command_token(&upper) {
            ParseErrorKind::LowerCaseCommand {
                found: readable(token),
                upper: readable(&upper),
            }
        } else {
            ParseErrorKind::UnknownCommand(readable(token))
        };
        ParseError::new(start, kind)
    }

    fn command(&mut self) -> Result<Command, ParseError> {
        let start = self.at;
        let Some(first) = self.bump() else {
            return Err(self.error(ParseErrorKind::Empty));
        };
        match first {
            b'@' => self.master(start),
            b'#' => match self.bump() {
                Some(b'S') => Ok(Command::StartSpeed(self.unsigned::<Speed>()?)),
                Some(b'E') => {
                    let slot = self.unsigned::<Slot>()?;
                    self.eat(b',', "`,` after the speed slot")?;
                    let speed = self.unsigned::<Speed>()?;
                    Ok(Command::EndSpeed { slot, speed })
                }
                Some(b'R') => Ok(Command::Ramp(self.unsigned::<RampMillis>()?)),
                None => Err(self.expected("S, E or R after `#`")),
                Some(_) => Err(self.unknown(start, 2)),
            },
            b'$' => match self.bump() {
                Some(b'H') => self.reference(),
                None => Err(self.expected("H after `$`")),
                Some(_) => Err(self.unknown(start, 2)),
            },
            b'&' => match self.bump() {
                Some(b'V') => Ok(Command::LinkE1(self.bit("0 (E1 link off) or 1 (on)")?)),
                None => Err(self.expected("V after `&`")),
                Some(_) => Err(self.unknown(start, 2)),
            },
            b'L' => self.vector(),
            b'A' => {
                let output = self.unsigned::<Output>()?;
                self.eat(b',', "`,` after the output number")?;
                let on = self.bit("0 (off) or 1 (on)")?;
                Ok(Command::SetOutput { output, on })
            }
            b'W' => Ok(Command::Wait(self.unsigned::<WaitMillis>()?)),
            _ => Err(self.unknown(start, 1)),
        }
    }

    fn master(&mut self, start: usize) -> Result<Command, ParseError> {
        let Some(letter) = self.bump() else {
            return Err(self.expected("a command letter after `@` (R V X L B S A C F J)"));
        };
        Ok(match letter {
            b'R' => Command::Reset,
            b'V' => Command::Version,
            b'X' => Command::Status,
            b'B' => Command::Halt,
            b'S' => Command::Stop,
            b'A' => Command::Pause,
            b'C' => Command::Resume,
            b'F' => Command::StoreJob,
            b'J' => Command::RunJob,
            b'L' => {
                let axis = self
                    .peek()
                    .and_then(EmcuAxis::from_upper)
                    .ok_or_else(|| self.expected("axis X, Y or Z (upper case) after `@L`"))?;
                self.at += 1;
                Command::Position(axis)
            }
            _ => return Err(self.unknown(start, 2)),
        })
    }

    /// `$H` axes: upper case, each once, in run order (manual 1.5.9).
    fn reference(&mut self) -> Result<Command, ParseError> {
        let mut axes = Vec::with_capacity(3);
        let mut seen = AxisSet::EMPTY;
        loop {
            let expected = if axes.is_empty() {
                "axis X, Y or Z (upper case) after `$H`"
            } else {
                "another axis X, Y or Z (upper case), or the end of the command"
            };
            match self.peek() {
                None if !axes.is_empty() => break,
                Some(b) => {
                    let axis = EmcuAxis::from_upper(b).ok_or_else(|| self.expected(expected))?;
                    if seen.contains(axis.axis()) {
                        return Err(self.error(ValueError::RepeatedAxis(axis.axis()).into()));
                    }
                    seen = seen.with(axis.axis());
                    axes.push(axis);
                    self.at += 1;
                }
                None => return Err(self.expected(expected)),
            }
        }
        ReferenceOrder::new(&axes)
            .map(Command::Reference)
            .map_err(|e| self.error(e.into()))
    }

    /// `L<slot>,<axis><steps>[,…]` (manual 1.5.10).
    fn vector(&mut self) -> Result<Command, ParseError> {
        let slot = self.unsigned::<Slot>()?;
        self.eat(b',', "`,` after the speed slot")?;
        let mut mode = None;
        let mut targets = Vec::with_capacity(3);
        let mut seen = AxisSet::EMPTY;
        loop {
            let at = self.at;
            let letter = self.peek();
            let (axis, this_mode) = match letter
                .map(|b| (b, EmcuAxis::from_upper(b.to_ascii_uppercase())))
            {
                Some((b, Some(axis))) if b.is_ascii_uppercase() => (axis, MoveMode::Absolute),
                Some((_, Some(axis))) => (axis, MoveMode::Relative),
                _ => return Err(self.expected("an axis X, Y, Z (absolute) or x, y, z (relative)")),
            };
            if seen.contains(axis.axis()) {
                return Err(self.error(ValueError::RepeatedAxis(axis.axis()).into()));
            }
            match mode {
                Some(m) if m != this_mode => {
                    return Err(ParseError::new(
                        at,
                        ParseErrorKind::MixedMoveModes {
                            found: char::from(letter.unwrap_or(b'?')),
                        },
                    ));
                }
                _ => mode = Some(this_mode),
            }
            seen = seen.with(axis.axis());
            self.at += 1;
            targets.push((axis, self.steps()?));
            match self.peek() {
                None => break,
                Some(b',') => self.at += 1,
                Some(_) => {
                    return Err(self.expected("`,` and another axis, or the end of the command"));
                }
            }
        }
        let mode = mode.unwrap_or(MoveMode::Absolute);
        Move::new(slot, mode, &targets)
            .map(Command::Move)
            .map_err(|e| self.error(e.into()))
    }

    /// Digits of a value that takes no sign.
    fn unsigned<T: Bounded>(&mut self) -> Result<T, ParseError> {
        let start = self.at;
        if let Some(sign @ (b'+' | b'-')) = self.peek() {
            return Err(self.error(ParseErrorKind::SignNotAllowed {
                what: T::WHAT,
                sign: char::from(sign),
                hint: "",
            }));
        }
        let value = self.digits(T::WHAT, T::DIGITS)?;
        let too_long = ParseErrorKind::TooManyDigits {
            what: T::WHAT,
            max: T::DIGITS,
        };
        let value = u16::try_from(value).map_err(|_| ParseError::new(start, too_long))?;
        T::new(value).map_err(|e| ParseError::new(start, e.into()))
    }

    /// Steps of one axis of `L`: a `-` for the negative direction, never `+`.
    fn steps(&mut self) -> Result<Steps, ParseError> {
        let start = self.at;
        let negative = match self.peek() {
            Some(b'-') => {
                self.at += 1;
                true
            }
            Some(b'+') => {
                return Err(self.error(ParseErrorKind::SignNotAllowed {
                    what: Steps::WHAT,
                    sign: '+',
                    hint: ": positive steps are written without a sign",
                }));
            }
            _ => false,
        };
        let magnitude = self.digits(Steps::WHAT, Steps::DIGITS).map_err(|mut e| {
            // A number that is too long is reported from its sign on.
            if matches!(e.kind, ParseErrorKind::TooManyDigits { .. }) {
                e.offset = start;
            }
            e
        })?;
        let magnitude = i64::from(magnitude);
        let value = if negative { -magnitude } else { magnitude };
        i32::try_from(value)
            .map_err(|_| ValueError::OutOfRange {
                what: Steps::WHAT,
                value,
                min: i64::from(Steps::MIN),
                max: i64::from(Steps::MAX),
            })
            .and_then(Steps::new)
            .map_err(|e| ParseError::new(start, e.into()))
    }

    /// One to `max_digits` decimal digits (leading zeros count).
    fn digits(&mut self, what: &'static str, max_digits: usize) -> Result<u32, ParseError> {
        let start = self.at;
        let mut value: u32 = 0;
        let mut count = 0;
        while let Some(d @ b'0'..=b'9') = self.peek() {
            count += 1;
            if count > max_digits {
                return Err(ParseError::new(
                    start,
                    ParseErrorKind::TooManyDigits {
                        what,
                        max: max_digits,
                    },
                ));
            }
            value = value.saturating_mul(10).saturating_add(u32::from(d - b'0'));
            self.at += 1;
        }
        if count == 0 {
            return Err(self.error(ParseErrorKind::Expected {
                expected: "a decimal number",
                found: self.found(),
            }));
        }
        Ok(value)
    }

    fn bit(&mut self, expected: &'static str) -> Result<bool, ParseError> {
        match self.peek() {
            Some(b'0') => {
                self.at += 1;
                Ok(false)
            }
            Some(b'1') => {
                self.at += 1;
                Ok(true)
            }
            _ => Err(self.expected(expected)),
        }
    }
}

/// Whether an upper-cased command token names a real command (for the
/// lower-case hint only).
fn is_command_token(token: &[u8]) -> bool {
    match token {
        [b'@', letter] => MASTER_LETTERS.contains(letter),
        [b'#', b'S' | b'E' | b'R'] | [b'$', b'H'] | [b'&', b'V'] => true,
        [b'L' | b'A' | b'W'] => true,
        _ => false,
    }
}
