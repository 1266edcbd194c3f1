//! The job log (issue 41, `docs/gcode.md` "Job log" and "Resume"): every run
//! of a job, by `jogterm run` or by the console, appends its records to one
//! append-only file of JSON lines in the state directory. A run writes a
//! `start` record, then a `line` record whenever a G-code line has run to
//! its end, then an `end` record; the reader folds them per run id. A run
//! whose records have no end did not end: the process was killed, crashed,
//! or the power went (or it still runs, which the file layer tells apart).
//!
//! - [`record`]: the records as data, one JSON object a line (sans-IO).
//! - [`fold`]: the records folded into runs, a torn or foreign line left out
//!   with a note, never a panic (sans-IO).
//! - [`table`]: the runs as an 80-column table and as JSON (sans-IO).
//! - [`resume`]: whether the last run of a file left a line to restart from,
//!   and how to say so (sans-IO).
//! - [`calibrate`]: the estimate refined by the last whole runs of a
//!   profile and way (sans-IO).
//! - [`file`]: the thin file layer: where the log lives, reading it, and the
//!   writer thread that appends and syncs off the run's own path.
//!
//! Why lines and not a rewritten file: an append of one line either reached
//! the kernel or not, so a `kill -9` loses at most the update the writer had
//! not handed over yet, and a power cut what was written since the last
//! sync (at most a second, `file::SYNC_EVERY`). A line cut in the middle is
//! the last one of the file and is left out when read.

pub mod calibrate;
pub mod file;
pub mod fold;
pub mod record;
pub mod resume;
pub mod table;

pub use file::JobLog;
pub use fold::{Ended, Folded, Run, fold};
pub use record::{How, Record, Start};
