//! The built-in simulators by protocol family.

use thiserror::Error;

use super::SimDevice;
use super::isel::{IselSim, SimConfigError};
use crate::config::Profile;
use crate::proto::Protocol;

/// Why no simulator could be built.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RegistryError {
    #[error("there is no built-in {0} simulator yet")]
    NotAvailable(Protocol),
    #[error(
        "the profile does not describe a machine the {protocol} simulator can build: {message}"
    )]
    Profile { protocol: Protocol, message: String },
}

/// The simulator of `protocol` for the machine `profile` describes.
pub fn build(protocol: Protocol, profile: &Profile) -> Result<Box<dyn SimDevice>, RegistryError> {
    match protocol {
        Protocol::Isel => IselSim::from_profile(profile)
            .map(|sim| Box::new(sim) as Box<dyn SimDevice>)
            .map_err(|e: SimConfigError| RegistryError::Profile {
                protocol,
                message: e.to_string(),
            }),
        Protocol::Emcu | Protocol::Emp => Err(RegistryError::NotAvailable(protocol)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn the_isel_simulator_is_built_for_the_profiles_machine() {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let device = build(Protocol::Isel, &profile).expect("isel simulator");
        assert_eq!(device.line().baud, 19200);
        assert!(device.input_names().contains(&"limit-x1"));
        assert!(
            device
                .describe(std::time::Instant::now())
                .contains("physical X 16000")
        );
    }
}
