//! Program languages as code: isel CNC programs (manual chapter 3) and EMCU
//! jobs (manual 1.5), for `jogterm check`, the editor panel and uploads.
//!
//! - [`Program::parse`]: text to lines, each blank, a comment or one command
//!   with spans of the command and its parameters. Single lines are parsed
//!   by the protocol cores (`proto::isel::parse_cnc`, `proto::emcu::parse_line`);
//!   comments and blank lines are stripped before upload and the command
//!   indices the controller counts map to source lines both ways
//!   ([`Program::line_of`], [`Program::index_of`]). Every line parses on its
//!   own, so an editor re-parses only what changed
//!   ([`Program::replace_lines`]).
//! - [`lint`]: diagnostics with severity, [`Span`], message and optional
//!   [`Fix`], for a machine described by a [`LintConfig`] (axes, soft
//!   limits, start position).
//! - [`path()`]: the tool's path through the program, segment by segment with
//!   source lines, and the predicted end position.
//! - [`format()`]: the canonical text, comments kept.
//! - [`store`]: program files on disk: atomic saves and recovery files.
//! - [`teach`], [`circle`]: program text generated from the machine and
//!   the operator's numbers: taught moves, dwells and outputs; the lines of
//!   an arc or helix (the editor's teach-in and circle helper, `jogterm
//!   arc`).
//!
//! The language rules (comments, file extensions, what the simulation
//! assumes) are in `docs/programs.md`.
//!
//! ```
//! use jogterm::axis::AxisSet;
//! use jogterm::program::{Language, LintConfig, Program, Start, format, lint, path};
//!
//! let text = "7 7        ; reference run\nM1000,900,0,900,0,900,0,900\n9\n";
//! let program = Program::parse(Language::Isel, text);
//! let diagnostics = lint(&program, &LintConfig::new(AxisSet::XYZ));
//! assert_eq!(diagnostics.len(), 1); // `M` is the table spelling of `m`
//! assert_eq!(format(&program), "77 ; reference run\nm1000,900,0,900,0,900,0,900\n9\n");
//! let end = path(&program, &Start::at_zero(AxisSet::XYZ)).end;
//! assert_eq!(end, [1000, 0, 0, 0]);
//! ```

pub mod checkout;
pub mod checkout_emcu;
pub mod circle;
mod emcu_line;
mod flow;
mod format;
mod isel_line;
pub mod lint;
mod model;
pub mod outputs;
pub mod path;
pub mod recent;
mod run;
pub mod source;
pub mod store;
pub mod teach;

pub use format::format;
pub use lint::{AxisLimit, DEFAULT_BUDGET, Diagnostic, Fix, LintConfig, Rule, Severity, lint};
pub use model::{
    Command, ISEL_CAPACITY, Item, Language, Line, LineKind, Note, Program, Statement, SyntaxError,
};
pub use path::{
    Arc, PATH_BOUND, Path, PathEnd, Position, Segment, SegmentKind, Start, path, path_with,
};
pub use source::Span;
