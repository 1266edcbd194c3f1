//! Profile values every family reads the same way: the axes in steps and Hz,
//! and how jogs behave. Each family's settings add their own controller
//! values on top.

use std::time::Duration;

use thiserror::Error;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::device::api::PerAxis;
use crate::proto::Protocol;

use super::limits::AxisLimits;

#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SettingsError {
    #[error("profile `{profile}` is for the {protocol} protocol, not {expected}")]
    WrongProtocol {
        profile: String,
        protocol: Protocol,
        expected: Protocol,
    },
    #[error("profile `{profile}`: {message}")]
    Invalid { profile: String, message: String },
}

impl SettingsError {
    /// `profile` is not for `expected`'s controllers.
    pub fn check_protocol(profile: &Profile, expected: Protocol) -> Result<(), SettingsError> {
        if profile.connection.protocol == expected {
            Ok(())
        } else {
            Err(SettingsError::WrongProtocol {
                profile: profile.name.clone(),
                protocol: profile.connection.protocol,
                expected,
            })
        }
    }

    pub fn invalid(profile: &Profile, message: impl Into<String>) -> SettingsError {
        SettingsError::Invalid {
            profile: profile.name.clone(),
            message: message.into(),
        }
    }
}

/// The profile's wiring (`crate::wiring`), or its first problem. A loaded
/// profile has been checked already; this catches a profile changed after
/// loading (`jogterm send --drive`).
pub fn wiring(profile: &Profile) -> Result<crate::wiring::Wiring, SettingsError> {
    profile.wiring().map_err(|problems| {
        let text = problems
            .iter()
            .map(|p| format!("{}: {}", p.key.join("."), p.message))
            .collect::<Vec<_>>()
            .join("; ");
        SettingsError::invalid(profile, text)
    })
}

/// How jogs and steps behave (`[jog]` of the profile).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JogSettings {
    pub allow_unreferenced: bool,
    /// Step presses remembered while a step runs (at least 1).
    pub step_queue: usize,
    /// Dead-man timeout once key repeats flow; with `max_overrun` it caps jog speeds.
    pub repeat_timeout: Duration,
    /// The jog off a limit switch, per axis of the profile.
    pub limit_jog: PerAxis<LimitJog>,
}

/// The jog off a limit switch of one axis (`jog.limit_jog_distance`,
/// `jog.limit_jog_speed`) in steps and Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitJog {
    /// The most it travels, steps (at least 1).
    pub distance: i64,
    /// Its speed, Hz: the profile's, at most the axis's `max_speed`; the
    /// family caps it to what its controller runs.
    pub hz: f64,
}

impl JogSettings {
    /// The jog off a limit switch of `axis`, or why there is none.
    pub fn limit_jog_of(&self, axis: Axis) -> Result<LimitJog, crate::device::api::Refusal> {
        self.limit_jog
            .get(axis)
            .ok_or_else(|| super::limits::invalid(format!("the profile has no [axes.{axis}]")))
    }

    pub fn from_profile(profile: &Profile) -> JogSettings {
        let jog = &profile.jog;
        let limit_jog = profile
            .axes
            .iter()
            .map(|(axis, p)| {
                let spu = p.steps_per_unit.abs();
                let limit = LimitJog {
                    distance: ((jog.limit_jog_distance * spu).round() as i64).max(1),
                    hz: jog.limit_jog_speed.min(p.max_speed) * spu,
                };
                (*axis, limit)
            })
            .collect();
        JogSettings {
            allow_unreferenced: jog.allow_unreferenced,
            step_queue: jog.step_queue.max(1),
            repeat_timeout: Duration::from_millis(jog.repeat_timeout_ms),
            limit_jog,
        }
    }
}

/// The listed axes of a profile in steps and Hz: soft limits, the highest
/// speed (`max_speed`, within `hz_range` of the controller) and
/// `jog.max_overrun` in steps.
pub fn axis_limits(
    profile: &Profile,
    axes: AxisSet,
    hz_range: (f64, f64),
) -> Result<PerAxis<AxisLimits>, SettingsError> {
    let (lowest, highest) = hz_range;
    let mut out = PerAxis::new();
    for axis in axes.iter() {
        let p = profile.axis(axis).ok_or_else(|| {
            SettingsError::invalid(profile, format!("axis {axis} has no [axes.{axis}] table"))
        })?;
        out.set(
            axis,
            AxisLimits {
                min: p.min_steps(),
                max: p.max_steps(),
                max_hz: p.speed_hz(p.max_speed).min(highest).max(lowest),
                max_overrun: (profile.jog.max_overrun * p.steps_per_unit).abs(),
            },
        );
    }
    Ok(out)
}

/// The axes `machine.axes` lists, or why they are no axes.
pub fn listed_axes(profile: &Profile) -> Result<AxisSet, SettingsError> {
    profile
        .machine
        .axis_set()
        .map_err(|m| SettingsError::invalid(profile, m))
}

/// The machine's axes in the order a reference run takes them: Z first (the
/// tool up, away from the work), then Y, X and A, as the isel controller
/// does (isel manual 2.2.22).
pub fn reference_order(axes: AxisSet) -> Vec<Axis> {
    [Axis::Z, Axis::Y, Axis::X, Axis::A]
        .into_iter()
        .filter(|a| axes.contains(*a))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_emcu_profile_becomes_steps_and_hertz() {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        let axes = listed_axes(&profile).expect("axes");
        assert_eq!(axes, AxisSet::XYZ);
        let limits = axis_limits(&profile, axes, (1.0, 9999.0)).expect("limits");
        let x = limits.get(Axis::X).expect("X");
        assert_eq!((x.min, x.max), (0, 60_000));
        assert_eq!(x.max_hz, 2_000.0);
        assert_eq!(x.max_overrun, 600.0);
        let jog = JogSettings::from_profile(&profile);
        assert_eq!(jog.step_queue, 2);
        assert_eq!(jog.repeat_timeout, Duration::from_millis(150));
    }

    #[test]
    fn speeds_are_held_inside_the_controllers_range() {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let limits = axis_limits(&profile, AxisSet::XYZ, (1.0, 5_000.0)).expect("limits");
        assert_eq!(limits.get(Axis::X).map(|l| l.max_hz), Some(5_000.0));
    }

    /// The profile's `connection.reply_margin_ms` (`docs/protocols.md`,
    /// "Assumptions", row 25) is every family's reply margin.
    #[test]
    fn every_family_takes_the_profiles_reply_margin() {
        use crate::device::emcu::EmcuSettings;
        use crate::device::emp::EmpSettings;
        use crate::device::isel::IselSettings;
        for name in ["default", "emcu", "emp"] {
            let mut p = load_profile(name, &ConfigDirs::builtin_only()).expect("profile");
            p.connection.reply_margin_ms = Some(350);
            let margin = match p.connection.protocol {
                Protocol::Isel => IselSettings::from_profile(&p).map(|s| s.timing.reply_margin),
                Protocol::Emcu => EmcuSettings::from_profile(&p).map(|s| s.timing.reply_margin),
                Protocol::Emp => EmpSettings::from_profile(&p).map(|s| s.timing.reply_margin),
            };
            assert_eq!(margin.ok(), Some(Duration::from_millis(350)), "{name}");
        }
    }

    #[test]
    fn the_wrong_family_is_named() {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        let err = SettingsError::check_protocol(&profile, Protocol::Emcu).unwrap_err();
        assert_eq!(
            err.to_string(),
            "profile `EMP DRS-500-ECS` is for the emp protocol, not emcu"
        );
    }

    #[test]
    fn references_run_z_first() {
        assert_eq!(
            reference_order(AxisSet::XYZA),
            vec![Axis::Z, Axis::Y, Axis::X, Axis::A]
        );
        assert_eq!(
            reference_order(AxisSet::from_mask(0b101)),
            vec![Axis::Z, Axis::X]
        );
    }
}
