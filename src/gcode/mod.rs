//! G-code from CAM (RS-274/NGC as grbl, LinuxCNC and Mach accept it) for
//! controllers that have no G-code: read, interpreted into a [`Toolpath`]
//! of machine moves, checked against the machine, and turned into each
//! family's own program (`docs/gcode.md`).
//!
//! ```text
//! text ──read──► blocks (words with spans) ──interpret──► Toolpath ──check──► per-family output
//! ```
//!
//! Every stage keeps the G-code line a thing came from ([`Origin`]): a
//! diagnostic, a generated controller line and a controller error during a
//! run all point at `FILE:LINE:COL`.
//!
//! Sans-IO: text in, values out; the CLI, the editor and the runs read the
//! files and talk to the device.

pub mod toolpath;

pub use toolpath::{
    Arc, Diagnostic, Dwell, Line, Op, Origin, OutputSwitch, Pause, Plane, Point, Rapid, Severity,
    Toolpath,
};
