//! What `jogterm send` and `jogterm poll` share: the machine profile and the
//! port from the command line, the device task in front of it (or of the
//! built-in simulator, in-process, with `--sim`), and the traffic log.

use std::fs::OpenOptions;
use std::time::Duration;

use anyhow::Context as _;

use super::{GlobalArgs, profile};
use crate::config::{ConfigDirs, Profile};
use crate::device::api::{Event, LinkState};
use crate::device::driver::Driver;
use crate::device::emp::{EmpDriver, EmpSettings};
use crate::device::isel::{IselDriver, IselSettings};
use crate::device::log::spawn_log;
use crate::device::{Connector, DeviceHandle, EventReceiver, TaskOptions, spawn_with};
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
/// `--baud` on top.
pub fn resolve(global: &GlobalArgs, baud: Option<u32>) -> Result<Profile, StartError> {
    let mut profile = profile::resolve(global, &ConfigDirs::from_env())
        .map_err(|e| StartError::Usage(format!("{e:#}")))?;
    if !matches!(profile.connection.protocol, Protocol::Isel | Protocol::Emp) {
        return Err(StartError::Usage(format!(
            "jogterm send and poll talk to isel and EMP controllers here, not {} (--protocol isel|emp)",
            profile.connection.protocol
        )));
    }
    if let Some(baud) = baud {
        profile.connection.baud = Some(baud);
    }
    Ok(profile)
}

/// Start the device task; `adjust` tunes the driver (polling).
pub fn start(
    global: &GlobalArgs,
    profile: Profile,
    adjust: impl FnOnce(&mut IselSettings),
) -> Result<Session, StartError> {
    let mut settings =
        IselSettings::from_profile(&profile).map_err(|e| StartError::Usage(e.to_string()))?;
    adjust(&mut settings);
    open(global, profile, Box::new(IselDriver::new(settings)))
}

/// Start the device task with the EMP driver; `adjust` tunes it (polling).
pub fn start_emp(
    global: &GlobalArgs,
    profile: Profile,
    adjust: impl FnOnce(&mut EmpSettings),
) -> Result<Session, StartError> {
    let mut settings =
        EmpSettings::from_profile(&profile).map_err(|e| StartError::Usage(e.to_string()))?;
    adjust(&mut settings);
    open(global, profile, Box::new(EmpDriver::new(settings)))
}

/// The device task with `driver` in front of the profile's port (or its
/// family's built-in simulator), and the traffic log.
fn open(
    global: &GlobalArgs,
    profile: Profile,
    driver: Box<dyn Driver>,
) -> Result<Session, StartError> {
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
        (
            Connector::Serial {
                path: profile.connection.port.clone().into(),
                line,
            },
            None,
        )
    };
    let (handle, events) =
        spawn_with(driver, connector, TaskOptions::default()).map_err(anyhow::Error::from)?;
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
    /// Wait until the port is open (or the first attempt failed).
    pub async fn linked(&mut self, within: Duration) -> Linked {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            match tokio::time::timeout_at(deadline, self.events.recv()).await {
                Ok(Some(Event::Link(LinkState::Connected))) => return Linked::Up,
                Ok(Some(Event::Link(LinkState::Lost { reason }))) => return Linked::Failed(reason),
                Ok(Some(_)) => {}
                Ok(None) => return Linked::Failed("the device task ended".into()),
                Err(_) => return Linked::Failed("no link within the time allowed".into()),
            }
        }
    }

    /// Stop, flush, close.
    pub async fn close(self) {
        self.handle.shutdown().await;
    }
}

/// Completes on SIGINT, SIGTERM or SIGHUP: the command then stops the
/// machine and closes the port itself (the default actions would end the
/// process without a stop byte, `../shared/field-notes.md`).
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

/// A current-thread runtime for a command.
pub fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}
