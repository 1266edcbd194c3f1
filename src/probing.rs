//! Probing as an operator asks for it (`docs/probing.md`), sans-IO: the
//! probe move of the profile's `[probe]` table in steps, what a touched
//! point means for a work offset (Z touch-off, edges, bores), and the words
//! for how a probe ended. The console and `jogterm probe` both use it; the
//! probing move itself is the device's (`Request::Probe`,
//! `device::common::probe`).

use crate::axis::Axis;
use crate::config::Profile;
use crate::config::probe::ProbeProfile;
use crate::config::profile::AxisProfile;
use crate::device::api::{Dir, PerAxis, ProbeEnd, ProbeMove};

/// The probe move along `axis` toward smaller (`Dir::Minus`) or larger
/// machine units, from the profile: travel and speeds in steps (the speeds
/// at most the axis's `max_speed`).
pub fn probe_move(profile: &Profile, axis: Axis, toward: Dir) -> Result<ProbeMove, String> {
    let a = profile
        .axis(axis)
        .ok_or_else(|| format!("the machine has no {axis} axis"))?;
    Ok(probe_move_of(a, &profile.probe, axis, toward))
}

/// The same for an axis and a `[probe]` table at hand.
pub fn probe_move_of(a: &AxisProfile, p: &ProbeProfile, axis: Axis, toward: Dir) -> ProbeMove {
    let spu = a.steps_per_unit;
    // Steps count the other way where steps_per_unit is negative.
    let dir = if spu < 0.0 { toward.reverse() } else { toward };
    let hz = |speed: f64| speed.min(a.max_speed) * spu.abs();
    ProbeMove {
        axis,
        dir,
        travel: (p.travel * spu).abs().round() as i64,
        fast_hz: hz(p.fast_speed),
        slow_hz: hz(p.slow_speed),
    }
}

/// Machine units of `steps` on `axis`.
pub fn units(profile: &Profile, axis: Axis, steps: i64) -> f64 {
    profile.axis(axis).map_or(0.0, |a| a.to_units(steps))
}

/// Machine steps of `units` on `axis`.
pub fn steps(profile: &Profile, axis: Axis, units: f64) -> i64 {
    profile.axis(axis).map_or(0, |a| a.to_steps(units))
}

/// The work zero of Z (machine steps) from a touched Z: the surface minus
/// the plate the tool touched on.
pub fn touch_off_zero(z: &AxisProfile, touched_z: i64, plate: f64) -> i64 {
    z.to_steps(z.to_units(touched_z) - plate)
}

/// Where the face lies (machine units) that a probe moving `toward` along
/// its axis touched with its centre at `touched` units: half the tip
/// further on.
pub fn edge(touched: f64, toward: Dir, tip: f64) -> f64 {
    touched + toward.sign() as f64 * tip / 2.0
}

/// The touched point of a probe that touched.
pub fn touched(end: &ProbeEnd) -> Option<&PerAxis<i64>> {
    match end {
        ProbeEnd::Touched { at, .. } => Some(at),
        _ => None,
    }
}

/// How a probe ended, in words (`what`: "the probe of Z-"; `axis`: its
/// axis as the profile describes it).
pub fn end_text(what: &str, axis: (Axis, &AxisProfile), end: &ProbeEnd) -> String {
    let (axis, a) = axis;
    match end {
        ProbeEnd::Touched { at, fast_stop } => {
            let z = at.get(axis).unwrap_or(0);
            format!(
                "{what} touched at {axis} {:.4} {unit} (the fast pass stopped {:.4} past it)",
                a.to_units(z),
                a.to_units(fast_stop - z).abs(),
                unit = a.unit.symbol(),
            )
        }
        ProbeEnd::NoTrip { travel } => format!(
            "{what} found no surface within its travel ({:.3} {}): it went back to where it \
             started",
            a.to_units(*travel).abs(),
            a.unit.symbol()
        ),
        ProbeEnd::Stopped => format!("{what} was stopped; nothing resumes"),
        ProbeEnd::Refused(why) => format!("{what} was refused: {why}"),
        ProbeEnd::Fault(f) => format!("{what} ended with an error: {}", f.meaning),
        ProbeEnd::LinkLost => format!("{what} ended: the link was lost; nothing resumes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn isel() -> Profile {
        load_profile("default", &ConfigDirs::builtin_only()).expect("profile")
    }

    #[test]
    fn the_probe_move_is_the_profiles_table_in_steps() {
        let p = probe_move(&isel(), Axis::Z, Dir::Minus).expect("Z");
        // 10 mm at 400 steps/mm; 5 and 0.5 mm/s.
        assert_eq!(p.travel, 4000);
        assert_eq!(p.dir, Dir::Minus);
        assert_eq!(p.fast_hz, 2000.0);
        assert_eq!(p.slow_hz, 200.0);
        assert!(probe_move(&isel(), Axis::A, Dir::Minus).is_err());
    }

    #[test]
    fn the_work_zero_is_the_surface_minus_the_plate() {
        // Touched at 30 mm on a 1.5 mm plate: work Z 0 at 28.5 mm.
        let profile = isel();
        let z = profile.axis(Axis::Z).expect("Z");
        assert_eq!(touch_off_zero(z, 12_000, 1.5), 11_400);
        assert_eq!(touch_off_zero(z, 12_000, 0.0), 12_000);
    }

    #[test]
    fn a_tool_is_measured_against_the_reference_tool() {
        let mut tools = ToolTable::default();
        assert_eq!(tools.measured("T1", 30.0), 0.0);
        assert_eq!(tools.reference.as_deref(), Some("T1"));
        // One millimetre longer: it touches one millimetre higher.
        assert_eq!(tools.measured("T2", 31.0), 1.0);
        assert_eq!(tools.offset("T1"), Some(0.0));
        assert_eq!(tools.active_offset(), Some(("T2".into(), 1.0)));
        tools.touched_off();
        assert_eq!(tools.active_offset(), None);
        assert_eq!(tools.measured("T2", 31.0), 0.0);
        assert_eq!(tools.offset("T1"), Some(-1.0));
    }

    #[test]
    fn an_edge_lies_half_the_tip_beyond_the_touch() {
        assert_eq!(edge(10.0, Dir::Plus, 3.0), 11.5);
        assert_eq!(edge(10.0, Dir::Minus, 3.0), 8.5);
    }
}

/// The tools measured on the fixed sensor (`jogterm probe tool`), kept in
/// the state directory per profile and port: the machine Z at which each
/// touched the sensor, and which one is the reference. A longer tool
/// touches higher; its offset is the difference to the reference tool.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ToolTable {
    /// The reference tool: the one measured right after a Z touch-off, or
    /// the first measured. `None`: the next tool measured becomes it.
    pub reference: Option<String>,
    /// Per tool, the machine Z (units) where it touched the sensor.
    pub touched: std::collections::BTreeMap<String, f64>,
    /// The tool in the spindle: the one measured last. Its offset shifts
    /// every Z of a job (`docs/probing.md`, "Tool length").
    #[serde(default)]
    pub active: Option<String>,
}

impl ToolTable {
    /// `tool` touched the sensor at machine Z `z`: kept (the reference
    /// when there is none), and its offset against the reference.
    pub fn measured(&mut self, tool: &str, z: f64) -> f64 {
        self.touched.insert(tool.to_owned(), z);
        self.active = Some(tool.to_owned());
        if self.reference.is_none() {
            self.reference = Some(tool.to_owned());
        }
        self.offset(tool).unwrap_or(0.0)
    }

    /// How much higher `tool` touches than the reference, units.
    pub fn offset(&self, tool: &str) -> Option<f64> {
        let reference = self.reference.as_deref()?;
        Some(self.touched.get(tool)? - self.touched.get(reference)?)
    }

    /// A Z touch-off sets the work Z with the tool in the spindle: the next
    /// tool measured is the reference, and until then the tool in the
    /// spindle has no offset (work Z is its own).
    pub fn touched_off(&mut self) {
        self.reference = None;
    }

    /// The tool in the spindle and its offset against the reference, when
    /// both are measured.
    pub fn active_offset(&self) -> Option<(String, f64)> {
        let tool = self.active.as_deref()?;
        Some((tool.to_owned(), self.offset(tool)?))
    }
}
