//! Easy Motion Protocol (MSR DRS-500-ECS): 8-byte hex frames ended by 0x1A.
//!
//! Sans-IO, in layers:
//! - [`frame`]: the eight bytes and their 16 hex characters; [`decoder`]: a
//!   streaming decoder that resynchronises on EOF and reports what it drops.
//! - [`address`]: the DS byte; [`values`], [`io`], [`adc`], [`rtc`], [`mode`]:
//!   the typed fields of the commands.
//! - [`request`] and [`reply`]: every command of the manual, typed, with its
//!   bytes placed as the manual's tables and examples show.
//! - [`correlate`]: matching replies (and the completions long actions send on
//!   their own) to the requests of several drives.
//! - [`reload`] and [`feed`]: the sample timer's reload value and the feed-rate
//!   arithmetic of the manual's "Berechnung" section.
//!
//! The manual is `the MSR DRS-500 EMP command set (German; docs/decisions.md lists the manuals)`; the
//! binding decisions are `docs/decisions.md` (EMP) and jogterm's own are
//! in `docs/protocols.md` (EMP).

pub mod adc;
pub mod address;
pub mod correlate;
pub mod decoder;
pub mod error;
pub mod feed;
pub mod frame;
pub mod ident;
pub mod io;
pub mod mode;
pub mod reload;
pub mod reply;
pub mod request;
pub mod rtc;
pub mod values;

#[cfg(test)]
mod manual_examples;
#[cfg(test)]
mod proptests;

pub use adc::{AdcCode, AdcInput, AdcMode, AdcPolarity, AdcResolution, Gain, JoystickParameters};
pub use address::DriveAddress;
pub use correlate::{Correlator, Event, UnexpectedReason};
pub use decoder::{FrameDecoder, Incoming};
pub use error::{ConversionError, FrameError, FrameFault, ReplyError, RequestError, ValueError};
pub use feed::{FeedSetting, Mechanics, feed_setting, reload_for};
pub use frame::{EOF, FRAME_HEX_LEN, FRAME_WIRE_LEN, Frame};
pub use ident::IdentText;
pub use io::{Inputs, Limits, Lines, Outputs};
pub use mode::{JoystickChannel, OperatingMode, SubMode};
pub use reload::ReloadValue;
pub use reply::{ErrorCode, Info, Reply, ReplyBody};
pub use request::{Command, IdentityQuery, OnScope, ParseRequestError, Request};
pub use rtc::{RtcDate, RtcTime};
pub use values::{Position, Speed, Velocity};

use crate::wire::LineSettings;

/// EMP runs at 38400 baud 8N1 (`docs/decisions.md`, "Serial defaults").
pub const LINE: LineSettings = LineSettings::new(38400);
