//! What the isel driver needs from a machine profile, converted once into
//! controller units: steps, step frequencies (Hz), the axis configuration
//! `@0<n>` and the timing of the line.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::device::api::PerAxis;
use crate::device::common::Polling;
use crate::device::common::settings::{axis_limits, listed_axes, wiring};
use crate::motion::Ramp;
use crate::proto::Protocol;
use crate::proto::isel::{AxisConfig, DeviceNumber, InputPort, SPEED_HZ};
use crate::wire::LineSettings;
use crate::wiring::Wiring;

pub use crate::device::common::{AxisLimits, JogSettings, PollRate, SettingsError};

/// What one poll cycle reads: `@0P`, and the input ports on a port cycle.
pub type PollPlan = crate::device::common::PollPlan<InputPort>;

impl PollPlan {
    /// The safety ports first: E-stop circuits (1), limit switches (3), then
    /// hood and power (2) (`docs/decisions.md` isel 7).
    pub const DEFAULT_PORTS: [InputPort; 3] = [
        InputPort::Status1,
        InputPort::LimitSwitches,
        InputPort::Status2,
    ];

    /// Every input port, safety first: what `jogterm watch` reads.
    pub const ALL_INPUT_PORTS: [InputPort; 4] = [
        InputPort::Status1,
        InputPort::LimitSwitches,
        InputPort::Status2,
        InputPort::User,
    ];

    /// The default ports, and port 0 (the user inputs) when the profile
    /// wires one of them to something jogterm watches or shows by role (a
    /// probe, a key, an E-stop …; `crate::wiring`), last.
    pub fn ports_for(wiring: &Wiring) -> Vec<InputPort> {
        let mut ports = Self::DEFAULT_PORTS.to_vec();
        let user_port_used = (0..8u8).any(|bit| {
            wiring
                .bit(&crate::wiring::isel_input_address(InputPort::User, bit))
                .is_some_and(|b| {
                    b.wired
                        && !matches!(
                            b.role,
                            crate::wiring::Role::User | crate::wiring::Role::Unused
                        )
                })
        });
        if user_port_used {
            ports.push(InputPort::User);
        }
        ports
    }
}

/// Tuning of the driver's timing; the defaults are documented in
/// `docs/device.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Added to a query's wire time for the controller's processing and the
    /// host's scheduling: the profile's `connection.reply_margin_ms`.
    pub reply_margin: Duration,
    /// Interval of estimated positions while a move runs (25 Hz).
    pub estimate_interval: Duration,
    /// Quiet time the line must show before the next command after a
    /// garbled reply or a stopped move, so stray bytes cannot be taken for
    /// the next reply.
    pub resync_gap: Duration,
    /// Time the controller is left alone after 0xFE (software reset).
    pub reset_settle: Duration,
    /// Quiet after the stop sequence that opens every connection, for the
    /// answer of a move that may still have been running.
    pub connect_settle: Duration,
    /// How long a session that only reads waits for a controller that
    /// answers nothing (a stored program runs) before it gives up: the
    /// profile's `isel.busy_wait_s`.
    pub busy_wait: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            reply_margin: Duration::from_millis(
                crate::config::profile::Connection::DEFAULT_REPLY_MARGIN_MS,
            ),
            estimate_interval: Duration::from_millis(40),
            resync_gap: Duration::from_millis(10),
            reset_settle: Duration::from_millis(100),
            connect_settle: Duration::from_millis(100),
            busy_wait: Duration::from_secs(
                crate::config::profile::IselProfile::DEFAULT_BUSY_WAIT_S,
            ),
        }
    }
}

/// The isel driver's view of a profile.
#[derive(Debug, Clone, PartialEq)]
pub struct IselSettings {
    pub device: DeviceNumber,
    /// The axis configuration the machine has (`machine.axes`).
    pub config: AxisConfig,
    pub axes: PerAxis<AxisLimits>,
    pub start_stop_hz: u32,
    pub accel_hz_per_ms: u32,
    pub reference_speed_hz: u32,
    /// Whether `@0T1` may be sent (`isel.test_mode`).
    pub test_mode_allowed: bool,
    /// Whether a stored program jogterm does not know may start on axes not
    /// referenced (`isel.start_unreferenced`).
    pub start_unreferenced: crate::config::StartUnreferenced,
    pub jog: JogSettings,
    pub line: LineSettings,
    pub poll: PollPlan,
    pub timing: Timing,
    /// What the machine's bits are wired to (`[io]`): names for every bit,
    /// and the only inputs jogterm refuses motion on itself.
    pub wiring: Wiring,
}

impl IselSettings {
    /// A command's own polling (`Polling`): positions (`@0P`), with
    /// `ports` the input ports 1, 3, 2 every cycle (and 0 when the profile
    /// wires a user input to a role, `PollPlan::ports_for`); the inputs
    /// alone: every input port, 1, 3, 2, 0. Without polling the profile's
    /// plan stays as it is.
    pub fn poll_as(&mut self, polling: Polling) {
        self.poll.rate = polling.rate;
        if polling.rate != PollRate::Off {
            self.poll.ports_every = 1;
            self.poll.positions = polling.positions;
            self.poll.ports = match (polling.ports, polling.positions) {
                (false, _) => Vec::new(),
                (true, true) => PollPlan::ports_for(&self.wiring),
                (true, false) => PollPlan::ALL_INPUT_PORTS.to_vec(),
            };
        }
    }

    pub fn from_profile(profile: &Profile) -> Result<IselSettings, SettingsError> {
        SettingsError::check_protocol(profile, Protocol::Isel)?;
        let listed = listed_axes(profile)?;
        let config = AxisConfig::ALL
            .into_iter()
            .find(|c| c.axes() == listed)
            .ok_or_else(|| {
                SettingsError::invalid(
                    profile,
                    format!("isel drives X, XY, XYZ or XYZA, not {listed}"),
                )
            })?;
        let device = DeviceNumber::new(profile.isel.device)
            .ok_or_else(|| SettingsError::invalid(profile, "isel device numbers are 0-9"))?;
        let wiring = wiring(profile)?;
        // isel decision 13: 1..=40000 Hz.
        let hz = (f64::from(*SPEED_HZ.start()), f64::from(*SPEED_HZ.end()));
        Ok(IselSettings {
            device,
            config,
            axes: axis_limits(profile, config.axes(), hz)?,
            start_stop_hz: profile.isel.start_stop_hz,
            accel_hz_per_ms: profile.isel.accel_hz_per_ms,
            reference_speed_hz: profile.isel.reference_speed_hz,
            test_mode_allowed: profile.isel.test_mode,
            start_unreferenced: profile.isel.start_unreferenced,
            jog: JogSettings::from_profile(profile),
            line: profile.connection.line(),
            poll: PollPlan {
                rate: PollRate::from_profile(profile.poll.rate_hz),
                positions: true,
                ports_every: profile.poll.ports_every.max(1),
                ports: PollPlan::ports_for(&wiring),
            },
            timing: Timing {
                reply_margin: profile.connection.reply_margin(),
                busy_wait: profile.isel.busy_wait(),
                ..Timing::default()
            },
            wiring,
        })
    }

    pub fn axis_set(&self) -> AxisSet {
        self.config.axes()
    }

    pub fn limits(&self, axis: Axis) -> Option<AxisLimits> {
        self.axes.get(axis)
    }

    /// The ramp of a move at `max_hz` with the start-stop frequency and
    /// acceleration the driver sets (`@0j`, `@0J`, manual 2.2.15/2.2.16).
    pub fn ramp(&self, max_hz: f64) -> Ramp {
        Ramp {
            start_hz: f64::from(self.start_stop_hz),
            max_hz,
            accel_hz_per_s: f64::from(self.accel_hz_per_ms) * 1000.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_default_profile_becomes_steps_and_hertz() {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let s = IselSettings::from_profile(&profile).expect("settings");
        assert_eq!(s.config, AxisConfig::XYZ);
        let x = s.limits(Axis::X).expect("X");
        assert_eq!((x.min, x.max), (0, 120_000));
        assert_eq!(x.max_hz, 10_000.0);
        assert_eq!(x.max_overrun, 1_200.0);
        assert_eq!(s.limits(Axis::A), None);
        assert_eq!(s.line.baud, 19200);
        assert_eq!(s.poll.rate, PollRate::LineSpeed);
    }

    #[test]
    fn other_protocols_are_refused() {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        assert!(matches!(
            IselSettings::from_profile(&profile),
            Err(SettingsError::WrongProtocol { .. })
        ));
    }
}
