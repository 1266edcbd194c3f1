//! The console: `jogterm` without a command.
//!
//! Everything that can be wrong with the configuration is found before the
//! terminal is touched: the profile with the command line's overrides on top,
//! the theme, the profile's `[keys]` table. A problem prints the loader's
//! `file:line:col: error: …` and exits with status 2.

use std::process::ExitCode;

use crate::config::{ConfigDirs, ConfigError, Profile, Source, Theme};
use crate::config::{load_profile_with_sources, load_theme};
use crate::proto::Protocol;
use crate::ui::keymap::Keymap;

/// The options of the console, as the command line gives them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TuiOptions {
    pub profile: Option<String>,
    pub port: Option<String>,
    pub protocol: Option<Protocol>,
    pub sim: Option<Protocol>,
    pub theme: Option<String>,
}

/// The console's configuration, checked.
#[derive(Debug, Clone)]
pub struct Resolved {
    pub profile: Profile,
    pub theme: Theme,
    pub keymap: Keymap,
}

/// Why the console cannot start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SetupError {
    /// A file is wrong: shown as the loader words it, `file:line:col: error: …`.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The options contradict each other or the profile.
    #[error("error: {0}")]
    Options(String),
}

impl SetupError {
    /// The exit status: configuration and usage errors are 2.
    pub fn exit_code(&self) -> ExitCode {
        ExitCode::from(2)
    }
}

/// The shipped theme used without `--theme`.
pub const DEFAULT_THEME: &str = "dark";
/// The profile used without `--profile`.
pub const DEFAULT_PROFILE: &str = "default";

/// Load and check everything the console needs.
pub fn resolve(options: &TuiOptions, dirs: &ConfigDirs) -> Result<Resolved, SetupError> {
    if let (Some(sim), Some(port)) = (options.sim, &options.port) {
        return Err(SetupError::Options(format!(
            "--sim {sim} runs the built-in simulator; it cannot be combined with --port {port}"
        )));
    }
    if let (Some(sim), Some(protocol)) = (options.sim, options.protocol)
        && sim != protocol
    {
        return Err(SetupError::Options(format!(
            "--protocol {protocol} and --sim {sim} name different families: give one of them"
        )));
    }
    let spec = options.profile.as_deref().unwrap_or(DEFAULT_PROFILE);
    let (mut profile, mut sources) = load_profile_with_sources(spec, dirs)?;
    if let Some(sim) = options.sim {
        // A profile of another family describes another machine: take the
        // shipped profile of the simulated family instead.
        if profile.connection.protocol != sim {
            (profile, sources) =
                load_profile_with_sources(sim.name(), &ConfigDirs::builtin_only())?;
        }
        profile.connection.port = crate::config::profile::Connection::SIMULATOR.to_string();
    }
    if let Some(protocol) = options.protocol
        && protocol != profile.connection.protocol
    {
        profile.connection.protocol = protocol;
        if let Some(problem) = profile.validate().into_iter().next() {
            return Err(SetupError::Options(format!(
                "--protocol {protocol}: the profile `{}` does not fit: {} ({})",
                profile.name,
                problem.message,
                problem.key.join(".")
            )));
        }
    }
    if let Some(port) = &options.port {
        profile.connection.port = port.clone();
    }
    let theme = load_theme(options.theme.as_deref().unwrap_or(DEFAULT_THEME), dirs)?;
    let refs: Vec<&Source> = sources.iter().collect();
    let keymap = Keymap::default().with_overrides(&profile.keys, &refs)?;
    Ok(Resolved {
        profile,
        theme,
        keymap,
    })
}

#[cfg(test)]
mod tests {
    use std::fs;

    use super::*;
    use crate::axis::{Axis, AxisSet};
    use crate::ui::key::KeyChord;
    use crate::ui::keymap::{Action, Mode};

    fn user_dir() -> (tempfile::TempDir, ConfigDirs) {
        let dir = tempfile::tempdir().expect("tempdir");
        fs::create_dir_all(dir.path().join("profiles")).expect("profiles");
        fs::create_dir_all(dir.path().join("themes")).expect("themes");
        let dirs = ConfigDirs {
            user: Some(dir.path().to_path_buf()),
        };
        (dir, dirs)
    }

    fn options() -> TuiOptions {
        TuiOptions::default()
    }

    #[test]
    fn without_options_it_is_the_isel_simulator_in_the_dark_theme() {
        let r = resolve(&options(), &ConfigDirs::builtin_only()).expect("ok");
        assert_eq!(r.profile.connection.protocol, Protocol::Isel);
        assert!(r.profile.connection.is_simulator());
        assert_eq!(r.theme.name, "dark");
    }

    #[test]
    fn sim_of_another_family_takes_that_familys_shipped_profile() {
        let r = resolve(
            &TuiOptions {
                sim: Some(Protocol::Emcu),
                ..options()
            },
            &ConfigDirs::builtin_only(),
        )
        .expect("ok");
        assert_eq!(r.profile.connection.protocol, Protocol::Emcu);
        assert_eq!(r.profile.name, "EMCU SMC3000");
        assert!(r.profile.connection.is_simulator());
        // The same family keeps the chosen profile, on the simulator.
        let r = resolve(
            &TuiOptions {
                profile: Some("emp".into()),
                sim: Some(Protocol::Emp),
                ..options()
            },
            &ConfigDirs::builtin_only(),
        )
        .expect("ok");
        assert_eq!(r.profile.axis_set(), AxisSet::EMPTY.with(Axis::X));
        assert!(r.profile.connection.is_simulator());
    }

    #[test]
    fn port_and_protocol_patch_the_profile() {
        let r = resolve(
            &TuiOptions {
                profile: Some("isel".into()),
                port: Some("/dev/pts/7".into()),
                protocol: Some(Protocol::Emcu),
                ..options()
            },
            &ConfigDirs::builtin_only(),
        )
        .expect("ok");
        assert_eq!(r.profile.connection.port, "/dev/pts/7");
        assert_eq!(r.profile.connection.protocol, Protocol::Emcu);
    }

    #[test]
    fn contradictions_are_refused_with_exit_status_2() {
        let dirs = ConfigDirs::builtin_only();
        for (bad, needle) in [
            (
                TuiOptions {
                    sim: Some(Protocol::Isel),
                    port: Some("/dev/ttyUSB0".into()),
                    ..options()
                },
                "cannot be combined",
            ),
            (
                TuiOptions {
                    sim: Some(Protocol::Isel),
                    protocol: Some(Protocol::Emp),
                    ..options()
                },
                "different families",
            ),
            (
                // The default profile's axes have no EMP drive addresses.
                TuiOptions {
                    protocol: Some(Protocol::Emp),
                    ..options()
                },
                "drive address",
            ),
        ] {
            let err = resolve(&bad, &dirs).expect_err(needle);
            assert!(err.to_string().contains(needle), "{err}");
            assert_eq!(err.exit_code(), ExitCode::from(2));
        }
    }

    #[test]
    fn a_broken_profile_theme_or_key_names_its_line() {
        let (dir, dirs) = user_dir();
        let profiles = dir.path().join("profiles");
        fs::write(
            profiles.join("broken.toml"),
            "name = \"x\"\n[jog]\nstep = \"big\"\n",
        )
        .expect("write");
        fs::write(
            profiles.join("keys.toml"),
            "name = \"keys\"\n\n[keys.main]\n\"x\" = \"fly\"\n",
        )
        .expect("write");
        fs::write(
            dir.path().join("themes/bad.toml"),
            "name = \"bad\"\n[styles]\ntext = { fg = \"nope\" }\n",
        )
        .expect("write");
        let cases = [
            (options_with_profile("broken"), "broken.toml:3:"),
            (options_with_profile("keys"), "keys.toml:4:"),
            (
                TuiOptions {
                    theme: Some("bad".into()),
                    ..options()
                },
                "bad.toml:3:",
            ),
        ];
        for (opts, place) in cases {
            let err = resolve(&opts, &dirs).expect_err(place);
            let shown = err.to_string();
            assert!(shown.contains(place), "{shown}");
            assert!(shown.contains(": error: "), "{shown}");
        }
    }

    fn options_with_profile(name: &str) -> TuiOptions {
        TuiOptions {
            profile: Some(name.into()),
            ..TuiOptions::default()
        }
    }

    #[test]
    fn profile_keys_reach_the_keymap() {
        let (dir, dirs) = user_dir();
        fs::write(
            dir.path().join("profiles/mill.toml"),
            "name = \"mill\"\n[keys.safety]\n\"ctrl-x\" = \"stop\"\n",
        )
        .expect("write");
        let r = resolve(&options_with_profile("mill"), &dirs).expect("ok");
        assert_eq!(
            r.keymap.lookup(Mode::Safety, &KeyChord::ctrl('x')),
            Some(Action::Stop)
        );
    }
}
