//! What the interpreter needs to know of the machine: units, work offsets,
//! named outputs and the profile's `[gcode]` table, already resolved, so
//! that interpreting is a pure function of text and setup. The application
//! fills it from a machine profile (jogterm's `gcode::profile::setup_of`).

use std::collections::BTreeMap;

use jogterm_proto::axis::Axis;
use jogterm_proto::wiring::{BitKind, Role, Wiring};

use crate::offsets::System;
use crate::toolpath::Point;

/// A file's unit, as G20/G21 select it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    Mm,
    Inch,
}

impl Units {
    pub fn mm(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Inch => 25.4,
        }
    }
}

/// An output the file may switch.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedOutput {
    pub address: String,
    pub name: String,
    pub role: Option<Role>,
    /// The number `M62 P<n>` … `M65` give it: its place among the
    /// profile's outputs (`docs/gcode.md`, "Outputs").
    pub number: u32,
}

/// What the profile's `[gcode]` table says of one code.
#[derive(Debug, Clone, PartialEq)]
pub enum CodeRule {
    /// Read and dropped, with a warning at every line that has it.
    Ignore,
    /// Switch this output (by role or address) on, or off for the codes
    /// that switch off (M5, M9, M63, M65).
    Output(String),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Axes the machine has, of X Y Z (a word of another is refused).
    pub axes: Vec<Axis>,
    /// The unit of a file that selects none.
    pub default_units: Option<Units>,
    /// The six work zeros in machine mm, and the one in force.
    pub zeros: [Point; System::COUNT],
    pub active: System,
    /// Where the tool stands when the job starts (machine mm); the first
    /// move starts here.
    pub start: Point,
    pub outputs: Vec<NamedOutput>,
    /// `m8`, `g64`, … (lower case, as in the profile) to what they do.
    pub codes: BTreeMap<String, CodeRule>,
}

impl Default for Setup {
    fn default() -> Setup {
        Setup {
            axes: vec![Axis::X, Axis::Y, Axis::Z],
            default_units: None,
            zeros: [Point::default(); System::COUNT],
            active: System::G54,
            start: Point::default(),
            outputs: Vec::new(),
            codes: BTreeMap::new(),
        }
    }
}

/// A `[gcode]` entry that makes no sense.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SetupError {
    pub key: String,
    pub message: String,
}

impl Setup {
    /// The profile's `[gcode]` table: the unit of a file that names none,
    /// and what each listed G or M code does (`m8 = "ignore"`,
    /// `m3 = "output:spindle"`). Every entry that makes no sense is an
    /// error by its key.
    pub fn apply_table(
        &mut self,
        unit: Option<&str>,
        codes: &BTreeMap<String, String>,
    ) -> Result<(), Vec<SetupError>> {
        let mut errors = Vec::new();
        self.default_units = match unit {
            None => None,
            Some("mm") => Some(Units::Mm),
            Some("inch") => Some(Units::Inch),
            Some(other) => {
                errors.push(SetupError {
                    key: "gcode.unit".into(),
                    message: format!("`{other}` is no unit: mm or inch"),
                });
                None
            }
        };
        for (code, rule) in codes {
            let key = format!("gcode.{code}");
            let lower = code.to_ascii_lowercase();
            if !is_code_name(&lower) {
                errors.push(SetupError {
                    key,
                    message: "not a G or M code (`m8`, `g64`) nor a [gcode] setting".into(),
                });
                continue;
            }
            let parsed = if rule == "ignore" {
                Ok(CodeRule::Ignore)
            } else if let Some(target) = rule.strip_prefix("output:") {
                if self.output(target).is_some() {
                    Ok(CodeRule::Output(target.to_owned()))
                } else {
                    Err(format!(
                        "`{target}` is no output of this profile (roles and addresses: {})",
                        self.output_names()
                    ))
                }
            } else {
                Err(format!(
                    "`{rule}`: a code is mapped to \"ignore\" or \"output:<role or address>\""
                ))
            };
            match parsed {
                Ok(rule) => {
                    self.codes.insert(lower, rule);
                }
                Err(message) => errors.push(SetupError { key, message }),
            }
        }
        if errors.is_empty() {
            Ok(())
        } else {
            Err(errors)
        }
    }

    /// An output by role (`spindle`), address (`out0.3`) or name.
    pub fn output(&self, key: &str) -> Option<&NamedOutput> {
        self.outputs.iter().find(|o| {
            o.address.eq_ignore_ascii_case(key)
                || o.name.eq_ignore_ascii_case(key)
                || o.role
                    .is_some_and(|r| r.to_string().eq_ignore_ascii_case(key))
        })
    }

    pub fn output_names(&self) -> String {
        if self.outputs.is_empty() {
            return "none".into();
        }
        self.outputs
            .iter()
            .map(|o| match o.role {
                Some(r) => format!("{} ({r})", o.address),
                None => o.address.clone(),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    pub fn zero(&self, system: System) -> Point {
        self.zeros.get(system.index()).copied().unwrap_or_default()
    }
}

fn is_code_name(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some('g' | 'm'))
        && !s[1..].is_empty()
        && s[1..].chars().all(|c| c.is_ascii_digit() || c == '.')
}

/// The wiring's outputs (all but those marked unused), numbered in order.
pub fn outputs_of(wiring: &Wiring) -> Vec<NamedOutput> {
    wiring
        .bits()
        .iter()
        .filter(|b| b.kind == BitKind::Output && b.role != Role::Unused)
        .zip(0u32..)
        .map(|(b, number)| NamedOutput {
            address: b.address.clone(),
            name: b.name.clone(),
            role: (b.role != Role::User).then_some(b.role),
            number,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gcode_table_maps_codes_and_refuses_what_makes_no_sense_by_key() {
        let mut setup = Setup {
            outputs: vec![NamedOutput {
                address: "out2".into(),
                name: "spindle".into(),
                role: Some(Role::Spindle),
                number: 0,
            }],
            ..Setup::default()
        };
        let codes: BTreeMap<String, String> = [("m8", "ignore"), ("M3", "output:spindle")]
            .map(|(code, rule)| (code.to_owned(), rule.to_owned()))
            .into();
        setup.apply_table(Some("mm"), &codes).expect("a good table");
        assert_eq!(setup.default_units, Some(Units::Mm));
        assert_eq!(setup.codes.get("m8"), Some(&CodeRule::Ignore));
        assert_eq!(
            setup.codes.get("m3"),
            Some(&CodeRule::Output("spindle".into()))
        );

        let bad: BTreeMap<String, String> = [
            ("m7", "output:coolant"),
            ("m9", "switch off"),
            ("speed", "ignore"),
        ]
        .map(|(code, rule)| (code.to_owned(), rule.to_owned()))
        .into();
        let errors = Setup::default()
            .apply_table(Some("furlong"), &bad)
            .expect_err("a bad table");
        let keys: Vec<&str> = errors.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["gcode.unit", "gcode.m7", "gcode.m9", "gcode.speed"]);
        assert!(errors[1].message.contains("no output of this profile"));
        assert!(errors[2].message.contains("\"ignore\" or \"output:"));
        assert!(errors[3].message.contains("not a G or M code"));
    }
}
