//! The console: `jogterm` without a command.
//!
//! Everything that can be wrong with the configuration is found before the
//! terminal is touched: the profile with the command line's overrides on top,
//! the theme, the profile's `[keys]` table. A problem prints the loader's
//! `file:line:col: error: …` and exits with status 2. Then the line is
//! opened (the built-in simulator in-process over a socket pair, or the
//! port), the device task started, and only then the terminal taken.

use std::fs::OpenOptions;
use std::future::Future;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context as _;
use tokio::sync::mpsc;

use super::profile::resolve_with_sources;
use super::{GlobalArgs, out};
use crate::config::{ConfigDirs, ConfigError, Profile, Source, Theme, load_theme};
use crate::device::api::{Event, Request};
use crate::device::log::spawn_log;
use crate::device::{DeviceHandle, EventReceiver, SessionMoves, TaskOptions};
use crate::offsets::Identity;
use crate::offsets::store::OffsetsFile;
use crate::program::store::RecoveryStore;
use crate::sim::registry;
use crate::sim::shell::{Shell, ShellControl, serve_socket};
use crate::transport::PortSpec;
use crate::ui::editor::io::EditorMsg;
use crate::ui::input::InputThreads;
use crate::ui::keymap::Keymap;
use crate::ui::palette::Palette;
use crate::ui::runtime::{self, DeviceLink, NotSent, RunOptions};
use crate::ui::terminal::{TerminalGuard, TerminalOptions, set_emergency};
use crate::ui::traffic_log::NoteLevel;
use crate::ui::{Model, Msg, Setup};

/// The console's configuration, checked.
#[derive(Debug, Clone)]
pub struct Resolved {
    pub profile: Profile,
    pub theme: Theme,
    pub keymap: Keymap,
    /// The name the profile was chosen by, for its work offsets file
    /// (`offsets::store::profile_key`).
    pub profile_key: String,
}

/// Why the console cannot start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SetupError {
    /// A file is wrong: shown as the loader words it, `file:line:col: error: …`.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The options contradict each other or the profile.
    #[error("jogterm: error: {0}")]
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

/// Load and check everything the console needs: the profile as every
/// command resolves it (`cli::profile`), the theme, the profile's keys.
pub fn resolve(global: &GlobalArgs, dirs: &ConfigDirs) -> Result<Resolved, SetupError> {
    let (profile, sources) =
        resolve_with_sources(global, dirs).map_err(|e| match e.downcast::<ConfigError>() {
            Ok(config) => SetupError::Config(config),
            Err(other) => SetupError::Options(format!("{other:#}")),
        })?;
    let theme = load_theme(global.theme.as_deref().unwrap_or(DEFAULT_THEME), dirs)?;
    let refs: Vec<&Source> = sources.iter().collect();
    let macro_names: Vec<&str> = profile.macros.keys().map(String::as_str).collect();
    let keymap = Keymap::builtin()?.with_overrides(&profile.keys, &macro_names, &refs)?;
    let profile_key = crate::offsets::store::profile_key(&sources);
    Ok(Resolved {
        profile,
        theme,
        keymap,
        profile_key,
    })
}

/// What the console opens with: `--program`, its `--height-map`, and
/// `--work-zero`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Opening<'a> {
    pub program: Option<&'a Path>,
    pub height_map: Option<&'a Path>,
    pub work_zero: Option<&'a str>,
}

/// `jogterm` without a command: run the console until the operator quits.
pub fn run(global: &GlobalArgs, opening: Opening<'_>) -> anyhow::Result<ExitCode> {
    let resolved = match resolve(global, &ConfigDirs::from_env()) {
        Ok(resolved) => resolved,
        Err(e) => {
            out::say(&e);
            return Ok(e.exit_code());
        }
    };
    // A G-code job is imported inside the console, with its work offsets
    // (`ui::editor::gcode_open`): one that does not fit opens with its
    // errors in the job panel. Only what no session could use is refused
    // here: a height map file that cannot be read, a map for a program.
    let message = match opening.program {
        Some(path) if crate::gcode::is_gcode_path(path) => {
            let height_map = match opening.height_map.map(super::import::read_height_map) {
                None => None,
                Some(Ok(map)) => Some(Arc::new(map)),
                Some(Err(why)) => {
                    out::say(format_args!("jogterm: {why}"));
                    return Ok(ExitCode::from(2));
                }
            };
            Some(EditorMsg::OpenGcode {
                path: path.to_path_buf(),
                height_map,
            })
        }
        Some(_) if opening.height_map.is_some() => {
            out::say(
                "jogterm: error: --height-map shifts G-code onto a surface; a controller program \
                 runs in the controller's own coordinates as it is",
            );
            return Ok(ExitCode::from(2));
        }
        Some(path) => Some(EditorMsg::Open(path.to_path_buf())),
        None => None,
    };
    if let Some(zero) = opening.work_zero {
        let mut probe = crate::offsets::WorkOffsets::default();
        if let Err(why) = super::import::apply_work_zero(zero, &resolved.profile, &mut probe) {
            out::say(format_args!("jogterm: error: {why}"));
            return Ok(ExitCode::from(2));
        }
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(session(global, resolved, message, opening.work_zero))?;
    Ok(ExitCode::SUCCESS)
}

/// The built-in simulator a session runs on, and its inputs.
struct Simulator {
    shell: Shell,
    inputs: Vec<(String, Option<bool>)>,
}

/// The line to the controller: the built-in simulator of the profile's
/// family, served in-process (`sim::shell::serve_socket`), or the port.
fn open_line(profile: &Profile) -> anyhow::Result<(PortSpec, Option<Simulator>)> {
    let protocol = profile.connection.protocol;
    if !profile.connection.is_simulator() {
        let spec = PortSpec::from_address(&profile.connection.port, profile.connection.line())?;
        return Ok((spec, None));
    }
    let device = registry::build(protocol, profile)?;
    let (shell, stream) =
        serve_socket(device).with_context(|| format!("starting the {protocol} simulator"))?;
    let inputs = shell
        .control()
        .input_levels()
        .with_context(|| format!("asking the {protocol} simulator for its inputs"))?
        .into_iter()
        .map(|(name, level)| (name.to_string(), level))
        .collect();
    let spec = PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: format!("built-in {protocol} simulator"),
    };
    Ok((spec, Some(Simulator { shell, inputs })))
}

/// The device task as the UI loop drives it.
struct Device {
    handle: DeviceHandle,
    events: EventReceiver,
}

impl DeviceLink for Device {
    fn request(&mut self, request: Request) -> Result<(), NotSent> {
        self.handle.request(request).map_err(NotSent::from)
    }

    fn stop(&mut self) {
        // The ticket says when the bytes left; the UI learns what happened
        // from the events that follow.
        drop(self.handle.stop());
    }

    fn stop_on_exit(&mut self) {
        if self.handle.moved() {
            self.stop();
        }
    }

    fn next_event(&mut self) -> impl Future<Output = Option<Event>> + Send {
        self.events.recv()
    }
}

/// Bound on closing the device after the console: the task stops the
/// machine and drains the stop bytes within its own bound (500 ms).
const CLOSE_WITHIN: Duration = Duration::from_secs(3);

async fn session(
    global: &GlobalArgs,
    resolved: Resolved,
    opening: Option<EditorMsg>,
    work_zero: Option<&str>,
) -> anyhow::Result<()> {
    let Resolved {
        profile,
        theme,
        keymap,
        profile_key,
    } = resolved;
    let (spec, simulator) = open_line(&profile)?;
    // The console sends no stop of its own until the operator has asked for
    // motion (`docs/device.md`, "Sessions that do not move").
    let options = TaskOptions {
        moves: SessionMoves::OnceAsked,
        ..TaskOptions::default()
    };
    let (handle, events) = crate::device::spawn(&profile, spec, options)?;
    // The panic hook and the hang-up path write the stop bytes themselves.
    let emergency = handle.emergency();
    set_emergency(Some(Arc::new(move || {
        let _ = emergency.fire();
    })));
    let setup = Setup::from_profile(&profile, simulator.as_ref().map(|s| s.inputs.clone()));
    let mut model = Model::new(setup, keymap, Palette::from(&theme), Instant::now());
    // Unsaved edits go to the user's state directory (`docs/editor.md`);
    // the tag tells this session's new programs from another's.
    if let Some(store) = RecoveryStore::from_env() {
        model
            .editor
            .keep_recoveries(store, session_tag(std::process::id(), SystemTime::now()));
    }
    // The files opened last (Ctrl-O's Up/Down), kept beside the recoveries.
    if let Some(dir) = crate::program::store::state_dir() {
        let list = crate::program::recent::read(&dir);
        model.editor.keep_recent(dir, list);
    }
    // Work offsets: the state directory's file for this profile and port,
    // applied only if it is this machine's (`docs/jogging.md`).
    let file = OffsetsFile::from_env(Identity::of(&profile_key, &profile));
    // The tool table beside them (`jogterm probe tool`): the tool in the
    // spindle shifts every Z of a job imported here.
    let tools_path = file.as_ref().and_then(crate::offsets::tools::table_path);
    let read = tools_path.as_deref().map(crate::offsets::tools::load);
    crate::ui::update::start_tools(&mut model, tools_path, read);
    crate::ui::update::start_offsets(&mut model, file.map(|f| (f.load(), f)));
    if let Some(zero) = work_zero {
        let table = &mut model.keypad.offsets.table;
        // Checked before the session started.
        if super::import::apply_work_zero(zero, &profile, table).is_ok() {
            let system = table.active();
            crate::ui::update::say(
                &mut model,
                NoteLevel::Info,
                format!(
                    "{system}'s zero at machine {zero} (--work-zero) for this session; the saved \
                     offsets change only when you set one (s, O)"
                ),
            );
        }
    }
    let device = Device {
        handle: handle.clone(),
        events,
    };
    let result = match start_log(global, &handle) {
        Ok(()) => {
            let control = simulator.as_ref().map(|s| s.shell.control());
            in_terminal(model, device, control, opening).await
        }
        Err(e) => Err(e),
    };
    // Whatever ended the console: the machine is stopped and the port
    // closed before the process goes.
    let _ = tokio::time::timeout(CLOSE_WITHIN, handle.shutdown()).await;
    set_emergency(None);
    if let Some(simulator) = simulator {
        let _ = tokio::task::spawn_blocking(move || simulator.shell.shutdown()).await;
    }
    result
}

/// A name for this session's unsaved new programs: the process and the
/// second it started, so a later session never takes it for its own.
fn session_tag(pid: u32, started: SystemTime) -> String {
    let secs = started
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    format!("{pid}-{secs}")
}

/// `--log FILE`: the traffic log, as `send` and `poll` write it.
fn start_log(global: &GlobalArgs, handle: &DeviceHandle) -> anyhow::Result<()> {
    if let Some(path) = &global.log {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("cannot open the log file {}", path.display()))?;
        spawn_log(handle.subscribe(), file);
    }
    Ok(())
}

/// Take the terminal, run the loop, give the terminal back (the guard does,
/// on every way out of here).
async fn in_terminal(
    mut model: Model,
    mut device: Device,
    simulator: Option<ShellControl>,
    opening: Option<EditorMsg>,
) -> anyhow::Result<()> {
    let (guard, mut terminal) =
        TerminalGuard::enter(TerminalOptions::from_env()).context("taking the terminal")?;
    if let Ok(size) = terminal.size() {
        model.size = (size.width, size.height);
    }
    // With the kitty keyboard protocol a key release stops a held jog at
    // once; without it the missing key repeat does (`docs/jogging.md`).
    model.keypad.set_releases(guard.reports_key_releases());
    let (tx, mut rx) = mpsc::unbounded_channel();
    // The editor's first work: look for edits an earlier session left,
    // then open the command line's program (which may have some of them).
    let _ = tx.send(Msg::Editor(EditorMsg::Scan));
    if let Some(msg) = opening {
        let _ = tx.send(Msg::Editor(msg));
    }
    let _input = InputThreads::spawn(tx).context("starting the input thread")?;
    runtime::run(
        &mut terminal,
        &mut model,
        &mut device,
        &mut rx,
        simulator,
        RunOptions::default(),
    )
    .await
    .context("the console failed")
}

#[cfg(test)]
mod tests {
    use std::fs;

    use super::*;
    use crate::proto::Protocol;
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

    fn with_profile(name: &str) -> GlobalArgs {
        GlobalArgs {
            profile: Some(name.into()),
            ..GlobalArgs::default()
        }
    }

    #[test]
    fn without_options_it_is_the_isel_simulator_in_the_dark_theme() {
        let r = resolve(&GlobalArgs::default(), &ConfigDirs::builtin_only()).expect("ok");
        assert_eq!(r.profile.connection.protocol, Protocol::Isel);
        assert!(r.profile.connection.is_simulator());
        assert_eq!(r.theme.name, "dark");
    }

    #[test]
    fn sim_of_another_family_takes_that_familys_shipped_profile() {
        let r = resolve(
            &GlobalArgs {
                sim: Some(Protocol::Emcu),
                theme: Some("mono16".into()),
                ..GlobalArgs::default()
            },
            &ConfigDirs::builtin_only(),
        )
        .expect("ok");
        assert_eq!(r.profile.connection.protocol, Protocol::Emcu);
        assert!(r.profile.connection.is_simulator());
        assert_eq!(r.theme.name, "mono16");
    }

    #[test]
    fn contradictions_are_refused_with_exit_status_2() {
        let err = resolve(
            &GlobalArgs {
                sim: Some(Protocol::Isel),
                port: Some("/dev/ttyUSB0".into()),
                ..GlobalArgs::default()
            },
            &ConfigDirs::builtin_only(),
        )
        .expect_err("contradiction");
        assert!(matches!(err, SetupError::Options(_)), "{err}");
        assert!(err.to_string().starts_with("jogterm: error: "), "{err}");
        assert_eq!(err.exit_code(), ExitCode::from(2));
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
            (with_profile("broken"), "broken.toml:3:"),
            (with_profile("keys"), "keys.toml:4:"),
            (
                GlobalArgs {
                    theme: Some("bad".into()),
                    ..GlobalArgs::default()
                },
                "bad.toml:3:",
            ),
        ];
        for (opts, place) in cases {
            let err = resolve(&opts, &dirs).expect_err(place);
            assert!(matches!(err, SetupError::Config(_)), "{err}");
            let shown = err.to_string();
            assert!(shown.contains(place), "{shown}");
            assert!(shown.contains(": error: "), "{shown}");
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
        let r = resolve(&with_profile("mill"), &dirs).expect("ok");
        assert_eq!(
            r.keymap.lookup(Mode::Safety, &KeyChord::ctrl('x')),
            Some(Action::Stop)
        );
    }
}
