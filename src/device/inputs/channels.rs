//! The inputs of a machine as its profile names them: the one place that
//! says what each input bit the recorder sees is called, what it is for,
//! whether something is wired to it and at which level it is active.
//!
//! It reads the profile's wiring (`Profile::wiring`: the manuals' tables
//! patched by `[io]`, `crate::wiring`) and keys each input bit by where it
//! is read: isel `in<port>.<bit>` (`@0b<port>`), EMP `<DS>.limit+`,
//! `.limit-`, `.ref`, `.I1`-`.I4` (`40 01`). The EMCU's `@X` flags are
//! status, not wiring, and come from the manual's table (1.5.3); its input
//! E1 cannot be read (`&V` only makes moves wait for it) and is left out.

use std::sync::Arc;

use crate::config::Profile;
use crate::device::api::{InputChannel, InputKey, InputRole, InputSource};
use crate::proto::Protocol;
use crate::proto::emcu::StatusFlag;
use crate::wiring::{BitKind, BitWiring, Level, Role, Wiring};

/// Every input of the profile's controller, in the controller's order
/// (isel ports 0-3 bit by bit; the `@X` flags; per EMP drive limit +,
/// limit -, reference, I1-I4).
pub fn channels(profile: &Profile) -> Vec<InputChannel> {
    if profile.connection.protocol == Protocol::Emcu {
        return emcu();
    }
    // A profile that loaded has a valid wiring; should it not, the
    // manuals' tables still name every bit.
    let wiring = profile
        .wiring()
        .unwrap_or_else(|_| Wiring::defaults(profile.connection.protocol, profile.axis_set(), &[]));
    wiring
        .bits()
        .iter()
        .filter(|b| b.kind == BitKind::Input)
        .filter_map(|b| Some(channel(key_of(&b.address)?, b)))
        .collect()
}

/// The same, shared, as the recorder hands them out with every change.
pub fn shared(profile: &Profile) -> Vec<Arc<InputChannel>> {
    channels(profile).into_iter().map(Arc::new).collect()
}

/// The recorder's category of a wiring role.
fn role(role: Role) -> InputRole {
    match role {
        Role::Limit(_) => InputRole::Limit,
        Role::Estop => InputRole::Estop,
        Role::Hood => InputRole::Hood,
        Role::Probe | Role::Reference => InputRole::Probe,
        Role::Start | Role::Stop => InputRole::Key,
        // An input for the spindle (coolant, a clamp …) follows what
        // jogterm switches.
        Role::Spindle | Role::Coolant | Role::Clamp | Role::Vacuum | Role::Lamp => {
            InputRole::Feedback
        }
        Role::Power => InputRole::Power,
        Role::User => InputRole::User,
        Role::Unused => InputRole::Unused,
    }
}

fn channel(key: InputKey, b: &BitWiring) -> InputChannel {
    InputChannel {
        key,
        address: b.address.clone(),
        name: b.name.clone(),
        role: role(b.role),
        wired: b.wired,
        active: b.active == Level::High,
    }
}

/// EMP decision 5: `40 01` answers the switches in PROP and I1-I4 in D0;
/// the recorder numbers them in that order.
const EMP_INPUTS: [&str; 7] = ["limit+", "limit-", "ref", "I1", "I2", "I3", "I4"];

/// Where an input address is read: `in3.0`, `11.limit+`; `None` for one
/// no command reads.
pub fn key_of(address: &str) -> Option<InputKey> {
    if let Some(rest) = address.strip_prefix("in") {
        let (port, bit) = rest.split_once('.')?;
        return Some(InputKey {
            source: InputSource::IselPort(port.parse().ok()?),
            bit: bit.parse().ok()?,
        });
    }
    let (ds, input) = address.split_once('.')?;
    Some(InputKey {
        source: InputSource::EmpDrive(u8::from_str_radix(ds, 16).ok()?),
        bit: u8::try_from(EMP_INPUTS.iter().position(|i| *i == input)?).ok()?,
    })
}

fn emcu() -> Vec<InputChannel> {
    (0u8..)
        .zip(StatusFlag::ALL)
        .map(|(bit, flag)| InputChannel {
            key: InputKey {
                source: InputSource::EmcuStatus,
                bit,
            },
            address: format!("@X.{bit}"),
            name: flag.to_string(),
            role: InputRole::Status,
            wired: true,
            active: true,
        })
        .collect()
}

impl InputChannel {
    /// The name with what tells it apart on a link of several EMP drives:
    /// `11 limit +`.
    pub fn label(&self) -> String {
        match self.key.source {
            InputSource::EmpDrive(ds) => format!("{ds:02X} {}", self.name),
            _ => self.name.clone(),
        }
    }

    /// A channel for a bit no profile names (a driver reporting more than
    /// the tables know): its panel name, counted as wired.
    pub fn unnamed(key: InputKey, name: &str) -> InputChannel {
        InputChannel {
            key,
            address: match key.source {
                InputSource::IselPort(p) => format!("in{p}.{}", key.bit),
                InputSource::EmcuStatus => format!("@X.{}", key.bit),
                InputSource::EmpDrive(ds) => match EMP_INPUTS.get(usize::from(key.bit)) {
                    Some(input) => format!("{ds:02X}.{input}"),
                    None => format!("{ds:02X}.{}", key.bit),
                },
            },
            name: name.to_owned(),
            role: InputRole::User,
            wired: true,
            active: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn profile(name: &str) -> Profile {
        load_profile(name, &ConfigDirs::builtin_only()).expect("shipped profile")
    }

    #[test]
    fn isel_inputs_follow_the_port_tables() {
        let ch = channels(&profile("isel"));
        assert_eq!(ch.len(), 32);
        let x1 = ch.iter().find(|c| c.address == "in3.0").expect("X1");
        assert_eq!(x1.name, "limit X1");
        assert_eq!(
            (x1.role, x1.active, x1.wired),
            (InputRole::Limit, true, true)
        );
        // An XYZ machine has no A switches.
        let a1 = ch.iter().find(|c| c.address == "in3.6").expect("A1");
        assert!(!a1.wired);
        let e2 = ch.iter().find(|c| c.address == "in1.1").expect("E-stop 2");
        assert_eq!((e2.role, e2.active), (InputRole::Estop, false));
        assert!(ch.iter().filter(|c| c.name == "not used").all(|c| !c.wired));
        // The key's bit is the port's bit: what the recorder counts on.
        assert!(ch.iter().all(|c| c.address
            == format!(
                "in{}.{}",
                match c.key.source {
                    InputSource::IselPort(p) => p,
                    _ => 99,
                },
                c.key.bit
            )));
    }

    #[test]
    fn emcu_flags_and_emp_drives() {
        let emcu = channels(&profile("emcu"));
        assert_eq!(emcu.len(), 6);
        assert_eq!(emcu[3].name, "position unknown");
        assert_eq!(emcu[3].address, "@X.3");
        let emp = channels(&profile("emp"));
        let names: Vec<String> = emp.iter().map(InputChannel::label).collect();
        assert_eq!(
            names,
            [
                "11 limit +",
                "11 limit -",
                "11 reference",
                "11 I1",
                "11 I2",
                "11 I3",
                "11 I4"
            ]
        );
        assert_eq!(emp[6].address, "11.I4");
        assert_eq!(emp[6].key.bit, 6);
        assert_eq!(emp[2].role, InputRole::Probe);
    }

    #[test]
    fn the_profiles_io_names_and_wires_the_inputs() {
        let mut profile = profile("isel");
        profile.io = toml::from_str(
            r#"
            "in0.2" = { name = "door switch", role = "hood", active = "low" }
            "in2.5" = { wired = true }
            "#,
        )
        .expect("[io]");
        let ch = channels(&profile);
        let door = ch.iter().find(|c| c.address == "in0.2").expect("in0.2");
        assert_eq!(door.name, "door switch");
        assert_eq!(
            (door.role, door.active, door.wired),
            (InputRole::Hood, false, true)
        );
        assert!(ch.iter().any(|c| c.address == "in2.5" && c.wired));
        assert_eq!(
            door.key,
            InputKey {
                source: InputSource::IselPort(0),
                bit: 2
            }
        );
    }
}
