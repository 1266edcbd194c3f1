//! jogterm's G-code core: G-code from CAM (RS-274/NGC as grbl, LinuxCNC and
//! Mach accept it) read, interpreted into a [`Toolpath`] of machine moves and
//! checked against a machine's limits, for controllers that have no G-code.
//! No I/O and no runtime: text and a [`Setup`] in, values out (a long
//! file is read ahead on a scoped thread that ends before [`interpret`]
//! returns, [`ahead`]). Which
//! controller program a toolpath becomes, and how a profile sets the machine
//! up, is the application's (jogterm's `gcode` module).
//!
//! ```text
//! text ──read──► blocks (words with spans) ──interpret──► Toolpath ──check──► per-family output
//! ```
//!
//! Every stage keeps the G-code line a thing came from ([`Origin`]): a
//! diagnostic, a generated controller line and a controller error during a
//! run all point at `FILE:LINE:COL`.

pub mod ahead;
pub mod check;
pub mod frame;
pub mod heightmap;
pub mod interp;
pub mod modal;
pub mod num;
pub mod offsets;
pub mod output;
pub mod reader;
pub mod setup;
pub mod target;
pub mod toolchange;
pub mod toolpath;
pub mod tools;

pub use interp::interpret;
pub use modal::{Modal, Spindle};
pub use setup::{CodeRule, NamedOutput, Setup, Units};
pub use target::Target;
pub use toolpath::{
    Arc, Diagnostic, Dwell, Line, Op, Origin, OutputSwitch, Pause, Plane, Point, Rapid, Severity,
    Toolpath,
};

/// The largest G-code file read (`jogterm import`, `check`, `upload`,
/// `run`): CAM files of half a million lines are 16 MiB; `/dev/zero` or a
/// runaway file stops here instead of filling the memory (issue 37).
pub const MAX_FILE_BYTES: u64 = 64 * 1024 * 1024;

/// File extensions that mark a G-code file (`jogterm check`, `upload`, the
/// editor); `--gcode` says so for any other name.
pub const EXTENSIONS: [&str; 5] = ["nc", "ngc", "gcode", "tap", "gc"];

/// Whether a path names a G-code file by its extension.
pub fn is_gcode_path(path: &std::path::Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| EXTENSIONS.iter().any(|g| g.eq_ignore_ascii_case(e)))
}

/// `FILE:LINE:COL: error: message`, as compilers print it.
pub fn render(file: &str, d: &Diagnostic) -> String {
    let kind = match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    };
    format!(
        "{file}:{}:{}: {kind}: {}",
        d.origin.line, d.origin.col, d.message
    )
}
