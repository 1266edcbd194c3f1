//! The inputs of a machine as its profile names them: the one place that
//! says what each input bit the recorder sees is called, what it is for,
//! whether something is wired to it and at which level it is active.
//!
//! Today the names and roles are the manuals' tables (isel manual 2.2.3,
//! `../shared/protocols.md` isel 7; EMCU manual 1.5.3; EMP decision 5), as the
//! drivers show them; a bit counts as wired unless the table marks it "not
//! used" or it is the limit switch of an axis the machine does not have.
//! Once profiles say how a machine is wired, this is the function that
//! reads it.

use std::sync::Arc;

use crate::axis::AxisSet;
use crate::config::Profile;
use crate::config::profile::parse_drive_address;
use crate::device::api::{InputChannel, InputKey, InputRole, InputSource};
use crate::proto::Protocol;
use crate::proto::emcu::StatusFlag;
use crate::proto::isel::ports::{INPUT_BITS, InputRole as IselRole};

/// Every input of the profile's controller, in the controller's order
/// (isel ports 0-3 bit by bit; the `@X` flags; per EMP drive limit +,
/// limit -, reference, I1-I4).
pub fn channels(profile: &Profile) -> Vec<InputChannel> {
    match profile.connection.protocol {
        Protocol::Isel => isel(profile.axis_set()),
        Protocol::Emcu => emcu(),
        Protocol::Emp => profile
            .axes
            .values()
            .filter_map(|a| a.drive.as_deref())
            .filter_map(|ds| parse_drive_address(ds).ok())
            .flat_map(emp)
            .collect(),
    }
}

/// The same, shared, as the recorder hands them out with every change.
pub fn shared(profile: &Profile) -> Vec<Arc<InputChannel>> {
    channels(profile).into_iter().map(Arc::new).collect()
}

fn isel(axes: AxisSet) -> Vec<InputChannel> {
    INPUT_BITS
        .iter()
        .map(|b| {
            // Active-high as read (isel 7), but E-stop circuits, power ok
            // and the hood bits read 1 while all is well.
            let (role, active) = match b.role {
                IselRole::User => (InputRole::User, true),
                IselRole::EmergencyStopCircuit => (InputRole::Estop, false),
                IselRole::OverTemperature => (InputRole::Power, true),
                IselRole::StartKey | IselRole::StopKey | IselRole::KeySwitch => {
                    (InputRole::Key, true)
                }
                IselRole::ToolLengthProbe => (InputRole::Probe, true),
                IselRole::Spindle => (InputRole::Feedback, true),
                IselRole::PowerOk => (InputRole::Power, false),
                IselRole::Hood => (InputRole::Hood, false),
                IselRole::LimitSwitch { .. } => (InputRole::Limit, true),
                IselRole::NotUsed => (InputRole::Unused, true),
            };
            let wired = match b.role {
                IselRole::NotUsed => false,
                IselRole::LimitSwitch { axis, .. } => axes.contains(axis),
                _ => true,
            };
            InputChannel {
                key: InputKey {
                    source: InputSource::IselPort(b.port.number()),
                    bit: b.bit,
                },
                address: format!("in{}.{}", b.port.number(), b.bit),
                name: b.name.to_owned(),
                role,
                wired,
                active,
            }
        })
        .collect()
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

/// EMP decision 5: `40 01` answers the switches in PROP and I1-I4 in D0.
fn emp(ds: u8) -> Vec<InputChannel> {
    let named = [
        ("limit+", "limit +", InputRole::Limit),
        ("limit-", "limit -", InputRole::Limit),
        ("ref", "reference", InputRole::Probe),
        ("I1", "I1", InputRole::User),
        ("I2", "I2", InputRole::User),
        ("I3", "I3", InputRole::User),
        ("I4", "I4", InputRole::User),
    ];
    (0u8..)
        .zip(named)
        .map(|(bit, (suffix, name, role))| InputChannel {
            key: InputKey {
                source: InputSource::EmpDrive(ds),
                bit,
            },
            address: format!("{ds:02X}.{suffix}"),
            name: name.to_owned(),
            role,
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
                InputSource::EmpDrive(ds) => format!("{ds:02X}.{}", key.bit),
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
    }
}
