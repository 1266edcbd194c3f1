//! jogterm's protocol cores: everything the three controller families' manuals
//! say, as code a stranger can reuse. Sans-IO: typed commands and replies, byte
//! encoders and incremental decoders, the manuals' port and bit tables. No I/O,
//! no clocks, no sleeps: whoever drives them passes bytes and (where a protocol
//! needs time) `Instant`s in. The crate depends on no runtime, terminal or
//! serial library (the workspace's CI step `scripts/check-core-deps` holds it
//! to that).
//!
//! - [`isel`], [`emcu`], [`emp`]: one module per controller family.
//! - [`typed`]: one typed line checked against any family's grammar.
//! - [`wiring`]: what each controller bit is wired to (names, roles, limit
//!   switches' axis and side), the manuals' tables patched by a profile.
//! - [`axis`], [`wire`], [`text`]: axes, line settings, bytes made readable.

pub mod axis;
pub mod emcu;
pub mod emp;
pub mod isel;
pub mod motion;
pub mod text;
pub mod typed;
pub mod wire;
pub mod wiring;

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::wire::LineSettings;

/// The three controller families jogterm speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// isel @-format: iMC-M, iMC-MP, iMC-S8.
    Isel,
    /// EMCU interface on SMC3000 stepper cards.
    Emcu,
    /// Easy Motion Protocol: MSR DRS-500-ECS servo drives.
    Emp,
}

impl Protocol {
    pub const ALL: [Protocol; 3] = [Protocol::Isel, Protocol::Emcu, Protocol::Emp];

    pub fn name(self) -> &'static str {
        match self {
            Protocol::Isel => "isel",
            Protocol::Emcu => "emcu",
            Protocol::Emp => "emp",
        }
    }

    /// The baud rate a controller of this family uses out of the box
    /// (`docs/decisions.md`, "Serial defaults").
    pub fn default_line(self) -> LineSettings {
        match self {
            Protocol::Isel | Protocol::Emcu => LineSettings::new(19200),
            Protocol::Emp => LineSettings::new(38400),
        }
    }
}

impl fmt::Display for Protocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Protocol {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Protocol::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| format!("unknown protocol `{s}`: expected isel, emcu or emp"))
    }
}
