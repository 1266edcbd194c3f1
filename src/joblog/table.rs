//! The runs of the log as `jogterm log` and the console show them: a table
//! that fits 80 columns, newest last (as a log reads, the newest beside the
//! prompt), or JSON. Sans-IO.

use serde_json::{Value, json};

use super::fold::Run;
use crate::gcode::ways::duration;

/// The table's head; every row is as wide or narrower (78 columns).
pub const HEAD: &str =
    "started (UTC)    file               way      line      took  estimate ended";

/// The width of the file column: a longer name is cut, its end marked.
const FILE: usize = 18;

/// One run as a row of the table.
pub fn row(run: &Run) -> String {
    let s = &run.start;
    let line = run.last_line.map_or_else(|| "-".into(), |l| l.to_string());
    let took = run.elapsed_s.map_or_else(|| "-".into(), duration);
    let estimate = s.estimate_s.map_or_else(|| "-".into(), duration);
    format!(
        "{:<16} {:<FILE$} {:<7} {:>6} {:>9} {:>9} {}",
        started(&s.at),
        cut(file_name(&s.file), FILE),
        s.way,
        line,
        took,
        estimate,
        run.how()
    )
}

/// The last `n` runs as the table, newest last.
pub fn table(runs: &[Run], n: usize) -> Vec<String> {
    let from = runs.len().saturating_sub(n);
    let mut lines = vec![HEAD.to_owned()];
    lines.extend(runs.get(from..).unwrap_or_default().iter().map(row));
    lines
}

/// `2026-12-07T11:05:12Z` as `2026-12-07 11:05`.
fn started(at: &str) -> String {
    let short: String = at.chars().take(16).collect();
    short.replacen('T', " ", 1)
}

/// The file's own name, without its folders.
fn file_name(path: &str) -> &str {
    path.rsplit('/').next().unwrap_or(path)
}

/// `text` within `width` characters, a cut one ending in `…`.
fn cut(text: &str, width: usize) -> String {
    if text.chars().count() <= width {
        return text.to_owned();
    }
    let mut short: String = text.chars().take(width.saturating_sub(1)).collect();
    short.push('…');
    short
}

/// One run as JSON (`jogterm log --json`).
pub fn json(run: &Run) -> Value {
    let s = &run.start;
    json!({
        "run": s.run,
        "file": s.file,
        "hash": s.hash,
        "profile": s.profile,
        "port": s.port,
        "work_offset": s.offset,
        "way": s.way,
        "by": s.by,
        "started": s.at,
        "ended": run.end_at,
        "how": run.how(),
        "last_line": run.last_line,
        "from_line": s.from_line,
        "estimated_s": s.estimate_s,
        "actual_s": run.elapsed_s,
        "resume_line": if run.interrupted() { run.resume_line() } else { None },
    })
}

#[cfg(test)]
mod tests {
    use super::super::fold::fold;
    use super::super::record::{How, Record, Start, test_start};
    use super::*;

    fn runs() -> Vec<Run> {
        let long = Start {
            file: "/jobs/a-very-long-name-of-a-cam-file-v2.nc".into(),
            estimate_s: Some(3725.0),
            way: "chunked".into(),
            ..test_start("b", "h2")
        };
        let text: String = [
            Record::start(test_start("a", "h1")),
            Record::Line {
                run: "a".into(),
                line: 1200,
                t: 70.0,
            },
            Record::End {
                run: "a".into(),
                at: "2026-12-07T11:06:22Z".into(),
                how: How::Done,
                line: Some(1234),
                t: 70.4,
            },
            Record::start(long),
            Record::Line {
                run: "b".into(),
                line: 999_999,
                t: 40_000.0,
            },
        ]
        .iter()
        .map(Record::line_text)
        .collect();
        fold("log", &text).runs
    }

    #[test]
    fn the_table_fits_80_columns_newest_last() {
        let lines = table(&runs(), 10);
        assert_eq!(
            lines,
            [
                HEAD,
                "2026-12-07 11:05 part.nc            stream    1234  1:10 min  1:04 min done",
                "2026-12-07 11:05 a-very-long-name-… chunked 999999 11:06:40 h 1:02:05 h crash",
            ]
        );
        assert!(lines.iter().all(|l| l.chars().count() <= 80), "{lines:#?}");
        // -n 1: the newest only.
        assert_eq!(table(&runs(), 1).len(), 2);
        assert!(table(&runs(), 1)[1].ends_with("crash"));
        assert_eq!(table(&[], 5), [HEAD]);
    }

    #[test]
    fn json_says_every_field_and_where_to_resume() {
        let runs = runs();
        let done = json(&runs[0]);
        assert_eq!(done["how"], "done");
        assert_eq!(done["last_line"], 1234);
        assert_eq!(done["actual_s"], 70.4);
        assert_eq!(done["estimated_s"], 64.0);
        assert_eq!(done["work_offset"], "G54 X50.000 Y50.000 Z60.000 mm");
        assert_eq!(done["resume_line"], Value::Null);
        let crash = json(&runs[1]);
        assert_eq!(crash["how"], "crash");
        assert_eq!(crash["ended"], Value::Null);
        assert_eq!(crash["resume_line"], 999_999);
    }
}
