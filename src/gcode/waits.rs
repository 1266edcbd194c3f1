//! A job's tool changes and pauses for a machine profile (`docs/gcode.md`,
//! "Tool changes"): the change position from the profile's `[tools]`
//! table, the job cut at its waits (`jogterm_gcode::toolchange`), each piece
//! checked against the soft limits and converted, and the tool-length
//! offset of the tool in the spindle. Sans-IO.

use crate::axis::Axis;
use crate::config::profile::Profile;

use super::check::check_limits;
use super::output::{Header, Program};
use super::profile::machine_of;
use super::target::Target;
use super::toolchange::{ChangeAt, Plan};
use super::toolpath::{Diagnostic, Origin, Toolpath};
use super::tools::tool_table;

/// The tool in the spindle and its length against the reference tool
/// (`jogterm probe tool`'s table): every Z of a job is this much higher.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolOffset {
    pub tool: String,
    pub offset_mm: f64,
}

/// The profile's change position (`[tools] change_at`, machine units).
pub fn change_at(profile: &Profile) -> Result<ChangeAt, String> {
    let Some(point) = profile.tools.change_at_point() else {
        return Ok(ChangeAt::default());
    };
    let point = point.map_err(|why| format!("tools.change_at: {why}"))?;
    // Machine units are mm for the G-code import's toolpath: the profile's
    // axes say so (`gcode::profile`), a linear axis in inches is refused
    // there already.
    Ok(ChangeAt {
        x: point.get(Axis::X),
        y: point.get(Axis::Y),
        z: point.get(Axis::Z),
    })
}

/// The job of `text` (interpreted as `path`) cut at its waits for `profile`.
pub fn plan_of(text: &str, path: &Toolpath, profile: &Profile) -> Result<Plan, Vec<Diagnostic>> {
    let at = change_at(profile)
        .map_err(|why| vec![Diagnostic::error(Origin { line: 1, col: 1 }, why)])?;
    Ok(Plan::of(
        path,
        &tool_table(text),
        at,
        profile.gcode.plunge_feed,
    ))
}

/// Piece `k` of `plan` (every Z `dz` higher, the piece before it `dz_before`),
/// checked against the soft limits and converted for `target`: the
/// program a host stores or streams between two waits. `path`: the
/// toolpath the plan was made of (`Import::toolpath`).
pub fn convert_piece(
    plan: &Plan,
    path: &Toolpath,
    k: usize,
    (dz_before, dz): (f64, f64),
    profile: &Profile,
    target: Target,
    header: &Header,
) -> Result<Program, Vec<Diagnostic>> {
    let piece = plan.segment(path, k, dz_before, dz);
    check_limits(&piece, &machine_of(profile, target)).map_err(|e| vec![e])?;
    let options = super::Options {
        continued: k > 0,
        safe_z: Some(plan.safe_z + dz),
    };
    let mut program = match target {
        Target::Isel => super::isel::convert_with(&piece, profile, header, &options),
        Target::Emcu => super::emcu::convert_with(&piece, profile, header, &options),
    }?;
    let mark = header.lines().len();
    program.lines.insert(
        mark.min(program.lines.len()),
        super::output::ProgramLine {
            command: String::new(),
            comment: Some(format!(
                "{} piece={}/{} z_shift={dz:.4}",
                Header::PREFIX,
                k + 1,
                plan.segments()
            )),
            origin: None,
        },
    );
    for r in &mut program.retracted {
        if *r >= mark {
            *r += 1;
        }
    }
    Ok(program)
}

/// The summary's lines of the waits: each with its line, what it waits
/// for and where (machine mm).
pub fn waits_text(plan: &Plan) -> Vec<String> {
    plan.waits
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let at = plan.waits_at(k, 0.0).unwrap_or(w.at);
            let place = if w.is_tool_change() {
                format!(
                    "the spindle off, waits at machine X {:.3} Y {:.3} Z {:.3}",
                    at.x, at.y, at.z
                )
            } else {
                "waits where the tool stands".to_owned()
            };
            format!("line {}: {} ({place})", w.origin.line, w.what())
        })
        .collect()
}

/// The summary's line of the tool-length offset applied.
pub fn tool_text(tool: Option<&ToolOffset>) -> String {
    match tool {
        Some(t) => format!(
            "tool offset {} {:+.3} mm on every Z (the tool in the spindle, measured by `jogterm probe tool`)",
            t.tool, t.offset_mm
        ),
        None => "tool offset: none (no tool measured since the Z touch-off)".to_owned(),
    }
}

/// `tool_change`, `pause`, `optional_pause`: a wait's kind in JSON.
pub fn kind_name(w: &super::toolchange::Wait) -> &'static str {
    match w.kind {
        super::toolchange::WaitKind::ToolChange { .. } => "tool_change",
        super::toolchange::WaitKind::Program => "pause",
        super::toolchange::WaitKind::Optional => "optional_pause",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::gcode::{Import, import};
    use crate::offsets::{System, WorkOffsets};

    const JOB: &str = "(T1 D=6 - flat)\n(T2 D=3 - ball)\nG21 G90\nM6 T1\nG0 Z5\nG0 X10 Y10\n\
        G1 Z-1 F100\nG1 X20 F300\nG0 Z5\nM6 T2\nG0 X30\nG1 Z-2 F100\nG0 Z5\nM30\n";

    fn imported(change_at: Option<&str>) -> (Profile, Import) {
        let mut profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        profile.tools.change_at = change_at.map(str::to_owned);
        let mut offsets = WorkOffsets::default();
        for (axis, mm) in [(Axis::X, 50.0), (Axis::Y, 50.0), (Axis::Z, 40.0)] {
            let steps = profile.axis(axis).map_or(0, |a| a.to_steps(mm));
            offsets.set(System::G54, axis, steps);
        }
        let i = import(JOB, "job.nc", &profile, &offsets, Target::Isel).expect("import");
        (profile, i)
    }

    #[test]
    fn a_job_with_tool_changes_is_cut_into_pieces_each_its_own_program() {
        let (profile, i) = imported(Some("X100 Y10 Z70"));
        assert_eq!(i.plan.segments(), 3);
        let header = Header {
            file: "job.nc".into(),
            profile: profile.name.clone(),
            system: "G54".into(),
            zero: crate::gcode::Point::default(),
        };
        let first = convert_piece(
            &i.plan,
            &i.toolpath,
            0,
            (0.0, 0.0),
            &profile,
            Target::Isel,
            &header,
        )
        .expect("piece 1");
        let text = first.text("job.nc");
        assert!(text.contains("77 "), "the first piece references: {text}");
        let second = convert_piece(
            &i.plan,
            &i.toolpath,
            2,
            (0.0, 1.0),
            &profile,
            Target::Isel,
            &header,
        )
        .expect("piece 3");
        let text = second.text("job.nc");
        assert!(!text.contains("\n77 "), "no reference run mid-job: {text}");
        assert!(text.contains("z_shift=1.0000"), "{text}");
        // Z-2 (work) at Z zero 40: machine 38, one higher after the change:
        // 39 mm, 15600 steps at 400 steps/mm.
        assert!(text.contains(",15600,"), "the cut 1 mm higher: {text}");
        // A change position outside the soft limits is the piece's error.
        let far = convert_piece(
            &i.plan,
            &i.toolpath,
            2,
            (0.0, 500.0),
            &profile,
            Target::Isel,
            &header,
        );
        assert!(far.is_err());
    }

    #[test]
    fn the_whole_program_waits_for_the_start_key_at_the_change_position() {
        let (_, i) = imported(Some("X100 Y10 Z70"));
        let text = i.program.text("job.nc");
        // To X100 Y10 Z70 (40000, 4000, 28000 steps), then the start key.
        let at = text.find("m40000,").expect("the change position");
        let wait = text.find("\no").expect("the wait");
        assert!(at < wait, "{text}");
        assert_eq!(i.program.pauses.len(), 2);
        let bad = load_profile("default", &ConfigDirs::builtin_only()).map(|mut p| {
            p.tools.change_at = Some("X".into());
            change_at(&p)
        });
        assert!(matches!(bad, Ok(Err(_))));
    }
}
