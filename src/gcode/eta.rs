//! The live ETA of a streamed job (issue 41 item 3), for `jogterm run
//! --stream` and the console's stream alike: the model's time of what is
//! left ([`Ways::stream_left`], at the speed factor in force), corrected
//! by the pace measured so far: the seconds the job has run since its first
//! G-code line, pauses left out, over the model's seconds of what it has
//! done, each command at the factor it was sent with. Sans-IO: the caller
//! hands in the time.

use std::collections::HashMap;
use std::sync::Arc;

use super::ways::Ways;

/// How far the measured pace may stretch the model: a hold-up early on
/// must not make a forecast of hours.
const PACE: std::ops::RangeInclusive<f64> = 0.5..=3.0;

#[derive(Debug, Clone, PartialEq)]
pub struct Eta {
    ways: Arc<Ways>,
    lines: usize,
    /// The model's time left from each line, per speed factor (percent).
    left: HashMap<u32, Vec<f64>>,
    /// The model's seconds of what has been done, at the factors it ran at.
    done_s: f64,
    /// The line being run and the factor it was sent with.
    at: Option<(usize, u32)>,
    /// The running seconds when the job's first G-code line started: the
    /// pace counts from there. The set-up before it (a reference run from
    /// wherever the axes stand) is a guess of the model's, not a pace.
    baseline_s: Option<f64>,
}

impl Eta {
    /// The ETA of a program of `lines` commands whose ways are `ways`.
    pub fn new(ways: Arc<Ways>, lines: usize) -> Eta {
        // The programmed speeds' table, for the lines before the first
        // G-code line (the set-up) says when the job will end.
        let programmed = ways.stream_left(lines, 1.0);
        Eta {
            ways,
            lines,
            left: HashMap::from([(100, programmed)]),
            done_s: 0.0,
            at: None,
            baseline_s: None,
        }
    }

    fn table(&mut self, percent: u32) -> &[f64] {
        let (ways, lines) = (&self.ways, self.lines);
        self.left
            .entry(percent)
            .or_insert_with(|| ways.stream_left(lines, f64::from(percent) / 100.0))
    }

    fn left_in(table: &[f64], line: usize) -> f64 {
        table
            .get(line.min(table.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0)
    }

    /// Program line `line` (a G-code line's command) starts with the speed
    /// factor `percent`, after `running_s` seconds of running: the line
    /// before it is done.
    pub fn start(&mut self, line: usize, percent: u32, running_s: f64) {
        self.baseline_s.get_or_insert(running_s);
        if let Some((before, p)) = self.at
            && line > before
        {
            let table = self.table(p);
            let done = Eta::left_in(table, before) - Eta::left_in(table, line);
            self.done_s += done;
        }
        self.table(percent);
        self.at = Some((line, percent));
    }

    /// Seconds left from program line `line` on at the factor of the line
    /// started last (before any, the programmed speeds), after `running_s`
    /// seconds of running (pauses not counted).
    pub fn left_s(&self, line: usize, running_s: f64) -> Option<f64> {
        let percent = self.at.map_or(100, |(_, p)| p);
        let model = Eta::left_in(self.left.get(&percent)?, line);
        let running_s = running_s - self.baseline_s.unwrap_or(running_s);
        Some(if self.done_s > 0.5 && running_s > 0.0 {
            let pace = (running_s / self.done_s).clamp(*PACE.start(), *PACE.end());
            model * pace
        } else {
            model
        })
    }

    /// The speed factor of the line started last.
    pub fn percent(&self) -> Option<u32> {
        self.at.map(|(_, p)| p)
    }
}

/// The time left of a job run in parts (issue 41 item 3), for `jogterm
/// run` and the console alike: a stored part reports nothing while it
/// runs, so the model's time of the part under way (its erase, upload,
/// start and run: [`Ways::part_s`]) less the time it has taken so far,
/// and of every part after it, each stretched by the pace of the parts
/// done (their time measured from the upload to the end, a pause before
/// a part left out, over the model's).
#[derive(Debug, Clone, PartialEq)]
pub struct PartsEta {
    model_s: Vec<f64>,
    done_model_s: f64,
    done_actual_s: f64,
}

impl PartsEta {
    /// `model_s`: each part's seconds by the model.
    pub fn new(model_s: Vec<f64>) -> PartsEta {
        PartsEta {
            model_s,
            done_model_s: 0.0,
            done_actual_s: 0.0,
        }
    }

    /// Part `k` (0-based) has ended after `actual_s` seconds.
    pub fn part_done(&mut self, k: usize, actual_s: f64) {
        if let Some(model) = self.model_s.get(k) {
            self.done_model_s += model;
            self.done_actual_s += actual_s;
        }
    }

    /// Seconds left while part `k` has run for `in_part_s` seconds.
    pub fn left_s(&self, k: usize, in_part_s: f64) -> Option<f64> {
        let here = *self.model_s.get(k)?;
        let after: f64 = self.model_s.iter().skip(k + 1).sum();
        let pace = if self.done_model_s > 0.5 {
            (self.done_actual_s / self.done_model_s).clamp(*PACE.start(), *PACE.end())
        } else {
            1.0
        };
        Some((here * pace - in_part_s).max(0.0) + after * pace)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::output::{Program, ProgramLine};
    use crate::gcode::ways::Costs;

    /// Moves of 10 000 steps at 5300 Hz, 1.933962 s each, and a stream
    /// of them at 19200 baud.
    fn job(moves: usize) -> (Program, Ways) {
        let mut p = Program {
            capacity: 10,
            ..Program::default()
        };
        for k in 0..=moves {
            let x = if k % 2 == 0 { 0 } else { 10_000 };
            p.lines.push(ProgramLine {
                command: format!("m{x},5300,0,5300,0,5300,0,5300"),
                comment: None,
                origin: None,
            });
            p.commands += 1;
        }
        let profile =
            crate::config::load_profile("isel", &crate::config::ConfigDirs::builtin_only())
                .expect("shipped profile");
        let costs = Costs::of(&profile, crate::program::Language::Isel);
        let ways = Ways::of(&p, 0.0, &costs);
        (p, ways)
    }

    fn eta(ways: &Ways, lines: usize) -> Eta {
        Eta::new(Arc::new(ways.clone()), lines)
    }

    fn left(eta: &Eta, line: usize, running_s: f64) -> f64 {
        eta.left_s(line, running_s).expect("a line started")
    }

    #[test]
    fn the_time_left_follows_the_model_then_the_pace() {
        let (p, ways) = job(10);
        let mut eta = eta(&ways, p.lines.len());
        assert_eq!(
            eta.left_s(0, 0.0),
            Some(ways.stream.total_s),
            "before the first line: the programmed speeds"
        );
        eta.start(0, 100, 0.0);
        let all = left(&eta, 0, 0.0);
        assert!((all - ways.stream.total_s).abs() < 1e-9);
        // Half done at the model's pace: half left.
        eta.start(6, 100, 0.0);
        let model_done = all - left(&eta, 6, 0.0);
        let rest = left(&eta, 6, model_done);
        assert!((rest - (all - model_done)).abs() < 1e-6, "{rest}");
        // Run 20 % slower than the model so far: 20 % more left.
        let slow = left(&eta, 6, model_done * 1.2);
        assert!((slow - 1.2 * rest).abs() < 1e-6, "{slow} {rest}");
    }

    #[test]
    fn the_set_up_before_the_first_line_is_no_pace() {
        let (p, ways) = job(10);
        let mut eta = eta(&ways, p.lines.len());
        // A reference run of 20 s before the job's first line.
        eta.start(0, 100, 20.0);
        let all = left(&eta, 0, 20.0);
        eta.start(6, 100, 20.0);
        let model_done = all - left(&eta, 6, 20.0);
        let rest = left(&eta, 6, 20.0 + model_done);
        assert!((rest - (all - model_done)).abs() < 1e-6, "{rest}");
    }

    #[test]
    fn half_the_speed_leaves_about_twice_the_motion() {
        let (p, ways) = job(10);
        let mut eta = eta(&ways, p.lines.len());
        eta.start(0, 100, 0.0);
        let full = left(&eta, 0, 0.0);
        eta.start(0, 50, 0.0);
        let half = left(&eta, 0, 0.0);
        assert_eq!(eta.percent(), Some(50));
        // The cruise doubles, the ramps shrink and the wire stays.
        assert!(half > 1.8 * full && half < 2.0 * full, "{full} {half}");
    }

    #[test]
    fn a_job_in_parts_counts_the_part_under_way_down_and_the_rest_at_the_pace_so_far() {
        let mut eta = PartsEta::new(vec![10.0, 20.0, 30.0]);
        assert_eq!(eta.left_s(0, 0.0), Some(60.0));
        assert_eq!(eta.left_s(0, 4.0), Some(56.0));
        // A part that overruns its model stays at nothing left, not less.
        assert_eq!(eta.left_s(0, 15.0), Some(50.0));
        // The first part took twice the model: what is left is stretched.
        eta.part_done(0, 20.0);
        assert_eq!(eta.left_s(1, 0.0), Some(100.0));
        assert_eq!(eta.left_s(1, 10.0), Some(90.0));
        assert_eq!(eta.left_s(3, 0.0), None);
        // A hold-up early on makes no forecast of hours: the pace is capped.
        let mut slow = PartsEta::new(vec![1.0, 100.0]);
        slow.part_done(0, 50.0);
        assert_eq!(slow.left_s(1, 0.0), Some(300.0));
    }
}
