//! The machine's start key on the built-in simulator: which simulator input
//! the profile wires as its start key (the `[io]` input with role `start`),
//! and the control that presses it. A job's pause (M0, M1, a tool change)
//! waits for that key (`docs/gcode.md`, isel `o<port>,<bit>,…`, EMCU `&V1`);
//! `jogterm run --sim-start-key` and the console's simulator panel press it
//! here, so that such a job can be tried without hardware
//! (`docs/simulator.md`, "The start key").

use crate::config::Profile;
use crate::proto::Protocol;
use crate::wiring::{BitKind, Role};

use super::InputControl;

/// The simulator input wired as the start key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StartKey {
    /// The simulator's name of the input (`start`, `e1`).
    pub input: String,
    /// The profile's name of the key, as the job's wait names it.
    pub name: String,
}

impl StartKey {
    /// The profile's wired start key as a simulator input the simulator can
    /// press; why not when there is none.
    pub fn of(profile: &Profile) -> Result<StartKey, String> {
        let wiring = profile
            .wiring()
            .map_err(|_| "the profile's [io] table has errors".to_owned())?;
        let key = wiring
            .bits()
            .iter()
            .find(|b| b.role == Role::Start && b.kind == BitKind::Input && b.wired)
            .ok_or_else(|| {
                "the profile wires no start key (an input with role \"start\" in [io])".to_owned()
            })?;
        let input = press_name(profile.connection.protocol, &key.address).ok_or_else(|| {
            format!(
                "the start key is wired to {} ({}), which the {} simulator has no button for",
                key.address, key.name, profile.connection.protocol
            )
        })?;
        Ok(StartKey {
            input: input.to_owned(),
            name: key.name.clone(),
        })
    }

    /// Press and release it (the simulator holds it down for a moment, as a
    /// finger does: long enough for a program that polls it to see it).
    pub fn press(&self) -> InputControl {
        InputControl::Press {
            name: self.input.clone(),
        }
    }
}

/// The button of the family's simulator at a controller address: the
/// inputs `press` works on (isel port 1 bit 3, the start key of manual
/// 2.2.3; EMCU E1, which a move linked to it waits for, manual 1.5.19).
fn press_name(protocol: Protocol, address: &str) -> Option<&'static str> {
    match (protocol, address) {
        (Protocol::Isel, "in1.3") => Some("start"),
        (Protocol::Emcu, a) if a.eq_ignore_ascii_case("E1") => Some(super::emcu::INPUT_E1),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn shipped(name: &str) -> Profile {
        load_profile(name, &ConfigDirs::builtin_only()).expect("a shipped profile")
    }

    #[test]
    fn the_families_start_keys_are_the_simulators_buttons() {
        let isel = StartKey::of(&shipped("isel")).expect("isel start key");
        assert_eq!(isel.input, "start");
        assert_eq!(
            isel.press(),
            InputControl::Press {
                name: "start".into()
            }
        );
        let emcu = StartKey::of(&shipped("emcu")).expect("EMCU start key");
        assert_eq!(emcu.input, "e1");
        // EMP drives have no start key.
        assert!(StartKey::of(&shipped("emp")).is_err());
    }
}
