//! G-code from CAM for controllers that have no G-code, as jogterm runs it:
//! the core (reader, interpreter, toolpath, machine check) is the
//! `jogterm-gcode` crate, re-exported here; this module adds what needs a
//! machine profile or a controller family: the setup and the machine from a
//! profile ([`profile`]), each family's program ([`isel`], [`emcu`]), the
//! one-call [`import`], restarts ([`restart`]) and the ways a job can run
//! ([`ways`]) (`docs/gcode.md`).

pub mod emcu;
pub mod import;
pub mod isel;
pub mod profile;
pub mod restart;
pub mod timing;
pub mod ways;

pub use jogterm_gcode::*;

pub use import::{HeightMapFile, Import, MapApplied, import, import_with_map};
pub use restart::{Restart, RestartError, restart};
