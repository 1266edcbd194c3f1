//! Which machine profile a command works with: `--profile`, else the shipped
//! one for the family `--sim`/`--protocol` names, else `default`; then the
//! connection overrides of the command line on top. One rule for every
//! command, so `jogterm --sim emp` and `jogterm --sim emp sim --pty` mean the
//! same machine.

use anyhow::bail;

use super::GlobalArgs;
use crate::config::profile::Connection;
use crate::config::source::error_for_key;
use crate::config::{ConfigDirs, Profile, Source, load_profile_with_sources};
use crate::proto::Protocol;
use crate::transport::PortAddress;

/// The profile the command line asks for, with `--sim`, `--protocol` and
/// `--port` applied.
pub fn resolve(global: &GlobalArgs, dirs: &ConfigDirs) -> anyhow::Result<Profile> {
    resolve_with_sources(global, dirs).map(|(profile, _)| profile)
}

/// [`resolve`], also returning the files the profile was layered from (most
/// specific first), so later checks of its contents (the console's `[keys]`
/// table) can name the line at fault.
pub fn resolve_with_sources(
    global: &GlobalArgs,
    dirs: &ConfigDirs,
) -> anyhow::Result<(Profile, Vec<Source>)> {
    let family = match (global.protocol, global.sim) {
        (Some(p), Some(s)) if p != s => {
            bail!("--protocol {p} and --sim {s} name different families: give one of them")
        }
        (Some(p), _) | (None, Some(p)) => Some(p),
        (None, None) => None,
    };
    if let (Some(port), Some(sim)) = (&global.port, global.sim) {
        bail!(
            "--port {port} and --sim {sim} contradict each other: a port or the built-in simulator"
        );
    }
    let (mut profile, sources) = match (&global.profile, family) {
        (Some(name), _) => load_profile_with_sources(name, dirs)?,
        (None, None) => load_profile_with_sources("default", dirs)?,
        (None, Some(family)) => {
            let default = load_profile_with_sources("default", dirs)?;
            if default.0.connection.protocol == family {
                default
            } else {
                // The shipped profile of each family is named after it.
                load_profile_with_sources(family.name(), dirs)?
            }
        }
    };
    if let Some(family) = family
        && profile.connection.protocol != family
    {
        bail!(
            "profile `{}` describes a {} machine, not {family}: choose a {family} profile or leave out --profile",
            profile.name,
            profile.connection.protocol
        );
    }
    if global.sim.is_some() {
        profile.connection.port = Connection::SIMULATOR.to_string();
    }
    if let Some(port) = &global.port {
        profile.connection.port = port.clone();
    }
    check_port(&profile, global, &sources)?;
    Ok((profile, sources))
}

/// The port must be `sim`, a device path or a serial port server's URL
/// (`tcp://HOST:PORT`, `rfc2217://HOST:PORT`); a bad one is refused before
/// anything opens, at its line in the profile or as the option it came from.
fn check_port(profile: &Profile, global: &GlobalArgs, sources: &[Source]) -> anyhow::Result<()> {
    if profile.connection.is_simulator() {
        return Ok(());
    }
    let Err(e) = PortAddress::parse(&profile.connection.port) else {
        return Ok(());
    };
    if global.port.is_some() {
        bail!("--port {e}");
    }
    let refs: Vec<&Source> = sources.iter().collect();
    let key = ["connection".to_owned(), "port".to_owned()];
    Err(error_for_key(&refs, &key, format!("`{}`: {}", e.given, e.problem)).into())
}

/// The family a profile resolved by [`resolve`] talks.
pub fn family(profile: &Profile) -> Protocol {
    profile.connection.protocol
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resolved(global: GlobalArgs) -> anyhow::Result<Profile> {
        resolve(&global, &ConfigDirs::builtin_only())
    }

    #[test]
    fn without_options_the_default_simulator() {
        let p = resolved(GlobalArgs::default()).unwrap();
        assert_eq!(family(&p), Protocol::Isel);
        assert!(p.connection.is_simulator());
    }

    #[test]
    fn sim_of_another_family_takes_its_shipped_profile_on_the_simulator() {
        let p = resolved(GlobalArgs {
            sim: Some(Protocol::Emp),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(family(&p), Protocol::Emp);
        assert!(p.connection.is_simulator());
        assert_eq!(p.axes.len(), 1);
    }

    #[test]
    fn protocol_alone_takes_the_shipped_hardware_profile() {
        let p = resolved(GlobalArgs {
            protocol: Some(Protocol::Emcu),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(family(&p), Protocol::Emcu);
        assert_eq!(p.connection.port, "/dev/ttyUSB0");
        let p = resolved(GlobalArgs {
            protocol: Some(Protocol::Isel),
            port: Some("/dev/ttyS3".into()),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(p.connection.port, "/dev/ttyS3");
    }

    #[test]
    fn network_ports_are_taken_and_bad_ones_refused_where_they_were_given() {
        let p = resolved(GlobalArgs {
            protocol: Some(Protocol::Isel),
            port: Some("rfc2217://pi.local:2001".into()),
            ..Default::default()
        })
        .expect("an RFC 2217 server");
        assert_eq!(p.connection.port, "rfc2217://pi.local:2001");
        let err = resolved(GlobalArgs {
            protocol: Some(Protocol::Isel),
            port: Some("tcp://pi.local".into()),
            ..Default::default()
        })
        .expect_err("no TCP port");
        assert!(
            err.to_string()
                .starts_with("--port port `tcp://pi.local`: expected HOST:PORT"),
            "{err}"
        );
        // In a profile: at its line.
        let dir = tempfile::tempdir().expect("dir");
        std::fs::create_dir(dir.path().join("profiles")).expect("dir");
        std::fs::write(
            dir.path().join("profiles/mill.toml"),
            "base = \"isel\"\n\n[connection]\nport = \"telnet://pi:23\"\n",
        )
        .expect("profile");
        let dirs = ConfigDirs {
            user: Some(dir.path().to_path_buf()),
        };
        let err = resolve(
            &GlobalArgs {
                profile: Some("mill".into()),
                ..Default::default()
            },
            &dirs,
        )
        .expect_err("a bad scheme");
        let text = format!("{err:#}");
        assert!(text.contains("mill.toml:4:"), "{text}");
        assert!(text.contains("unknown scheme"), "{text}");
        assert!(text.contains("connection.port"), "{text}");
    }

    #[test]
    fn contradictions_are_refused_with_the_reason() {
        let err = resolved(GlobalArgs {
            protocol: Some(Protocol::Isel),
            sim: Some(Protocol::Emp),
            ..Default::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("different families"), "{err}");
        let err = resolved(GlobalArgs {
            port: Some("/dev/x".into()),
            sim: Some(Protocol::Isel),
            ..Default::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("contradict"), "{err}");
        let err = resolved(GlobalArgs {
            profile: Some("emcu".into()),
            sim: Some(Protocol::Emp),
            ..Default::default()
        })
        .unwrap_err();
        assert!(
            err.to_string().contains("describes a emcu machine"),
            "{err}"
        );
    }
}
