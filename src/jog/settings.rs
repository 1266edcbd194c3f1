//! What jogging needs from a machine profile, converted once: axes in steps
//! and step frequencies, the step and speed lists, the dead-man timing, and
//! how the family brakes (for the speed caps the keypad shows).

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::config::profile::{JogMode, Unit};
use crate::device::api::{Dir, PerAxis};
use crate::proto::Protocol;

use crate::motion::{Braking, speed_cap};

/// One axis as jogging sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JogAxis {
    pub axis: Axis,
    pub steps_per_unit: f64,
    pub unit: Unit,
    /// The profile's `max_speed`, units per second.
    pub max_speed: f64,
    /// Soft limits in units (machine coordinates).
    pub min: f64,
    pub max: f64,
    /// `jog.max_overrun` in steps of this axis.
    pub max_overrun_steps: f64,
}

impl JogAxis {
    pub fn to_steps(&self, units: f64) -> i64 {
        (units * self.steps_per_unit).round() as i64
    }

    pub fn hz(&self, units_per_second: f64) -> f64 {
        units_per_second.min(self.max_speed) * self.steps_per_unit
    }

    pub fn units_per_second(&self, hz: f64) -> f64 {
        hz / self.steps_per_unit
    }
}

/// The jog part of a profile, ready to use.
#[derive(Debug, Clone, PartialEq)]
pub struct JogSettings {
    pub protocol: Protocol,
    pub axes: Vec<JogAxis>,
    /// Step-jog distances (units), smallest first.
    pub steps: Vec<f64>,
    /// Continuous-jog speeds (units per second), slowest first.
    pub speeds: Vec<f64>,
    pub mode: JogMode,
    /// The first lease of a held jog: the terminal's delay before its first
    /// key repeat (`jog.first_repeat_grace_ms`).
    pub grace: Duration,
    /// The lease each key repeat renews (`jog.repeat_timeout_ms`).
    pub repeat_timeout: Duration,
    pub step_queue: usize,
    pub allow_unreferenced: bool,
    /// How the controller brakes, where the profile says (isel, EMCU).
    pub braking: Option<Braking>,
    /// The jog off a limit switch: the most it travels (units) and its
    /// speed (units per second), `jog.limit_jog_distance`/`_speed`.
    pub limit_distance: f64,
    pub limit_speed: f64,
}

impl JogSettings {
    pub fn from_profile(profile: &Profile) -> JogSettings {
        let jog = &profile.jog;
        let axes = profile
            .axes
            .iter()
            .map(|(axis, p)| JogAxis {
                axis: *axis,
                steps_per_unit: p.steps_per_unit,
                unit: p.unit,
                max_speed: p.max_speed,
                min: p.min,
                max: p.max,
                max_overrun_steps: (jog.max_overrun * p.steps_per_unit).abs(),
            })
            .collect();
        let braking = match profile.connection.protocol {
            // isel manual 2.2.15/2.2.16: the driver sets `@0j`/`@0J` from
            // the profile on connect and on initialise.
            Protocol::Isel => Some(Braking::Ramp {
                start_hz: f64::from(profile.isel.start_stop_hz),
                accel_hz_per_s: f64::from(profile.isel.accel_hz_per_ms) * 1000.0,
            }),
            // EMCU manual 1.5.5, 1.5.7: `#S` and `#R`.
            Protocol::Emcu => Some(Braking::FixedTime {
                start_hz: f64::from(profile.emcu.start_speed_hz),
                ramp: Duration::from_millis(u64::from(profile.emcu.ramp_ms)),
            }),
            // The DRS-500 brakes under its own control (EMP "08", "2A");
            // the profile says nothing about how fast: only the driver can cap.
            Protocol::Emp => None,
        };
        JogSettings {
            protocol: profile.connection.protocol,
            axes,
            steps: jog.steps.clone(),
            speeds: jog.speeds.clone(),
            mode: jog.mode,
            grace: Duration::from_millis(jog.first_repeat_grace_ms),
            repeat_timeout: Duration::from_millis(jog.repeat_timeout_ms),
            step_queue: jog.step_queue,
            allow_unreferenced: jog.allow_unreferenced,
            braking,
            limit_distance: jog.limit_jog_distance,
            limit_speed: jog.limit_jog_speed,
        }
    }

    pub fn axis(&self, axis: Axis) -> Option<&JogAxis> {
        self.axes.iter().find(|a| a.axis == axis)
    }

    pub fn axis_set(&self) -> AxisSet {
        self.axes.iter().map(|a| a.axis).collect()
    }

    /// Per-axis step frequencies for a jog or step along `vector` at a path
    /// speed of `units_per_second`: the path, not each axis, runs at the
    /// speed (a diagonal gives each axis 1/√2 of it), each axis at most at
    /// its `max_speed`.
    pub fn speeds_hz(&self, vector: &[(Axis, Dir)], units_per_second: f64) -> PerAxis<f64> {
        let share = units_per_second / (vector.len().max(1) as f64).sqrt();
        vector
            .iter()
            .filter_map(|(axis, _)| self.axis(*axis).map(|a| (*axis, a.hz(share))))
            .collect()
    }

    /// The per-axis step counts of one step of `units` along `vector`: every
    /// axis named moves by the step (a diagonal step is one step in each).
    pub fn step_delta(&self, vector: &[(Axis, Dir)], units: f64) -> PerAxis<i64> {
        vector
            .iter()
            .filter_map(|(axis, dir)| {
                self.axis(*axis)
                    .map(|a| (*axis, dir.sign() * a.to_steps(units).max(1)))
            })
            .collect()
    }

    /// The fastest path speed (units per second) along `vector` that keeps
    /// the overrun bound for a lease of `lease` on every axis; `None` when
    /// the braking is not known to the console (the driver caps alone).
    pub fn speed_cap(&self, vector: &[(Axis, Dir)], lease: Duration) -> Option<f64> {
        let braking = self.braking?;
        let n = (vector.len().max(1) as f64).sqrt();
        vector
            .iter()
            .filter_map(|(axis, _)| self.axis(*axis))
            .map(|a| {
                let hz = speed_cap(&braking, lease, a.max_overrun_steps);
                a.units_per_second(hz).min(a.max_speed) * n
            })
            .min_by(f64::total_cmp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn settings(name: &str) -> JogSettings {
        let profile = load_profile(name, &ConfigDirs::builtin_only()).expect("profile");
        JogSettings::from_profile(&profile)
    }

    #[test]
    fn the_default_profile_in_steps() {
        let s = settings("default");
        assert_eq!(s.axis_set(), AxisSet::XYZ);
        assert_eq!(s.grace, Duration::from_millis(750));
        assert_eq!(s.repeat_timeout, Duration::from_millis(150));
        let x = s.axis(Axis::X).expect("X");
        assert_eq!(x.max_overrun_steps, 1200.0);
        // 2 mm/s along X is 800 Hz; diagonally each axis gets 2/√2 mm/s.
        let v = s.speeds_hz(&[(Axis::X, Dir::Plus)], 2.0);
        assert_eq!(v.get(Axis::X), Some(800.0));
        let d = s.speeds_hz(&[(Axis::X, Dir::Plus), (Axis::Y, Dir::Minus)], 2.0);
        let each = 800.0 / 2f64.sqrt();
        assert!((d.get(Axis::Y).unwrap_or(0.0) - each).abs() < 1e-9);
        // Never above the axis maximum (25 mm/s).
        let fast = s.speeds_hz(&[(Axis::X, Dir::Plus)], 100.0);
        assert_eq!(fast.get(Axis::X), Some(10_000.0));
        let step = s.step_delta(&[(Axis::X, Dir::Minus), (Axis::Y, Dir::Plus)], 0.1);
        assert_eq!(step.get(Axis::X), Some(-40));
        assert_eq!(step.get(Axis::Y), Some(40));
        // A step smaller than the resolution still moves one step.
        assert_eq!(
            s.step_delta(&[(Axis::Z, Dir::Plus)], 0.0001).get(Axis::Z),
            Some(1)
        );
    }

    #[test]
    fn caps_are_known_for_isel_and_emcu_but_not_emp() {
        let isel = settings("default");
        let x = [(Axis::X, Dir::Plus)];
        let grace = isel
            .speed_cap(&x, isel.grace)
            .expect("isel brakes on a ramp");
        let repeat = isel.speed_cap(&x, isel.repeat_timeout).expect("cap");
        assert!(grace < repeat, "{grace} {repeat}");
        assert!(grace > 3.5 && grace < 4.0, "{grace}");
        let emcu = settings("emcu");
        assert!(emcu.speed_cap(&x, emcu.repeat_timeout).is_some());
        let emp = settings("emp");
        assert_eq!(emp.speed_cap(&x, emp.repeat_timeout), None);
    }
}
