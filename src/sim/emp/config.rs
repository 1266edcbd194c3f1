//! What a simulated EMP link is built from: one [`DriveConfig`] per drive,
//! either written out (tests) or taken from a machine profile's EMP axes
//! (`[axes.X] drive = "11"`, `[sim]`), so that the simulated machine matches the
//! one the console drives.
//!
//! All lengths are physical encoder counts from machine 0 (where the reference
//! point is), speeds counts per second.

use crate::axis::Axis;
use crate::config::profile::{AxisProfile, SimProfile, parse_drive_address};
use crate::config::{ProbeSurface, Profile, SimVariant};
use crate::proto::Protocol;
use crate::proto::emp::{DriveAddress, IdentText, ReloadValue};

/// Drives one link can address: modules 1 to F (EMP manual "02 : Mehrere
/// Baugruppen EIN": "insgesamt 15 Achsen").
pub const MAX_DRIVES: usize = 15;

/// Why a link cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmpSimError {
    #[error("profile `{profile}` is for {protocol}: the EMP simulator needs an emp profile")]
    WrongProtocol { profile: String, protocol: Protocol },
    #[error("axis {axis} has no EMP drive address: add drive = \"11\" to [axes.{axis}]")]
    NoDriveAddress { axis: Axis },
    #[error("axis {axis}: {message}")]
    BadDriveAddress { axis: Axis, message: String },
    #[error("an EMP link has 1 to {MAX_DRIVES} drives, this one {0}")]
    DriveCount(usize),
    #[error("drive {0} is configured twice")]
    DuplicateDrive(DriveAddress),
    #[error(
        "the probe surface needs a drive input with role probe in the profile's [io] \
         (e.g. [io.\"11.I1\"] role = \"probe\"): the EMP simulator's surface drives that input"
    )]
    NoProbeInput,
    #[error(
        "the probe input {0} is no input I1-I4: the drive's limit and reference switches \
         follow its axis' own switches, a probe surface can drive only I1-I4"
    )]
    ProbeNotAnInput(String),
    #[error("drive {ds}: {what} must be {expected}, got {value}")]
    BadSetting {
        ds: DriveAddress,
        what: &'static str,
        expected: &'static str,
        value: f64,
    },
}

/// One simulated DRS-500-ECS drive and its axis.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveConfig {
    pub ds: DriveAddress,
    /// The machine axis the drive moves, for `describe`.
    pub axis: Option<Axis>,
    /// Where the axis stands at power-up. The drive's counter starts at 0
    /// there: an incremental encoder knows nothing before homing.
    pub start_position: f64,
    /// Limit switch + is on at and above this position.
    pub limit_plus: f64,
    /// Limit switch - is on at and below this position.
    pub limit_minus: f64,
    /// The reference switch is on over `[-reference_cam, 0)`.
    pub reference_cam: f64,
    /// Sample timer reload value at power-up, 1-FFFF (`20 DS 19` changes
    /// it).
    pub reload: u16,
    /// The motor's top speed; set-points above it are clipped.
    pub max_speed: f64,
    /// Acceleration of positioning ramps and deceleration of the drive's own
    /// braking (`08`, limit switches, mode changes, homing reversals), /s².
    pub accel: f64,
    /// Deceleration of `2A 03` fast stop, and of switching the current off
    /// (`24`, `04`, `20 05`), /s².
    pub fast_decel: f64,
    /// PWM load model: the torque byte the load's friction holds without
    /// moving (|torque| at or below it stands still).
    pub friction: u8,
    /// PWM load model: speed per torque unit above the friction.
    pub torque_gain: f64,
    /// PV mode's proportional speed error under the load, a fraction of the
    /// commanded speed (IV integrates it away).
    pub pv_droop: f64,
    /// Program version answered to `00 DS 00`: major 0-99, minor 0-9.
    pub version: (u8, u8),
    /// Device number answered to `00 DS 01`, 0-9999.
    pub device_number: u16,
    /// The ADC jumper: `2x` then reads unipolar channel 3 and no negative
    /// voltages.
    pub adc_unipolar: bool,
    /// Before `02` (and after `04`) `0A` is rejected too, like every other
    /// request ("Ohne diesen Einschalt-Befehl werden keine Kommandos
    /// angenommen", manual "02"; `docs/decisions.md` "EMP before
    /// `02`"); when false it answers with error `02`, so a console can
    /// learn why (decision 2). The variant `emp-rejects-0a-before-on`
    /// (`[sim] variants`, `config::variant`).
    pub rejects_0a_before_on: bool,
}

/// The sample rate after power-up: 1 kHz, the manual's "0x3600 = 1 ms"
/// ballpark, as `1/f * 50 MHz / 4` (decision 6) gives `30D4`.
pub const POWER_UP_RELOAD: u16 = 0x30D4;

/// The manual's example program version ("DRS-500-ECS_V8.2").
pub const VERSION: (u8, u8) = (8, 2);

/// The manual's example device number ("mit der Gerätenummer 650").
pub const DEVICE_NUMBER: u16 = 650;

impl DriveConfig {
    /// A drive on a bench axis: ±1 000 000 counts between the limit
    /// switches, standing at 0, 100 000 counts/s top speed.
    pub fn new(ds: DriveAddress) -> DriveConfig {
        DriveConfig::with_speed(ds, 100_000.0)
            .within(-1_000_000.0, 1_000_000.0)
            .starting_at(0.0)
    }

    fn with_speed(ds: DriveAddress, max_speed: f64) -> DriveConfig {
        // Full speed in 0.1 s; a fast stop four times as hard.
        let accel = max_speed * 10.0;
        let friction = 4;
        DriveConfig {
            ds,
            axis: None,
            start_position: 0.0,
            limit_plus: 0.0,
            limit_minus: 0.0,
            reference_cam: 0.0,
            reload: POWER_UP_RELOAD,
            max_speed,
            accel,
            fast_decel: accel * 4.0,
            friction,
            // Torque 127 runs at the top speed.
            torque_gain: max_speed / f64::from(127 - friction),
            pv_droop: 0.02,
            version: VERSION,
            // Modules count up from the example number.
            device_number: DEVICE_NUMBER + u16::from(ds.module_number()) - 1,
            adc_unipolar: false,
            rejects_0a_before_on: false,
        }
    }

    /// Limit switches at `minus` and `plus`; the reference cam takes half the
    /// room between machine 0 and limit - when 0 is inside, else 1 count.
    pub fn within(mut self, minus: f64, plus: f64) -> DriveConfig {
        self.limit_minus = minus;
        self.limit_plus = plus;
        self.reference_cam = if minus < 0.0 {
            (-minus / 2.0).max(1.0)
        } else {
            1.0
        };
        self
    }

    pub fn starting_at(mut self, x: f64) -> DriveConfig {
        self.start_position = x;
        self
    }

    /// The drive of a profile axis: switches `limit_margin` beyond the soft
    /// limits, the reference cam half the margin long below machine 0, the
    /// power-up position `start_position`, a top speed of twice the axis'
    /// `max_speed` (the console never asks more than `max_speed`).
    pub fn for_axis(
        ds: DriveAddress,
        axis: Axis,
        profile: &AxisProfile,
        sim: &SimProfile,
    ) -> DriveConfig {
        let counts = |units: f64| units * profile.steps_per_unit;
        let mut d = DriveConfig::with_speed(ds, 2.0 * counts(profile.max_speed))
            .within(
                counts(profile.min - sim.limit_margin),
                counts(profile.max + sim.limit_margin),
            )
            .starting_at(counts(sim.start_position));
        d.reference_cam = counts(sim.limit_margin / 2.0).max(1.0);
        d.rejects_0a_before_on = sim.variants.contains(&SimVariant::EmpRejects0aBeforeOn);
        d.axis = Some(axis);
        d
    }

    /// The power-up reload value, checked.
    pub(crate) fn reload_value(&self) -> Result<ReloadValue, EmpSimError> {
        ReloadValue::new(self.reload).map_err(|_| EmpSimError::BadSetting {
            ds: self.ds,
            what: "reload",
            expected: "1 to 65535",
            value: f64::from(self.reload),
        })
    }

    fn validate(&self) -> Result<(), EmpSimError> {
        self.reload_value()?;
        let bad = |what, expected, value| EmpSimError::BadSetting {
            ds: self.ds,
            what,
            expected,
            value,
        };
        let positive = |what, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(what, "a positive number", v))
            }
        };
        positive("max_speed", self.max_speed)?;
        positive("accel", self.accel)?;
        positive("fast_decel", self.fast_decel)?;
        positive("torque_gain", self.torque_gain)?;
        positive("reference_cam", self.reference_cam)?;
        for (what, v) in [
            ("start_position", self.start_position),
            ("limit_plus", self.limit_plus),
            ("limit_minus", self.limit_minus),
        ] {
            if !v.is_finite() {
                return Err(bad(what, "a finite number", v));
            }
        }
        if self.limit_minus >= self.limit_plus {
            return Err(bad("limit_minus", "below limit_plus", self.limit_minus));
        }
        if !(0.0..1.0).contains(&self.pv_droop) {
            return Err(bad("pv_droop", "0 to below 1", self.pv_droop));
        }
        if IdentText::version(self.version.0, self.version.1).is_err() {
            let (major, minor) = self.version;
            return Err(bad(
                "version",
                "0.0 to 99.9",
                f64::from(major) + f64::from(minor) / 10.0,
            ));
        }
        if IdentText::device_number(self.device_number).is_err() {
            return Err(bad(
                "device_number",
                "0 to 9999",
                f64::from(self.device_number),
            ));
        }
        Ok(())
    }
}

/// A work piece under the probe (variant `probe-surface`): which drive
/// input follows it, and which drives' positions place the carriage.
///
/// The probing axis is Z when the link has a Z drive, else the axis of the
/// drive the probe is wired to (an EMP machine is mostly one axis). The
/// X and Y drives' positions, where the link has such drives other than
/// the probing axis, place the carriage over the work piece (a plane's
/// slopes, a block's or a bore's outline); an axis the link lacks counts as
/// 0, so on a one-axis machine a plane is the position `z0` alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceProbe {
    pub surface: ProbeSurface,
    /// The drive and input (1-4) the probe is wired to.
    pub drive: DriveAddress,
    pub input: u8,
    /// The input reads 1 when touched (`active = "high"`), else 0.
    pub active_high: bool,
    /// The drive of the probing axis: touched inside the material.
    pub axis: DriveAddress,
    pub x: Option<DriveAddress>,
    pub y: Option<DriveAddress>,
}

/// The drives of one link.
#[derive(Debug, Clone, PartialEq)]
pub struct EmpSimConfig {
    pub drives: Vec<DriveConfig>,
}

impl EmpSimConfig {
    /// One drive at address `11` with [`DriveConfig::new`].
    pub fn single() -> EmpSimConfig {
        EmpSimConfig {
            drives: vec![DriveConfig::new(DriveAddress::SINGLE)],
        }
    }

    /// The link of a machine profile: one drive per axis it lists, at that
    /// axis' `drive` address.
    pub fn from_profile(profile: &Profile) -> Result<EmpSimConfig, EmpSimError> {
        if profile.connection.protocol != Protocol::Emp {
            return Err(EmpSimError::WrongProtocol {
                profile: profile.name.clone(),
                protocol: profile.connection.protocol,
            });
        }
        let listed = profile.machine.axis_set().unwrap_or(profile.axis_set());
        let mut drives = Vec::new();
        for (&axis, p) in profile.axes.iter().filter(|(a, _)| listed.contains(**a)) {
            let text = p
                .drive
                .as_deref()
                .ok_or(EmpSimError::NoDriveAddress { axis })?;
            let ds = parse_drive_address(text)
                .and_then(|b| DriveAddress::from_byte(b).map_err(|e| e.to_string()))
                .map_err(|message| EmpSimError::BadDriveAddress { axis, message })?;
            drives.push(DriveConfig::for_axis(ds, axis, p, &profile.sim));
        }
        let config = EmpSimConfig { drives };
        config.validate()?;
        Ok(config)
    }

    pub(crate) fn validate(&self) -> Result<(), EmpSimError> {
        if !(1..=MAX_DRIVES).contains(&self.drives.len()) {
            return Err(EmpSimError::DriveCount(self.drives.len()));
        }
        let mut seen = Vec::new();
        for d in &self.drives {
            if seen.contains(&d.ds) {
                return Err(EmpSimError::DuplicateDrive(d.ds));
            }
            seen.push(d.ds);
            d.validate()?;
        }
        Ok(())
    }
}

impl SurfaceProbe {
    /// The probe surface of a profile's `[sim] variants` (the last one),
    /// on the link `config` built from it; `None` without one.
    pub fn from_profile(
        profile: &Profile,
        config: &EmpSimConfig,
    ) -> Result<Option<SurfaceProbe>, EmpSimError> {
        let surface = profile.sim.variants.iter().rev().find_map(|v| match v {
            SimVariant::ProbeSurface(s) => Some(*s),
            _ => None,
        });
        surface
            .map(|s| surface_probe(profile, s, &config.drives))
            .transpose()
    }
}

/// The probe of a profile's wiring (`[io]`, role `probe`: the first such
/// input) for a work piece `surface` on the link of `drives`.
fn surface_probe(
    profile: &Profile,
    surface: ProbeSurface,
    drives: &[DriveConfig],
) -> Result<SurfaceProbe, EmpSimError> {
    use crate::wiring::{BitKind, Level, Role};
    // A profile whose wiring does not load is refused where it is read;
    // here it simply names no probe.
    let wiring = profile.wiring().map_err(|_| EmpSimError::NoProbeInput)?;
    let bit = wiring
        .bits()
        .iter()
        .find(|b| b.kind == BitKind::Input && b.role == Role::Probe)
        .ok_or(EmpSimError::NoProbeInput)?;
    let not_input = || EmpSimError::ProbeNotAnInput(bit.address.clone());
    let (ds, name) = bit.address.split_once('.').ok_or_else(not_input)?;
    let input = match name {
        "I1" => 1,
        "I2" => 2,
        "I3" => 3,
        "I4" => 4,
        _ => return Err(not_input()),
    };
    let drive = u8::from_str_radix(ds, 16)
        .ok()
        .and_then(|b| DriveAddress::from_byte(b).ok())
        .ok_or_else(not_input)?;
    let of = |axis: Axis| drives.iter().find(|d| d.axis == Some(axis)).map(|d| d.ds);
    let own = drives.iter().find(|d| d.ds == drive).and_then(|d| d.axis);
    let probing = if of(Axis::Z).is_some() {
        Axis::Z
    } else {
        own.unwrap_or(Axis::Z)
    };
    let tilt = |axis: Axis| of(axis).filter(|_| axis != probing);
    Ok(SurfaceProbe {
        surface,
        drive,
        input,
        active_high: bit.active == Level::High,
        axis: of(probing).unwrap_or(drive),
        x: tilt(Axis::X),
        y: tilt(Axis::Y),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_emp_profile_gives_one_drive_on_11() {
        let p = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
        let c = EmpSimConfig::from_profile(&p).unwrap();
        assert_eq!(c.drives.len(), 1);
        let d = &c.drives[0];
        assert_eq!(d.ds, DriveAddress::SINGLE);
        assert_eq!(d.axis, Some(Axis::X));
        // 11200 counts/mm; soft limits 0..500 mm, margin 2 mm, start 40 mm.
        assert_eq!(d.limit_minus, -22_400.0);
        assert_eq!(d.limit_plus, 502.0 * 11_200.0);
        assert_eq!(d.reference_cam, 11_200.0);
        assert_eq!(d.start_position, 448_000.0);
        assert_eq!(d.max_speed, 112_000.0);
        assert_eq!(d.reload, 0x30D4);
        assert_eq!(d.device_number, 650);
    }

    #[test]
    fn profiles_of_other_families_and_axes_without_drives_are_refused() {
        let p = load_profile("isel", &ConfigDirs::builtin_only()).unwrap();
        assert!(matches!(
            EmpSimConfig::from_profile(&p),
            Err(EmpSimError::WrongProtocol { .. })
        ));
        let mut p = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
        if let Some(x) = p.axes.get_mut(&Axis::X) {
            x.drive = None;
        }
        assert_eq!(
            EmpSimConfig::from_profile(&p),
            Err(EmpSimError::NoDriveAddress { axis: Axis::X })
        );
        if let Some(x) = p.axes.get_mut(&Axis::X) {
            x.drive = Some("17".into());
        }
        let e = EmpSimConfig::from_profile(&p).unwrap_err();
        assert!(e.to_string().contains("drive number"), "{e}");
    }

    #[test]
    fn links_are_checked() {
        let mut c = EmpSimConfig::single();
        assert!(c.validate().is_ok());
        c.drives.push(DriveConfig::new(DriveAddress::SINGLE));
        assert_eq!(
            c.validate(),
            Err(EmpSimError::DuplicateDrive(DriveAddress::SINGLE))
        );
        let c = EmpSimConfig { drives: vec![] };
        assert_eq!(c.validate(), Err(EmpSimError::DriveCount(0)));
        let mut d = DriveConfig::new(DriveAddress::SINGLE);
        d.accel = 0.0;
        assert!(EmpSimConfig { drives: vec![d] }.validate().is_err());
        let d = DriveConfig::new(DriveAddress::SINGLE).within(5.0, 5.0);
        assert!(EmpSimConfig { drives: vec![d] }.validate().is_err());
        let mut d = DriveConfig::new(DriveAddress::SINGLE);
        d.reload = 0;
        assert!(EmpSimConfig { drives: vec![d] }.validate().is_err());
        let mut d = DriveConfig::new(DriveAddress::SINGLE);
        d.version = (100, 0);
        assert!(EmpSimConfig { drives: vec![d] }.validate().is_err());
    }
}
