//! The go-to prompt: a position typed in work coordinates and units
//! (`X10 Y-2.5`, `x=10, z=0`), checked against the machine's axes and soft
//! limits before a `MoveTo` goes out; and the move to the work zero.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Frame, MachineState, PerAxis, Request};
use crate::jog::JogSettings;

use super::super::line_edit::LineEdit;

/// The prompt's state: the line being typed and why it was refused.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GoToPrompt {
    pub line: LineEdit,
}

/// A target parsed from the prompt: units per axis, work coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    pub units: Vec<(Axis, f64)>,
}

/// Why a typed target cannot be gone to.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetError {
    #[error("type an axis and a position, such as X10 Y-2.5")]
    Empty,
    #[error("`{0}` is not an axis and a position (such as X10)")]
    Syntax(String),
    #[error("the machine has no {axis} axis (axes {machine})")]
    NoAxis { axis: Axis, machine: AxisSet },
    #[error("{0} is given twice")]
    Twice(Axis),
    #[error("{axis}{work} is outside the soft limits: work {lo}..{hi} (machine {min}..{max})")]
    SoftLimit {
        axis: Axis,
        work: String,
        lo: String,
        hi: String,
        min: String,
        max: String,
    },
}

/// Parse `X10,Y-2.5`, `x=10 z=0`, `X10Y-2.5`: an axis letter, an optional
/// `=`, a decimal number; items separated by commas or blanks, or not at
/// all (Space is the stop key and never types a blank in jogterm).
pub fn parse(text: &str, settings: &JogSettings) -> Result<Target, TargetError> {
    let machine = settings.axis_set();
    let mut units: Vec<(Axis, f64)> = Vec::new();
    for word in items(text) {
        let mut chars = word.chars();
        let axis = chars
            .next()
            .and_then(Axis::from_letter)
            .ok_or_else(|| TargetError::Syntax(word.clone()))?;
        let rest = chars.as_str();
        let number = rest.strip_prefix('=').unwrap_or(rest);
        let value: f64 = number
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| TargetError::Syntax(word.clone()))?;
        if !machine.contains(axis) {
            return Err(TargetError::NoAxis { axis, machine });
        }
        if units.iter().any(|(a, _)| *a == axis) {
            return Err(TargetError::Twice(axis));
        }
        units.push((axis, value));
    }
    if units.is_empty() {
        return Err(TargetError::Empty);
    }
    units.sort_by_key(|(a, _)| a.index());
    Ok(Target { units })
}

/// The items of a target line: split at blanks and commas, and before every
/// axis letter that does not start an item already.
fn items(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut current = String::new();
    for c in text.chars() {
        let separator = c.is_whitespace() || c == ',';
        let axis = Axis::from_letter(c).is_some();
        if (separator || axis) && !current.is_empty() {
            out.push(std::mem::take(&mut current));
        }
        if !separator {
            current.push(c);
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

fn amount(v: f64) -> String {
    super::super::position::format_amount(v)
}

/// The move to `target` at a path speed of `speed` units per second, if it
/// stays within the soft limits: the driver checks them again (it knows
/// the position then), this says at once what is wrong.
pub fn request(
    target: &Target,
    settings: &JogSettings,
    machine: &MachineState,
    speed: f64,
) -> Result<Request, TargetError> {
    let mut steps = PerAxis::new();
    let mut pairs = Vec::new();
    for (axis, work) in &target.units {
        let Some(a) = settings.axis(*axis) else {
            return Err(TargetError::NoAxis {
                axis: *axis,
                machine: settings.axis_set(),
            });
        };
        let zero_steps = machine.work_zero.get(*axis).unwrap_or(0);
        let zero = zero_steps as f64 / a.steps_per_unit;
        let machine_units = work + zero;
        // A hair of tolerance, so a limit typed exactly is not refused for
        // the rounding of its steps.
        let eps = 0.5 / a.steps_per_unit;
        if machine_units < a.min - eps || machine_units > a.max + eps {
            return Err(TargetError::SoftLimit {
                axis: *axis,
                work: amount(*work),
                lo: amount(a.min - zero),
                hi: amount(a.max - zero),
                min: amount(a.min),
                max: amount(a.max),
            });
        }
        steps.set(*axis, a.to_steps(*work));
        // The direction does not matter for the speed of each axis.
        pairs.push((*axis, Dir::Plus));
    }
    Ok(Request::MoveTo {
        target: steps,
        frame: Frame::Work,
        speed_hz: settings.speeds_hz(&pairs, speed),
    })
}

/// The move to the work zero of every axis.
pub fn zero_target(settings: &JogSettings) -> Target {
    Target {
        units: settings.axes.iter().map(|a| (a.axis, 0.0)).collect(),
    }
}

/// `X10 Y-2.5` for messages.
pub fn describe(target: &Target) -> String {
    target
        .units
        .iter()
        .map(|(a, v)| format!("{a}{}", amount(*v)))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn settings() -> JogSettings {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        JogSettings::from_profile(&profile)
    }

    #[test]
    fn targets_parse_in_any_spelling() {
        let s = settings();
        for text in [
            "X10 Y-2.5",
            "x=10, y=-2.5",
            " y-2.5,x10 ",
            "X10Y-2.5",
            "x10,y=-2.5",
        ] {
            assert_eq!(
                parse(text, &s),
                Ok(Target {
                    units: vec![(Axis::X, 10.0), (Axis::Y, -2.5)]
                }),
                "{text}"
            );
        }
        assert_eq!(parse("", &s), Err(TargetError::Empty));
        assert_eq!(parse("X", &s), Err(TargetError::Syntax("X".into())));
        assert_eq!(parse("Q5", &s), Err(TargetError::Syntax("Q5".into())));
        assert_eq!(parse("X1=2", &s), Err(TargetError::Syntax("X1=2".into())));
        assert_eq!(parse("Xinf", &s), Err(TargetError::Syntax("Xinf".into())));
        assert_eq!(parse("X1 X2", &s), Err(TargetError::Twice(Axis::X)));
        assert!(matches!(
            parse("A5", &s),
            Err(TargetError::NoAxis { axis: Axis::A, .. })
        ));
    }

    proptest::proptest! {
        /// Whatever is typed: an answer, never a panic; an accepted target
        /// names each of the machine's axes at most once, with a finite value.
        #[test]
        fn any_typed_line_is_parsed_or_refused(text in "[xyzaXYZA0-9=,.+\\-e ]{0,24}|\\PC{0,24}") {
            let s = settings();
            if let Ok(t) = parse(&text, &s) {
                proptest::prop_assert!(!t.units.is_empty());
                for (i, (axis, v)) in t.units.iter().enumerate() {
                    proptest::prop_assert!(v.is_finite());
                    proptest::prop_assert!(s.axis_set().contains(*axis));
                    proptest::prop_assert!(t.units.iter().skip(i + 1).all(|(a, _)| a != axis));
                }
                let _ = request(&t, &s, &MachineState::default(), 2.0);
            }
        }
    }

    #[test]
    fn soft_limits_count_from_the_work_zero() {
        let s = settings();
        // Work zero at X = 100 mm (40000 steps): X may go from -100 to 200.
        let m = MachineState {
            work_zero: PerAxis::new().with(Axis::X, 40_000),
            ..MachineState::default()
        };
        let ok = parse("X-100", &s).and_then(|t| request(&t, &s, &m, 2.0));
        let Ok(Request::MoveTo {
            target,
            frame,
            speed_hz,
        }) = ok
        else {
            panic!("{ok:?}")
        };
        assert_eq!(target.get(Axis::X), Some(-40_000));
        assert_eq!(frame, Frame::Work);
        assert_eq!(speed_hz.get(Axis::X), Some(800.0));
        let err = parse("X201", &s).and_then(|t| request(&t, &s, &m, 2.0));
        assert_eq!(
            err.map_err(|e| e.to_string()),
            Err("X201 is outside the soft limits: work -100..200 (machine 0..300)".into())
        );
    }
}
