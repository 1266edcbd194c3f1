//! The records of the job log, one JSON object a line. Sans-IO: text in,
//! text out.

use serde::{Deserialize, Serialize};

/// How a run ended, as its `end` record says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum How {
    /// The job ran to its end.
    Done,
    /// The operator stopped it (a stop key, Ctrl-C, a hang-up).
    Stopped,
    /// The controller refused or answered an error, or jogterm could not go
    /// on (a fault).
    Error,
    /// The line to the controller was lost.
    Lost,
}

impl How {
    pub fn name(self) -> &'static str {
        match self {
            How::Done => "done",
            How::Stopped => "stopped",
            How::Error => "error",
            How::Lost => "lost",
        }
    }
}

/// What a run is, said once at its start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Start {
    /// The run's id: unique per run (start time and process id).
    pub run: String,
    /// When it started, UTC (`2026-12-07T11:05:12Z`).
    pub at: String,
    /// The job's file, its path made absolute where it could be.
    pub file: String,
    /// The file's content hash (`program::store::Fingerprint`: FNV-1a and
    /// length): the same file is the same content, wherever it lies.
    pub hash: String,
    pub profile: String,
    pub port: String,
    /// The work offset and its zero in machine units (`G54 X50.000 Y50.000
    /// Z60.000 mm`); empty for a controller program.
    pub offset: String,
    /// `stored`, `chunked` or `stream`.
    pub way: String,
    /// The way's estimate in seconds, where there is one.
    pub estimate_s: Option<f64>,
    /// A restart's first line (`--from-line`).
    pub from_line: Option<u32>,
    /// Who ran it: `run` (the command) or `console`.
    pub by: String,
    /// The process that runs it, and the boot it runs in
    /// (`/proc/sys/kernel/random/boot_id`): a run without an end whose
    /// process still lives in the same boot still runs.
    pub pid: u32,
    pub boot: Option<String>,
}

/// One line of the log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "lowercase")]
pub enum Record {
    Start(Box<Start>),
    /// G-code line `line` has run to its end, `t` seconds after the start.
    Line {
        run: String,
        line: u32,
        t: f64,
    },
    /// The run ended `how`, `t` seconds after its start; `line`: the last
    /// G-code line that ran to its end.
    End {
        run: String,
        at: String,
        how: How,
        line: Option<u32>,
        t: f64,
    },
}

impl Record {
    /// A start record (boxed: a start is much bigger than a line record,
    /// and a log is mostly line records).
    pub fn start(start: Start) -> Record {
        Record::Start(Box::new(start))
    }

    pub fn run(&self) -> &str {
        match self {
            Record::Start(s) => &s.run,
            Record::Line { run, .. } | Record::End { run, .. } => run,
        }
    }

    /// The record as one line of the file, newline included.
    pub fn line_text(&self) -> String {
        // Serialising these plain structs cannot fail (no maps with
        // non-string keys, no foreign Serialize impls); an empty object
        // would be left out by the reader, never a panic.
        let mut text = serde_json::to_string(self).unwrap_or_else(|_| "{}".into());
        text.push('\n');
        text
    }

    /// One line of the file; `None` when it is no record of ours.
    pub fn parse(line: &str) -> Option<Record> {
        serde_json::from_str(line).ok()
    }
}

/// `t` rounded to milliseconds: a log line need not say nanoseconds.
pub fn seconds(t: f64) -> f64 {
    (t * 1000.0).round() / 1000.0
}

/// A start record for the tests of this module and its siblings.
#[cfg(test)]
pub(crate) fn test_start(run: &str, hash: &str) -> Start {
    Start {
        run: run.into(),
        at: "2026-12-07T11:05:12Z".into(),
        file: "/jobs/part.nc".into(),
        hash: hash.into(),
        profile: "default".into(),
        port: "/dev/ttyUSB0".into(),
        offset: "G54 X50.000 Y50.000 Z60.000 mm".into(),
        way: "stream".into(),
        estimate_s: Some(64.0),
        from_line: None,
        by: "run".into(),
        pid: 42,
        boot: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_as_one_line_each() {
        for r in [
            Record::start(test_start("a", "h")),
            Record::Line {
                run: "a".into(),
                line: 12,
                t: 1.5,
            },
            Record::End {
                run: "a".into(),
                at: "2026-12-07T11:06:16Z".into(),
                how: How::Lost,
                line: Some(12),
                t: 64.25,
            },
        ] {
            let text = r.line_text();
            assert!(text.ends_with('\n'));
            assert_eq!(text.matches('\n').count(), 1);
            assert_eq!(Record::parse(text.trim_end()), Some(r));
        }
        assert!(
            Record::Line {
                run: "a".into(),
                line: 3,
                t: 0.0
            }
            .line_text()
            .starts_with(r#"{"event":"line","run":"a","line":3"#)
        );
    }

    #[test]
    fn foreign_and_cut_lines_are_no_records() {
        assert_eq!(Record::parse(""), None);
        assert_eq!(Record::parse(r#"{"event":"line","run":"a","li"#), None);
        assert_eq!(Record::parse(r#"{"event":"other","run":"a"}"#), None);
        assert_eq!(Record::parse("garbage"), None);
    }
}
