//! Operator controls of the EMP simulator (`docs/simulator.md`, EMP): the
//! inputs I1-I4 of each drive and its analogue channels.
//!
//! A name may carry the drive's address in front (`21.i3`); without one it
//! means the first drive of the link (the lowest address).
//!
//! A channel's voltage is set with `value adc1 1234` (mV); `press adc1-up` /
//! `press adc1-down` step by 100 mV, `press adc1-zero` returns to 0.

use super::analog::MAX_INPUT_MV;
use crate::proto::emp::DriveAddress;
use crate::sim::InputControl;

/// Step of `adcN-up` / `adcN-down`.
pub const ADC_STEP_MV: f64 = 100.0;

/// The names `help` lists.
pub const INPUT_NAMES: &[&str] = &[
    "i1",
    "i2",
    "i3",
    "i4",
    "adc1",
    "adc1-up",
    "adc1-down",
    "adc1-zero",
    "adc2",
    "adc2-up",
    "adc2-down",
    "adc2-zero",
    "adc3",
    "adc3-up",
    "adc3-down",
    "adc3-zero",
];

/// What a control does to one drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Action {
    /// Input `n` (1-4) to a level.
    Input(u8, bool),
    /// Channel (1-3) to a voltage.
    AdcSet(usize, f64),
    /// Channel (1-3) up or down by a voltage.
    AdcStep(usize, f64),
}

/// A parsed control: the drive it is for (`None` = the first) and what it
/// does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Parsed {
    pub drive: Option<DriveAddress>,
    pub action: Action,
}

fn names_hint() -> String {
    format!(
        "EMP inputs are {} (prefix a drive address for another drive than the first, e.g. 21.i1)",
        INPUT_NAMES.join(", ")
    )
}

fn split_drive(name: &str) -> Result<(Option<DriveAddress>, &str), String> {
    match name.split_once('.') {
        None => Ok((None, name)),
        Some((ds, _)) => {
            let rest = name.get(ds.len() + 1..).unwrap_or("");
            let ds = ds
                .parse::<DriveAddress>()
                .map_err(|e| format!("`{name}`: {e}"))?;
            Ok((Some(ds), rest))
        }
    }
}

fn input_number(name: &str) -> Option<u8> {
    match name.to_ascii_lowercase().as_str() {
        "i1" => Some(1),
        "i2" => Some(2),
        "i3" => Some(3),
        "i4" => Some(4),
        _ => None,
    }
}

/// The drive and number (1-4) of a digital input's name (`i3`, `21.i3`).
pub(crate) fn digital_input(name: &str) -> Option<(Option<DriveAddress>, u8)> {
    let (drive, local) = split_drive(name).ok()?;
    Some((drive, input_number(local)?))
}

/// `adcN` and what follows it.
fn adc_channel(name: &str) -> Option<(usize, &str)> {
    let lower = name.get(..3)?;
    if !lower.eq_ignore_ascii_case("adc") {
        return None;
    }
    let channel = match name.get(3..4)? {
        "1" => 1,
        "2" => 2,
        "3" => 3,
        _ => return None,
    };
    Some((channel, name.get(4..)?))
}

pub(crate) fn parse(control: &InputControl) -> Result<Parsed, String> {
    let name = control.name();
    let (drive, local) = split_drive(name)?;
    let action = if let Some(n) = input_number(local) {
        match control {
            InputControl::Set { level, .. } => Action::Input(n, *level),
            InputControl::Press { .. } | InputControl::Value { .. } => {
                return Err(format!(
                    "`{name}` is an input that stays as set: use `set {name} on|off`"
                ));
            }
        }
    } else if let Some((channel, rest)) = adc_channel(local) {
        let usage = || {
            format!(
                "`{name}` is an analogue channel: use `value adc{channel} <mV>` (-{MAX_INPUT_MV} to {MAX_INPUT_MV}) or `press adc{channel}-up|-down|-zero`"
            )
        };
        match (control, rest.to_ascii_lowercase().as_str()) {
            (InputControl::Value { value, .. }, "")
                if value.is_finite() && value.abs() <= MAX_INPUT_MV =>
            {
                Action::AdcSet(channel, *value)
            }
            (InputControl::Press { .. }, "-up") => Action::AdcStep(channel, ADC_STEP_MV),
            (InputControl::Press { .. }, "-down") => Action::AdcStep(channel, -ADC_STEP_MV),
            (InputControl::Press { .. }, "-zero") => Action::AdcSet(channel, 0.0),
            _ => return Err(usage()),
        }
    } else {
        return Err(format!("unknown input `{name}`: {}", names_hint()));
    };
    Ok(Parsed { drive, action })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(name: &str, level: bool) -> InputControl {
        InputControl::Set {
            name: name.into(),
            level,
        }
    }

    fn press(name: &str) -> InputControl {
        InputControl::Press { name: name.into() }
    }

    fn value(name: &str, value: f64) -> InputControl {
        InputControl::Value {
            name: name.into(),
            value,
        }
    }

    #[test]
    fn inputs_channels_and_drive_prefixes() {
        assert_eq!(
            parse(&set("i3", true)).unwrap(),
            Parsed {
                drive: None,
                action: Action::Input(3, true)
            }
        );
        let p = parse(&set("21.I1", false)).unwrap();
        assert_eq!(p.drive, Some(DriveAddress::module(2).unwrap()));
        assert_eq!(p.action, Action::Input(1, false));
        assert_eq!(
            parse(&value("adc1", 1234.0)).unwrap().action,
            Action::AdcSet(1, 1234.0)
        );
        assert_eq!(
            parse(&value("ADC2", -50.5)).unwrap().action,
            Action::AdcSet(2, -50.5)
        );
        assert_eq!(
            parse(&press("adc3-down")).unwrap().action,
            Action::AdcStep(3, -100.0)
        );
        assert_eq!(
            parse(&press("adc1-zero")).unwrap().action,
            Action::AdcSet(1, 0.0)
        );
    }

    #[test]
    fn wrong_names_and_forms_say_what_exists() {
        let e = parse(&set("i5", true)).unwrap_err();
        assert!(e.contains("i1, i2"), "{e}");
        assert!(parse(&press("i1")).unwrap_err().contains("set i1 on|off"));
        assert!(
            parse(&set("adc1", true))
                .unwrap_err()
                .contains("value adc1 <mV>")
        );
        assert!(parse(&value("adc4", 1.0)).is_err());
        assert!(parse(&press("adc1")).is_err());
        assert!(parse(&value("adc1", 1e9)).is_err());
        assert!(parse(&value("adc1", f64::NAN)).is_err());
        assert!(parse(&press("1.i1")).unwrap_err().contains("drive address"));
        assert_eq!(
            parse(&value("21.adc1", 0.5)).unwrap(),
            Parsed {
                drive: Some(DriveAddress::module(2).unwrap()),
                action: Action::AdcSet(1, 0.5)
            }
        );
        assert!(parse(&press("ü")).is_err());
        assert!(parse(&set("a", true)).is_err());
    }
}
