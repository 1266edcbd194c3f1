//! What the EMCU driver needs from a machine profile, in steps and Hz: the
//! axes (X, Y, Z at most, manual 1.5.4), the start speed and ramp length it
//! sets (`#S`, `#R`, manual 1.5.5/1.5.7), the end-speed slot of its moves
//! (`#E<slot>`, decision 3), and the timing of the line.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::device::api::PerAxis;
use crate::device::common::settings::{axis_limits, listed_axes};
use crate::device::common::{AxisLimits, JogSettings, PollPlan, PollRate, Polling, SettingsError};
use crate::motion::Ramp;
use crate::proto::Protocol;
use crate::proto::emcu::{RampMillis, Slot, Speed};
use crate::wire::LineSettings;

/// What a port cycle reads: the `@X` status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StatusPoll;

/// Tuning of the driver's timing; the defaults are in `docs/device.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// The longest an acknowledgement may take (manual 1.4.2: 500 ms), on
    /// top of the bytes' wire time.
    pub ack: Duration,
    /// Added for the host's scheduling: the profile's
    /// `connection.reply_margin_ms`.
    pub reply_margin: Duration,
    /// Quiet the line must show after a reply that did not fit, before the
    /// exchange counts as lost (a late answer may still come).
    pub resync_gap: Duration,
    /// Quiet after the `@B` that opens every connection, for its answers
    /// (the CR, and the 0x02 CR of a job it ended).
    pub connect_settle: Duration,
    /// Added to a run's planned duration before it counts as overdue.
    pub run_margin: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            ack: crate::proto::emcu::MAX_ACK_DELAY,
            reply_margin: Duration::from_millis(
                crate::config::profile::Connection::DEFAULT_REPLY_MARGIN_MS,
            ),
            resync_gap: Duration::from_millis(40),
            connect_settle: Duration::from_millis(100),
            run_margin: Duration::from_secs(1),
        }
    }
}

/// The EMCU driver's view of a profile.
#[derive(Debug, Clone, PartialEq)]
pub struct EmcuSettings {
    /// The machine's axes (a subset of X, Y, Z).
    pub axes: AxisSet,
    pub limits: PerAxis<AxisLimits>,
    /// `#S`: start speed, also the reference speed (manual 1.5.8).
    pub start_speed: Speed,
    /// `#R`: ramp length.
    pub ramp: RampMillis,
    /// The `#E` slot of jogterm's moves.
    pub move_slot: Slot,
    /// Whether a ROM job jogterm does not know may run on axes not
    /// referenced (`emcu.start_unreferenced`).
    pub start_unreferenced: crate::config::StartUnreferenced,
    pub jog: JogSettings,
    pub line: LineSettings,
    pub poll: PollPlan<StatusPoll>,
    pub timing: Timing,
    /// What E1, A1 and A2 are wired to (`[io]`, `crate::wiring`).
    pub wiring: crate::wiring::Wiring,
}

impl EmcuSettings {
    /// A command's own polling (`Polling`): positions (`@LX`, `@LY`,
    /// `@LZ`), with `ports` `@X` every cycle.
    pub fn poll_as(&mut self, polling: Polling) {
        self.poll.rate = polling.rate;
        if polling.rate != PollRate::Off {
            self.poll.ports_every = 1;
            self.poll.positions = polling.positions;
            if !polling.ports {
                self.poll.ports.clear();
            }
        }
    }

    pub fn from_profile(profile: &Profile) -> Result<EmcuSettings, SettingsError> {
        SettingsError::check_protocol(profile, Protocol::Emcu)?;
        let axes = listed_axes(profile)?;
        if axes.contains(Axis::A) || axes.is_empty() {
            return Err(SettingsError::invalid(
                profile,
                format!("the EMCU drives X, Y and Z, not {axes}"),
            ));
        }
        let invalid =
            |e: crate::proto::emcu::ValueError| SettingsError::invalid(profile, e.to_string());
        let emcu = &profile.emcu;
        let start_speed = u16::try_from(emcu.start_speed_hz)
            .ok()
            .map_or_else(|| Speed::new(u16::MAX), Speed::new)
            .map_err(invalid)?;
        let ramp = u16::try_from(emcu.ramp_ms)
            .ok()
            .map_or_else(|| RampMillis::new(u16::MAX), RampMillis::new)
            .map_err(invalid)?;
        let move_slot = Slot::new(u16::from(emcu.move_slot)).map_err(invalid)?;
        let hz = (f64::from(Speed::MIN), f64::from(Speed::MAX));
        Ok(EmcuSettings {
            axes,
            limits: axis_limits(profile, axes, hz)?,
            start_speed,
            ramp,
            move_slot,
            start_unreferenced: emcu.start_unreferenced,
            jog: JogSettings::from_profile(profile),
            line: profile.connection.line(),
            poll: PollPlan {
                rate: PollRate::from_profile(profile.poll.rate_hz),
                positions: true,
                ports_every: profile.poll.ports_every.max(1),
                ports: vec![StatusPoll],
            },
            timing: Timing {
                reply_margin: profile.connection.reply_margin(),
                ..Timing::default()
            },
            wiring: crate::device::common::settings::wiring(profile)?,
        })
    }

    pub fn limits(&self, axis: Axis) -> Option<AxisLimits> {
        self.limits.get(axis)
    }

    /// How a move brakes: the `#R` ramp time from any speed down to the
    /// start speed (manual 1.5.5-1.5.7), the same ramp [`Self::move_ramp`]
    /// runs.
    pub fn braking(&self) -> crate::motion::Braking {
        crate::motion::Braking::FixedTime {
            start_hz: f64::from(self.start_speed.get()),
            ramp: std::time::Duration::from_millis(u64::from(self.ramp.get())),
        }
    }

    /// The ramp of the leading axis of an `L` move whose slot is at
    /// `end_hz`: `#R` ms from the start speed to the end speed and the same
    /// down (manual 1.5.5-1.5.7); an end speed at or below the start speed
    /// runs without a ramp (`docs/protocols.md`, EMCU).
    pub fn move_ramp(&self, end_hz: f64) -> Ramp {
        let start = f64::from(self.start_speed.get());
        let ramp_s = f64::from(self.ramp.get()) / 1000.0;
        Ramp {
            start_hz: start,
            max_hz: end_hz,
            accel_hz_per_s: if end_hz > start {
                (end_hz - start) / ramp_s
            } else {
                0.0
            },
        }
    }

    /// The reference speed: the start speed (manual 1.5.8).
    pub fn reference_hz(&self) -> f64 {
        f64::from(self.start_speed.get())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn profile(name: &str) -> Profile {
        load_profile(name, &ConfigDirs::builtin_only()).expect("profile")
    }

    #[test]
    fn the_shipped_profile_becomes_steps_slots_and_ramps() {
        let s = EmcuSettings::from_profile(&profile("emcu")).expect("settings");
        assert_eq!(s.axes, AxisSet::XYZ);
        assert_eq!(s.start_speed.get(), 200);
        assert_eq!(s.ramp.get(), 500);
        assert_eq!(s.move_slot.get(), 9);
        assert_eq!(s.limits(Axis::Z).map(|l| l.max_hz), Some(1000.0));
        assert_eq!(s.line.baud, 19200);
        let ramp = s.move_ramp(1000.0);
        assert_eq!(ramp.accel_hz_per_s, 1600.0);
        assert_eq!(s.move_ramp(100.0).accel_hz_per_s, 0.0);
    }

    #[test]
    fn other_families_and_bad_values_are_refused() {
        assert!(matches!(
            EmcuSettings::from_profile(&profile("default")),
            Err(SettingsError::WrongProtocol { .. })
        ));
        let mut p = profile("emcu");
        p.emcu.ramp_ms = 0;
        let err = EmcuSettings::from_profile(&p).unwrap_err();
        assert!(err.to_string().contains("ramp length"), "{err}");
        let mut p = profile("emcu");
        p.emcu.start_speed_hz = 70_000;
        assert!(EmcuSettings::from_profile(&p).is_err());
    }
}
