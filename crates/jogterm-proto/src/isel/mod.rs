//! isel @-format (iMC-M / iMC-MP / iMC-S8): DNC commands, CNC (stored
//! program) commands, init commands, control bytes and replies. Sans-IO: no
//! I/O, clocks or sleeps; bytes and "the line has been silent" come in as
//! arguments.
//!
//! Sources: the isel iMC programming manual chapters 1–5, the binding
//! decisions in `docs/decisions.md` (isel 1–13) and jogterm's own
//! decisions in `docs/protocols.md` (section "isel @-format").
//!
//! # Sending commands
//!
//! A DNC command is a [`Command`] addressed to a [`DeviceNumber`] in a
//! [`Frame`]; [`Frame::encode`] gives the bytes (`@0A5000,900` CR, no space
//! after the letter). Stored program lines are [`CncCommand`]s, encoded
//! without the `@<dev>` prefix ([`CncCommand::encode`]). The control bytes
//! 0xFD/0xFE/0xFF are [`ControlByte`]s; they may be written at any time, even
//! between the bytes of a command.
//!
//! Before sending, [`check`] (or [`check_with`] while the axes may not be set)
//! tests a command against the [`AxisConfig`] and the manual's ranges and
//! says which reply code a controller would give. [`validate_frame`] and
//! [`validate_cnc`] parse and check a typed line in one go and return a
//! [`Rejection`] with code, message and span.
//!
//! ```
//! use jogterm_proto::isel::{validate_frame, AxisConfig, ReplyCode};
//!
//! let ok = validate_frame("@0A 5000,900", Some(AxisConfig::X)).unwrap();
//! assert_eq!(ok.value.encode(), b"@0A5000,900\r");
//!
//! let too_few = validate_frame("@0A5000,900", Some(AxisConfig::XYZ)).unwrap_err();
//! assert_eq!(too_few.code, ReplyCode::ParameterCount);
//! println!("{}", too_few.message); // `A` with XYZ takes 4 steps,speed pairs (x, y, z1, z2), got 1
//! ```
//!
//! # Parsing text
//!
//! [`parse_frame`] and [`parse_cnc`] accept what a controller accepts
//! (spaces after the command code, CR / CR LF / LF line ends, the letters
//! `a m r s ?`, the CNC table spellings `F M O P W Y Z`) and report each such
//! liberty as a [`Note`] with its byte span. Their [`ParseError`] carries the
//! reply code a controller would answer ([`ParseError::code`]) and a message
//! saying what was expected: a simulator answers with the code, the console
//! shows the message. The parser does not know the axis configuration;
//! counts and ranges that depend on it are [`check`]'s job.
//!
//! # Replies
//!
//! [`Expect::for_command`] says what reply a command gets. [`ReplyDecoder`]
//! is fed the received bytes in any split and returns [`Event`]s: the
//! [`Reply`], sync characters of a running program, unsolicited bytes, and
//! [`DecodeError`]s for garbage (after which nothing is outstanding and the
//! machine state must be treated as unknown). `@0V`/`@0U` end on silence: the
//! caller calls [`ReplyDecoder::silence`] after [`TEXT_SILENCE`] without a
//! byte. [`decode`] is the pure function underneath.
//!
//! Every [`ReplyCode`] has a [`meaning`](ReplyCode::meaning) and a
//! [`Recovery`] with [`advice`](Recovery::advice) for the operator;
//! [`ReplyCode::loses_reference`] flags `2` and `9`. A simulator answers with
//! [`Reply::encode`] and cuts its input with [`RequestFramer`].
//!
//! # Tables and arithmetic
//!
//! [`ports`] holds every input bit and output port as data (names, roles,
//! which outputs need confirmation), the `@0DRp`/`@0DRn` bits and the `@0IE`
//! word. [`circle()`] and [`helix`] compute the `f` and `y`/`w` parameters of
//! manual 2.3; [`CircleParams::end_point`] and [`ArcGeometry`] say where a
//! `y`/`w` leaves the tool. [`estimate`] says where the axes are while a
//! move runs, from the ramp the controller runs (`@0j`, `@0J`).

mod axes;
mod check;
mod circle;
mod cnc;
mod command;
mod decode;
mod device;
mod encode;
pub mod estimate;
mod framer;
mod parse;
pub mod ports;
mod reply;
mod walk;

#[cfg(test)]
mod tests;

pub use axes::{AxisConfig, AxisSetting};
pub use check::{
    ACCELERATION_HZ_PER_MS, CheckError, LOOP_COUNT, REFERENCE_CLEAR_STEPS, Rejection, SPEED_HZ,
    START_STOP_HZ, STEPS, USER_INFO_MAX_CHARS, check, check_cnc, check_with, validate_cnc,
    validate_frame,
};
pub use circle::{
    ArcEnd, ArcGeometry, CircleError, CircleMove, HelixMove, arc_end, circle, helix,
    radius_from_parameters,
};
pub use cnc::{CncCommand, PROGRAM_CAPACITY, SyncChar};
pub use command::{
    CircleDirection, CircleParams, Command, ControlByte, Diagnosis, DiagnosisKind, Frame,
    HelixParams, InitCommand, MovePair, Plane, PortMove, PortSignal, PortWatch, Sign,
};
pub use decode::{
    Decode, DecodeError, Event, Expect, MAX_TEXT_REPLY, Outstanding, ReplyDecoder, TEXT_SILENCE,
    decode,
};
pub use device::DeviceNumber;
pub use encode::CR;
pub use framer::{MAX_LINE, Received, RequestFramer};
pub use parse::{Note, NoteKind, ParseError, Parsed, parse_cnc, parse_frame};
pub use ports::{InputPort, OutputPort, PortBits};
pub use reply::{Positions, Recovery, Reply, ReplyCode, ReplyEncodeError, TextEnd, UnusedCode};
pub use walk::ArcWalk;
