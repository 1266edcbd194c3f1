//! The built-in simulators by protocol family.

use thiserror::Error;

use super::SimDevice;
use super::emcu::EmcuSim;
use super::emp::EmpSim;
use super::isel::IselSim;
use crate::config::{Profile, SimVariant};
use crate::proto::Protocol;

/// Why no simulator could be built.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RegistryError {
    #[error(
        "the profile does not describe a machine the {protocol} simulator can build: {message}"
    )]
    Profile { protocol: Protocol, message: String },
}

/// The simulator of `protocol` for the machine `profile` describes, as its
/// `[sim] variants` say (`config::variant`): each family's config applies
/// its own variants when it is built from the profile; `memory=` is the
/// `memory` control of every family that stores programs.
pub fn build(protocol: Protocol, profile: &Profile) -> Result<Box<dyn SimDevice>, RegistryError> {
    let profile_error = |message: String| RegistryError::Profile { protocol, message };
    if let Some(why) = profile
        .sim
        .variants
        .iter()
        .find_map(|v| v.refusal(protocol))
    {
        return Err(profile_error(why));
    }
    let mut device = build_plain(protocol, profile)?;
    for variant in &profile.sim.variants {
        if let SimVariant::Memory(commands) = variant {
            device
                .set_program_memory(*commands)
                .map_err(|e| profile_error(format!("variant `{variant}`: {e}")))?;
        }
    }
    Ok(device)
}

fn build_plain(protocol: Protocol, profile: &Profile) -> Result<Box<dyn SimDevice>, RegistryError> {
    let profile_error = |message: String| RegistryError::Profile { protocol, message };
    match protocol {
        Protocol::Isel => IselSim::from_profile(profile)
            .map(|sim| Box::new(sim) as Box<dyn SimDevice>)
            .map_err(|e| profile_error(e.to_string())),
        Protocol::Emcu => EmcuSim::from_profile(profile)
            .map(|sim| Box::new(sim) as Box<dyn SimDevice>)
            .map_err(|e| profile_error(e.to_string())),
        Protocol::Emp => EmpSim::from_profile(profile)
            .map(|sim| Box::new(sim) as Box<dyn SimDevice>)
            .map_err(|e| profile_error(e.to_string())),
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

    #[test]
    fn every_family_has_a_simulator_for_its_shipped_profile() {
        for (name, protocol, input) in
            [("emcu", Protocol::Emcu, "e1"), ("emp", Protocol::Emp, "i1")]
        {
            let profile = load_profile(name, &ConfigDirs::builtin_only()).expect("profile");
            let device = build(protocol, &profile).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(device.line(), protocol.default_line());
            assert!(device.input_names().contains(&input), "{name}");
        }
    }

    #[test]
    fn variants_shape_the_simulator_built() {
        let mut emcu = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        emcu.sim.variants = vec![SimVariant::Memory(12)];
        let device = build(Protocol::Emcu, &emcu).expect("EMCU with a small ROM");
        assert!(
            device
                .describe(std::time::Instant::now())
                .contains("(room for 12)")
        );
        emcu.sim.variants = vec![SimVariant::Memory(100_000)];
        let err = build(Protocol::Emcu, &emcu).err().expect("too much");
        assert!(err.to_string().contains("at most 256"), "{err}");
        emcu.sim.variants = vec![SimVariant::HoodUnwired];
        let err = build(Protocol::Emcu, &emcu)
            .err()
            .expect("no hood on an EMCU");
        assert!(
            err.to_string().contains("no variant `hood-unwired`"),
            "{err}"
        );
    }

    #[test]
    fn a_probe_surface_is_refused_for_the_emcu_with_the_reason() {
        let mut emcu = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        emcu.sim.variants = vec!["probe-surface=8000".parse().expect("a surface")];
        let err = build(Protocol::Emcu, &emcu)
            .err()
            .expect("no probe on an EMCU");
        assert!(
            err.to_string().contains("cannot read its input E1"),
            "{err}"
        );
    }

    #[test]
    fn a_profile_for_another_machine_is_refused_with_the_reason() {
        let isel = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let err = build(Protocol::Emp, &isel)
            .err()
            .expect("EMP needs drive addresses");
        assert!(err.to_string().contains("EMP simulator"), "{err}");
    }
}
