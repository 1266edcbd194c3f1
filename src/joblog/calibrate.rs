//! The estimate refined by the log (issue 41 item 6): per profile and way,
//! the median of actual over estimated time of the last whole jobs that ran
//! to their end on this machine. Sans-IO: the folded log in, the factor
//! out; the model's own figure stays what it is and is said beside it.
//!
//! Only whole runs count: a restart from a line ran part of the job, a
//! stopped or failed run did not reach its end. A run that waited for the
//! operator (a tool change, M0) counts its wait, which no model knows; the
//! median of several keeps one such run from moving the figure.

use super::fold::{Ended, Folded};
use super::record::How;

/// How many of the newest runs the median is taken over.
pub const RUNS: usize = 5;

/// Fewer runs than this refine nothing: one odd run is no measurement.
pub const AT_LEAST: usize = 3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Actual over estimated time, the median.
    pub ratio: f64,
    /// The runs it was taken over.
    pub runs: usize,
}

impl Calibration {
    /// `1:04 min by the model, 1:10 min from the last 5 jobs on this
    /// machine (profile isel, stored)`.
    pub fn describe(&self, estimate_s: f64, profile: &str, way: &str) -> String {
        format!(
            "{} by the model, {} from the last {} jobs on this machine (profile {profile}, {way})",
            crate::gcode::ways::duration(estimate_s),
            crate::gcode::ways::duration(estimate_s * self.ratio),
            self.runs
        )
    }
}

/// The factor for `profile` and `way` (`stored`, `chunked`, `stream`, as
/// the start record says them); `None` with fewer than [`AT_LEAST`] runs.
pub fn of(folded: &Folded, profile: &str, way: &str) -> Option<Calibration> {
    let mut ratios: Vec<f64> = folded
        .runs
        .iter()
        .rev()
        .filter(|r| {
            r.ended == Ended::By(How::Done)
                && r.start.profile == profile
                && r.start.way == way
                && r.start.from_line.is_none()
        })
        .filter_map(|r| {
            let estimate = r.start.estimate_s.filter(|e| *e > 0.0)?;
            let actual = r.elapsed_s.filter(|a| *a > 0.0)?;
            Some(actual / estimate)
        })
        .filter(|q| q.is_finite())
        .take(RUNS)
        .collect();
    if ratios.len() < AT_LEAST {
        return None;
    }
    ratios.sort_by(f64::total_cmp);
    let mid = ratios.len() / 2;
    let ratio = if ratios.len() % 2 == 1 {
        ratios[mid]
    } else {
        (ratios[mid - 1] + ratios[mid]) / 2.0
    };
    Some(Calibration {
        ratio,
        runs: ratios.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::fold::fold;
    use super::super::record::{Record, test_start};
    use super::*;

    /// A whole run of `way` estimated at 64 s that took `took` s and ended
    /// as `how`.
    fn run(id: &str, way: &str, took: f64, how: How, from_line: Option<u32>) -> String {
        let mut start = test_start(id, "h");
        start.way = way.into();
        start.from_line = from_line;
        [
            Record::start(start),
            Record::End {
                run: id.into(),
                at: "2026-12-07T11:06:00Z".into(),
                how,
                line: None,
                t: took,
            },
        ]
        .iter()
        .map(Record::line_text)
        .collect()
    }

    #[test]
    fn the_median_of_the_last_whole_runs_that_ended() {
        let mut text = String::new();
        // Older runs beyond the last five do not count.
        for k in 0..3 {
            text += &run(&format!("old{k}"), "stream", 640.0, How::Done, None);
        }
        for (k, took) in [70.0, 72.0, 80.0, 66.0, 200.0].iter().enumerate() {
            text += &run(&format!("r{k}"), "stream", *took, How::Done, None);
        }
        // Neither a stopped run, a restart, nor another way counts.
        text += &run("s", "stream", 10.0, How::Stopped, None);
        text += &run("f", "stream", 10.0, How::Done, Some(40));
        text += &run("w", "stored", 10.0, How::Done, None);
        let c = of(&fold("log", &text), "default", "stream").expect("five runs");
        assert_eq!(c.runs, 5);
        assert!((c.ratio - 72.0 / 64.0).abs() < 1e-9, "{c:?}");
        assert_eq!(
            c.describe(64.0, "default", "stream"),
            "1:04 min by the model, 1:12 min from the last 5 jobs on this machine (profile default, stream)"
        );
    }

    #[test]
    fn fewer_than_three_runs_refine_nothing() {
        let text =
            run("a", "stream", 70.0, How::Done, None) + &run("b", "stream", 70.0, How::Done, None);
        assert_eq!(of(&fold("log", &text), "default", "stream"), None);
        assert_eq!(of(&Folded::default(), "default", "stream"), None);
    }
}
