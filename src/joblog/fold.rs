//! The log's records folded into runs. Sans-IO: the file's text in, the
//! runs in the order they started and notes on what was left out.

use super::record::{How, Record, Start};

/// How a run ended, as the log knows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    By(How),
    /// No end record: the process was killed, crashed or lost its power,
    /// or it still runs (`Run::running`, set by the file layer).
    NoEnd,
}

/// One run, folded from its records.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub start: Start,
    /// The last G-code line that ran to its end.
    pub last_line: Option<u32>,
    /// Seconds from the start to the end, else to the last line recorded.
    pub elapsed_s: Option<f64>,
    pub ended: Ended,
    /// When it ended, UTC.
    pub end_at: Option<String>,
    /// The process that runs it still lives (the file layer asks the
    /// system; the fold cannot know).
    pub running: bool,
}

impl Run {
    fn new(start: Start) -> Run {
        Run {
            start,
            last_line: None,
            elapsed_s: None,
            ended: Ended::NoEnd,
            end_at: None,
            running: false,
        }
    }

    /// The run ended by a crash, a fault or a lost line (not by the
    /// operator, not at its end) and is not running.
    pub fn interrupted(&self) -> bool {
        !self.running
            && matches!(
                self.ended,
                Ended::NoEnd | Ended::By(How::Error) | Ended::By(How::Lost)
            )
    }

    /// The line a restart takes the job up again at: the last line that
    /// ran to its end (run again: it cuts the same path, and covers an
    /// update a power cut may have lost), else a restart's own first line.
    /// `None` when nothing is known to have run (a stored program is not
    /// followed line by line).
    pub fn resume_line(&self) -> Option<u32> {
        self.last_line.or(self.start.from_line)
    }

    /// How it ended, in a word.
    pub fn how(&self) -> &'static str {
        match self.ended {
            Ended::By(how) => how.name(),
            Ended::NoEnd if self.running => "running",
            Ended::NoEnd => "crash",
        }
    }
}

/// The runs of a log and what was left out of it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Folded {
    /// In the order they started (the file's order).
    pub runs: Vec<Run>,
    pub notes: Vec<String>,
}

impl Folded {
    /// The newest run of the file with content `hash`.
    pub fn last_of(&self, hash: &str) -> Option<&Run> {
        self.runs.iter().rev().find(|r| r.start.hash == hash)
    }
}

/// Fold the text of a log (`name` in the notes). A last line without its
/// newline that is no record was cut by a crash while it was written; any
/// other line that is no record, or names a run that never started, is
/// left out and counted.
pub fn fold(name: &str, text: &str) -> Folded {
    let mut folded = Folded::default();
    let mut foreign = Vec::new();
    let torn = !text.is_empty() && !text.ends_with('\n');
    let lines: Vec<&str> = text.split('\n').collect();
    let count = lines.len();
    for (k, line) in lines.into_iter().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let Some(record) = Record::parse(line) else {
            if torn && k + 1 == count {
                folded.notes.push(format!(
                    "{name}: its last line is cut off (written when the process ended): left out"
                ));
            } else {
                foreign.push(k + 1);
            }
            continue;
        };
        if !apply(&mut folded.runs, record) {
            foreign.push(k + 1);
        }
    }
    if let Some(first) = foreign.first() {
        folded.notes.push(format!(
            "{name}: {} line(s) that are no record of a run left out (the first: line {first})",
            foreign.len()
        ));
    }
    folded
}

/// Put one record into its run; `false` for a record of no started run.
fn apply(runs: &mut Vec<Run>, record: Record) -> bool {
    if let Record::Start(start) = record {
        runs.push(Run::new(*start));
        return true;
    }
    // The newest run of that id: ids are unique, but a log put together
    // from two files must not fold one run into another's start.
    let Some(run) = runs.iter_mut().rev().find(|r| r.start.run == record.run()) else {
        return false;
    };
    match record {
        Record::Start(_) => {}
        Record::Line { line, t, .. } => {
            run.last_line = Some(line);
            run.elapsed_s = Some(t);
        }
        Record::End {
            at, how, line, t, ..
        } => {
            run.last_line = line.or(run.last_line);
            run.elapsed_s = Some(t);
            run.ended = Ended::By(how);
            run.end_at = Some(at);
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::super::record::test_start;
    use super::*;

    fn text(records: &[Record]) -> String {
        records.iter().map(Record::line_text).collect()
    }

    fn line(run: &str, line: u32, t: f64) -> Record {
        Record::Line {
            run: run.into(),
            line,
            t,
        }
    }

    fn end(run: &str, how: How, line: Option<u32>, t: f64) -> Record {
        Record::End {
            run: run.into(),
            at: "2026-12-07T11:06:00Z".into(),
            how,
            line,
            t,
        }
    }

    #[test]
    fn runs_fold_in_their_order_each_with_its_last_line_and_end() {
        let log = text(&[
            Record::start(test_start("a", "h1")),
            Record::start(test_start("b", "h2")),
            line("a", 10, 1.0),
            line("b", 3, 1.5),
            line("a", 11, 2.0),
            end("a", How::Done, Some(12), 3.0),
            end("b", How::Stopped, None, 2.5),
            Record::start(test_start("c", "h1")),
            line("c", 5, 0.5),
        ]);
        let f = fold("log", &log);
        assert!(f.notes.is_empty(), "{:?}", f.notes);
        let runs: Vec<_> = f
            .runs
            .iter()
            .map(|r| (r.start.run.as_str(), r.last_line, r.elapsed_s, r.how()))
            .collect();
        assert_eq!(
            runs,
            [
                ("a", Some(12), Some(3.0), "done"),
                // An end without a line keeps the last one recorded.
                ("b", Some(3), Some(2.5), "stopped"),
                ("c", Some(5), Some(0.5), "crash"),
            ]
        );
        assert_eq!(f.last_of("h1").map(|r| r.start.run.as_str()), Some("c"));
        assert_eq!(f.last_of("h3"), None);
    }

    #[test]
    fn a_missing_end_is_a_crash_that_offers_its_last_line() {
        let f = fold(
            "log",
            &text(&[Record::start(test_start("a", "h")), line("a", 40, 9.0)]),
        );
        let run = &f.runs[0];
        assert_eq!(run.ended, Ended::NoEnd);
        assert!(run.interrupted());
        assert_eq!(run.resume_line(), Some(40));
        // Still running in another process: no crash, nothing to offer.
        let running = Run {
            running: true,
            ..run.clone()
        };
        assert!(!running.interrupted());
        assert_eq!(running.how(), "running");
    }

    #[test]
    fn faults_and_lost_lines_are_interrupted_stops_and_ends_are_not() {
        for (how, interrupted) in [
            (How::Done, false),
            (How::Stopped, false),
            (How::Error, true),
            (How::Lost, true),
        ] {
            let f = fold(
                "log",
                &text(&[
                    Record::start(test_start("a", "h")),
                    end("a", how, Some(7), 1.0),
                ]),
            );
            assert_eq!(f.runs[0].interrupted(), interrupted, "{how:?}");
        }
    }

    #[test]
    fn a_restart_that_completed_nothing_offers_its_own_first_line() {
        let start = Start {
            from_line: Some(42),
            ..test_start("a", "h")
        };
        let f = fold("log", &text(&[Record::start(start)]));
        assert_eq!(f.runs[0].resume_line(), Some(42));
        let f = fold("log", &text(&[Record::start(test_start("a", "h"))]));
        assert_eq!(f.runs[0].resume_line(), None);
    }

    #[test]
    fn a_torn_last_line_is_left_out_with_a_note() {
        let mut log = text(&[Record::start(test_start("a", "h")), line("a", 7, 1.0)]);
        let torn = line("a", 8, 1.2).line_text();
        log.push_str(&torn[..torn.len() / 2]);
        let f = fold("jobs.jsonl", &log);
        assert_eq!(f.runs.len(), 1);
        assert_eq!(f.runs[0].last_line, Some(7));
        assert_eq!(
            f.notes,
            ["jobs.jsonl: its last line is cut off (written when the process ended): left out"]
        );
        // Cut at every byte: never a panic, never a wrong line; only the
        // newline missing, the record is whole and counts.
        for k in 0..torn.len() {
            let mut log = text(&[Record::start(test_start("a", "h")), line("a", 7, 1.0)]);
            log.push_str(&torn[..k]);
            let f = fold("log", &log);
            let whole = k + 1 == torn.len();
            let expected = if whole { 8 } else { 7 };
            assert_eq!(f.runs[0].last_line, Some(expected), "cut at {k}");
            assert_eq!(f.notes.is_empty(), whole || k == 0, "cut at {k}");
        }
    }

    #[test]
    fn a_line_after_a_torn_one_and_foreign_lines_are_counted_not_fatal() {
        // The writer starts a fresh line after a torn one; a line of
        // garbage or of a run that never started is left out and counted.
        let mut log = text(&[Record::start(test_start("a", "h"))]);
        log.push_str("{\"event\":\"line\",\"ru\n");
        log.push_str("not json\n");
        log.push_str(&line("zz", 3, 1.0).line_text());
        log.push_str(&line("a", 9, 2.0).line_text());
        let f = fold("log", &log);
        assert_eq!(f.runs[0].last_line, Some(9));
        assert_eq!(
            f.notes,
            ["log: 3 line(s) that are no record of a run left out (the first: line 2)"]
        );
        assert_eq!(fold("log", ""), Folded::default());
    }
}
