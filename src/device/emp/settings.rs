//! What the EMP driver takes from a machine profile: one drive (DS byte) per
//! axis, limits in encoder counts, speeds in counts per second, the stop and
//! jog styles and the homing speeds of `[emp]`, and the timing of the line.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::config::profile::{EmpJog, EmpStop};
use crate::device::api::PerAxis;
use crate::device::common::settings::{axis_limits, listed_axes};
use crate::device::common::{AxisLimits, JogSettings, PollRate, Polling, SettingsError};
use crate::proto::Protocol;
use crate::proto::emp::reload::TIMER_HZ;
use crate::proto::emp::{DriveAddress, FRAME_WIRE_LEN, Speed};
use crate::wire::LineSettings;

use super::speed::{MAX_HZ, MIN_HZ};

/// The drive's processing time between a request's EOF and its reply (EMP
/// manual "Chronologischer Befehlsumfang": 1.6 ms of the 10.8 ms round trip).
pub const PROCESSING: Duration = Duration::from_micros(1600);

/// How long a servo drive is assumed to need to brake from any speed to rest.
/// The manual gives no figure ("Der Motor wird sehr schnell abgebremst"); the
/// jog speed cap and the soft-limit look-ahead use it (docs/protocols.md, EMP).
pub const BRAKE_TIME: Duration = Duration::from_millis(100);

/// One axis and the drive that moves it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveAxis {
    pub axis: Axis,
    pub ds: DriveAddress,
}

/// Timing of the line and the drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// One request and its reply: two frames at the baud rate and the
    /// drive's processing (10.8 ms at 38400 baud).
    pub round_trip: Duration,
    /// A first reply may take this much longer than its round trip (stops
    /// queued ahead of it, the host's scheduling).
    pub reply_margin: Duration,
    /// Quiet after connecting, so the answers to what was in flight before
    /// fall into it.
    pub connect_settle: Duration,
}

/// The profile in the driver's terms.
#[derive(Debug, Clone, PartialEq)]
pub struct EmpSettings {
    pub name: String,
    pub line: LineSettings,
    /// In X, Y, Z, A order.
    pub drives: Vec<DriveAxis>,
    pub axes: AxisSet,
    pub limits: PerAxis<AxisLimits>,
    pub jog: JogSettings,
    pub jog_style: EmpJog,
    pub stop: EmpStop,
    pub home_fast: Speed,
    pub home_slow: Speed,
    /// Position polls (the profile's `poll.rate_hz`, 0 = line speed).
    pub poll: PollRate,
    /// Read the positions every cycle; without, a cycle reads every drive's
    /// inputs only (`jogterm watch`).
    pub poll_positions: bool,
    pub ports_every: u32,
    pub timing: Timing,
    /// What each drive's bits are wired to (`[io]`, `crate::wiring`).
    pub wiring: crate::wiring::Wiring,
    /// `probe.step` in counts per axis (at least 1): the length of each
    /// move of a probe's back-off and second pass (`probe_op`).
    pub probe_step: PerAxis<i64>,
}

impl EmpSettings {
    /// A command's own polling (`Polling`): positions (`2C` of every
    /// drive), with `ports` `40` every cycle.
    pub fn poll_as(&mut self, polling: Polling) {
        self.poll = polling.rate;
        if polling.rate != PollRate::Off {
            self.ports_every = if polling.ports { 1 } else { u32::MAX };
            self.poll_positions = polling.positions;
        }
    }

    pub fn from_profile(profile: &Profile) -> Result<EmpSettings, SettingsError> {
        SettingsError::check_protocol(profile, Protocol::Emp)?;
        let axes = listed_axes(profile)?;
        let mut drives = Vec::new();
        for axis in axes.iter() {
            let text = profile
                .axis(axis)
                .and_then(|a| a.drive.clone())
                .ok_or_else(|| {
                    SettingsError::invalid(
                        profile,
                        format!("axis {axis} names no drive (`drive = \"11\"` in [axes.{axis}])"),
                    )
                })?;
            let ds: DriveAddress = text.parse().map_err(|e| {
                SettingsError::invalid(profile, format!("axis {axis}: drive `{text}`: {e}"))
            })?;
            if let Some(other) = drives.iter().find(|d: &&DriveAxis| d.ds == ds) {
                return Err(SettingsError::invalid(
                    profile,
                    format!("axes {} and {axis} both name drive {ds}", other.axis),
                ));
            }
            drives.push(DriveAxis { axis, ds });
        }
        let speed = |what: &str, v: u8| {
            Speed::new(v).map_err(|e| SettingsError::invalid(profile, format!("emp.{what}: {e}")))
        };
        let line = profile.connection.line();
        let round_trip = line.transfer_time(2 * FRAME_WIRE_LEN) + PROCESSING;
        Ok(EmpSettings {
            name: profile.name.clone(),
            line,
            limits: axis_limits(profile, axes, (MIN_HZ, MAX_HZ))?,
            drives,
            axes,
            jog: JogSettings::from_profile(profile),
            jog_style: profile.emp.jog,
            stop: profile.emp.stop,
            home_fast: speed("home_fast", profile.emp.home_fast)?,
            home_slow: speed("home_slow", profile.emp.home_slow)?,
            poll: PollRate::from_profile(profile.poll.rate_hz),
            poll_positions: true,
            ports_every: profile.poll.ports_every,
            timing: Timing {
                round_trip,
                reply_margin: profile.connection.reply_margin(),
                connect_settle: Duration::from_millis(50),
            },
            wiring: crate::device::common::settings::wiring(profile)?,
            probe_step: profile
                .axes
                .iter()
                .map(|(axis, p)| {
                    let counts = (profile.probe.step * p.steps_per_unit).abs().round();
                    (*axis, (counts as i64).max(1))
                })
                .collect(),
        })
    }

    pub fn drive_of(&self, axis: Axis) -> Option<DriveAddress> {
        self.drives.iter().find(|d| d.axis == axis).map(|d| d.ds)
    }

    pub fn axis_of(&self, ds: DriveAddress) -> Option<Axis> {
        self.drives.iter().find(|d| d.ds == ds).map(|d| d.axis)
    }

    /// How long a first reply may take: its own round trip and one for each
    /// stop frame that may be queued ahead of it, plus the margin.
    pub fn reply_timeout(&self) -> Duration {
        let frames = u32::try_from(self.drives.len() + 1).unwrap_or(u32::MAX);
        self.timing.round_trip * frames + self.timing.reply_margin
    }

    /// Homing speeds in counts per second: jogterm sets the sample rate to
    /// 1 kHz before `26` so that `home_fast`/`home_slow` mean counts per
    /// millisecond (docs/protocols.md, EMP).
    pub fn home_hz(&self, speed: Speed) -> f64 {
        f64::from(speed.value()) * f64::from(TIMER_HZ) / f64::from(HOME_RELOAD)
    }
}

/// The reload value jogterm sets before a reference run: 1 kHz (`30D4`).
pub const HOME_RELOAD: u16 = 0x30D4;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_shipped_profile_has_one_drive_at_11() {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        let s = EmpSettings::from_profile(&profile).expect("settings");
        assert_eq!(s.drives.len(), 1);
        assert_eq!(s.drive_of(Axis::X), Some(DriveAddress::SINGLE));
        assert_eq!(s.axis_of(DriveAddress::SINGLE), Some(Axis::X));
        let x = s.limits.get(Axis::X).expect("X");
        assert_eq!((x.min, x.max), (0, 5_600_000));
        // 10.8 ms in the manual: 2 x 17 bytes at 38400 baud is 8.85 ms + 1.6 ms.
        let rt = s.timing.round_trip.as_secs_f64() * 1000.0;
        assert!((rt - 10.45).abs() < 0.05, "{rt}");
        assert!((s.home_hz(s.home_fast) - 20_000.0).abs() < 1.0);
    }

    #[test]
    fn a_missing_or_shared_drive_is_named() {
        let mut profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        if let Some(x) = profile.axes.get_mut(&Axis::X) {
            x.drive = None;
        }
        let err = EmpSettings::from_profile(&profile).unwrap_err().to_string();
        assert!(err.contains("axis X names no drive"), "{err}");
        if let Some(x) = profile.axes.get_mut(&Axis::X) {
            x.drive = Some("10".into());
        }
        let err = EmpSettings::from_profile(&profile).unwrap_err().to_string();
        assert!(err.contains("drive `10`"), "{err}");
        let other = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        assert!(EmpSettings::from_profile(&other).is_err());
    }
}
