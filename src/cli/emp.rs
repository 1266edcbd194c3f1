//! What `jogterm send` and `jogterm poll` need for EMP drives: `--drive`
//! addressing (which drives are on the link, and the DS of a frame typed
//! without one) and the checked list of frames to send.

use crate::axis::Axis;
use crate::config::Profile;
use crate::proto::emp::{DriveAddress, Request};

use super::send::Item;

/// `--drive 11,21`: the drives on the link, for the axes X, Y, Z, A in that
/// order. An axis the profile lacks takes the table of its first axis
/// (same mechanics), with the new drive.
pub fn apply_drives(profile: &mut Profile, drives: &[String]) -> Result<(), String> {
    let addresses: Vec<DriveAddress> = drives
        .iter()
        .flat_map(|d| d.split(','))
        .map(|d| {
            d.trim()
                .parse::<DriveAddress>()
                .map_err(|e| format!("--drive `{d}`: {e}"))
        })
        .collect::<Result<_, _>>()?;
    if addresses.is_empty() {
        return Ok(());
    }
    if addresses.len() > Axis::ALL.len() {
        return Err(format!(
            "--drive names {} drives; a machine has at most {} axes",
            addresses.len(),
            Axis::ALL.len()
        ));
    }
    let template = profile
        .axes
        .values()
        .next()
        .cloned()
        .ok_or_else(|| format!("profile `{}` has no axes", profile.name))?;
    let mut letters = String::new();
    for (axis, ds) in Axis::ALL.into_iter().zip(&addresses) {
        let mut table = profile
            .axes
            .get(&axis)
            .cloned()
            .unwrap_or_else(|| template.clone());
        table.drive = Some(ds.to_string());
        profile.axes.insert(axis, table);
        letters.push(axis.letter());
    }
    profile.axes.retain(|a, _| letters.contains(a.letter()));
    profile.machine.axes = letters;
    Ok(())
}

/// A typed frame: 16 hex characters (spaces allowed), or 14 without the DS
/// byte, which is then `ds` (inserted after CMD). Checked with the core's
/// parser; the text returned is the frame as the driver names it.
pub fn frame(arg: &str, ds: DriveAddress) -> Result<Request, String> {
    let hex: String = arg.chars().filter(|c| !c.is_whitespace()).collect();
    let full = if hex.len() == 14 && hex.is_ascii() {
        let (cmd, rest) = hex.split_at(2);
        format!("{cmd}{ds}{rest}")
    } else {
        hex
    };
    full.parse::<Request>().map_err(|e| e.to_string())
}

/// The items `jogterm send` sends: every frame checked before anything is
/// sent.
pub fn plan(args: &[String], ds: DriveAddress) -> Result<Vec<Item>, String> {
    args.iter()
        .enumerate()
        .map(|(i, arg)| {
            let request = frame(arg, ds).map_err(|e| format!("command {} `{arg}`: {e}", i + 1))?;
            let text = request.to_frame().to_string();
            Ok(Item::Line {
                canonical: text.clone(),
                text,
                may_move: request.command.may_move(),
            })
        })
        .collect()
}

/// The DS a frame without one is sent to: the first drive of the profile.
pub fn default_drive(profile: &Profile) -> DriveAddress {
    profile
        .axes
        .values()
        .find_map(|a| a.drive.as_deref()?.parse().ok())
        .unwrap_or(DriveAddress::SINGLE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn frames_take_the_drive_when_they_have_none() {
        let ds = DriveAddress::new(2, 1).expect("21");
        let r = frame("2C 00 00 00000000", ds).expect("frame");
        assert_eq!(r.to_frame().to_string(), "2C21000000000000");
        let r = frame("2A 11 01 0B 000186A0", ds).expect("frame");
        assert_eq!(r.ds, DriveAddress::SINGLE);
        assert!(frame("2C 11 00", ds).is_err());
        assert!(frame("2c11000000000000", ds).is_err());
    }

    #[test]
    fn drives_become_axes() {
        let mut p = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        apply_drives(&mut p, &["11,21".into()]).expect("drives");
        assert_eq!(p.machine.axes, "XY");
        assert_eq!(
            p.axes.get(&Axis::Y).and_then(|a| a.drive.clone()),
            Some("21".into())
        );
        assert!(apply_drives(&mut p, &["10".into()]).is_err());
        assert!(apply_drives(&mut p, &["11,21,31,41,51".into()]).is_err());
    }
}
