//! Circle lines: the direction `f` and the arc `y` (helix `w`) of a stored
//! isel program (manual 2.3, 3.2.11), computed by the protocol core's
//! `circle`/`helix`. One place for both users: `jogterm arc` gives an arc
//! in steps and Hz ([`ArcSteps`]); the editor's circle helper
//! (`docs/editor.md`, "Circle helper") gives what the operator typed, in
//! the axes' units, and the lines go in the plane in force where they are
//! inserted ([`typed`]).

use crate::axis::Axis;
use crate::config::profile::AxisProfile;
use crate::proto::isel::{CircleDirection, CircleError, CncCommand, Plane, circle, helix};

use super::teach::{insertion_point, number};
use super::{Command, Program};

/// An arc in steps and Hz: `radius` steps from `start` to `end` degrees
/// (counter-clockwise from axis 1 of the plane; equal angles make a full
/// circle) in `direction` at `speed` Hz path speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcSteps {
    pub radius: u32,
    pub start: f64,
    pub end: f64,
    pub direction: CircleDirection,
    pub speed: u32,
    /// A helix: steps of the plane's third axis over the arc (`w`, manual
    /// 2.2.27) instead of a plain arc (`y`).
    pub helix: Option<i32>,
}

impl ArcSteps {
    /// `f…` then `y…` (or `w…`), as program lines.
    pub fn lines(&self) -> Result<[CncCommand; 2], CircleError> {
        match self.helix {
            None => circle(
                self.radius,
                self.start,
                self.end,
                self.direction,
                self.speed,
            )
            .map(|arc| arc.cnc_lines()),
            Some(s3) => helix(
                self.radius,
                self.start,
                self.end,
                self.direction,
                self.speed,
                s3,
            )
            .map(|h| h.cnc_lines()),
        }
    }
}

/// What the operator typed into the circle helper's form, field by field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TypedArc<'a> {
    /// In the unit of the plane's first axis.
    pub radius: &'a str,
    /// Degrees, counter-clockwise from axis 1.
    pub start: &'a str,
    pub end: &'a str,
    /// `cw` or `ccw`.
    pub direction: &'a str,
    /// Units per second.
    pub speed: &'a str,
    /// The third axis' travel in its unit; empty for a plain arc.
    pub helix: &'a str,
}

/// The lines to insert and what they are, in words (the form shows it while
/// the operator types).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CircleLines {
    pub lines: Vec<String>,
    pub note: String,
}

/// The plane circles run in at line `at`: the last `e` before it (XY
/// before any, manual 3.2.11).
pub fn plane_at(program: &Program, at: usize) -> Plane {
    program
        .statements()
        .take_while(|(line, _)| *line < at)
        .filter_map(|(_, s)| match &s.command {
            Ok(Command::Isel(CncCommand::SetPlane(p))) => Some(*p),
            _ => None,
        })
        .last()
        .unwrap_or_default()
}

/// The arc `typed` asks for, as lines to insert into `program` with the
/// cursor on line `cursor`, for a machine with `axes`; or what is wrong
/// with it. Checked in the order the form reads (the first problem is the
/// one shown).
pub fn typed(
    program: &Program,
    cursor: usize,
    axes: &[(Axis, AxisProfile)],
    typed: &TypedArc,
) -> Result<CircleLines, String> {
    let at = insertion_point(program, cursor);
    let plane = plane_at(program, at);
    let (a1, _) = plane.axes();
    let spu = |axis| {
        axes.iter()
            .find(|(a, _)| *a == axis)
            .map(|(_, p)| p.steps_per_unit)
            .ok_or_else(|| format!("the machine has no {axis} axis for the {plane:?} plane"))
    };
    let spu1 = spu(a1)?;
    let radius = number(typed.radius, "radius")? * spu1;
    let start = number(typed.start, "start angle")?;
    let end = number(typed.end, "end angle")?;
    let direction = match typed.direction.trim().to_ascii_lowercase().as_str() {
        "cw" => CircleDirection::Cw,
        "ccw" => CircleDirection::Ccw,
        other => return Err(format!("the direction is cw or ccw, not `{other}`")),
    };
    let speed = number(typed.speed, "speed")? * spu1;
    let radius = u32::try_from(radius.round() as i64)
        .map_err(|_| "the radius must be positive".to_string())?;
    let speed = u32::try_from(speed.round() as i64)
        .map_err(|_| "the speed must be positive".to_string())?;
    let helix = if typed.helix.trim().is_empty() {
        None
    } else {
        let third = plane.third_axis();
        let s3 = (number(typed.helix, "helix height")? * spu(third)?).round() as i64;
        Some(i32::try_from(s3).map_err(|_| "the helix height is too large".to_string())?)
    };
    let arc = ArcSteps {
        radius,
        start,
        end,
        direction,
        speed,
        helix,
    };
    let lines: Vec<String> = arc
        .lines()
        .map_err(|e| e.to_string())?
        .iter()
        .map(ToString::to_string)
        .collect();
    let note = format!(
        "{:?} plane, R {radius} steps, {speed} Hz: {}",
        plane,
        lines.join("  ")
    );
    Ok(CircleLines { lines, note })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::profile::Unit;
    use crate::program::Language;

    fn mm(spu: f64) -> AxisProfile {
        AxisProfile {
            steps_per_unit: spu,
            unit: Unit::Mm,
            min: 0.0,
            max: 300.0,
            max_speed: 25.0,
            drive: None,
        }
    }

    fn xyz() -> Vec<(Axis, AxisProfile)> {
        vec![
            (Axis::X, mm(400.0)),
            (Axis::Y, mm(400.0)),
            (Axis::Z, mm(200.0)),
        ]
    }

    fn form<'a>(radius: &'a str, helix: &'a str) -> TypedArc<'a> {
        TypedArc {
            radius,
            start: "135",
            end: "225",
            direction: "ccw",
            speed: "3,75",
            helix,
        }
    }

    #[test]
    fn steps_give_the_manuals_worked_example() {
        // Manual 2.3.6: R 200, 135° to 225° CCW at 1500 Hz.
        let arc = ArcSteps {
            radius: 200,
            start: 135.0,
            end: 225.0,
            direction: CircleDirection::Ccw,
            speed: 1500,
            helix: None,
        };
        let lines = arc.lines().expect("an arc").map(|l| l.to_string());
        assert_eq!(lines, ["f-1", "y400,1500,119,-141,141,-1,-1"]);
        let helix = ArcSteps {
            helix: Some(-400),
            ..arc
        };
        let lines = helix.lines().expect("a helix").map(|l| l.to_string());
        assert_eq!(lines[1], "w400,1500,119,-141,141,-1,-1,-400");
    }

    #[test]
    fn typed_arcs_are_scaled_to_steps_in_the_plane_in_force() {
        let program = Program::parse(Language::Isel, "7 7\n9\n");
        // 0.5 mm at 400 steps/mm is the example's 200 steps; 3.75 mm/s 1500 Hz.
        let c = typed(&program, 0, &xyz(), &form("0.5", "")).expect("lines");
        assert_eq!(c.lines, ["f-1", "y400,1500,119,-141,141,-1,-1"]);
        assert_eq!(
            c.note,
            "XY plane, R 200 steps, 1500 Hz: f-1  y400,1500,119,-141,141,-1,-1"
        );
        // In the XZ plane the third axis is Y: 1 mm is 400 of its steps.
        let program = Program::parse(Language::Isel, "e1\n9\n");
        let c = typed(&program, 0, &xyz(), &form("0.5", "-1")).expect("lines");
        assert!(c.note.starts_with("XZ plane"), "{}", c.note);
        assert!(c.lines[1].ends_with(",-400"), "{:?}", c.lines);
        // The plane is the one before the insertion point.
        assert_eq!(plane_at(&program, 0), Plane::XY);
        assert_eq!(plane_at(&program, 1), Plane::XZ);
    }

    #[test]
    fn the_first_problem_in_the_forms_order_is_the_one_said() {
        let program = Program::parse(Language::Isel, "9\n");
        let err = |t: TypedArc| typed(&program, 0, &xyz(), &t).expect_err("refused");
        assert_eq!(err(form("r", "x")), "the radius is no number: `r`");
        assert_eq!(err(form("-1", "x")), "the radius must be positive");
        assert_eq!(err(form("1", "x")), "the helix height is no number: `x`");
        let wrong = TypedArc {
            direction: "left",
            ..form("1", "")
        };
        assert_eq!(err(wrong), "the direction is cw or ccw, not `left`");
        // A machine without the plane's first axis.
        let z_only = vec![(Axis::Z, mm(200.0))];
        assert_eq!(
            typed(&program, 0, &z_only, &form("r", "")).expect_err("refused"),
            "the machine has no X axis for the XY plane"
        );
    }
}
