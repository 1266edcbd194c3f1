//! One call from G-code text to everything the CLI, the editor and the
//! runs need: the toolpath, its check against the machine, the figures and
//! the controller program.

use crate::config::profile::Profile;
use crate::offsets::WorkOffsets;
use crate::proto::Protocol;

use super::check::{Machine, Summary, check_limits, summarise};
use super::output::{Header, Program};
use super::setup::Setup;
use super::toolpath::{Diagnostic, Origin, Toolpath};

/// Which controller program to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    Isel,
    Emcu,
}

impl Target {
    /// The profile's family, or why it has none.
    pub fn of(protocol: Protocol) -> Result<Target, String> {
        match protocol {
            Protocol::Isel => Ok(Target::Isel),
            Protocol::Emcu => Ok(Target::Emcu),
            Protocol::Emp => Err(
                "the EMP (MSR DRS-500-ECS) drives run independently: they have no interpolated path, so G-code cannot run on them".into(),
            ),
        }
    }

    /// The positions in steps the family's counter holds: isel 24-bit two's
    /// complement (`@0P`, manual 3.2.16), EMCU `L` moves ±999999 steps.
    pub fn counter(self) -> std::ops::RangeInclusive<i64> {
        match self {
            Target::Isel => {
                let r = crate::proto::isel::STEPS;
                i64::from(*r.start())..=i64::from(*r.end())
            }
            Target::Emcu => {
                use crate::proto::emcu::values::Steps;
                i64::from(Steps::MIN)..=i64::from(Steps::MAX)
            }
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Target::Isel => "isel",
            Target::Emcu => "emcu",
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Import {
    pub toolpath: Toolpath,
    pub summary: Summary,
    pub program: Program,
    pub target: Target,
    /// The interpreter's and the output's warnings, in line order.
    pub warnings: Vec<Diagnostic>,
}

fn at_start(message: impl Into<String>) -> Vec<Diagnostic> {
    vec![Diagnostic::error(Origin { line: 1, col: 1 }, message)]
}

/// Reads, interprets, checks and converts `text` (named `file` in the
/// program's header) for `profile`, with the work offsets in force.
pub fn import(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    target: Target,
) -> Result<Import, Vec<Diagnostic>> {
    let setup = Setup::from_profile(profile, offsets).map_err(|errors| {
        errors
            .into_iter()
            .flat_map(|e| at_start(format!("profile: {}: {}", e.key, e.message)))
            .collect::<Vec<_>>()
    })?;
    let toolpath = super::interpret(text, &setup)?;
    let machine = Machine::from_profile(profile, target);
    check_limits(&toolpath, &machine).map_err(|e| vec![e])?;
    let summary = summarise(&toolpath, &machine);
    let header = Header {
        file: file.to_owned(),
        profile: profile.name.clone(),
        system: summary.system.to_string(),
        zero: summary.zero,
    };
    let program = match target {
        Target::Isel => super::isel::convert(&toolpath, profile, &header)?,
        Target::Emcu => super::emcu::convert(&toolpath, profile, &header)?,
    };
    let mut warnings = toolpath.warnings.clone();
    warnings.extend(program.warnings.iter().cloned());
    warnings.sort_by_key(|w| w.origin);
    Ok(Import {
        toolpath,
        summary,
        program,
        target,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    //! Random toolpaths through the whole import and back: the isel program
    //! jogterm writes, run through the program preview (`program::path`,
    //! the controller's own arithmetic in steps), ends where the G-code ends
    //! and stays inside the G-code's extents; so does the EMCU job.

    use proptest::prelude::*;

    use super::*;
    use crate::axis::Axis;
    use crate::config::{ConfigDirs, load_profile};
    use crate::offsets::System;
    use crate::program::path::{Start, path};
    use crate::program::{Language, Program as ControllerProgram};

    fn profile() -> Profile {
        load_profile("default", &ConfigDirs::builtin_only()).expect("the default profile")
    }

    /// G54's zero at machine X100 Y100 Z40 mm, in steps.
    fn offsets(profile: &Profile) -> WorkOffsets {
        let mut o = WorkOffsets::default();
        for (axis, mm) in [(Axis::X, 100.0), (Axis::Y, 100.0), (Axis::Z, 40.0)] {
            let steps = profile.axis(axis).map_or(0, |p| p.to_steps(mm));
            o.set(System::G54, axis, steps);
        }
        o
    }

    #[derive(Debug, Clone)]
    enum Step {
        Line(f64, f64, f64),
        Arc {
            dx: f64,
            dy: f64,
            span: f64,
            cw: bool,
        },
    }

    fn step() -> impl Strategy<Value = Step> {
        prop_oneof![
            (-40.0..40.0f64, -40.0..40.0f64, -20.0..20.0f64)
                .prop_map(|(x, y, z)| Step::Line(x, y, z)),
            (-15.0..15.0f64, -15.0..15.0f64, 0.2..6.0f64, any::<bool>())
                .prop_map(|(dx, dy, span, cw)| Step::Arc { dx, dy, span, cw }),
        ]
    }

    /// G-code of the steps and its last point in work mm (to 4 decimals,
    /// as printed).
    fn gcode(steps: &[Step]) -> (String, [f64; 3]) {
        let mut text = String::from("G21 G90 G17\nG0 X0 Y0 Z5\n");
        let mut at = [0.0f64, 0.0, 5.0];
        for s in steps {
            match *s {
                Step::Line(x, y, z) => {
                    let (x, y, z) = (round4(x), round4(y), round4(z));
                    text.push_str(&format!("G1 X{x:.4} Y{y:.4} Z{z:.4} F1200\n"));
                    at = [x, y, z];
                }
                Step::Arc { dx, dy, span, cw } => {
                    // Centre at (dx, dy) from here; the end `span` radians on.
                    let (cx, cy) = (at[0] + dx, at[1] + dy);
                    let r = dx.hypot(dy);
                    if r < 0.5 {
                        continue;
                    }
                    let a0 = (-dy).atan2(-dx);
                    let a1 = if cw { a0 - span } else { a0 + span };
                    let (ex, ey) = (round4(cx + r * a1.cos()), round4(cy + r * a1.sin()));
                    let (i, j) = (round4(dx), round4(dy));
                    let g = if cw { 2 } else { 3 };
                    text.push_str(&format!("G{g} X{ex:.4} Y{ey:.4} I{i:.4} J{j:.4} F900\n"));
                    at = [ex, ey, at[2]];
                }
            }
        }
        text.push_str("M30\n");
        (text, at)
    }

    fn round4(v: f64) -> f64 {
        (v * 1e4).round() / 1e4
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn random_toolpaths_end_and_stay_where_the_gcode_says_in_steps(
            steps in prop::collection::vec(step(), 1..12)
        ) {
            let profile = profile();
            let offsets = offsets(&profile);
            let (text, last) = gcode(&steps);
            let imported = match import(&text, "r.nc", &profile, &offsets, Target::Isel) {
                Ok(i) => i,
                // An arc whose printed end left its circle by rounding, or
                // that left the machine: nothing to compare.
                Err(e) => {
                    let why = format!("{e:?}");
                    prop_assume!(false, "{}", why);
                    unreachable!()
                }
            };
            let expected: Vec<i64> = [(Axis::X, 100.0), (Axis::Y, 100.0), (Axis::Z, 40.0)]
                .iter()
                .zip(last)
                .map(|((axis, zero), v)| {
                    profile.axis(*axis).map_or(0, |p| p.to_steps(v + zero))
                })
                .collect();
            // The controller's view: the stored program from the reference
            // point, through the preview's step arithmetic.
            let program_text = imported.program.text("r.nc");
            let program = ControllerProgram::parse(Language::Isel, &program_text);
            let run = path(&program, &Start::new(profile.axis_set(), [0; 4]));
            prop_assert_eq!(&run.end[..3], &expected[..], "{}", program_text);
            // Every point of it inside the G-code's extents (arcs' bulges
            // included), within a step of rounding.
            let e = &imported.summary.extents;
            for segment in &run.segments {
                for (i, axis) in [Axis::X, Axis::Y, Axis::Z].into_iter().enumerate() {
                    let Some((min, max)) = e.range(i) else { continue };
                    let p = profile.axis(axis).expect("axis");
                    let zero = [100.0, 100.0, 40.0][i];
                    let (lo, hi) = (p.to_steps(min + zero) - 2, p.to_steps(max + zero) + 2);
                    let v = segment.to[i];
                    // The reference run and the first rapid start outside
                    // the file's own points.
                    if segment.index < 3 {
                        continue;
                    }
                    prop_assert!(v >= lo && v <= hi, "{axis} {v} outside {lo}..{hi}\n{program_text}");
                }
            }
            // The EMCU job ends there too (its chords end on the arcs' ends).
            let job = import(&text, "r.nc", &profile, &offsets, Target::Emcu);
            if let Ok(job) = job {
                let last_move = job.program.lines.iter().rev().find(|l| l.command.starts_with('L'));
                let words: Vec<i64> = last_move
                    .map(|l| l.command.split(',').skip(1).map(|w| w[1..].parse().unwrap_or(0)).collect())
                    .unwrap_or_default();
                prop_assert_eq!(&words[..], &expected[..]);
            }
        }
    }
}
