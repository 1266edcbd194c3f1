//! One call from G-code text to everything the CLI, the editor and the
//! runs need: the toolpath, its check against the machine, the figures and
//! the controller program.

use crate::config::profile::Profile;
use crate::offsets::WorkOffsets;

use super::check::{Summary, check_limits_ops, first_system, summarise};
use super::heightmap::{Applied, Surface};
use super::output::{Header, Program};
use super::profile::{fit_of, machine_of, setup_of};
use super::target::Target;
use super::toolpath::{Diagnostic, Origin, Toolpath};

#[derive(Debug, Clone, PartialEq)]
pub struct Import {
    pub toolpath: Toolpath,
    pub summary: Summary,
    pub program: Program,
    pub target: Target,
    /// The interpreter's and the output's warnings, in line order.
    pub warnings: Vec<Diagnostic>,
    /// The height map the toolpath follows (`--height-map`).
    pub height_map: Option<MapApplied>,
    /// The job cut at its tool changes and pauses (`gcode::waits`); the
    /// program is its whole job, each wait the program's own.
    pub plan: super::toolchange::Plan,
    /// The tool-length offset applied to every Z (`jogterm probe tool`).
    pub tool: Option<super::waits::ToolOffset>,
}

/// A height map read from its file (`--height-map FILE`), to import with.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMapFile {
    /// The file as the operator named it.
    pub name: String,
    pub surface: Surface,
}

/// What a height map did to an import, for its summary.
#[derive(Debug, Clone, PartialEq)]
pub struct MapApplied {
    pub file: String,
    pub applied: Applied,
}

impl MapApplied {
    /// The summary's line of a height map (`now_unix`: seconds since
    /// 1970, for how long ago it was probed).
    pub fn describe(&self, now_unix: i64) -> String {
        let a = &self.applied;
        let mut line = format!(
            "  height map {}: {} points, correction {:+.3} .. {:+.3} mm, probed {}; {} feed moves as {} on the surface",
            self.file,
            a.points,
            a.correction_min,
            a.correction_max,
            age(a.age_s(now_unix)),
            a.feed_moves,
            a.feed_segments,
        );
        match a.arcs_as_segments {
            0 => {}
            1 => line.push_str(" (1 arc as segments)"),
            n => line.push_str(&format!(" ({n} arcs as segments)")),
        }
        line.push_str(&format!(", rapids raised {:.3} mm", a.rapids_raised));
        if a.z_zero_moved.abs() > 5e-4 {
            line.push_str(&format!(
                "; the Z zero moved {:+.3} mm since probing: the cut moves with it",
                a.z_zero_moved
            ));
        }
        line.push('\n');
        line
    }
}

/// How long ago a map was probed: minutes, hours or days.
fn age(seconds: i64) -> String {
    match seconds {
        s if s < 0 => "in the future (check this computer's clock)".to_owned(),
        s if s < 3600 => format!("{} min ago", s / 60),
        s if s < 2 * 86_400 => format!("{} h {} min ago", s / 3600, s / 60 % 60),
        s => format!("{} days ago", s / 86_400),
    }
}

/// The name a G-code file goes by in its program's header and reports:
/// its file name.
pub fn header_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

fn at_start(message: impl Into<String>) -> Vec<Diagnostic> {
    vec![Diagnostic::error(Origin { line: 1, col: 1 }, message)]
}

/// The machine check's and the summary's time as a share of the isel
/// conversion's (`cargo bench --bench gcode`: 11-15 ms against 78-90 ms).
const CHECK_SHARE: f64 = 0.14;

/// Reads, interprets, checks and converts `text` (named `file` in the
/// program's header) for `profile`, with the work offsets in force.
pub fn import(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    target: Target,
) -> Result<Import, Vec<Diagnostic>> {
    import_with_map(text, file, profile, offsets, target, None)
}

/// [`import`], and when given onto a height map's surface: after
/// interpreting and before the machine check, so that the soft limits and
/// the program see the Z the tool cuts at.
pub fn import_with_map(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    target: Target,
    height_map: Option<&HeightMapFile>,
) -> Result<Import, Vec<Diagnostic>> {
    import_with_tool(text, file, profile, offsets, target, height_map, None)
}

/// [`import_with_map`], every Z shifted by the tool-length offset of the
/// tool in the spindle (after the height map: the offset is the tool's,
/// the map the surface's).
pub fn import_with_tool(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    target: Target,
    height_map: Option<&HeightMapFile>,
    tool: Option<&super::waits::ToolOffset>,
) -> Result<Import, Vec<Diagnostic>> {
    let setup = setup_of(profile, offsets).map_err(|errors| {
        errors
            .into_iter()
            .flat_map(|e| at_start(format!("profile: {}: {}", e.key, e.message)))
            .collect::<Vec<_>>()
    })?;
    let toolpath = super::interpret(text, &setup)?;
    let (toolpath, height_map) = match height_map {
        Some(map) => {
            let (path, applied) = map.surface.apply(&toolpath, &fit_of(profile))?;
            let applied = MapApplied {
                file: map.name.clone(),
                applied,
            };
            (path, Some(applied))
        }
        None => (toolpath, None),
    };
    let dz = tool.map_or(0.0, |t| t.offset_mm);
    let toolpath = if dz == 0.0 {
        toolpath
    } else {
        super::toolchange::shift_toolpath(&toolpath, dz)
    };
    // The plan of the shifted job: its pieces shift no further (dz 0).
    let plan = super::waits::plan_of(text, &toolpath, profile)?;
    // The whole job with the moves around its waits, one op at a time:
    // not collected, so that the job's ops are not copied.
    let slices = plan.expanded_slices(&toolpath);
    let whole = || slices.iter().flat_map(|s| s.iter());
    let machine = machine_of(profile, target);
    let (system, zero) = first_system(&toolpath);
    let header = Header {
        file: file.to_owned(),
        profile: profile.name.clone(),
        system: system.to_string(),
        zero,
    };
    let options = super::Options {
        continued: false,
        safe_z: Some(plan.safe_z),
    };
    let check = || {
        check_limits_ops(whole(), &machine)?;
        Ok::<_, Diagnostic>(summarise(&toolpath, &machine))
    };
    // The machine check and the summary beside the conversion, on two
    // cores: neither needs the other, and the import of a long file then
    // takes the conversion's time alone (issue 41 item 7). A job the check
    // refuses is refused as before: its error first, the program made
    // meanwhile dropped (nothing left the process).
    let (checked, program) = match target {
        Target::Isel => {
            let mut checked = None;
            let program = super::isel::convert_ops_beside(
                whole,
                profile,
                &header,
                &options,
                super::isel::Beside {
                    work: &mut || checked = Some(check()),
                    share: CHECK_SHARE,
                },
            );
            (checked.unwrap_or_else(check), program)
        }
        Target::Emcu => std::thread::scope(|scope| {
            let checking = std::thread::Builder::new()
                .name("gcode-check".into())
                .spawn_scoped(scope, check);
            let program = super::emcu::convert_ops(whole(), profile, &header, &options);
            // A thread the system would not start: the check runs here.
            let checked = match checking {
                Ok(checking) => checking
                    .join()
                    .unwrap_or_else(|payload| std::panic::resume_unwind(payload)),
                Err(_) => check(),
            };
            (checked, program)
        }),
    };
    let summary = checked.map_err(|e| vec![e])?;
    let program = program?;
    let mut warnings = toolpath.warnings.clone();
    warnings.extend(program.warnings.iter().cloned());
    warnings.sort_by_key(|w| w.origin);
    Ok(Import {
        toolpath,
        summary,
        program,
        target,
        warnings,
        height_map,
        plan,
        tool: tool.cloned(),
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
