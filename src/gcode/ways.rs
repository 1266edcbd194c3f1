//! The ways a converted job can run, what each costs before it starts, and
//! which one jogterm takes (issue 27, `docs/gcode.md` "Jobs bigger than the
//! memory").
//!
//! - **stored**: the whole program stored (`@0i`, `@F`) and started; only
//!   when it fits the controller's memory.
//! - **stream**: every command sent as a DNC command when the one before has
//!   been answered. The controllers buffer nothing and answer a move only
//!   once it has ended (isel manual 2.2), so between two commands the axes
//!   stand still for at least the command's and the reply's wire time: in
//!   the material unless the tool stands retracted.
//! - **chunked**: the job cut where the tool stands retracted at the safe
//!   height into parts that fit, each stored, run and replaced in turn. The
//!   tool waits for the erase (`@0k`, about 2 s, manual 2.2.17) and the
//!   next part's upload above the part, never in it.
//!
//! The choice weighs first the time the tool stands still in the material
//! (marks on the part), then the time in all. Motion is the controller's
//! model ([`super::timing`]: ramps from the profile's start-stop frequency
//! and acceleration, circles by their steps, dwells, reference runs); the
//! wire runs at the line's baud rate with 10 bits a byte, and a stream adds
//! the host's turnaround between an answer and the next command
//! ([`Costs::TURNAROUND_S`]). `cargo bench --bench jobs` measures every way
//! against it (`docs/performance.md`).

use std::sync::Arc;

use super::output::Program;
use super::timing::{Controller, Timing};
use crate::config::profile::Profile;
use crate::program::Language;

/// What the line and the controller cost besides motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Costs {
    /// The line's baud rate.
    pub baud: f64,
    /// Erasing the stored program before the next part is stored (isel
    /// `@0k`: about 2 s, manual 2.2.17).
    pub erase_s: f64,
    /// Whether the controller's jobs can be run in parts (isel: a part ends
    /// with `9` and the next is stored after an erase; EMCU jobs are not).
    pub parts: bool,
    /// The controller's model: ramps, reference runs, the DNC form.
    pub controller: Controller,
    /// Between a stream's answer and its next command: the host reading
    /// the answer and writing the next line (seconds).
    pub turnaround_s: f64,
}

impl Costs {
    pub const ISEL_ERASE_S: f64 = 2.0;
    /// The host's turnaround in a stream: the device task hands the answer
    /// to the run loop, which asks for the next line (measured with
    /// `cargo bench --bench jobs`, `docs/performance.md`).
    pub const TURNAROUND_S: f64 = 0.0;

    /// What the line and controller of `profile` cost besides motion, for
    /// a program in `language` (`jogterm run` and the editor's run key).
    pub fn of(profile: &Profile, language: Language) -> Costs {
        let baud = f64::from(profile.connection.line().baud);
        match language {
            Language::Isel => Costs {
                baud,
                erase_s: Costs::ISEL_ERASE_S,
                parts: true,
                controller: Controller::of(profile, language),
                turnaround_s: Costs::TURNAROUND_S,
            },
            // `@F` replaces a stored job; jobs are not run in parts.
            Language::Emcu => Costs {
                baud,
                erase_s: 0.0,
                parts: false,
                controller: Controller::of(profile, language),
                turnaround_s: Costs::TURNAROUND_S,
            },
        }
    }

    /// Seconds `bytes` take on the line.
    fn wire_s(&self, bytes: usize) -> f64 {
        bytes as f64 * 10.0 / self.baud.max(1.0)
    }
}

/// A way of running a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Way {
    Stored,
    Stream,
    Chunked,
}

impl std::fmt::Display for Way {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Way::Stored => "stored",
            Way::Stream => "stream",
            Way::Chunked => "chunked",
        })
    }
}

/// What one way costs, in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub way: Way,
    /// From the first command out to the last move's end.
    pub total_s: f64,
    /// The controller's motion time by the model (ramps, circles, dwells,
    /// reference runs): what every way spends moving.
    pub motion_s: f64,
    /// Still with the tool below the safe height: between two commands of
    /// a stream.
    pub at_part_s: f64,
    /// How many times the axes stop there.
    pub stops_at_part: usize,
    /// Still with the tool retracted (erases and uploads of parts after the
    /// first), or before the first move (the first upload).
    pub retracted_s: f64,
    /// Parts stored one after the other (1 for a stored program).
    pub parts: usize,
}

/// Every way that can run the job, the one taken and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Ways {
    pub stored: Option<Estimate>,
    pub stream: Estimate,
    /// Why the job cannot be cut where the tool stands retracted, or the
    /// controller runs no parts.
    pub chunked: Result<Estimate, String>,
    pub chosen: Way,
    /// The planner's time: feeds and rapids without ramps, no wire.
    pub floor_s: f64,
    /// The model the estimates come from, for the time left during a run.
    pub timing: Arc<Timing>,
    pub costs: Costs,
    /// Run in parts: each part's seconds (its erase, upload, start and
    /// run), which add up to `chunked`'s total; the time left of a job in
    /// parts (`eta::PartsEta`).
    pub part_s: Vec<f64>,
}

impl Ways {
    /// The estimates of `program` (its planner's motion time `floor_s`,
    /// no ramps) on a line and controller that cost `costs`.
    pub fn of(program: &Program, floor_s: f64, costs: &Costs) -> Ways {
        let timing = Arc::new(Timing::of(program, &costs.controller));
        let all = 0..program.lines.len();
        // Storing: `@0i` (isel) or `@F` (EMCU) and its answer, each line
        // and its answer, the program's end.
        let upload_s =
            |lines: std::ops::Range<usize>| costs.wire_s(timing.upload_bytes(lines) + 5 + 3);
        let motion_s = timing.motion_only_s(all.clone(), 1.0);
        let stored = program.fits().then(|| {
            let upload = upload_s(all.clone());
            // `@0S` / `@J` and the program's answer at its end.
            let start = costs.wire_s(5);
            let run = timing.stored_run_s(all.clone());
            Estimate {
                way: Way::Stored,
                total_s: upload + start + run,
                motion_s,
                at_part_s: 0.0,
                stops_at_part: 0,
                retracted_s: upload + start,
                parts: 1,
            }
        });
        let stream = Ways::stream_of(program, &timing, costs, 0..program.lines.len(), 1.0);
        let mut part_s = Vec::new();
        let chunked = if !costs.parts {
            Err("the controller's jobs are not run in parts".to_owned())
        } else {
            program.parts(program.capacity).map(|parts| {
                let mut retracted_s = 0.0;
                let mut run_s = 0.0;
                for (k, part) in parts.iter().enumerate() {
                    let lines = part.lines.clone();
                    let in_part = timing.within_count(lines.clone());
                    // The part's own `z1` and `9`, two bytes each with CR
                    // and answer, `z1` run for 1 ms.
                    let extra = costs.wire_s(3 * (part.commands.saturating_sub(in_part)));
                    let mut retracted = upload_s(lines.clone()) + extra + costs.wire_s(5);
                    let mut run = timing.stored_run_s(lines);
                    if k > 0 {
                        retracted += costs.erase_s;
                        run += Controller::ISEL_PROGRAM_STEP_S;
                    }
                    part_s.push(retracted + run);
                    retracted_s += retracted;
                    run_s += run;
                }
                Estimate {
                    way: Way::Chunked,
                    total_s: run_s + retracted_s,
                    motion_s,
                    at_part_s: 0.0,
                    stops_at_part: 0,
                    retracted_s,
                    parts: parts.len(),
                }
            })
        };
        let chosen = if stored.is_some() {
            Way::Stored
        } else {
            match &chunked {
                Ok(c) if (c.at_part_s, c.total_s) <= (stream.at_part_s, stream.total_s) => {
                    Way::Chunked
                }
                _ => Way::Stream,
            }
        };
        Ways {
            stored,
            stream,
            chunked,
            chosen,
            floor_s,
            timing,
            costs: *costs,
            part_s,
        }
    }

    /// The stream of `lines` at `factor` of the programmed speeds: every
    /// command sent when the one before has been answered, the axes
    /// standing from a move's end until the next command has arrived.
    fn stream_of(
        program: &Program,
        timing: &Timing,
        costs: &Costs,
        lines: std::ops::Range<usize>,
        factor: f64,
    ) -> Estimate {
        let mut at_part_s = 0.0;
        let mut stops_at_part = 0;
        let mut standing_s = 0.0;
        let mut moving_s = 0.0;
        let start = lines.start;
        let mut retracted = program.retracted.iter().peekable();
        while retracted.next_if(|&&r| r < start).is_some() {}
        let mut previous: Option<usize> = None;
        for step in timing.stream(lines, factor) {
            moving_s += step.motion_s;
            if step.bytes == 0 {
                continue;
            }
            let gap = costs.wire_s(step.bytes) + costs.turnaround_s * step.trips as f64;
            standing_s += gap;
            if let Some(before) = previous {
                while retracted.next_if(|&&r| r < before).is_some() {}
                if retracted.peek() != Some(&&before) {
                    at_part_s += gap;
                    stops_at_part += 1;
                }
            }
            previous = Some(step.line);
        }
        Estimate {
            way: Way::Stream,
            total_s: moving_s + standing_s,
            motion_s: moving_s,
            at_part_s,
            stops_at_part,
            retracted_s: standing_s - at_part_s,
            parts: 1,
        }
    }

    /// For every program line, the seconds a stream takes from it to the
    /// end at `factor` of the programmed speeds (one more entry: 0 at the
    /// end): the live ETA's model time, in one pass.
    pub fn stream_left(&self, lines: usize, factor: f64) -> Vec<f64> {
        let mut per_line = vec![0.0; lines + 1];
        for step in self.timing.stream(0..lines, factor) {
            let wire = if step.bytes == 0 {
                0.0
            } else {
                self.costs.wire_s(step.bytes) + self.costs.turnaround_s * step.trips as f64
            };
            if let Some(cell) = per_line.get_mut(step.line) {
                *cell += step.motion_s + wire;
            }
        }
        let mut left = 0.0;
        for cell in per_line.iter_mut().rev() {
            left += *cell;
            *cell = left;
        }
        per_line
    }

    /// The ways of an imported job (or of its restart's program, `restart`)
    /// on `profile`'s line and controller.
    pub fn of_import(
        import: &super::Import,
        restart: Option<&super::Restart>,
        profile: &Profile,
    ) -> Ways {
        let language = match import.target {
            super::target::Target::Isel => Language::Isel,
            super::target::Target::Emcu => Language::Emcu,
        };
        let (program, floor_s) = match restart {
            Some(r) => (&r.program, r.estimated_s),
            None => (&import.program, import.summary.estimated_s),
        };
        Ways::of(program, floor_s, &Costs::of(profile, language))
    }

    /// The time of the way chosen.
    pub fn chosen_s(&self) -> f64 {
        self.estimate(self.chosen)
            .map_or(self.stream.total_s, |e| e.total_s)
    }

    /// The estimate of `way`, where it can run the job.
    pub fn estimate(&self, way: Way) -> Option<&Estimate> {
        match way {
            Way::Stored => self.stored.as_ref(),
            Way::Stream => Some(&self.stream),
            Way::Chunked => self.chunked.as_ref().ok(),
        }
    }

    /// What to do with a job that does not fit the memory, from the same
    /// estimates as [`Ways::describe`], so that the advice never names a
    /// way its list says is not possible (issue 37): in parts where the
    /// job can be cut, else streamed.
    pub fn advice(&self) -> String {
        match &self.chunked {
            Ok(c) => format!(
                "store and run it in {} parts (`jogterm run FILE`, or `jogterm upload FILE \
                 --start --chunked`), or split the file in the CAM",
                c.parts
            ),
            Err(why) => format!(
                "it cannot run in parts ({why}): stream it (`jogterm run FILE --stream`), or \
                 split the file in the CAM"
            ),
        }
    }

    /// The operator's lines: each way with its cost, and the choice with
    /// by how much it beats the other.
    pub fn describe(&self) -> Vec<String> {
        let mut lines = Vec::new();
        if let Some(s) = &self.stored {
            lines.push(format!(
                "stored:  {} in all, {} of it storing the program before the start",
                duration(s.total_s),
                duration(s.retracted_s)
            ));
        }
        let s = &self.stream;
        lines.push(format!(
            "stream:  {} in all; the axes stop {} times with the tool in the part, {} there at least",
            duration(s.total_s),
            s.stops_at_part,
            duration(s.at_part_s)
        ));
        match &self.chunked {
            // A job that fits is stored whole: one part is no other way.
            _ if self.stored.is_some() => {}
            Ok(c) => lines.push(format!(
                "chunked: {} in all in {} parts; the tool waits {} retracted while parts are stored, never in the part",
                duration(c.total_s),
                c.parts,
                duration(c.retracted_s)
            )),
            Err(why) => lines.push(format!("chunked: not possible: {why}")),
        }
        lines.push(format!(
            "motion by the controller's ramps: {} (feeds alone, no ramps: {})",
            duration(self.stream.motion_s),
            duration(self.floor_s)
        ));
        let s = &self.stream;
        lines.push(format!(
            "stream: the tool stands {} in all between commands ({} of it in the part)",
            duration(s.at_part_s + s.retracted_s),
            duration(s.at_part_s)
        ));
        for why in &self.timing.listed {
            lines.push(format!("not timed (waits for the operator): {why}"));
        }
        let chosen = self.estimate(self.chosen).copied();
        let other = [Way::Stored, Way::Stream, Way::Chunked]
            .into_iter()
            .filter(|w| *w != self.chosen)
            .filter(|w| !(*w == Way::Chunked && self.stored.is_some()))
            .filter_map(|w| self.estimate(w))
            .min_by(|a, b| a.total_s.total_cmp(&b.total_s));
        if let (Some(c), Some(o)) = (chosen, other) {
            let by = o.total_s - c.total_s;
            let pace = if by >= 0.0 {
                format!("{} faster than {}", duration(by), o.way)
            } else {
                format!("{} slower than {}", duration(-by), o.way)
            };
            let part = if c.at_part_s < o.at_part_s {
                format!(
                    ", and {} less standing in the part",
                    duration(o.at_part_s - c.at_part_s)
                )
            } else {
                String::new()
            };
            lines.push(format!("chosen: {} ({pace}{part})", self.chosen));
        } else {
            lines.push(format!("chosen: {}", self.chosen));
        }
        lines
    }
}

/// `1:05:12`, `4:31 min`, `12.5 s`.
pub fn duration(s: f64) -> String {
    let s = s.max(0.0);
    if s < 60.0 {
        return format!("{s:.1} s");
    }
    let whole = s.round() as u64;
    let (h, m, sec) = (whole / 3600, whole / 60 % 60, whole % 60);
    if h > 0 {
        format!("{h}:{m:02}:{sec:02} h")
    } else {
        format!("{m}:{sec:02} min")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::output::ProgramLine;

    /// isel at 10 000 baud (1000 bytes/s), nothing else costing time: the
    /// test programs' `m1,2,3,4` go nowhere from their first point.
    const ISEL: Costs = Costs {
        baud: 10_000.0,
        erase_s: 2.0,
        parts: true,
        controller: Controller {
            language: Language::Isel,
            ramping: super::super::timing::Ramping::Accel {
                start_hz: 300.0,
                accel_hz_per_s: 100_000.0,
            },
            reference_hz: 2000.0,
            device: 0,
        },
        turnaround_s: 0.0,
    };

    /// Commands of 8 bytes (`m1,2,3,4`); `retracted`: indices into lines.
    fn program(commands: usize, retracted: &[usize], capacity: usize) -> Program {
        let mut p = Program {
            capacity,
            ..Program::default()
        };
        for _ in 0..commands {
            p.lines.push(ProgramLine {
                command: "m1,2,3,4".into(),
                comment: None,
                origin: None,
            });
        }
        p.commands = commands;
        p.retracted = retracted.to_vec();
        p
    }

    #[test]
    fn a_job_that_fits_is_stored() {
        let ways = Ways::of(&program(4, &[1], 10), 30.0, &ISEL);
        assert_eq!(ways.chosen, Way::Stored);
        let stored = ways.stored.unwrap();
        // 4 commands of 8 bytes + CR + reply, `@0i` and `9` with their
        // answers (8 bytes), `@0S` and the end's answer (5) at 1000 bytes/s.
        assert!((stored.retracted_s - 0.053).abs() < 1e-9, "{stored:?}");
        // The moves go nowhere: the run is 4 ms of stored commands.
        assert!((stored.total_s - 0.057).abs() < 1e-9, "{stored:?}");
    }

    #[test]
    fn the_stream_stops_at_the_part_at_every_boundary_but_the_retracts() {
        let ways = Ways::of(&program(6, &[2], 4), 10.0, &ISEL);
        let s = ways.stream;
        // Boundaries after 0,1,2,3,4: the one after 2 is at the safe height.
        assert_eq!(s.stops_at_part, 4);
        // Each: 8 bytes + `@0` + CR + reply = 12 bytes, and without a
        // reference run the position read after it (23 bytes): 35 ms.
        assert!((s.at_part_s - 0.140).abs() < 1e-9, "{s:?}");
        assert!((s.total_s - 6.0 * 0.035).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn chunked_wins_where_the_job_can_be_cut_and_says_by_how_much() {
        // 8 commands, memory 6 (4 after a part's z1 and 9), retract after 3.
        let ways = Ways::of(&program(8, &[3], 6), 10.0, &ISEL);
        let chunked = ways.chunked.clone().unwrap();
        assert_eq!(chunked.parts, 2);
        // Each part's time, the erase in the second's, adds up to the way's.
        assert_eq!(ways.part_s.len(), 2);
        assert!(ways.part_s[1] > 2.0, "{:?}", ways.part_s);
        let sum: f64 = ways.part_s.iter().sum();
        assert!((sum - chunked.total_s).abs() < 1e-9, "{sum} {chunked:?}");
        assert_eq!(ways.chosen, Way::Chunked);
        // One erase of 2 s between the parts, nothing at the part.
        assert!(chunked.retracted_s > 2.0 && chunked.at_part_s == 0.0);
        let text = ways.describe().join("\n");
        assert!(text.contains("chosen: chunked ("), "{text}");
        assert!(text.contains("slower than stream"), "{text}");
        assert!(text.contains("less standing in the part"), "{text}");
    }

    #[test]
    fn without_a_retract_to_cut_at_the_stream_is_chosen_and_why_is_said() {
        let ways = Ways::of(&program(8, &[], 6), 10.0, &ISEL);
        assert_eq!(ways.chosen, Way::Stream);
        let text = ways.describe().join("\n");
        assert!(text.contains("chunked: not possible: no retract"), "{text}");
        let emcu = Costs {
            parts: false,
            ..ISEL
        };
        let ways = Ways::of(&program(8, &[3], 6), 10.0, &emcu);
        assert_eq!(ways.chosen, Way::Stream);
        assert!(ways.chunked.is_err());
    }

    #[test]
    fn the_time_left_of_a_stream_counts_from_each_line_to_the_end() {
        let p = program(6, &[2], 4);
        let ways = Ways::of(&p, 10.0, &ISEL);
        let left = ways.stream_left(p.lines.len(), 1.0);
        assert_eq!(left.len(), 7);
        assert!((left[0] - ways.stream.total_s).abs() < 1e-9);
        // Each command 35 ms (its bytes and the position read, the moves
        // going nowhere).
        assert!((left[4] - 0.070).abs() < 1e-9, "{left:?}");
        assert_eq!(left[6], 0.0);
    }

    #[test]
    fn durations_read_as_an_operator_reads_them() {
        assert_eq!(duration(12.46), "12.5 s");
        assert_eq!(duration(271.0), "4:31 min");
        assert_eq!(duration(3912.0), "1:05:12 h");
    }
}
