//! One call from G-code text to everything the CLI, the editor and the
//! runs need: the toolpath, its check against the machine, the figures and
//! the controller program.

use crate::config::profile::Profile;
use crate::offsets::WorkOffsets;
use crate::proto::Protocol;

use super::check::{Machine, Summary, check_limits, summarise};
use super::output::{Header, Program};
use super::setup::Setup;
use super::toolpath::{Diagnostic, Origin, Severity, Toolpath};

/// Which controller program to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    Isel,
    Emcu,
}

impl Target {
    /// The profile's family, or why it has none.
    pub fn of(protocol: Protocol) -> Result<Target, String> {
        match protocol {
            Protocol::Isel => Ok(Target::Isel),
            Protocol::Emcu => Ok(Target::Emcu),
            Protocol::Emp => Err(
                "the EMP (MSR DRS-500-ECS) drives run independently: they have no interpolated path, so G-code cannot run on them".into(),
            ),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Target::Isel => "isel",
            Target::Emcu => "emcu",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Import {
    pub toolpath: Toolpath,
    pub summary: Summary,
    pub program: Program,
    pub target: Target,
    /// The interpreter's and the output's warnings, in line order.
    pub warnings: Vec<Diagnostic>,
}

fn at_start(message: impl Into<String>) -> Vec<Diagnostic> {
    vec![Diagnostic {
        severity: Severity::Error,
        origin: Origin { line: 1, col: 1 },
        message: message.into(),
    }]
}

/// Reads, interprets, checks and converts `text` (named `file` in the
/// program's header) for `profile`, with the work offsets in force.
pub fn import(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    target: Target,
) -> Result<Import, Vec<Diagnostic>> {
    let setup = Setup::from_profile(profile, offsets).map_err(|errors| {
        errors
            .into_iter()
            .flat_map(|e| at_start(format!("profile: {}: {}", e.key, e.message)))
            .collect::<Vec<_>>()
    })?;
    let toolpath = super::interpret(text, &setup)?;
    let machine = Machine::from_profile(profile);
    check_limits(&toolpath, &machine).map_err(|e| vec![e])?;
    let summary = summarise(&toolpath, &machine);
    let header = Header {
        file: file.to_owned(),
        profile: profile.name.clone(),
        system: summary.system.to_string(),
        zero: summary.zero,
    };
    let program = match target {
        Target::Isel => super::isel::convert(&toolpath, profile, &header)?,
        Target::Emcu => super::emcu::convert(&toolpath, profile, &header)?,
    };
    let mut warnings = toolpath.warnings.clone();
    warnings.extend(program.warnings.iter().cloned());
    warnings.sort_by_key(|w| w.origin);
    Ok(Import {
        toolpath,
        summary,
        program,
        target,
        warnings,
    })
}
