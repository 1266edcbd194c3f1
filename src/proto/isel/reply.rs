//! What the controller answers: reply codes with their meaning and the
//! recovery each needs (isel manual chapter 5), the typed replies, and the
//! reply encoder a simulator answers with.

use std::fmt;

use thiserror::Error;

use crate::axis::Axis;

/// A reply code character (isel manual chapter 5, `docs/decisions.md`
/// isel "Reply codes").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ReplyCode {
    /// `0`: handshake, the command was executed.
    Ok,
    /// `1`: a number could not be read or is out of range.
    BadNumber,
    /// `2`: a limit switch was hit; positions are lost.
    LimitSwitch,
    /// `3`: an axis that is not initialised, or a bad axis combination.
    BadAxis,
    /// `4`: no axes initialised yet.
    NoAxes,
    /// `5`: syntax error or unknown command.
    Syntax,
    /// `6`: program memory full.
    MemoryFull,
    /// `7`: wrong number of parameters.
    ParameterCount,
    /// `8`: the command cannot be stored in a CNC program.
    NotStorable,
    /// `9`: machine fault: power, safety circuit, hood, temperature, E-stop.
    MachineFault,
    /// `D`: speed out of range.
    BadSpeed,
    /// `F`: stopped by the stop key or 0xFD; the rest can be resumed.
    UserStop,
    /// `G`: nothing to start, or a program is already stored.
    InvalidDataField,
    /// `H`: not allowed with the hood open.
    HoodOpen,
    /// `R`: a reference run is required first.
    ReferenceRequired,
    /// `A`, `B`, `C`, `E`, `=`: codes of the @-format this controller never sends.
    Unused(UnusedCode),
}

/// The reply code characters the iMC controllers do not use (isel manual
/// chapter 5: A, B, C, E; `=` from other controllers of the @-format).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnusedCode {
    A,
    B,
    C,
    E,
    Equals,
}

impl ReplyCode {
    /// Every code, the used ones first.
    pub const ALL: [ReplyCode; 20] = [
        ReplyCode::Ok,
        ReplyCode::BadNumber,
        ReplyCode::LimitSwitch,
        ReplyCode::BadAxis,
        ReplyCode::NoAxes,
        ReplyCode::Syntax,
        ReplyCode::MemoryFull,
        ReplyCode::ParameterCount,
        ReplyCode::NotStorable,
        ReplyCode::MachineFault,
        ReplyCode::BadSpeed,
        ReplyCode::UserStop,
        ReplyCode::InvalidDataField,
        ReplyCode::HoodOpen,
        ReplyCode::ReferenceRequired,
        ReplyCode::Unused(UnusedCode::A),
        ReplyCode::Unused(UnusedCode::B),
        ReplyCode::Unused(UnusedCode::C),
        ReplyCode::Unused(UnusedCode::E),
        ReplyCode::Unused(UnusedCode::Equals),
    ];

    /// The character on the wire.
    pub fn byte(self) -> u8 {
        match self {
            ReplyCode::Ok => b'0',
            ReplyCode::BadNumber => b'1',
            ReplyCode::LimitSwitch => b'2',
            ReplyCode::BadAxis => b'3',
            ReplyCode::NoAxes => b'4',
            ReplyCode::Syntax => b'5',
            ReplyCode::MemoryFull => b'6',
            ReplyCode::ParameterCount => b'7',
            ReplyCode::NotStorable => b'8',
            ReplyCode::MachineFault => b'9',
            ReplyCode::BadSpeed => b'D',
            ReplyCode::UserStop => b'F',
            ReplyCode::InvalidDataField => b'G',
            ReplyCode::HoodOpen => b'H',
            ReplyCode::ReferenceRequired => b'R',
            ReplyCode::Unused(UnusedCode::A) => b'A',
            ReplyCode::Unused(UnusedCode::B) => b'B',
            ReplyCode::Unused(UnusedCode::C) => b'C',
            ReplyCode::Unused(UnusedCode::E) => b'E',
            ReplyCode::Unused(UnusedCode::Equals) => b'=',
        }
    }

    pub fn char(self) -> char {
        char::from(self.byte())
    }

    /// The code a byte stands for; `None` for bytes that are no reply code.
    /// Letters are upper case only, as the controller sends them.
    pub fn from_byte(byte: u8) -> Option<ReplyCode> {
        ReplyCode::ALL.into_iter().find(|c| c.byte() == byte)
    }

    pub fn is_ok(self) -> bool {
        self == ReplyCode::Ok
    }

    /// Whether the iMC controllers send this code at all.
    pub fn is_used(self) -> bool {
        !matches!(self, ReplyCode::Unused(_))
    }

    /// Whether the controller has lost its positions and its reference with
    /// this reply (codes `2` and `9`, `docs/decisions.md` isel 4), so the
    /// console must not move before re-initialising and referencing.
    pub fn loses_reference(self) -> bool {
        matches!(self, ReplyCode::LimitSwitch | ReplyCode::MachineFault)
    }

    /// A short name for status lines.
    pub fn name(self) -> &'static str {
        match self {
            ReplyCode::Ok => "ok",
            ReplyCode::BadNumber => "bad number",
            ReplyCode::LimitSwitch => "limit switch",
            ReplyCode::BadAxis => "bad axis",
            ReplyCode::NoAxes => "no axes defined",
            ReplyCode::Syntax => "syntax error",
            ReplyCode::MemoryFull => "memory full",
            ReplyCode::ParameterCount => "wrong parameter count",
            ReplyCode::NotStorable => "not storable",
            ReplyCode::MachineFault => "machine fault",
            ReplyCode::BadSpeed => "bad speed",
            ReplyCode::UserStop => "user stop",
            ReplyCode::InvalidDataField => "invalid data field",
            ReplyCode::HoodOpen => "hood open",
            ReplyCode::ReferenceRequired => "reference required",
            ReplyCode::Unused(_) => "unused code",
        }
    }

    /// What the code means, in a sentence (isel manual chapter 5).
    pub fn meaning(self) -> &'static str {
        match self {
            ReplyCode::Ok => "The command was executed; the next one may be sent.",
            ReplyCode::BadNumber => {
                "A number could not be read: it is out of range or contains invalid characters."
            }
            ReplyCode::LimitSwitch => {
                "A limit switch was hit and the move stopped without a ramp, so steps were \
                 probably lost; or the reference run was not done or failed."
            }
            ReplyCode::BadAxis => {
                "The command names an axis that is not initialised, or an axis combination \
                 that is not allowed."
            }
            ReplyCode::NoAxes => {
                "No axes are initialised: the axis setting `@0<n>` must come before moves and \
                 commands whose parameters depend on the axes."
            }
            ReplyCode::Syntax => "The command is malformed or does not exist on this controller.",
            ReplyCode::MemoryFull => "The CNC program does not fit into the program memory.",
            ReplyCode::ParameterCount => {
                "The command has too many or too few parameters for the initialised axes."
            }
            ReplyCode::NotStorable => "The command cannot be stored in a CNC program.",
            ReplyCode::MachineFault => {
                "Machine fault: power is off, the safety circuit is open, the hood is open while \
                 the power stages switch on, the power stages are over temperature, or an \
                 E-stop occurred."
            }
            ReplyCode::BadSpeed => "A speed is outside its allowed range.",
            ReplyCode::UserStop => {
                "The move was stopped by the stop key or a soft stop (0xFD); the rest of it is kept."
            }
            ReplyCode::InvalidDataField => {
                "Start without anything to resume or run, or a program upload while a program \
                 (or part of one) is still stored."
            }
            ReplyCode::HoodOpen => "The command is not allowed while the hood is open.",
            ReplyCode::ReferenceRequired => {
                "The move cannot be executed because a reference run is required first."
            }
            ReplyCode::Unused(_) => {
                "This code is not used by the iMC controllers: the line or the controller type \
                 is probably wrong."
            }
        }
    }

    /// What has to happen before work can go on.
    pub fn recovery(self) -> Recovery {
        match self {
            ReplyCode::Ok => Recovery::None,
            ReplyCode::BadNumber
            | ReplyCode::BadAxis
            | ReplyCode::Syntax
            | ReplyCode::ParameterCount
            | ReplyCode::BadSpeed => Recovery::FixCommand,
            ReplyCode::NoAxes => Recovery::InitialiseAxes,
            ReplyCode::LimitSwitch => Recovery::ReinitialiseAndReference,
            ReplyCode::MachineFault => Recovery::ClearFaultReinitialiseAndReference,
            ReplyCode::MemoryFull => Recovery::ShortenProgram,
            ReplyCode::NotStorable => Recovery::FixProgram,
            ReplyCode::UserStop => Recovery::ResumeOrBreak,
            ReplyCode::InvalidDataField => Recovery::EraseProgram,
            ReplyCode::HoodOpen => Recovery::CloseHood,
            ReplyCode::ReferenceRequired => Recovery::Reference,
            ReplyCode::Unused(_) => Recovery::CheckLink,
        }
    }
}

impl fmt::Display for ReplyCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}` {}", self.char(), self.name())
    }
}

/// The recovery a reply code needs, as a value a UI can act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Recovery {
    /// Nothing to do.
    None,
    /// Correct the command and send it again.
    FixCommand,
    /// Send the axis setting (`@01`, `@03`, `@07`, then `@08`).
    InitialiseAxes,
    /// Run a reference (`@0R`), or simulate one (`@0N`) / use test mode.
    Reference,
    /// Send the axis setting again, then reference: positions are lost.
    ReinitialiseAndReference,
    /// Clear the cause (E-stop, power, hood, temperature), then send the
    /// axis setting again and reference.
    ClearFaultReinitialiseAndReference,
    /// Close the hood and send the command again.
    CloseHood,
    /// Erase the stored program with `@0k` (about 2 s) before uploading; or,
    /// answering a start, there was nothing to resume or run.
    EraseProgram,
    /// Erase the stored program (`@0k`) and upload a shorter one.
    ShortenProgram,
    /// Fix the program line, erase the stored program (`@0k`) and upload again.
    FixProgram,
    /// Press start or send `@0S` to finish the stopped move, or send 0xFF to
    /// forget its rest.
    ResumeOrBreak,
    /// An unexpected code: check the serial settings and the controller type.
    CheckLink,
}

impl Recovery {
    /// What the operator should do, in a sentence.
    pub fn advice(self) -> &'static str {
        match self {
            Recovery::None => "Nothing to do.",
            Recovery::FixCommand => "Correct the command and send it again.",
            Recovery::InitialiseAxes => {
                "Initialise the axes first (@01, @03, @07, then @08 for A)."
            }
            Recovery::Reference => "Run a reference (@0R) before moving.",
            Recovery::ReinitialiseAndReference => {
                "Positions are lost: initialise the axes again and run a reference."
            }
            Recovery::ClearFaultReinitialiseAndReference => {
                "Clear the fault (E-stop, power, hood, temperature), then initialise the axes \
                 again and run a reference."
            }
            Recovery::CloseHood => "Close the hood and try again.",
            Recovery::EraseProgram => {
                "After an upload: erase the stored program (@0k) first. After a start: there \
                 is nothing to resume and no program to run."
            }
            Recovery::ShortenProgram => {
                "The program is too long: erase it (@0k) and upload a shorter one."
            }
            Recovery::FixProgram => {
                "Fix the program line, erase the stored program (@0k) and upload again."
            }
            Recovery::ResumeOrBreak => {
                "Press start or send @0S to finish the move, or send break (0xFF) to drop its rest."
            }
            Recovery::CheckLink => "Unexpected reply: check the baud rate and the controller type.",
        }
    }
}

/// The positions of a `@0P` reply: X, Y, Z always, A with 4 axes
/// (isel manual 2.2.21, `docs/decisions.md` isel 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Positions {
    pub x: i32,
    pub y: i32,
    pub z: i32,
    pub a: Option<i32>,
}

impl Positions {
    /// Smallest and largest position a 24-bit two's complement field holds.
    pub const MIN: i32 = -(1 << 23);
    pub const MAX: i32 = (1 << 23) - 1;

    pub fn get(&self, axis: Axis) -> Option<i32> {
        match axis {
            Axis::X => Some(self.x),
            Axis::Y => Some(self.y),
            Axis::Z => Some(self.z),
            Axis::A => self.a,
        }
    }

    /// The positions in X, Y, Z(, A) order.
    pub fn to_vec(&self) -> Vec<i32> {
        let mut v = vec![self.x, self.y, self.z];
        v.extend(self.a);
        v
    }
}

/// A complete reply.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Reply {
    /// A reply code on its own: the handshake `0`, or an error, also where
    /// data was expected (`R` to `@0P`).
    Code(ReplyCode),
    /// `0` and 6 hex digits per axis, answering `@0P`.
    Positions(Positions),
    /// `0` and 2 hex digits, answering `@0b` and `@0D`.
    Byte(u8),
    /// CR LF terminated text lines (`@0H`, `@0h`, `@0V`, `@0U`). Each line is
    /// decoded as Latin-1, so no byte is lost; render with care, the lines may
    /// hold control characters.
    Text { lines: Vec<String>, end: TextEnd },
}

/// How a text reply ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TextEnd {
    /// `@0H`/`@0h`: a reply code after the last line, normally `0`.
    Code(ReplyCode),
    /// `@0V`/`@0U`: the controller fell silent (`docs/decisions.md` isel 8).
    Silence,
}

/// Why a reply cannot be encoded unambiguously.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ReplyEncodeError {
    #[error("text line {line} contains a CR or LF")]
    LineBreakInLine { line: usize },
    #[error("text line {line} contains a character above U+00FF, which has no byte")]
    NotLatin1 { line: usize },
    #[error(
        "text line {line} starts with a digit, which a reader takes for the closing reply code"
    )]
    LineStartsWithDigit { line: usize },
    #[error(
        "a text reply closed by {0} cannot be told from text: only the digit codes 0-9 can close it"
    )]
    LetterClosesText(ReplyCode),
    #[error("a text reply without lines closed by {0} is the code reply {0} on its own")]
    BareErrorAsText(ReplyCode),
}

impl Reply {
    /// The bytes a controller sends for this reply. Positions wrap to 24
    /// bits as the controller's counters do.
    pub fn encode(&self) -> Result<Vec<u8>, ReplyEncodeError> {
        let mut out = Vec::new();
        match self {
            Reply::Code(code) => out.push(code.byte()),
            Reply::Positions(p) => {
                out.push(b'0');
                for v in p.to_vec() {
                    let wrapped = (v as u32) & 0x00FF_FFFF;
                    out.extend_from_slice(format!("{wrapped:06X}").as_bytes());
                }
            }
            Reply::Byte(b) => out.extend_from_slice(format!("0{b:02X}").as_bytes()),
            Reply::Text { lines, end } => {
                if let TextEnd::Code(code) = end {
                    if !code.byte().is_ascii_digit() {
                        return Err(ReplyEncodeError::LetterClosesText(*code));
                    }
                    if lines.is_empty() && !code.is_ok() {
                        return Err(ReplyEncodeError::BareErrorAsText(*code));
                    }
                }
                for (n, line) in lines.iter().enumerate() {
                    let line_no = n + 1;
                    if matches!(end, TextEnd::Code(_))
                        && line.bytes().next().is_some_and(|b| b.is_ascii_digit())
                    {
                        return Err(ReplyEncodeError::LineStartsWithDigit { line: line_no });
                    }
                    for c in line.chars() {
                        if c == '\r' || c == '\n' {
                            return Err(ReplyEncodeError::LineBreakInLine { line: line_no });
                        }
                        let byte = u8::try_from(u32::from(c))
                            .map_err(|_| ReplyEncodeError::NotLatin1 { line: line_no })?;
                        out.push(byte);
                    }
                    out.extend_from_slice(b"\r\n");
                }
                match end {
                    TextEnd::Code(code) => out.push(code.byte()),
                    TextEnd::Silence => {}
                }
            }
        }
        Ok(out)
    }

    /// The reply code this reply carries: `0` for data and text closed by
    /// silence.
    pub fn code(&self) -> ReplyCode {
        match self {
            Reply::Code(code) => *code,
            Reply::Text {
                end: TextEnd::Code(code),
                ..
            } => *code,
            Reply::Positions(_) | Reply::Byte(_) | Reply::Text { .. } => ReplyCode::Ok,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_has_its_character_meaning_and_recovery() {
        let table = [
            ('0', ReplyCode::Ok, Recovery::None),
            ('1', ReplyCode::BadNumber, Recovery::FixCommand),
            (
                '2',
                ReplyCode::LimitSwitch,
                Recovery::ReinitialiseAndReference,
            ),
            ('3', ReplyCode::BadAxis, Recovery::FixCommand),
            ('4', ReplyCode::NoAxes, Recovery::InitialiseAxes),
            ('5', ReplyCode::Syntax, Recovery::FixCommand),
            ('6', ReplyCode::MemoryFull, Recovery::ShortenProgram),
            ('7', ReplyCode::ParameterCount, Recovery::FixCommand),
            ('8', ReplyCode::NotStorable, Recovery::FixProgram),
            (
                '9',
                ReplyCode::MachineFault,
                Recovery::ClearFaultReinitialiseAndReference,
            ),
            ('D', ReplyCode::BadSpeed, Recovery::FixCommand),
            ('F', ReplyCode::UserStop, Recovery::ResumeOrBreak),
            ('G', ReplyCode::InvalidDataField, Recovery::EraseProgram),
            ('H', ReplyCode::HoodOpen, Recovery::CloseHood),
            ('R', ReplyCode::ReferenceRequired, Recovery::Reference),
            ('A', ReplyCode::Unused(UnusedCode::A), Recovery::CheckLink),
            ('B', ReplyCode::Unused(UnusedCode::B), Recovery::CheckLink),
            ('C', ReplyCode::Unused(UnusedCode::C), Recovery::CheckLink),
            ('E', ReplyCode::Unused(UnusedCode::E), Recovery::CheckLink),
            (
                '=',
                ReplyCode::Unused(UnusedCode::Equals),
                Recovery::CheckLink,
            ),
        ];
        assert_eq!(table.len(), ReplyCode::ALL.len());
        for (c, code, recovery) in table {
            assert_eq!(ReplyCode::from_byte(c as u8), Some(code), "{c}");
            assert_eq!(code.char(), c);
            assert_eq!(code.recovery(), recovery, "{c}");
            assert!(!code.meaning().is_empty() && !code.recovery().advice().is_empty());
            assert_eq!(code.is_used(), !matches!(c, 'A' | 'B' | 'C' | 'E' | '='));
            assert_eq!(code.loses_reference(), matches!(c, '2' | '9'));
        }
        // Lower-case letters and everything else are no reply codes.
        for b in [b'r', b'd', b'I', b' ', b'\r', 0xFD] {
            assert_eq!(ReplyCode::from_byte(b), None);
        }
        assert!(ReplyCode::HoodOpen.meaning().contains("hood"));
        assert!(ReplyCode::UserStop.recovery().advice().contains("@0S"));
        assert_eq!(ReplyCode::BadSpeed.to_string(), "`D` bad speed");
    }

    #[test]
    fn positions_encode_as_24_bit_twos_complement() {
        let p = Positions {
            x: 256,
            y: 131087,
            z: -2,
            a: None,
        };
        assert_eq!(
            Reply::Positions(p).encode().ok(),
            Some(b"000010002000FFFFFFE".to_vec())
        );
        let wrap = Positions {
            x: Positions::MAX + 1,
            y: 0,
            z: 0,
            a: Some(-1),
        };
        assert_eq!(
            Reply::Positions(wrap).encode().ok(),
            Some(b"0800000000000000000FFFFFF".to_vec())
        );
    }

    #[test]
    fn ambiguous_text_replies_are_refused() {
        let text = |lines: &[&str], end| Reply::Text {
            lines: lines.iter().map(|s| s.to_string()).collect(),
            end,
        };
        assert_eq!(
            text(&["X1: 0", "ok"], TextEnd::Code(ReplyCode::Ok)).encode(),
            Ok(b"X1: 0\r\nok\r\n0".to_vec())
        );
        assert_eq!(
            text(&["1 axis"], TextEnd::Code(ReplyCode::Ok)).encode(),
            Err(ReplyEncodeError::LineStartsWithDigit { line: 1 })
        );
        assert_eq!(
            text(&["1 axis"], TextEnd::Silence).encode(),
            Ok(b"1 axis\r\n".to_vec())
        );
        assert!(text(&["a\rb"], TextEnd::Silence).encode().is_err());
        assert!(text(&["\u{20ac}"], TextEnd::Silence).encode().is_err());
        assert_eq!(
            text(&["Grüße"], TextEnd::Silence).encode(),
            Ok(b"Gr\xfc\xdfe\r\n".to_vec())
        );
        assert!(
            text(&[], TextEnd::Code(ReplyCode::HoodOpen))
                .encode()
                .is_err()
        );
        assert!(
            text(&[], TextEnd::Code(ReplyCode::Syntax))
                .encode()
                .is_err()
        );
    }
}
