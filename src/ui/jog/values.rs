//! The jog step and speed beyond the profile's presets (`docs/jogging.md`,
//! "Step and speed"): typed ones (`J`, [`ValuesForm`]), checked against the
//! axes (one step of resolution, the travel, the top speed), and the speed
//! override (`(` `)` by 10 %, `%` back to 100 %), bounded by the top speed
//! of the fastest axis. The overrun caps still apply on top: the keypad
//! asks for the lower of the speed chosen here and what the overrun bound
//! allows (`crate::jog::pad`).

use crate::jog::{JogAxis, JogSettings};

use super::super::line_edit::LineEdit;
use super::super::position::format_amount;

/// The override's bounds and step, percent.
pub const OVERRIDE_MIN: u16 = 10;
pub const OVERRIDE_MAX: u16 = 200;
pub const OVERRIDE_STEP: u16 = 10;

/// What the operator chose beyond the presets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JogValues {
    /// A typed step (units), in place of the preset until `[` or `]`.
    pub step: Option<f64>,
    /// A typed speed (units per second), in place of the preset until `-`
    /// or `+`.
    pub speed: Option<f64>,
    /// The speed override, percent of the chosen speed.
    pub override_pct: u16,
}

impl Default for JogValues {
    fn default() -> Self {
        JogValues {
            step: None,
            speed: None,
            override_pct: 100,
        }
    }
}

/// The top speed of the fastest axis: nothing jogs faster.
fn top_speed(settings: &JogSettings) -> Option<&JogAxis> {
    // The first of equals: X before Y.
    settings
        .axes
        .iter()
        .fold(None, |best: Option<&JogAxis>, a| match best {
            Some(b) if b.max_speed >= a.max_speed => Some(b),
            _ => Some(a),
        })
}

impl JogValues {
    /// `base` (units per second) with the override, at most the fastest
    /// axis' top speed (each axis is held to its own by the requests).
    pub fn speed_with_override(&self, base: f64, settings: &JogSettings) -> f64 {
        let speed = base * f64::from(self.override_pct) / 100.0;
        top_speed(settings).map_or(speed, |a| speed.min(a.max_speed))
    }

    /// The override `delta` percent further (±10), within its bounds and,
    /// going up, until the speed reaches the fastest axis' top speed.
    pub fn change_override(
        &mut self,
        up: bool,
        base: f64,
        settings: &JogSettings,
    ) -> Result<String, String> {
        let at_top = top_speed(settings)
            .filter(|a| base * f64::from(self.override_pct) / 100.0 >= a.max_speed - 1e-9);
        let next = if up {
            if let Some(a) = at_top {
                return Err(format!(
                    "override stays at {} %: the jog speed is at the top speed of {} ({} {}/s)",
                    self.override_pct,
                    a.axis,
                    format_amount(a.max_speed),
                    a.unit.symbol()
                ));
            }
            self.override_pct.saturating_add(OVERRIDE_STEP)
        } else {
            self.override_pct.saturating_sub(OVERRIDE_STEP)
        };
        if !(OVERRIDE_MIN..=OVERRIDE_MAX).contains(&next) {
            return Err(format!(
                "override stays at {} %: it goes from {OVERRIDE_MIN} to {OVERRIDE_MAX} %",
                self.override_pct
            ));
        }
        self.override_pct = next;
        Ok(format!(
            "jog speed override {} %: {} per second",
            self.override_pct,
            format_amount(self.speed_with_override(base, settings))
        ))
    }
}

/// A typed number, or why it is none.
fn number(text: &str, what: &str) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite())
        .ok_or_else(|| {
            format!(
                "`{}` is not a number: type the {what}, such as 0.25",
                text.trim()
            )
        })?;
    if value <= 0.0 {
        return Err(format!("the {what} must be more than 0"));
    }
    Ok(value)
}

/// A typed step (units): at least one step of every axis, at most the
/// travel of the shortest (named when it is more). The note says where an axis cannot step it
/// exactly (not a whole number of its steps).
pub fn parse_step(text: &str, settings: &JogSettings) -> Result<(f64, Option<String>), String> {
    let step = number(text, "step")?;
    for a in &settings.axes {
        let one = 1.0 / a.steps_per_unit;
        if step < one * (1.0 - 1e-9) {
            return Err(format!(
                "a step of {} is less than one step of {} ({} {})",
                format_amount(step),
                a.axis,
                format_amount(one),
                a.unit.symbol()
            ));
        }
    }
    // The limit is the shortest travel: name that axis.
    let shortest = settings
        .axes
        .iter()
        .filter(|a| (a.max - a.min).is_finite())
        .fold(None, |best: Option<&JogAxis>, a| match best {
            Some(b) if b.max - b.min <= a.max - a.min => Some(b),
            _ => Some(a),
        });
    if let Some(a) = shortest
        && step > a.max - a.min
    {
        return Err(format!(
            "a step of {} is more than the travel of {} ({} {})",
            format_amount(step),
            a.axis,
            format_amount(a.max - a.min),
            a.unit.symbol()
        ));
    }
    let inexact: Vec<String> = settings
        .axes
        .iter()
        .filter_map(|a| {
            let steps = step * a.steps_per_unit;
            let whole = steps.round();
            ((steps - whole).abs() > 1e-6).then(|| {
                format!(
                    "{} steps {} {} ({} steps)",
                    a.axis,
                    format_amount(whole / a.steps_per_unit),
                    a.unit.symbol(),
                    whole
                )
            })
        })
        .collect();
    let note = (!inexact.is_empty()).then(|| {
        format!(
            "{} is no whole number of steps: {}",
            format_amount(step),
            inexact.join(", ")
        )
    });
    Ok((step, note))
}

/// A typed speed (units per second): at least one step per second of every
/// axis, at most the top speed of the fastest (slower axes run at most
/// their own, as with the presets).
pub fn parse_speed(text: &str, settings: &JogSettings) -> Result<f64, String> {
    let speed = number(text, "speed")?;
    for a in &settings.axes {
        let one = 1.0 / a.steps_per_unit;
        if speed < one * (1.0 - 1e-9) {
            return Err(format!(
                "{} per second is slower than one step per second of {} ({} {}/s)",
                format_amount(speed),
                a.axis,
                format_amount(one),
                a.unit.symbol()
            ));
        }
    }
    if let Some(a) = top_speed(settings)
        && speed > a.max_speed + 1e-9
    {
        return Err(format!(
            "{} per second is faster than any axis may run (top speed: {} {} {}/s)",
            format_amount(speed),
            a.axis,
            format_amount(a.max_speed),
            a.unit.symbol()
        ));
    }
    Ok(speed)
}

/// What the `J` popup's fields hold, checked: a step (with the note of
/// [`parse_step`]) and a speed, `None` where the field was left empty.
#[derive(Debug, Clone, PartialEq)]
pub struct Typed {
    pub step: Option<(f64, Option<String>)>,
    pub speed: Option<f64>,
}

/// The `J` popup: a step and a speed, typed; an empty field keeps what is
/// chosen.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ValuesForm {
    pub step: LineEdit,
    pub speed: LineEdit,
    /// 0: the step field has the input, 1: the speed field.
    pub field: usize,
}

impl ValuesForm {
    pub fn line(&mut self) -> &mut LineEdit {
        if self.field == 0 {
            &mut self.step
        } else {
            &mut self.speed
        }
    }

    pub fn other_field(&mut self) {
        self.field = 1 - self.field.min(1);
    }

    /// The values typed, checked; `None` when one is refused: the field at
    /// fault gets the error and the input.
    pub fn check(&mut self, settings: &JogSettings) -> Option<Typed> {
        let fail = |line: &mut LineEdit, message: String| {
            line.error = Some(super::super::line_edit::LineError {
                message,
                span: None,
            });
        };
        self.step.error = None;
        self.speed.error = None;
        let step = if self.step.text().trim().is_empty() {
            None
        } else {
            match parse_step(self.step.text(), settings) {
                Ok(s) => Some(s),
                Err(e) => {
                    fail(&mut self.step, e);
                    self.field = 0;
                    return None;
                }
            }
        };
        let speed = if self.speed.text().trim().is_empty() {
            None
        } else {
            match parse_speed(self.speed.text(), settings) {
                Ok(s) => Some(s),
                Err(e) => {
                    fail(&mut self.speed, e);
                    self.field = 1;
                    return None;
                }
            }
        };
        Some(Typed { step, speed })
    }
}

/// The preset a step or speed key chooses in `list` (sorted ascending):
/// the next one from the preset `current`, or from a `typed` value the one
/// beside it ([`preset_beside`]).
pub fn next_preset(list: &[f64], current: usize, typed: Option<f64>, up: bool) -> usize {
    match typed {
        Some(value) => preset_beside(list, value, up).unwrap_or(current),
        None if up => (current + 1).min(list.len().saturating_sub(1)),
        None => current.saturating_sub(1),
    }
}

/// The preset after (`up`) or before a typed `value` in `list` (sorted
/// ascending): `[` from a typed 0.25 goes to 0.1, `]` to 1.
pub fn preset_beside(list: &[f64], value: f64, up: bool) -> Option<usize> {
    if up {
        list.iter()
            .position(|p| *p > value * (1.0 + 1e-9))
            .or_else(|| list.len().checked_sub(1))
    } else {
        list.iter()
            .rposition(|p| *p < value * (1.0 - 1e-9))
            .or(if list.is_empty() { None } else { Some(0) })
    }
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
    fn typed_steps_are_checked_against_the_axes() {
        let s = settings();
        assert_eq!(parse_step("0.25", &s), Ok((0.25, None)));
        assert_eq!(parse_step(" 1 ", &s), Ok((1.0, None)));
        let (step, note) = parse_step("0.1234", &s).expect("a step");
        assert_eq!(step, 0.1234);
        let note = note.unwrap_or_default();
        assert!(note.contains("X steps 0.1225 mm (49 steps)"), "{note}");
        assert_eq!(
            parse_step("0.001", &s),
            Err("a step of 0.001 is less than one step of X (0.0025 mm)".into())
        );
        assert_eq!(
            parse_step("100", &s),
            Err("a step of 100 is more than the travel of Z (80 mm)".into())
        );
        for bad in ["", "abc", "1,5", "NaN", "inf"] {
            let e = parse_step(bad, &s).expect_err(bad);
            assert!(e.contains("is not a number"), "{bad}: {e}");
        }
        assert_eq!(
            parse_step("-1", &s),
            Err("the step must be more than 0".into())
        );
    }

    #[test]
    fn typed_speeds_are_checked_against_the_axes() {
        let s = settings();
        assert_eq!(parse_speed("3", &s), Ok(3.0));
        // X and Y run 25 mm/s, Z 15: 20 is allowed (Z at its own top).
        assert_eq!(parse_speed("20", &s), Ok(20.0));
        assert_eq!(
            parse_speed("30", &s),
            Err("30 per second is faster than any axis may run (top speed: X 25 mm/s)".into())
        );
        assert_eq!(
            parse_speed("0.001", &s),
            Err("0.001 per second is slower than one step per second of X (0.0025 mm/s)".into())
        );
    }

    #[test]
    fn the_override_goes_by_ten_percent_up_to_the_top_speed() {
        let s = settings();
        let mut v = JogValues::default();
        assert_eq!(v.speed_with_override(2.0, &s), 2.0);
        assert_eq!(
            v.change_override(true, 2.0, &s),
            Ok("jog speed override 110 %: 2.2 per second".into())
        );
        assert_eq!(v.speed_with_override(2.0, &s), 2.2);
        for _ in 0..20 {
            let _ = v.change_override(false, 2.0, &s);
        }
        assert_eq!(v.override_pct, OVERRIDE_MIN);
        let e = v
            .change_override(false, 2.0, &s)
            .expect_err("at the bottom");
        assert!(e.contains("from 10 to 200 %"), "{e}");
        // 15 mm/s: 170 % reaches X's 25 mm/s, no further.
        let mut v = JogValues::default();
        let mut last = Ok(String::new());
        for _ in 0..10 {
            last = v.change_override(true, 15.0, &s);
        }
        assert_eq!(v.override_pct, 170);
        assert_eq!(v.speed_with_override(15.0, &s), 25.0);
        let e = last.expect_err("at the top speed");
        assert!(e.contains("top speed of X (25 mm/s)"), "{e}");
    }

    #[test]
    fn presets_beside_a_typed_value() {
        let list = [0.01, 0.1, 1.0, 10.0];
        assert_eq!(preset_beside(&list, 0.25, false), Some(1));
        assert_eq!(preset_beside(&list, 0.25, true), Some(2));
        assert_eq!(preset_beside(&list, 1.0, true), Some(3));
        assert_eq!(preset_beside(&list, 1.0, false), Some(1));
        assert_eq!(preset_beside(&list, 100.0, true), Some(3));
        assert_eq!(preset_beside(&list, 0.001, false), Some(0));
        assert_eq!(preset_beside(&[], 1.0, true), None);
    }
}
