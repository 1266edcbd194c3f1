//! The work offsets file as text (TOML), sans-IO. It says whose offsets
//! they are: the profile, the family, the port, and every axis with its
//! unit and steps per unit. A work zero is a count of steps from the
//! reference point, so it means the same place only on the same machine with
//! the same steps per unit: read back, the file is applied only when all of
//! that matches the session, else refused with what differs. A file that
//! cannot be read is refused with its line and column. Nothing is guessed.
//!
//! ```toml
//! format = 1
//! profile = "default"
//! protocol = "isel"
//! port = "sim"
//! active = "G55"
//!
//! [axes]
//! X = { unit = "mm", steps_per_unit = 400.0 }
//!
//! [offsets]
//! G54 = { X = 0 }
//! G55 = { X = 40000 }
//! ```

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::axis::Axis;
use crate::config::profile::{Profile, Unit};
use crate::config::{ConfigError, Source, source};
use crate::proto::Protocol;

use super::{MAX_ZERO_STEPS, System, WorkOffsets};

/// The version of the layout written; another one is refused.
pub const FORMAT: u32 = 1;

/// One axis as the offsets were measured with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisIdentity {
    pub axis: Axis,
    pub unit: Unit,
    pub steps_per_unit: f64,
}

/// What the offsets belong to: a step count is a place only on this machine
/// with these steps per unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Identity {
    /// The profile as the operator names it (`--profile mill`: `mill`).
    pub profile: String,
    pub protocol: Protocol,
    /// The port of the session (`sim` for the built-in simulator).
    pub port: String,
    /// The profile's axes, X, Y, Z, A order.
    pub axes: Vec<AxisIdentity>,
}

impl Identity {
    /// The session's identity: `profile` is the name the profile was
    /// chosen by (`store::profile_key`).
    pub fn of(profile_key: &str, profile: &Profile) -> Identity {
        Identity {
            profile: profile_key.to_string(),
            protocol: profile.connection.protocol,
            port: profile.connection.port.clone(),
            axes: profile
                .axes
                .iter()
                .map(|(axis, p)| AxisIdentity {
                    axis: *axis,
                    unit: p.unit,
                    steps_per_unit: p.steps_per_unit,
                })
                .collect(),
        }
    }

    /// What differs from `other` (the file's), in words; empty when both
    /// describe the same machine.
    fn differences(&self, file: &Identity) -> Vec<String> {
        let mut out = Vec::new();
        if self.profile != file.profile {
            out.push(format!(
                "profile `{}`, this session `{}`",
                file.profile, self.profile
            ));
        }
        if self.protocol != file.protocol {
            out.push(format!(
                "controller family {}, this session {}",
                file.protocol, self.protocol
            ));
        }
        if self.port != file.port {
            out.push(format!("port {}, this session {}", file.port, self.port));
        }
        let letters = |ids: &[AxisIdentity]| -> String {
            ids.iter().map(|a| a.axis.letter()).collect::<String>()
        };
        if letters(&self.axes) != letters(&file.axes) {
            out.push(format!(
                "axes {}, the profile {}",
                letters(&file.axes),
                letters(&self.axes)
            ));
            return out;
        }
        for (mine, theirs) in self.axes.iter().zip(&file.axes) {
            if mine.steps_per_unit != theirs.steps_per_unit || mine.unit != theirs.unit {
                out.push(format!(
                    "{} at {} steps per {}, the profile {} steps per {}",
                    mine.axis,
                    theirs.steps_per_unit,
                    unit_word(theirs.unit),
                    mine.steps_per_unit,
                    unit_word(mine.unit)
                ));
            }
        }
        out
    }
}

fn unit_word(unit: Unit) -> &'static str {
    match unit {
        Unit::Mm => "mm",
        Unit::Deg => "degree",
        Unit::Steps => "step",
    }
}

/// What a file read back means for the session.
#[derive(Debug, Clone, PartialEq)]
pub enum Loaded {
    /// The file's offsets, for this machine.
    Offsets(WorkOffsets),
    /// Not applied, and why: what differs from the session, or where the
    /// file is broken (`file:line:col: error: …`).
    Refused(String),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    format: u32,
    profile: String,
    protocol: Protocol,
    port: String,
    active: String,
    #[serde(default)]
    axes: BTreeMap<String, RawAxis>,
    #[serde(default)]
    offsets: BTreeMap<String, BTreeMap<String, i64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    unit: Unit,
    steps_per_unit: f64,
}

/// Read `source` (the file's text and path) for the session `identity`.
pub fn decode(source: &Source, identity: &Identity) -> Loaded {
    match read(source, identity) {
        Ok(offsets) => Loaded::Offsets(offsets),
        Err(reason) => Loaded::Refused(reason),
    }
}

fn read(source: &Source, identity: &Identity) -> Result<WorkOffsets, String> {
    let raw: RawFile = source::deserialize_text(source).map_err(|e| e.to_string())?;
    let at = |key: &[&str], message: String| {
        let key: Vec<String> = key.iter().map(|k| k.to_string()).collect();
        ConfigError::at_key(source, &key, message).to_string()
    };
    if raw.format != FORMAT {
        return Err(at(
            &["format"],
            format!(
                "format {} is not one this jogterm reads (format {FORMAT})",
                raw.format
            ),
        ));
    }
    let mut axes = Vec::new();
    for (name, a) in &raw.axes {
        let axis = axis_named(name).ok_or_else(|| {
            at(
                &["axes", name],
                format!("`{name}` is not an axis: expected X, Y, Z or A"),
            )
        })?;
        axes.push(AxisIdentity {
            axis,
            unit: a.unit,
            steps_per_unit: a.steps_per_unit,
        });
    }
    axes.sort_by_key(|a| a.axis.index());
    let file = Identity {
        profile: raw.profile.clone(),
        protocol: raw.protocol,
        port: raw.port.clone(),
        axes,
    };
    let differences = identity.differences(&file);
    if !differences.is_empty() {
        return Err(format!(
            "saved for another machine or other steps per unit: {} (file {})",
            differences.join("; "),
            source.origin
        ));
    }
    let mut table = WorkOffsets::default();
    let active = System::from_name(&raw.active).ok_or_else(|| {
        at(
            &["active"],
            format!("`{}` is not a work offset: expected G54 … G59", raw.active),
        )
    })?;
    table.select(active);
    for (name, zeros) in &raw.offsets {
        let system = System::from_name(name).ok_or_else(|| {
            at(
                &["offsets", name],
                format!("`{name}` is not a work offset: expected G54 … G59"),
            )
        })?;
        for (letter, steps) in zeros {
            let axis = axis_named(letter)
                .filter(|a| file.axes.iter().any(|f| f.axis == *a))
                .ok_or_else(|| {
                    at(
                        &["offsets", name, letter],
                        format!("`{letter}` is not one of the file's axes"),
                    )
                })?;
            if steps.abs() > MAX_ZERO_STEPS {
                return Err(at(
                    &["offsets", name, letter],
                    format!(
                        "{steps} steps is farther from the reference point than any controller counts ({MAX_ZERO_STEPS})"
                    ),
                ));
            }
            table.set(system, axis, *steps);
        }
    }
    Ok(table)
}

fn axis_named(name: &str) -> Option<Axis> {
    let mut chars = name.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) if c.is_ascii_uppercase() => Axis::from_letter(c),
        _ => None,
    }
}

/// The file's text for `offsets` of the session `identity`.
pub fn encode(offsets: &WorkOffsets, identity: &Identity) -> String {
    let quoted = |s: &str| toml::Value::String(s.to_string()).to_string();
    let mut out = String::from(
        "# jogterm work offsets (docs/jogging.md, \"Work offsets\"), written by jogterm.\n\
         # Each work zero is a machine position in steps from the reference point;\n\
         # the file is used only for the profile, port and steps per unit below.\n",
    );
    out += &format!("format = {FORMAT}\n");
    out += &format!("profile = {}\n", quoted(&identity.profile));
    out += &format!("protocol = {}\n", quoted(identity.protocol.name()));
    out += &format!("port = {}\n", quoted(&identity.port));
    out += &format!("active = {}\n", quoted(offsets.active().name()));
    out += "\n[axes]\n";
    for a in &identity.axes {
        let unit = match a.unit {
            Unit::Mm => "mm",
            Unit::Deg => "deg",
            Unit::Steps => "steps",
        };
        out += &format!(
            "{} = {{ unit = {}, steps_per_unit = {} }}\n",
            a.axis,
            quoted(unit),
            toml::Value::Float(a.steps_per_unit)
        );
    }
    out += "\n[offsets]\n";
    for system in System::ALL {
        let zeros: Vec<String> = identity
            .axes
            .iter()
            .map(|a| format!("{} = {}", a.axis, offsets.zero(system, a.axis)))
            .collect();
        out += &format!("{system} = {{ {} }}\n", zeros.join(", "));
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::config::{ConfigDirs, Origin, load_profile};

    fn identity() -> Identity {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        Identity::of("default", &profile)
    }

    fn source(text: &str) -> Source {
        Source {
            origin: Origin::File(PathBuf::from("/state/offsets/default@sim.toml")),
            text: text.to_string(),
        }
    }

    fn sample() -> WorkOffsets {
        let mut t = WorkOffsets::default();
        let g55 = System::ALL[1];
        t.set(System::G54, Axis::X, 40_000);
        t.set(g55, Axis::Y, -1_234);
        t.set(g55, Axis::Z, 7);
        t.select(g55);
        t
    }

    #[test]
    fn offsets_survive_the_round_trip() {
        let id = identity();
        let text = encode(&sample(), &id);
        assert!(text.contains("active = \"G55\""), "{text}");
        assert!(
            text.contains("X = { unit = \"mm\", steps_per_unit = 400.0 }"),
            "{text}"
        );
        assert!(text.contains("G55 = { X = 0, Y = -1234, Z = 7 }"), "{text}");
        assert_eq!(decode(&source(&text), &id), Loaded::Offsets(sample()));
    }

    #[test]
    fn another_machine_or_other_steps_per_unit_are_refused_with_what_differs() {
        let id = identity();
        let text = encode(&sample(), &id);
        let mut other = id.clone();
        other.port = "/dev/ttyUSB0".into();
        if let Some(x) = other.axes.first_mut() {
            x.steps_per_unit = 200.0;
        }
        let Loaded::Refused(why) = decode(&source(&text), &other) else {
            panic!("applied")
        };
        assert!(why.starts_with("saved for another machine"), "{why}");
        assert!(
            why.ends_with("(file /state/offsets/default@sim.toml)"),
            "{why}"
        );
        assert!(why.contains("port sim, this session /dev/ttyUSB0"), "{why}");
        assert!(
            why.contains("X at 400 steps per mm, the profile 200 steps per mm"),
            "{why}"
        );
        let mut fewer = id.clone();
        fewer.axes.pop();
        let Loaded::Refused(why) = decode(&source(&text), &fewer) else {
            panic!("applied")
        };
        assert!(why.contains("axes XYZ, the profile XY"), "{why}");
        let mut emcu = id;
        emcu.protocol = Protocol::Emcu;
        emcu.profile = "emcu".into();
        let Loaded::Refused(why) = decode(&source(&text), &emcu) else {
            panic!("applied")
        };
        assert!(
            why.contains("profile `default`, this session `emcu`"),
            "{why}"
        );
        assert!(
            why.contains("controller family isel, this session emcu"),
            "{why}"
        );
    }

    #[test]
    fn a_broken_file_is_refused_with_its_line_and_column() {
        let id = identity();
        let good = encode(&sample(), &id);
        let cases = [
            (good.replace("G55 = {", "G55 = {{"), ":17:", "expected key"),
            (
                good.replace("active = \"G55\"", "active = \"G60\""),
                ":8:",
                "`G60` is not a work offset",
            ),
            (
                good.replace("G56 =", "G66 ="),
                ":18:",
                "`G66` is not a work offset",
            ),
            (
                good.replace("G54 = { X = 40000", "G54 = { Q = 40000"),
                ":16:",
                "`Q` is not one of the file's axes",
            ),
            (
                good.replace("X = 40000", "X = 4000000000000"),
                ":16:",
                "farther from the reference point",
            ),
            (good.replace("format = 1", "format = 2"), ":4:", "format 2"),
            (
                good.replace("format = 1", "colour = 1"),
                ":",
                "unknown field",
            ),
            ("\u{0}garbage".to_string(), ":1:", "error"),
            (String::new(), ":", "missing field"),
        ];
        for (text, place, needle) in cases {
            let Loaded::Refused(why) = decode(&source(&text), &id) else {
                panic!("applied: {text}")
            };
            assert!(why.contains(place), "{place}: {why}\n{text}");
            assert!(why.contains(needle), "{needle}: {why}");
            assert!(why.starts_with("/state/offsets/default@sim.toml"), "{why}");
        }
    }

    proptest::proptest! {
        /// Whatever the file holds: refused or applied, never a panic; an
        /// applied file keeps every zero within bounds.
        #[test]
        fn any_text_is_read_or_refused(text in "\\PC{0,200}") {
            if let Loaded::Offsets(t) = decode(&source(&text), &identity()) {
                for system in System::ALL {
                    for axis in Axis::ALL {
                        proptest::prop_assert!(t.zero(system, axis).abs() <= MAX_ZERO_STEPS);
                    }
                }
            }
        }

        /// Any table written is read back as it was.
        #[test]
        fn any_table_round_trips(
            zeros in proptest::collection::vec(-MAX_ZERO_STEPS..=MAX_ZERO_STEPS, 18),
            active in 0usize..6,
        ) {
            let id = identity();
            let mut t = WorkOffsets::default();
            for (i, z) in zeros.iter().enumerate() {
                let system = System::ALL[i / 3];
                let axis = Axis::ALL[i % 3];
                t.set(system, axis, *z);
            }
            t.select(System::ALL[active]);
            let text = encode(&t, &id);
            proptest::prop_assert_eq!(decode(&source(&text), &id), Loaded::Offsets(t));
        }
    }
}
