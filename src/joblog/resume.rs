//! Resume after a crash or a lost line (issue 41 item 5, `docs/gcode.md`
//! "Resume"): when the newest run of a file with the same content did not
//! end, or ended by a fault or a lost line, the next run of it offers to
//! restart from the last line that ran to its end, through the restart
//! entry (`--from-line`). Sans-IO: the decision and its words.

use super::fold::{Folded, Run};

/// What the log says about running a file again.
#[derive(Debug, Clone, PartialEq)]
pub enum Offer<'a> {
    /// Nothing to offer: no run of it, or the last one ended at its end or
    /// was stopped by the operator.
    Nothing,
    /// Restart from `line`.
    Resume { run: &'a Run, line: u32 },
    /// The last run was interrupted, but no line is known to have run to
    /// its end (a stored program is not followed line by line, or it broke
    /// off before its first line ended).
    NoLine { run: &'a Run },
}

/// The offer for a file of content `hash`.
pub fn offer<'a>(folded: &'a Folded, hash: &str) -> Offer<'a> {
    match folded.last_of(hash) {
        Some(run) if run.interrupted() => match run.resume_line() {
            Some(line) => Offer::Resume { run, line },
            None => Offer::NoLine { run },
        },
        _ => Offer::Nothing,
    }
}

/// How the run broke off, for a sentence: `did not end (killed, crashed or
/// the power went)`, `ended by a fault`, `ended when the line was lost`.
pub fn broke_off(run: &Run) -> &'static str {
    match run.how() {
        "error" => "ended by a fault",
        "lost" => "ended when the line to the controller was lost",
        _ => "did not end (killed, crashed, or the power went)",
    }
}

/// The offer in words: which run, how it ended, the line.
pub fn said(offer: &Offer<'_>) -> Option<String> {
    let (run, tail) = match offer {
        Offer::Nothing => return None,
        Offer::Resume { run, line } => (
            *run,
            match run.last_line {
                Some(_) => format!("; line {line} was the last to run to its end"),
                None => format!("; it restarted from line {line} and no line ran to its end"),
            },
        ),
        Offer::NoLine { run } => (
            *run,
            format!(
                "; no line is known to have run to its end ({}): choose one with --from-line",
                if run.start.way == "stream" {
                    "it broke off in its first line"
                } else {
                    "a stored program is not followed line by line"
                }
            ),
        ),
    };
    Some(format!(
        "the last run of this file (same content, {} UTC, {}, {}) {}{tail}",
        run.start.at.replacen('T', " ", 1).trim_end_matches('Z'),
        run.start.way,
        run.start.offset_or_program(),
        broke_off(run),
    ))
}

impl super::record::Start {
    /// The work offset, or that it was a controller program.
    fn offset_or_program(&self) -> &str {
        if self.offset.is_empty() {
            "a controller program"
        } else {
            &self.offset
        }
    }
}

/// What the console says when it opens `path` and the log has an offer
/// for its content: the offer and the command that takes it up (the
/// console runs whole jobs; the restart is `jogterm run`'s).
pub fn console_note(path: &std::path::Path) -> Option<String> {
    let bytes = std::fs::read(path).ok()?;
    let hash = crate::program::store::Fingerprint::of(&bytes).to_string();
    let folded = super::file::read(&super::file::dir()?);
    let offer = offer(&folded, &hash);
    let said = said(&offer)?;
    let how = match offer {
        Offer::Resume { line, .. } => format!(
            "; to restart from line {line}: jogterm run {} --from-line {line} (or --resume)",
            path.display()
        ),
        _ => String::new(),
    };
    Some(format!("{}: {said}{how}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::super::fold::fold;
    use super::super::record::{How, Record, Start, test_start};
    use super::*;

    fn log(records: &[Record]) -> Folded {
        let text: String = records.iter().map(Record::line_text).collect();
        fold("log", &text)
    }

    fn line(run: &str, line: u32) -> Record {
        Record::Line {
            run: run.into(),
            line,
            t: 1.0,
        }
    }

    fn end(run: &str, how: How) -> Record {
        Record::End {
            run: run.into(),
            at: "2026-12-07T11:06:00Z".into(),
            how,
            line: None,
            t: 2.0,
        }
    }

    #[test]
    fn a_crash_offers_its_last_line_and_says_so() {
        let f = log(&[Record::start(test_start("a", "h")), line("a", 120)]);
        let o = offer(&f, "h");
        assert!(matches!(o, Offer::Resume { line: 120, .. }), "{o:?}");
        assert_eq!(
            said(&o).as_deref(),
            Some(
                "the last run of this file (same content, 2026-12-07 11:05:12 UTC, stream, G54 \
                 X50.000 Y50.000 Z60.000 mm) did not end (killed, crashed, or the power went); \
                 line 120 was the last to run to its end"
            )
        );
        // Another file's content: nothing.
        assert_eq!(offer(&f, "other"), Offer::Nothing);
    }

    #[test]
    fn only_the_newest_run_of_the_file_counts() {
        // A crash, then a whole run to the end: nothing left to resume.
        let f = log(&[
            Record::start(test_start("a", "h")),
            line("a", 120),
            Record::start(test_start("b", "h")),
            end("b", How::Done),
        ]);
        assert_eq!(offer(&f, "h"), Offer::Nothing);
        // A stop by the operator is no crash.
        let f = log(&[
            Record::start(test_start("a", "h")),
            line("a", 5),
            end("a", How::Stopped),
        ]);
        assert_eq!(offer(&f, "h"), Offer::Nothing);
        // A lost line is.
        let f = log(&[
            Record::start(test_start("a", "h")),
            line("a", 5),
            end("a", How::Lost),
        ]);
        let o = offer(&f, "h");
        assert!(matches!(o, Offer::Resume { line: 5, .. }));
        assert!(said(&o).is_some_and(|s| s.contains("ended when the line")));
    }

    #[test]
    fn a_stored_run_without_lines_offers_no_line() {
        let stored = Start {
            way: "stored".into(),
            ..test_start("a", "h")
        };
        let f = log(&[Record::start(stored), end("a", How::Error)]);
        let o = offer(&f, "h");
        assert!(matches!(o, Offer::NoLine { .. }));
        assert!(said(&o).is_some_and(|s| s.ends_with(
            "ended by a fault; no line is known to have run to its end (a stored program is not \
             followed line by line): choose one with --from-line"
        )));
    }
}
