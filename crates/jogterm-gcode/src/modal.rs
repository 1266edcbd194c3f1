//! The interpreter's modal state at a line, as data and as the words an
//! operator reads before a restart (`docs/gcode.md`, "Restart from a
//! line"): what the skipped lines left in force.

use crate::offsets::System;

use super::setup::Units;
use super::toolpath::Plane;

/// The spindle as M3/M4/M5 left it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Spindle {
    #[default]
    Off,
    /// M3.
    Clockwise,
    /// M4 (the controllers have no direction output: the same output as M3).
    CounterClockwise,
}

/// The modal state in force before a line runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Modal {
    /// `None` while the file has said neither G20 nor G21 and the profile
    /// names no unit.
    pub units: Option<Units>,
    pub plane: Plane,
    /// G90 (true) or G91.
    pub absolute: bool,
    /// G90.1 (true) or G91.1.
    pub arc_absolute: bool,
    pub system: System,
    /// mm per minute.
    pub feed: Option<f64>,
    pub spindle: Spindle,
    /// The last S word, rpm.
    pub speed: Option<f64>,
    /// M7.
    pub mist: bool,
    /// M8.
    pub flood: bool,
    /// The last T word.
    pub tool: Option<u32>,
}

impl Modal {
    /// The state as G-code words with what they mean, in the order the
    /// confirmation says them: `["G21 mm", "G17 XY", "G90", "G54", "F800",
    /// "spindle M3 S12000", "coolant M8"]`. The feed is in the file's unit.
    pub fn words(&self) -> Vec<String> {
        let mut out = Vec::new();
        out.push(match self.units {
            Some(Units::Mm) => "G21 mm".to_owned(),
            Some(Units::Inch) => "G20 inch".to_owned(),
            None => "no unit set".to_owned(),
        });
        let axes = match self.plane {
            Plane::Xy => "XY",
            Plane::Zx => "ZX",
            Plane::Yz => "YZ",
        };
        out.push(format!("{} {axes}", self.plane_code()));
        out.push(if self.absolute { "G90" } else { "G91" }.to_owned());
        if self.arc_absolute {
            out.push("G90.1".to_owned());
        }
        out.push(self.system.to_string());
        if let Some(feed) = self.feed {
            let unit = self.units.map_or(1.0, Units::mm);
            out.push(format!("F{}", number(feed / unit)));
        }
        let speed = self
            .speed
            .map_or_else(String::new, |s| format!(" S{}", number(s)));
        out.push(match self.spindle {
            Spindle::Off => format!("spindle M5{speed}"),
            Spindle::Clockwise => format!("spindle M3{speed}"),
            Spindle::CounterClockwise => format!("spindle M4{speed}"),
        });
        out.push(match (self.mist, self.flood) {
            (false, false) => "coolant M9".to_owned(),
            (true, false) => "coolant M7".to_owned(),
            (false, true) => "coolant M8".to_owned(),
            (true, true) => "coolant M7 M8".to_owned(),
        });
        if let Some(t) = self.tool {
            out.push(format!("T{t}"));
        }
        out
    }

    pub fn plane_code(&self) -> &'static str {
        match self.plane {
            Plane::Xy => "G17",
            Plane::Zx => "G18",
            Plane::Yz => "G19",
        }
    }

    /// [`Modal::words`] as one line.
    pub fn text(&self) -> String {
        self.words().join(", ")
    }
}

/// A number as G-code prints it: no trailing zeros, at most 4 decimals.
pub fn number(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}
