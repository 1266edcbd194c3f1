//! G-code from CAM for controllers that have no G-code, as jogterm runs it:
//! the core (reader, interpreter, toolpath, machine check) is the
//! `jogterm-gcode` crate, re-exported here; this module adds what needs a
//! machine profile or a controller family: the setup and the machine from a
//! profile ([`profile`]), each family's program ([`isel`], [`emcu`]), the
//! one-call [`import`], restarts ([`restart`]) and the ways a job can run
//! ([`ways`]) (`docs/gcode.md`).

pub mod emcu;
pub mod eta;
pub mod import;
pub mod isel;
pub mod profile;
pub mod restart;
pub mod timing;
pub mod waits;
pub mod ways;

pub use jogterm_gcode::*;

pub use import::{HeightMapFile, Import, MapApplied, import, import_with_map, import_with_tool};
pub use restart::{Restart, RestartError, restart};

/// How a toolpath is converted besides the profile's settings.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Options {
    /// A piece of a job after a wait (`waits`): the job's first piece ran
    /// the reference run, this one starts where the tool stands.
    pub continued: bool,
    /// The job's safe height (machine mm), where parts may be cut: a
    /// piece's own highest rapid may be a tool change's travel.
    pub safe_z: Option<f64>,
}
