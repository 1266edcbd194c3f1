//! The profile's `[probe]` table (`docs/probing.md`): how far and how fast
//! a probe goes, the touch plate, the probe's tip and the fixed tool
//! sensor. The input a probe watches is not here: it is the `[io]` input
//! with the role `probe` (isel in1.5 by default).

use serde::{Deserialize, Serialize};

use crate::axis::Axis;
use crate::axis::PerAxis;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProbeProfile {
    /// The farthest the first pass goes looking for the surface, units.
    pub travel: f64,
    /// The first pass, units/s.
    pub fast_speed: f64,
    /// The back-off and the second pass, units/s. isel runs it at most at
    /// the start-stop frequency (`isel.start_stop_hz`), which it stops
    /// from within a step.
    pub slow_speed: f64,
    /// EMP only: the length of each short move of the back-off and the
    /// second pass, units, which is the accuracy of the touched point (EMP
    /// has no move that ends on an input, `docs/probing.md`).
    pub step: f64,
    /// Thickness of the touch plate under the tool, units: work Z 0 is the
    /// touched surface minus this.
    pub plate: f64,
    /// Diameter of the probe's tip (or of the tool that touches), units:
    /// an edge lies half of it beyond the touched centre. 0: a point.
    pub tip: f64,
    /// For edges and bores: how far beside a face the probe starts, units.
    pub clearance: f64,
    /// Machine coordinates of the point above the fixed tool-length
    /// sensor, `"X10 Y250 Z70"`; absent: no sensor.
    pub tool_sensor: Option<String>,
}

impl Default for ProbeProfile {
    fn default() -> Self {
        ProbeProfile {
            travel: 10.0,
            fast_speed: 5.0,
            slow_speed: 0.5,
            step: 0.01,
            plate: 0.0,
            tip: 0.0,
            clearance: 5.0,
            tool_sensor: None,
        }
    }
}

impl ProbeProfile {
    /// What serde cannot check: `(key, message)` per problem.
    pub fn problems(&self) -> Vec<(&'static str, String)> {
        let mut out = Vec::new();
        let positive = [
            ("travel", self.travel),
            ("fast_speed", self.fast_speed),
            ("slow_speed", self.slow_speed),
            ("step", self.step),
            ("clearance", self.clearance),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                out.push((key, format!("{v}: must be more than 0")));
            }
        }
        for (key, v) in [("plate", self.plate), ("tip", self.tip)] {
            if !(v.is_finite() && v >= 0.0) {
                out.push((key, format!("{v}: must be 0 or more")));
            }
        }
        if self.slow_speed > self.fast_speed {
            out.push((
                "slow_speed",
                format!(
                    "{}: the second pass cannot be faster than the first ({})",
                    self.slow_speed, self.fast_speed
                ),
            ));
        }
        if let Some(text) = &self.tool_sensor
            && let Err(why) = parse_point(text)
        {
            out.push(("tool_sensor", why));
        }
        out
    }

    /// The tool sensor's point, machine units per axis.
    pub fn tool_sensor_point(&self) -> Option<Result<PerAxis<f64>, String>> {
        self.tool_sensor.as_deref().map(parse_point)
    }
}

/// The profile's `[tools]` table (`docs/gcode.md`, "Tool changes"): where
/// a job's tool change waits.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ToolsProfile {
    /// Machine coordinates of the tool change position, `"X100 Y10 Z70"`;
    /// an axis left out stays where it is (Z: at the job's safe height);
    /// absent: the change waits above where the tool stands.
    pub change_at: Option<String>,
}

impl ToolsProfile {
    pub fn problems(&self) -> Vec<(&'static str, String)> {
        match self.change_at_point() {
            Some(Err(why)) => vec![("change_at", why)],
            _ => Vec::new(),
        }
    }

    /// The change position, machine units per axis.
    pub fn change_at_point(&self) -> Option<Result<PerAxis<f64>, String>> {
        self.change_at.as_deref().map(parse_point)
    }
}

/// `"X10 Y250 Z70"`: axis letters with numbers, each axis once.
pub fn parse_point(text: &str) -> Result<PerAxis<f64>, String> {
    let mut point = PerAxis::new();
    for word in text.split_whitespace() {
        let mut chars = word.chars();
        let letter = chars.next().unwrap_or(' ');
        let axis = Axis::from_letter(letter.to_ascii_uppercase()).ok_or_else(|| {
            format!("`{word}` in {text:?}: expected an axis letter (X, Y, Z, A) and a number")
        })?;
        let value: f64 = chars
            .as_str()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("`{word}` in {text:?}: expected a number after {axis}"))?;
        if point.get(axis).is_some() {
            return Err(format!("{text:?} names {axis} twice"));
        }
        point.set(axis, value);
    }
    if point.axes().is_empty() {
        return Err(format!(
            "{text:?}: expected a point such as \"X10 Y250 Z70\""
        ));
    }
    Ok(point)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_reads_by_axis_letters() {
        let p = parse_point("X10 y250.5 Z-3").expect("point");
        assert_eq!(p.get(Axis::X), Some(10.0));
        assert_eq!(p.get(Axis::Y), Some(250.5));
        assert_eq!(p.get(Axis::Z), Some(-3.0));
        assert!(parse_point("X10 X11").is_err());
        assert!(parse_point("Q1").is_err());
        assert!(parse_point("Xten").is_err());
        assert!(parse_point("").is_err());
    }

    #[test]
    fn nonsense_settings_are_named() {
        let bad = ProbeProfile {
            travel: 0.0,
            slow_speed: 9.0,
            step: -0.01,
            plate: -1.0,
            tool_sensor: Some("X1 W2".into()),
            ..ProbeProfile::default()
        };
        let keys: Vec<&str> = bad.problems().iter().map(|(k, _)| *k).collect();
        assert_eq!(
            keys,
            ["travel", "step", "plate", "slow_speed", "tool_sensor"]
        );
        assert!(ProbeProfile::default().problems().is_empty());
    }
}
