//! What `jogterm send` and `jogterm poll` share: the machine profile and the
//! port from the command line, the device task in front of it (or of the
//! built-in simulator, in-process, with `--sim`), and the traffic log.

use std::fs::OpenOptions;
use std::time::Duration;

use anyhow::Context as _;

use super::{GlobalArgs, profile};
use crate::config::{ConfigDirs, Profile};
use crate::device::api::{Activity, Event, LinkState};
use crate::device::inputs::RecorderConfig;
use crate::device::log::spawn_log;
use crate::device::{
    Connector, DeviceHandle, EventReceiver, SessionMoves, TaskOptions, spawn_recording,
};
use crate::proto::Protocol;
use crate::sim::registry;
use crate::sim::shell::{Shell, serve_socket};
use crate::transport::PortSpec;
use crate::wire::LineSettings;

/// Exit status for a link failure (timeout, port gone, cannot open).
pub const EXIT_LINK: u8 = 3;
/// Exit status for bad usage.
pub const EXIT_USAGE: u8 = 2;

/// A command's connection: the device task and, with `--sim`, the
/// simulator it talks to.
pub struct Session {
    pub handle: DeviceHandle,
    pub events: EventReceiver,
    /// What the machine does, as the last state event said.
    pub activity: Activity,
    /// Whether the command was asked to move.
    pub moves: Moves,
    /// Kept alive as long as the session; `None` on a real port.
    _simulator: Option<Shell>,
}

/// Why a session could not start: bad usage or a failure.
pub enum StartError {
    Usage(String),
    Failed(anyhow::Error),
}

impl From<anyhow::Error> for StartError {
    fn from(e: anyhow::Error) -> Self {
        StartError::Failed(e)
    }
}

/// The profile for a talking command: `--profile` etc. as everywhere, with
/// `--baud` on top; only families with a driver here.
pub fn resolve(global: &GlobalArgs, baud: Option<u32>) -> Result<Profile, StartError> {
    let mut profile = profile::resolve(global, &ConfigDirs::from_env())
        .map_err(|e| StartError::Usage(format!("{e:#}")))?;
    if !talks(profile.connection.protocol) {
        return Err(StartError::Usage(format!(
            "jogterm send and poll do not talk {} (--protocol isel, emcu or emp)",
            profile.connection.protocol
        )));
    }
    if let Some(baud) = baud {
        // Refused before a port is opened: a line at 0 baud has no wire
        // time, and a session waited for ever (issue 37).
        crate::config::profile::Connection::check_baud(baud)
            .map_err(|m| StartError::Usage(format!("--baud {m}")))?;
        profile.connection.baud = Some(baud);
    }
    Ok(profile)
}

/// How a command ends early: its exit status, or a failure for `main`.
pub type Ended = anyhow::Result<std::process::ExitCode>;

fn usage(command: &str, message: &str) -> Ended {
    super::out::say(format_args!("jogterm {command}: {message}"));
    Ok(std::process::ExitCode::from(EXIT_USAGE))
}

/// What `poll`, `watch` and `commission` take first: the profile with
/// `--baud` and, for EMP, the drives of `--drive`; bad usage is said as
/// `jogterm <command>: …` and ends the command with status 2.
pub fn command_profile(
    command: &str,
    global: &GlobalArgs,
    baud: Option<u32>,
    drives: &[String],
) -> Result<Profile, Ended> {
    let mut profile = match resolve(global, baud) {
        Ok(p) => p,
        Err(StartError::Usage(m)) => return Err(usage(command, &m)),
        Err(StartError::Failed(e)) => return Err(Err(e)),
    };
    if profile.connection.protocol == Protocol::Emp
        && let Err(m) = super::emp::apply_drives(&mut profile, drives)
    {
        return Err(usage(command, &m));
    }
    Ok(profile)
}

/// Then the session, up to the link: bad usage ends the command with
/// status 2, a link that does not come up (within 10 s) with status 3, both
/// said as `jogterm <command>: …`.
pub async fn command_session(
    command: &str,
    global: &GlobalArgs,
    profile: Profile,
    polling: Polling,
    moves: Moves,
) -> Result<Session, Ended> {
    let mut session = match start(global, profile, polling, moves) {
        Ok(s) => s,
        Err(StartError::Usage(m)) => return Err(usage(command, &m)),
        Err(StartError::Failed(e)) => return Err(Err(e)),
    };
    if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
        super::out::say(format_args!(
            "jogterm {command}: link failure: {reason}; {}",
            crate::device::api::Recovery::CheckLink.instruction()
        ));
        session.close().await;
        return Err(Ok(std::process::ExitCode::from(EXIT_LINK)));
    }
    Ok(session)
}

/// The families `send` and `poll` talk.
fn talks(protocol: Protocol) -> bool {
    matches!(protocol, Protocol::Isel | Protocol::Emcu | Protocol::Emp)
}

pub use crate::device::common::Polling;

/// Whether a command was asked to move (`docs/device.md`, "Sessions that
/// do not move"): one that was not sends no stop of its own, at connect,
/// at exit or on an interrupt; whatever the controller runs (a stored
/// program started from its own start key) goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Moves {
    /// Reads only (`watch`, `poll`, `send` of reads).
    No,
    /// Sends motion, or may: the stops at connect and on the interrupted
    /// paths stay.
    Yes,
}

/// Start the device task, polling as `polling` says.
pub fn start(
    global: &GlobalArgs,
    profile: Profile,
    polling: Polling,
    moves: Moves,
) -> Result<Session, StartError> {
    let driver = crate::device::driver_for(&profile, Some(polling))
        .map_err(|e| StartError::Usage(e.to_string()))?;
    let family = profile.connection.protocol;
    let line: LineSettings = profile.connection.line();
    let (connector, simulator) = if profile.connection.is_simulator() {
        let device = registry::build(family, &profile).map_err(anyhow::Error::from)?;
        let (shell, stream) = serve_socket(device).context("starting the built-in simulator")?;
        let spec = PortSpec::InProcess {
            stream,
            line: shell.line(),
            name: format!("built-in {family} simulator"),
        };
        (Connector::from(spec), Some(shell))
    } else {
        let spec = PortSpec::from_address(&profile.connection.port, line)
            .map_err(|e| StartError::Usage(e.to_string()))?;
        (Connector::from(spec), None)
    };
    let inputs = RecorderConfig::from_profile(&profile);
    let options = TaskOptions {
        moves: match moves {
            Moves::Yes => SessionMoves::Yes,
            Moves::No => SessionMoves::No,
        },
        ..TaskOptions::default()
    };
    let (handle, events) =
        spawn_recording(driver, connector, options, inputs).map_err(anyhow::Error::from)?;
    if let Some(path) = &global.log {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("cannot open the log file {}", path.display()))?;
        spawn_log(handle.subscribe(), file);
    }
    Ok(Session {
        handle,
        events,
        activity: Activity::Idle,
        moves,
        _simulator: simulator,
    })
}

/// How waiting for the link ended.
pub enum Linked {
    Up,
    /// The port could not be opened or was lost: the reason.
    Failed(String),
}

impl Session {
    /// The next event; state events update `activity` on the way.
    pub async fn next_event(&mut self) -> Option<Event> {
        let event = self.events.recv().await;
        if let Some(Event::State(s)) = &event {
            self.activity = s.activity;
        }
        event
    }

    /// Wait until the port is open (or the first attempt failed).
    pub async fn linked(&mut self, within: Duration) -> Linked {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            match tokio::time::timeout_at(deadline, self.next_event()).await {
                Ok(Some(Event::Link(LinkState::Connected))) => return Linked::Up,
                Ok(Some(Event::Link(LinkState::Lost { reason }))) => return Linked::Failed(reason),
                Ok(Some(_)) => {}
                Ok(None) => return Linked::Failed("the device task ended".into()),
                Err(_) => return Linked::Failed("no link within the time allowed".into()),
            }
        }
    }

    /// The built-in simulator's controls, when the session runs on it.
    pub fn simulator(&self) -> Option<crate::sim::shell::ShellControl> {
        self._simulator.as_ref().map(Shell::control)
    }

    /// Close: after a stop when the session moves, else with nothing sent
    /// but what was on its way.
    pub async fn close(self) {
        self.handle.shutdown().await;
    }
}

/// Completes on SIGINT, SIGTERM or SIGHUP: the command then stops the
/// machine and closes the port itself (the default actions would end the
/// process without a stop byte, `docs/field-notes.md`).
pub async fn interrupted() {
    use tokio::signal::unix::{SignalKind, signal};
    match (
        signal(SignalKind::interrupt()),
        signal(SignalKind::terminate()),
        signal(SignalKind::hangup()),
    ) {
        (Ok(mut int), Ok(mut term), Ok(mut hup)) => {
            tokio::select! {
                _ = int.recv() => {}
                _ = term.recv() => {}
                _ = hup.recv() => {}
            }
        }
        // Without the handlers at least Ctrl-C.
        _ => {
            let _ = tokio::signal::ctrl_c().await;
        }
    }
}

/// Say on stderr that a signal stopped the machine. Not `eprintln!`: after
/// a hang-up stderr may be the dead terminal, where it panics (status 101,
/// and the orderly close after it skipped; `docs/field-notes.md`,
/// "Order on hang-up").
pub fn say_interrupted(command: &str, moves: Moves) {
    let after = match moves {
        Moves::Yes => ": the machine was stopped",
        Moves::No => "",
    };
    super::out::say(format_args!("jogterm {command}: interrupted{after}"));
}

/// A session that moves, on a runtime of its own, handed to `body` (the
/// commands that store and run programs); a configuration it cannot start
/// with is said as `jogterm <command>: …`, exit 2.
pub fn moving(
    global: &GlobalArgs,
    profile: Profile,
    command: &str,
    body: impl AsyncFnOnce(Session) -> std::process::ExitCode,
) -> anyhow::Result<std::process::ExitCode> {
    runtime()?.block_on(async {
        match start(global, profile, Polling::OFF, Moves::Yes) {
            Ok(session) => Ok(body(session).await),
            Err(StartError::Usage(m)) => {
                super::out::say(format_args!("jogterm {command}: {m}"));
                Ok(std::process::ExitCode::from(EXIT_USAGE))
            }
            Err(StartError::Failed(e)) => Err(e),
        }
    })
}

/// A current-thread runtime for a command.
pub fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}
