//! The text parser for DNC frames (`@0A 5000,900`) and CNC lines (`3 25,-1`).
//!
//! It accepts what a controller accepts (`docs/decisions.md` isel 1 and
//! 10): spaces between the command code and its first parameter, a line end
//! of CR, CR LF or LF, the alternative letters `a m r s ?` and, in CNC lines,
//! the upper-case spellings `F M O P W Y Z`. Everything it accepted but the
//! encoder would write differently is reported as a [`Note`] with its span,
//! so an editor can warn and a formatter can rewrite.
//!
//! The parser knows nothing about the axis configuration: it checks syntax,
//! that numbers are numbers and fit their field, and the values of
//! categorical operands (ports, planes, flags, axis settings). Parameter
//! counts that depend on the axes and the ranges of the manual are checked by
//! [`check`](super::check()). Every error carries the reply code a controller
//! would answer and a message saying what was expected.

use std::ops::Range;
use std::str::FromStr;

use thiserror::Error;

use crate::axis::{Axis, AxisSet};
use crate::traffic::readable;

use super::axes::AxisSetting;
use super::cnc::{CncCommand, SyncChar, cnc_code};
use super::command::{
    CircleDirection, CircleParams, Command, Diagnosis, Frame, HelixParams, InitCommand, MovePair,
    Plane, PortMove, PortSignal, PortWatch, Sign,
};
use super::device::DeviceNumber;
use super::ports::{InputPort, OutputPort, PortBits};
use super::reply::ReplyCode;

/// A successfully parsed line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Parsed<T> {
    pub value: T,
    /// What was accepted but is not the canonical spelling.
    pub notes: Vec<Note>,
    /// Byte spans of the parameters in the line, in order; a
    /// [`CheckError::param`](super::CheckError::param) indexes this list.
    pub params: Vec<Range<usize>>,
}

/// Something accepted that the encoder writes differently.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    pub kind: NoteKind,
    /// Byte span in the line.
    pub span: Range<usize>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoteKind {
    /// Spaces between the command code and the first parameter.
    SpaceAfterCode,
    /// `a`, `m`, `r`, `s` or `?` for `A`, `M`, `R`, `S`, `V` (same command).
    AlternateLetter { written: char, canonical: char },
    /// A CNC code in the upper-case spelling of the manual's table (`M`)
    /// instead of its section's (`m`), `docs/decisions.md` isel 10.
    TableSpelling { written: char, section: char },
    /// Counter-clockwise written as `1`; the encoder writes `-1`.
    CcwWrittenAsOne,
}

/// A line the controller would refuse, with the code it would answer.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{message} (a controller answers {code})")]
pub struct ParseError {
    /// The reply code a controller gives for this line.
    pub code: ReplyCode,
    /// What was expected and what was found.
    pub message: String,
    /// Where in the line (bytes).
    pub span: Range<usize>,
    /// The device a DNC frame addressed, once it could be read, so a
    /// simulator can stay silent on frames for other devices.
    pub device: Option<DeviceNumber>,
}

/// The DNC command letters after the alternatives are mapped (`a` to `A`
/// …), other than `I` and `D`, which have codes of their own.
const DNC_LETTERS: &[u8] = b"AMbBdefFgGhHijJknNPRSTUVwyzZ";

/// The init codes after `@0I` (isel manual 2.2.14, chapter 4).
const INIT_CODES: &[u8] = b"dFJjOEeDRTAaHNCLWX";

/// Longest number the parser reads (digits, without the sign): longer ones
/// answer `1` whatever their value.
const MAX_DIGITS: usize = 12;

/// Parse one DNC frame, with or without its line end.
pub fn parse_frame(line: impl AsRef<[u8]>) -> Result<Parsed<Frame>, ParseError> {
    let raw = line.as_ref();
    // The addressed device, known before anything else is read, so that a
    // controller can ignore even a broken frame for another device.
    let addressed = match raw {
        [b'@', digit, ..] => DeviceNumber::from_ascii(*digit),
        _ => None,
    };
    let bytes = printable_line(raw).map_err(|e| ParseError {
        device: addressed,
        ..e
    })?;
    let mut p = LineParser::new(bytes);
    if bytes.first() != Some(&b'@') {
        return Err(p.error(
            ReplyCode::Syntax,
            0..1.min(bytes.len()),
            format!(
                "a DNC command starts with `@` and the device number, got `{}`",
                readable(bytes.get(..1).unwrap_or_default())
            ),
        ));
    }
    let device = match bytes.get(1).and_then(|b| DeviceNumber::from_ascii(*b)) {
        Some(d) => d,
        None => {
            return Err(p.error(
                ReplyCode::Syntax,
                1..2.min(bytes.len()).max(1),
                "expected the device number 0-9 after `@`".into(),
            ));
        }
    };
    p.device = Some(device);
    let command = p.dnc_command()?;
    Ok(p.finish(Frame { device, command }))
}

/// Parse one stored CNC line (no `@<dev>` prefix), with or without its line end.
pub fn parse_cnc(line: impl AsRef<[u8]>) -> Result<Parsed<CncCommand>, ParseError> {
    let bytes = printable_line(line.as_ref())?;
    let mut p = LineParser::new(bytes);
    let command = p.cnc_command()?;
    Ok(p.finish(command))
}

impl FromStr for Frame {
    type Err = ParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_frame(s).map(|p| p.value)
    }
}

impl FromStr for CncCommand {
    type Err = ParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_cnc(s).map(|p| p.value)
    }
}

/// The line without its end (CR, CR LF or LF), refused with `5` when it
/// holds anything but printable ASCII.
fn printable_line(line: &[u8]) -> Result<&[u8], ParseError> {
    let body = line
        .strip_suffix(b"\r\n")
        .or_else(|| line.strip_suffix(b"\r"))
        .or_else(|| line.strip_suffix(b"\n"))
        .unwrap_or(line);
    match body.iter().position(|b| !(0x20..=0x7E).contains(b)) {
        None => Ok(body),
        Some(at) => Err(ParseError {
            code: ReplyCode::Syntax,
            message: format!(
                "unexpected byte {} at column {}: commands are printable ASCII ended by CR",
                readable(&body[at..=at]),
                at + 1
            ),
            span: at..at + 1,
            device: None,
        }),
    }
}

/// A number read from the parameter list.
#[derive(Debug, Clone)]
struct Field {
    value: i64,
    span: Range<usize>,
}

struct LineParser<'a> {
    bytes: &'a [u8],
    device: Option<DeviceNumber>,
    notes: Vec<Note>,
    params: Vec<Range<usize>>,
}

impl<'a> LineParser<'a> {
    fn new(bytes: &'a [u8]) -> LineParser<'a> {
        LineParser {
            bytes,
            device: None,
            notes: Vec::new(),
            params: Vec::new(),
        }
    }

    fn finish<T>(self, value: T) -> Parsed<T> {
        Parsed {
            value,
            notes: self.notes,
            params: self.params,
        }
    }

    fn error(&self, code: ReplyCode, span: Range<usize>, message: String) -> ParseError {
        ParseError {
            code,
            message,
            span,
            device: self.device,
        }
    }

    fn text(&self, span: Range<usize>) -> String {
        String::from_utf8_lossy(self.bytes.get(span).unwrap_or_default()).into_owned()
    }

    /// Skip spaces at `at` (noting them) and read the comma-separated numbers
    /// up to the end of the line.
    fn fields(&mut self, at: usize) -> Result<Vec<Field>, ParseError> {
        let start = self.skip_spaces(at);
        self.numbers(start)
    }

    fn skip_spaces(&mut self, at: usize) -> usize {
        let spaces = self
            .bytes
            .get(at..)
            .unwrap_or_default()
            .iter()
            .take_while(|b| **b == b' ')
            .count();
        if spaces > 0 {
            self.notes.push(Note {
                kind: NoteKind::SpaceAfterCode,
                span: at..at + spaces,
            });
        }
        at + spaces
    }

    fn numbers(&mut self, start: usize) -> Result<Vec<Field>, ParseError> {
        let mut fields = Vec::new();
        if start >= self.bytes.len() {
            return Ok(fields);
        }
        let mut pos = start;
        loop {
            let end = self.bytes[pos..]
                .iter()
                .position(|b| *b == b',')
                .map_or(self.bytes.len(), |i| pos + i);
            let span = pos..end;
            fields.push(Field {
                value: self.number(span.clone())?,
                span: span.clone(),
            });
            self.params.push(span);
            if end >= self.bytes.len() {
                return Ok(fields);
            }
            pos = end + 1;
        }
    }

    fn number(&self, span: Range<usize>) -> Result<i64, ParseError> {
        let raw = self.bytes.get(span.clone()).unwrap_or_default();
        let digits = raw.strip_prefix(b"-").unwrap_or(raw);
        if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
            let got = if raw.is_empty() {
                "nothing".to_string()
            } else {
                format!("`{}`", self.text(span.clone()))
            };
            return Err(self.error(
                ReplyCode::BadNumber,
                span,
                format!("expected a whole decimal number, got {got}"),
            ));
        }
        if digits.len() > MAX_DIGITS {
            let message = format!("the number `{}` is far too long", self.text(span.clone()));
            return Err(self.error(ReplyCode::BadNumber, span, message));
        }
        let magnitude = digits
            .iter()
            .fold(0i64, |acc, d| acc * 10 + i64::from(d - b'0'));
        Ok(if raw.first() == Some(&b'-') {
            -magnitude
        } else {
            magnitude
        })
    }

    fn dnc_command(&mut self) -> Result<Command, ParseError> {
        let len = self.bytes.len();
        let Some(&letter) = self.bytes.get(2) else {
            return Err(self.error(
                ReplyCode::Syntax,
                len..len,
                "expected a command letter or an axis setting (1, 3, 7, 8) after the device number"
                    .into(),
            ));
        };
        if letter.is_ascii_digit() {
            return self.axis_setting();
        }
        let canonical = match letter {
            b'a' => b'A',
            b'm' => b'M',
            b'r' => b'R',
            b's' => b'S',
            b'?' => b'V',
            other => other,
        };
        if canonical != letter {
            self.notes.push(Note {
                kind: NoteKind::AlternateLetter {
                    written: char::from(letter),
                    canonical: char::from(canonical),
                },
                span: 2..3,
            });
        }
        let name = format!("`{}`", char::from(letter));
        match canonical {
            b'I' => return self.init_command(),
            b'D' => return self.diagnosis(),
            c if !DNC_LETTERS.contains(&c) => {
                return Err(self.error(
                    ReplyCode::Syntax,
                    2..3,
                    format!("there is no command {name}"),
                ));
            }
            _ => {}
        }
        let fields = self.fields(3)?;
        let mut args = Args {
            p: self,
            fields,
            name,
            line_end: len,
        };
        let command = match canonical {
            b'A' => Command::MoveRelative(args.pairs()?),
            b'M' => Command::MoveAbsolute(args.pairs()?),
            b'b' => {
                args.exactly(1, "the port number")?;
                Command::ReadPort(args.input_port(0)?)
            }
            b'B' => {
                args.exactly(2, "port number and value")?;
                Command::WritePort {
                    port: args.output_port(0)?,
                    value: args.byte(1, "the port value")?,
                }
            }
            b'd' => Command::SetReferenceSpeeds(args.speeds()?),
            b'e' => Command::SetPlane(args.plane()?),
            b'f' => Command::SetCircleDirection(args.direction()?),
            b'F' => {
                args.exactly(1, "the axis (1 X, 2 Y, 4 Z, 8 A)")?;
                Command::ClearLimitSwitch(args.single_axis(0)?)
            }
            b'g' => Command::SetBrake(args.only_flag("brake")?),
            b'G' => {
                args.exactly(1, "the new device number")?;
                let v = args.field(0)?;
                let n = u8::try_from(v.value)
                    .ok()
                    .and_then(DeviceNumber::new)
                    .ok_or_else(|| {
                        args.fail(
                            ReplyCode::BadNumber,
                            0,
                            format!("the device number must be 0-9, got {}", v.value),
                        )
                    })?;
                Command::SetDeviceNumber(n)
            }
            b'h' => args.none(Command::LimitSwitchStatus)?,
            b'H' => args.none(Command::Status)?,
            b'i' => args.none(Command::StoreProgram)?,
            b'j' => Command::SetStartStop(args.only_speed("start-stop frequency")?),
            b'J' => Command::SetAcceleration(args.only_speed("acceleration")?),
            b'k' => args.none(Command::EraseProgram)?,
            b'n' => Command::SetZero(args.only_mask()?),
            b'N' => Command::SimulateReference(args.only_mask()?),
            b'P' => args.none(Command::ReadPosition)?,
            b'R' => Command::Reference(args.only_mask()?),
            b'S' => args.none(Command::Start)?,
            b'T' => Command::SetTestMode(args.only_flag("test mode")?),
            b'U' => args.none(Command::ReadUserInfo)?,
            b'V' => args.none(Command::ReadVersion)?,
            b'w' => Command::Helix(args.helix()?),
            b'y' => Command::Circle(args.circle()?),
            b'z' => Command::Set3dInterpolation(args.only_flag("3D interpolation")?),
            // `DNC_LETTERS` holds no other letter; `Z` is the last one.
            _ => Command::MoveUntilPort(args.port_move()?),
        };
        Ok(command)
    }

    /// `@0<n>`: only digits may follow the device number.
    fn axis_setting(&mut self) -> Result<Command, ParseError> {
        let span = 2..self.bytes.len();
        if let Some(bad) = self.bytes[2..].iter().position(|b| !b.is_ascii_digit()) {
            let at = 2 + bad;
            return Err(self.error(
                ReplyCode::Syntax,
                at..at + 1,
                "the axis setting `@0<n>` is a number and nothing else".into(),
            ));
        }
        self.params.push(span.clone());
        let value = self.number(span.clone())?;
        let setting = u64::try_from(value).ok().and_then(AxisSetting::from_value);
        setting.map(Command::SetAxes).ok_or_else(|| {
            self.error(
                ReplyCode::BadAxis,
                span,
                format!(
                    "the axis setting must be 1 (X), 3 (XY), 7 (XYZ) or 8 (A, after 7), got {value}"
                ),
            )
        })
    }

    /// `@0D<c1><c2>`: two letters or digits, nothing after them.
    fn diagnosis(&mut self) -> Result<Command, ParseError> {
        let start = self.skip_spaces(3);
        let codes = self.bytes.get(start..start + 2);
        let diagnosis = codes.and_then(|c| Diagnosis::new(c[0], c[1]));
        let Some(diagnosis) = diagnosis else {
            let end = (start + 2).min(self.bytes.len());
            return Err(self.error(
                ReplyCode::Syntax,
                start..end,
                format!(
                    "`D` expects two code characters such as `Rp` or `Rn`, got `{}`",
                    self.text(start..end)
                ),
            ));
        };
        if self.bytes.len() > start + 2 {
            return Err(self.error(
                ReplyCode::Syntax,
                start + 2..self.bytes.len(),
                "`D` takes its two code characters and nothing else".into(),
            ));
        }
        Ok(Command::Diagnose(diagnosis))
    }

    fn init_command(&mut self) -> Result<Command, ParseError> {
        let len = self.bytes.len();
        let Some(&code) = self.bytes.get(3) else {
            return Err(self.error(
                ReplyCode::Syntax,
                len..len,
                "`I` needs a parameter code: one of d F J j O E e D R T A a H N C U L W X".into(),
            ));
        };
        if code == b'U' {
            // The user info is taken verbatim: a leading space is part of it.
            if len > 4 {
                self.params.push(4..len);
            }
            let text = self.text(4..len);
            return Ok(Command::Init(InitCommand::SetUserInfo(text)));
        }
        let name = format!("`I{}`", char::from(code));
        if !INIT_CODES.contains(&code) {
            return Err(self.error(
                ReplyCode::Syntax,
                3..4,
                format!(
                    "there is no init command {name}: the codes are d F J j O E e D R T A a H N C U L W X"
                ),
            ));
        }
        let fields = self.fields(4)?;
        let args = Args {
            p: self,
            fields,
            name,
            line_end: len,
        };
        let init = match code {
            b'd' => {
                args.exactly(4, "a reference speed for each of X, Y, Z, A")?;
                InitCommand::DefaultReferenceSpeeds(args.four(|i| args.speed(i))?)
            }
            b'F' => {
                args.exactly(4, "the clearing steps for each of X, Y, Z, A")?;
                InitCommand::ReferenceClearSteps(args.four(|i| {
                    args.int(i, ReplyCode::BadNumber, "the clearing steps", "0 or more")
                })?)
            }
            b'J' => InitCommand::DefaultAcceleration(args.only_speed("acceleration")?),
            b'j' => InitCommand::DefaultStartStop(args.only_speed("start-stop frequency")?),
            b'O' => InitCommand::IoOnly(args.only_flag("IO-only mode")?),
            b'C' => InitCommand::Baud9600(args.only_flag("9600 baud mode")?),
            b'E' => {
                args.exactly(1, "the 16-bit limit switch word")?;
                InitCommand::LimitSwitches(args.int(
                    0,
                    ReplyCode::BadNumber,
                    "the limit switch word",
                    "0-65535",
                )?)
            }
            b'e' => InitCommand::SwapLimitSwitches(args.only_axis_code()?),
            b'D' => InitCommand::InvertDirections(args.only_axis_code()?),
            b'R' => InitCommand::InvertReferenceDirections(args.only_axis_code()?),
            b'T' => InitCommand::RotaryAxes(args.only_axis_code()?),
            b'A' => InitCommand::AbortInput(args.port_watch()?),
            b'H' => InitCommand::HoodInput(args.port_watch()?),
            b'N' => InitCommand::EmergencyStopInput(args.port_watch()?),
            b'a' => {
                args.exactly(3, "port, mask and value")?;
                InitCommand::ErrorOutput(PortSignal {
                    port: args.output_port(0)?,
                    mask: args.byte(1, "the mask")?,
                    value: args.byte(2, "the value")?,
                })
            }
            b'L' => args.none(InitCommand::LoadFromFlash)?,
            b'W' => args.none(InitCommand::WriteToFlash)?,
            // `INIT_CODES` holds no other code; `X` is the last one.
            _ => args.none(InitCommand::RestoreDefaults)?,
        };
        Ok(Command::Init(init))
    }

    fn cnc_command(&mut self) -> Result<CncCommand, ParseError> {
        let Some(&first) = self.bytes.first() else {
            return Err(self.error(
                ReplyCode::Syntax,
                0..0,
                "empty line: expected a CNC command".into(),
            ));
        };
        if first == b'@' {
            return Err(self.error(
                ReplyCode::NotStorable,
                0..self.bytes.len(),
                "a DNC command cannot be stored: CNC lines have no `@<device>` prefix".into(),
            ));
        }
        let Some((code, table_spelling)) = cnc_code(first) else {
            let codes = "0 1 2 3 5 6 7 9 d e f g j J m n N o p T w y z";
            let first = char::from(first);
            return Err(if first.is_ascii_alphanumeric() || first == '?' {
                self.error(
                    ReplyCode::NotStorable,
                    0..1,
                    format!("`{first}` is not a storable command; the CNC codes are {codes}"),
                )
            } else {
                self.error(
                    ReplyCode::Syntax,
                    0..1,
                    format!("a CNC line starts with its command code ({codes}), got `{first}`"),
                )
            });
        };
        if table_spelling {
            self.notes.push(Note {
                kind: NoteKind::TableSpelling {
                    written: char::from(first),
                    section: char::from(code),
                },
                span: 0..1,
            });
        }
        let name = format!("CNC `{}`", char::from(code));
        let len = self.bytes.len();
        let fields = self.fields(1)?;
        let mut args = Args {
            p: self,
            fields,
            name,
            line_end: len,
        };
        Ok(match code {
            b'0' => CncCommand::MoveRelative(args.pairs()?),
            b'm' => CncCommand::MoveAbsolute(args.pairs()?),
            b'1' => {
                args.exactly(1, "the ASCII code of the sync character")?;
                CncCommand::SendSync(args.sync_char(0)?)
            }
            b'2' => {
                args.exactly(2, "the sync character's ASCII code and the jump offset")?;
                CncCommand::WaitSync {
                    sync: args.sync_char(0)?,
                    offset: args.offset(1)?,
                }
            }
            b'3' => {
                args.exactly(2, "loop count (0 = jump) and offset")?;
                CncCommand::Loop {
                    count: args.int(0, ReplyCode::BadNumber, "the loop count", "0-32767")?,
                    offset: args.offset(1)?,
                }
            }
            b'5' => {
                args.exactly(1, "the delay in tenths of a second")?;
                CncCommand::Delay(args.int(0, ReplyCode::BadNumber, "the delay", "0-65535")?)
            }
            b'6' => {
                args.exactly(3, "port, bit (1-8 or 128) and value")?;
                CncCommand::PortCondition {
                    port: args.input_port(0)?,
                    bits: args.bits(1, true)?,
                    value: args.byte(2, "the comparison value")?,
                }
            }
            b'7' => CncCommand::Reference(args.only_mask()?),
            b'9' => args.none(CncCommand::End)?,
            b'd' => CncCommand::SetReferenceSpeeds(args.speeds()?),
            b'e' => CncCommand::SetPlane(args.plane()?),
            b'f' => CncCommand::SetCircleDirection(args.direction()?),
            b'g' => CncCommand::SetBrake(args.only_flag("brake")?),
            b'j' => CncCommand::SetStartStop(args.only_speed("start-stop frequency")?),
            b'J' => CncCommand::SetAcceleration(args.only_speed("acceleration")?),
            b'n' => CncCommand::SetZero(args.only_mask()?),
            b'N' => CncCommand::SimulateReference(args.only_mask()?),
            b'o' => {
                args.exactly(4, "port, bit (0-7 or 128), value and jump offset")?;
                CncCommand::BranchOnPort {
                    port: args.input_port(0)?,
                    bits: args.bits(1, false)?,
                    value: args.byte(2, "the comparison value")?,
                    offset: args.offset(3)?,
                }
            }
            b'p' => {
                args.exactly(3, "port, bit (0-7 or 128) and value")?;
                CncCommand::SetPort {
                    port: args.output_port(0)?,
                    bits: args.bits(1, false)?,
                    value: args.byte(2, "the value")?,
                }
            }
            b'T' => CncCommand::SetTestMode(args.only_flag("test mode")?),
            b'w' => CncCommand::Helix(args.helix()?),
            b'y' => CncCommand::Circle(args.circle()?),
            // `cnc_code` yields no other codes; `z` is the last one.
            _ => CncCommand::Set3dInterpolation(args.only_flag("3D interpolation")?),
        })
    }
}

/// The parameters of one command and the conversions that give each the
/// reply code a controller would answer.
struct Args<'p, 'a> {
    p: &'p mut LineParser<'a>,
    fields: Vec<Field>,
    /// The command for messages: "`A`", "`IF`", "CNC `o`".
    name: String,
    line_end: usize,
}

impl Args<'_, '_> {
    fn fail(&self, code: ReplyCode, index: usize, message: String) -> ParseError {
        let span = self
            .fields
            .get(index)
            .map_or(self.line_end..self.line_end, |f| f.span.clone());
        self.p.error(code, span, message)
    }

    fn whole_span(&self) -> Range<usize> {
        match (self.fields.first(), self.fields.last()) {
            (Some(a), Some(b)) => a.span.start..b.span.end,
            _ => self.line_end..self.line_end,
        }
    }

    fn count_error(&self, expected: String) -> ParseError {
        self.p.error(
            ReplyCode::ParameterCount,
            self.whole_span(),
            format!(
                "{} takes {expected}, got {} parameter{}",
                self.name,
                self.fields.len(),
                if self.fields.len() == 1 { "" } else { "s" }
            ),
        )
    }

    fn exactly(&self, n: usize, what: &str) -> Result<(), ParseError> {
        if self.fields.len() == n {
            Ok(())
        } else {
            Err(self.count_error(format!("{n} ({what})")))
        }
    }

    fn none<T>(&self, value: T) -> Result<T, ParseError> {
        if self.fields.is_empty() {
            Ok(value)
        } else {
            Err(self.count_error("no parameters".into()))
        }
    }

    fn field(&self, index: usize) -> Result<&Field, ParseError> {
        self.fields
            .get(index)
            .ok_or_else(|| self.count_error(format!("at least {} parameters", index + 1)))
    }

    /// A number converted to `T`, or `code` with "`what` must be `range`".
    fn int<T: TryFrom<i64>>(
        &self,
        index: usize,
        code: ReplyCode,
        what: &str,
        range: &str,
    ) -> Result<T, ParseError> {
        let f = self.field(index)?;
        T::try_from(f.value).map_err(|_| {
            self.fail(
                code,
                index,
                format!("{what} must be {range}, got {}", f.value),
            )
        })
    }

    fn steps(&self, index: usize) -> Result<i32, ParseError> {
        self.int(
            index,
            ReplyCode::BadNumber,
            "a step count or position",
            "a 24-bit number",
        )
    }

    fn speed(&self, index: usize) -> Result<u32, ParseError> {
        self.int(index, ReplyCode::BadSpeed, "a speed", "1-40000 Hz")
    }

    fn byte(&self, index: usize, what: &str) -> Result<u8, ParseError> {
        self.int(index, ReplyCode::BadNumber, what, "0-255")
    }

    fn offset(&self, index: usize) -> Result<i16, ParseError> {
        self.int(
            index,
            ReplyCode::BadNumber,
            "the jump offset",
            "-32768..32767",
        )
    }

    fn four<T: Default + Copy>(
        &self,
        get: impl Fn(usize) -> Result<T, ParseError>,
    ) -> Result<[T; 4], ParseError> {
        let mut out = [T::default(); 4];
        for (i, slot) in out.iter_mut().enumerate() {
            *slot = get(i)?;
        }
        Ok(out)
    }

    fn pairs(&self) -> Result<Vec<MovePair>, ParseError> {
        let n = self.fields.len();
        if n == 0 || !n.is_multiple_of(2) || n > 8 {
            return Err(
                self.count_error("1 to 4 steps,speed pairs (one per axis, 4 with 3 axes)".into())
            );
        }
        (0..n / 2)
            .map(|i| Ok(MovePair::new(self.steps(2 * i)?, self.speed(2 * i + 1)?)))
            .collect()
    }

    fn speeds(&self) -> Result<Vec<u32>, ParseError> {
        if self.fields.is_empty() || self.fields.len() > 4 {
            return Err(self.count_error("1 to 4 speeds (one per axis)".into()));
        }
        (0..self.fields.len()).map(|i| self.speed(i)).collect()
    }

    fn only_speed(&self, what: &str) -> Result<u32, ParseError> {
        self.exactly(1, &format!("the {what}"))?;
        self.speed(0)
    }

    fn flag_at(&self, index: usize, what: &str) -> Result<bool, ParseError> {
        let f = self.field(index)?;
        match f.value {
            0 => Ok(false),
            1 => Ok(true),
            v => Err(self.fail(
                ReplyCode::BadNumber,
                index,
                format!("{what} is 0 (off) or 1 (on), got {v}"),
            )),
        }
    }

    fn only_flag(&self, what: &str) -> Result<bool, ParseError> {
        self.exactly(1, "0 (off) or 1 (on)")?;
        self.flag_at(0, what)
    }

    fn mask_value(&self, index: usize, code: ReplyCode) -> Result<AxisSet, ParseError> {
        let f = self.field(index)?;
        match u8::try_from(f.value) {
            Ok(m) if m <= 15 => Ok(AxisSet::from_mask(m)),
            _ => Err(self.fail(
                code,
                index,
                format!(
                    "an axis mask is 1 X, 2 Y, 4 Z, 8 A or a sum of them (0-15), got {}",
                    f.value
                ),
            )),
        }
    }

    /// The axis mask of `R`, `n`, `N`, CNC `7`: out of range answers `3`.
    fn only_mask(&self) -> Result<AxisSet, ParseError> {
        self.exactly(1, "the axis mask")?;
        self.mask_value(0, ReplyCode::BadAxis)
    }

    /// The axis code of `Ie`, `ID`, `IR`, `IT`: a 4-bit number, `1` otherwise.
    fn only_axis_code(&self) -> Result<AxisSet, ParseError> {
        self.exactly(1, "the axis code 0-15")?;
        self.mask_value(0, ReplyCode::BadNumber)
    }

    fn single_axis(&self, index: usize) -> Result<Axis, ParseError> {
        let f = self.field(index)?;
        Axis::ALL
            .into_iter()
            .find(|a| i64::from(a.mask_bit()) == f.value)
            .ok_or_else(|| {
                self.fail(
                    ReplyCode::BadAxis,
                    index,
                    format!("expected one axis: 1 X, 2 Y, 4 Z or 8 A, got {}", f.value),
                )
            })
    }

    fn input_port(&self, index: usize) -> Result<InputPort, ParseError> {
        let f = self.field(index)?;
        u64::try_from(f.value)
            .ok()
            .and_then(InputPort::from_number)
            .ok_or_else(|| {
                self.fail(
                    ReplyCode::BadNumber,
                    index,
                    format!("the input ports are 0-3, got {}", f.value),
                )
            })
    }

    fn output_port(&self, index: usize) -> Result<OutputPort, ParseError> {
        let f = self.field(index)?;
        u64::try_from(f.value)
            .ok()
            .and_then(OutputPort::from_number)
            .ok_or_else(|| {
                self.fail(
                    ReplyCode::BadNumber,
                    index,
                    format!("the output ports are 0-6, 100 and 101, got {}", f.value),
                )
            })
    }

    /// Bit 1-8 (CNC `6`) or 0-7 (`o`, `p`), or 128 for the whole byte.
    fn bits(&self, index: usize, one_based: bool) -> Result<PortBits, ParseError> {
        let f = self.field(index)?;
        let first = i64::from(one_based);
        if f.value == i64::from(PortBits::BYTE_VALUE) {
            return Ok(PortBits::Byte);
        }
        match u8::try_from(f.value - first) {
            Ok(bit) if bit <= 7 => Ok(PortBits::Bit(bit)),
            _ => Err(self.fail(
                ReplyCode::BadNumber,
                index,
                format!(
                    "the bit is {}-{} or 128 for the whole byte, got {}",
                    first,
                    first + 7,
                    f.value
                ),
            )),
        }
    }

    fn sync_char(&self, index: usize) -> Result<SyncChar, ParseError> {
        let f = self.field(index)?;
        u8::try_from(f.value)
            .ok()
            .and_then(SyncChar::new)
            .ok_or_else(|| {
                self.fail(
                    ReplyCode::BadNumber,
                    index,
                    format!("a sync character is an ASCII code 33-126, got {}", f.value),
                )
            })
    }

    fn plane(&self) -> Result<Plane, ParseError> {
        self.exactly(1, "the plane")?;
        let f = self.field(0)?;
        Plane::from_value(f.value).ok_or_else(|| {
            self.fail(
                ReplyCode::BadNumber,
                0,
                format!("the plane is 0 (XY), 1 (XZ) or 2 (YZ), got {}", f.value),
            )
        })
    }

    fn direction(&mut self) -> Result<CircleDirection, ParseError> {
        self.exactly(1, "the direction")?;
        let f = self.field(0)?.clone();
        let dir = CircleDirection::from_value(f.value).ok_or_else(|| {
            self.fail(
                ReplyCode::BadNumber,
                0,
                format!(
                    "the circle direction is 0 (CW) or -1 (CCW), got {}",
                    f.value
                ),
            )
        })?;
        if f.value == 1 {
            self.p.notes.push(Note {
                kind: NoteKind::CcwWrittenAsOne,
                span: f.span,
            });
        }
        Ok(dir)
    }

    fn sign(&self, index: usize, what: &str) -> Result<Sign, ParseError> {
        let f = self.field(index)?;
        Sign::from_value(f.value).ok_or_else(|| {
            self.fail(
                ReplyCode::BadNumber,
                index,
                format!("{what} is -1 or 1, got {}", f.value),
            )
        })
    }

    fn circle_fields(&self) -> Result<CircleParams, ParseError> {
        Ok(CircleParams {
            arc_length: self.int(
                0,
                ReplyCode::BadNumber,
                "the arc length B",
                "1 or more steps",
            )?,
            speed: self.speed(1)?,
            d: self.int(
                2,
                ReplyCode::BadNumber,
                "the interpolation parameter D",
                "a 32-bit number",
            )?,
            xs: self.steps(3)?,
            ys: self.steps(4)?,
            rx: self.sign(5, "Rx")?,
            ry: self.sign(6, "Ry")?,
        })
    }

    fn circle(&self) -> Result<CircleParams, ParseError> {
        self.exactly(7, "B, V, D, Xs, Ys, Rx, Ry")?;
        self.circle_fields()
    }

    fn helix(&self) -> Result<HelixParams, ParseError> {
        self.exactly(8, "B, V, D, Xs, Ys, Rx, Ry, S3")?;
        Ok(HelixParams {
            circle: self.circle_fields()?,
            s3: self.steps(7)?,
        })
    }

    fn port_move(&self) -> Result<PortMove, ParseError> {
        let n = self.fields.len();
        if !(5..=8).contains(&n) {
            return Err(self.count_error(
                "port, mask, value, speed and one step count per axis (5 to 8 numbers)".into(),
            ));
        }
        Ok(PortMove {
            port: self.input_port(0)?,
            mask: self.byte(1, "the mask")?,
            value: self.byte(2, "the value")?,
            speed: self.speed(3)?,
            steps: (4..n).map(|i| self.steps(i)).collect::<Result<_, _>>()?,
        })
    }

    fn port_watch(&self) -> Result<PortWatch, ParseError> {
        self.exactly(3, "port, mask and set value")?;
        Ok(PortWatch {
            port: self.input_port(0)?,
            mask: self.byte(1, "the mask")?,
            value: self.byte(2, "the set value")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(s: &str) -> Frame {
        match parse_frame(s) {
            Ok(p) => p.value,
            Err(e) => panic!("{s}: {e}"),
        }
    }

    fn code(s: &str) -> ReplyCode {
        match parse_frame(s) {
            Ok(p) => panic!("{s} parsed as {:?}", p.value),
            Err(e) => e.code,
        }
    }

    #[test]
    fn spaces_line_ends_and_alternate_letters_are_accepted_and_noted() {
        let p = parse_frame("@0a 5000,900\r\n").ok();
        let p = p.as_ref();
        assert_eq!(
            p.map(|p| p.value.to_string()),
            Some("@0A5000,900".to_string())
        );
        assert_eq!(
            p.map(|p| p.notes.iter().map(|n| n.kind).collect::<Vec<_>>()),
            Some(vec![
                NoteKind::AlternateLetter {
                    written: 'a',
                    canonical: 'A'
                },
                NoteKind::SpaceAfterCode
            ])
        );
        assert_eq!(p.map(|p| p.params.clone()), Some(vec![4..8, 9..12]));
        assert_eq!(frame("@0?").command, Command::ReadVersion);
        assert_eq!(frame("@0P\r").command, Command::ReadPosition);
        assert_eq!(frame("@0P \n").command, Command::ReadPosition);
    }

    #[test]
    fn errors_carry_the_controllers_code_and_a_span() {
        assert_eq!(code("0A5000,900"), ReplyCode::Syntax);
        assert_eq!(code("@xA5000,900"), ReplyCode::Syntax);
        assert_eq!(code("@0"), ReplyCode::Syntax);
        assert_eq!(code("@0x"), ReplyCode::Syntax);
        assert_eq!(code("@0A5000,9x0"), ReplyCode::BadNumber);
        assert_eq!(code("@0A5000,"), ReplyCode::BadNumber);
        assert_eq!(code("@0A5000, 900"), ReplyCode::BadNumber);
        assert_eq!(code("@0A5000"), ReplyCode::ParameterCount);
        assert_eq!(code("@0A5000,-900"), ReplyCode::BadSpeed);
        assert_eq!(code("@0P1"), ReplyCode::ParameterCount);
        assert_eq!(code("@0R16"), ReplyCode::BadAxis);
        assert_eq!(code("@09"), ReplyCode::BadAxis);
        assert_eq!(code("@07 "), ReplyCode::Syntax);
        assert_eq!(code("@0A1234567890123,900"), ReplyCode::BadNumber);
        assert_eq!(code("@0A\u{e4}"), ReplyCode::Syntax);
        let e = parse_frame("@4A\u{1}").err();
        assert_eq!(e.and_then(|e| e.device), DeviceNumber::new(4));
        let e = parse_frame("@3b7").err();
        assert_eq!(e.as_ref().map(|e| e.span.clone()), Some(3..4));
        assert_eq!(e.as_ref().and_then(|e| e.device), DeviceNumber::new(3));
        assert!(e.is_some_and(|e| e.message.contains("0-3")));
    }

    #[test]
    fn cnc_codes_follow_decision_10() {
        let p = parse_cnc("M30,800").ok();
        assert_eq!(
            p.as_ref().map(|p| p.value.to_string()),
            Some("m30,800".to_string())
        );
        assert_eq!(
            p.map(|p| p.notes[0].kind),
            Some(NoteKind::TableSpelling {
                written: 'M',
                section: 'm'
            })
        );
        let cnc_code = |s: &str| parse_cnc(s).err().map(|e| e.code);
        assert_eq!(cnc_code("@0P"), Some(ReplyCode::NotStorable));
        assert_eq!(cnc_code("A5000,900"), Some(ReplyCode::NotStorable));
        assert_eq!(cnc_code("G1"), Some(ReplyCode::NotStorable));
        assert_eq!(cnc_code("4"), Some(ReplyCode::NotStorable));
        assert_eq!(cnc_code("#"), Some(ReplyCode::Syntax));
        assert_eq!(cnc_code(""), Some(ReplyCode::Syntax));
        assert_eq!(cnc_code("69,1,0"), Some(ReplyCode::BadNumber));
        assert_eq!(cnc_code("60,0,0"), Some(ReplyCode::BadNumber));
        assert_eq!(cnc_code("o0,8,0,1"), Some(ReplyCode::BadNumber));
        assert_eq!(cnc_code("132"), Some(ReplyCode::BadNumber));
    }
}
