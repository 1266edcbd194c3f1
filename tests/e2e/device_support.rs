//! Shared by the device task tests: the isel simulator behind a socket pair
//! (or any family's on a pty), the device task in front of it, and waiting
//! for events.
use std::time::Duration;

use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Event, LinkState, Request};
use jogterm::device::driver::Driver;
use jogterm::device::isel::{IselDriver, IselSettings, PollRate};
use jogterm::device::{Connector, DeviceHandle, EventReceiver, TaskOptions, spawn_with};
use jogterm::proto::Protocol;
use jogterm::sim::fault::Fault;
use jogterm::sim::registry;
use jogterm::sim::shell::{PtyOptions, Shell, serve_pty, serve_socket};
use jogterm::traffic::Direction;
use jogterm::transport::PortSpec;

pub fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("default profile")
}

/// Driver settings for tests on a loaded machine: a wider reply margin, so
/// a test thread that is late does not declare the link dead.
pub fn settings(rate: PollRate) -> IselSettings {
    let mut s = IselSettings::from_profile(&profile()).expect("settings");
    s.poll.rate = rate;
    s.timing.reply_margin = Duration::from_millis(400);
    s
}

pub struct Rig {
    pub shell: Shell,
    pub handle: DeviceHandle,
    pub events: EventReceiver,
    pub seen: Vec<Event>,
}

/// The isel simulator of the default profile on a socket pair, and the
/// device task talking to it.
pub fn socket_rig(settings: IselSettings) -> Rig {
    let device = registry::build(Protocol::Isel, &profile()).expect("simulator");
    let (shell, stream) = serve_socket(device).expect("serve");
    let spec = PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: "isel simulator".into(),
    };
    let (handle, events) = spawn_with(
        Box::new(IselDriver::new(settings)),
        Connector::from(spec),
        TaskOptions::default(),
    )
    .expect("device task");
    Rig {
        shell,
        handle,
        events,
        seen: Vec::new(),
    }
}

/// The same on a pseudo-terminal reachable through the stable `link`, so
/// the line can be closed and brought back (`fault close <ms>`).
pub fn pty_rig(settings: IselSettings, link: &std::path::Path) -> Rig {
    pty_rig_for(Box::new(IselDriver::new(settings)), &profile(), link)
}

/// Any family's driver in front of the simulator of `profile`'s family, on
/// a pty reachable through `link`.
pub fn pty_rig_for(driver: Box<dyn Driver>, profile: &Profile, link: &std::path::Path) -> Rig {
    let device = registry::build(profile.connection.protocol, profile).expect("simulator");
    let shell = serve_pty(
        device,
        PtyOptions {
            link: Some(link.to_path_buf()),
        },
    )
    .expect("serve");
    let connector = Connector::Serial {
        path: link.to_path_buf(),
        line: shell.line(),
    };
    let (handle, events) =
        spawn_with(driver, connector, TaskOptions::default()).expect("device task");
    Rig {
        shell,
        handle,
        events,
        seen: Vec::new(),
    }
}

impl Rig {
    /// Wait for an event matching `pred` (all events are kept in `seen`).
    pub async fn wait_for(
        &mut self,
        what: &str,
        within: Duration,
        pred: impl Fn(&Event) -> bool,
    ) -> Event {
        let deadline = tokio::time::Instant::now() + within;
        loop {
            match tokio::time::timeout_at(deadline, self.events.recv()).await {
                Ok(Some(e)) => {
                    self.seen.push(e.clone());
                    if pred(&e) {
                        return e;
                    }
                }
                Ok(None) => panic!("the device task ended while waiting for {what}"),
                Err(_) => panic!(
                    "no {what} within {within:?}; seen: {:#?}",
                    self.seen.iter().rev().take(30).collect::<Vec<_>>()
                ),
            }
        }
    }

    /// Collect events for a while.
    pub async fn run_for(&mut self, d: Duration) {
        let deadline = tokio::time::Instant::now() + d;
        while let Ok(Some(e)) = tokio::time::timeout_at(deadline, self.events.recv()).await {
            self.seen.push(e);
        }
    }

    /// Wait until the read-back after a connect is done.
    pub async fn connected(&mut self) {
        self.wait_for(
            "the read-back",
            Duration::from_secs(5),
            |e| matches!(e, Event::Notice(n) if n.starts_with("state read back")),
        )
        .await;
    }

    /// The line closes under the task (reopened 300 ms later): the loss,
    /// the reconnect and its read-back. The number of events seen before
    /// the reconnect, so that what was sent after it can be told apart.
    pub async fn close_and_reconnect(&mut self) -> usize {
        self.shell
            .control()
            .fault(Fault::Close {
                reopen_after: Some(Duration::from_millis(300)),
            })
            .expect("close");
        self.wait_for("the loss", Duration::from_secs(5), |e| {
            matches!(e, Event::Link(LinkState::Lost { .. }))
        })
        .await;
        let before = self.seen.len();
        self.wait_for("the reconnect", Duration::from_secs(10), |e| {
            matches!(e, Event::Link(LinkState::Connected))
        })
        .await;
        self.connected().await;
        before
    }

    pub fn request(&self, r: Request) {
        self.handle.request(r).expect("request taken");
    }

    /// Initialise, then a simulated reference (`@0N7`, no travel).
    pub async fn ready(&mut self) {
        self.connected().await;
        self.request(Request::Initialise);
        self.request(Request::Raw {
            line: "@0N7".into(),
        });
        self.wait_for(
            "@0N7 answered",
            Duration::from_secs(5),
            |e| matches!(e, Event::Reply { command, .. } if command == "@0N7"),
        )
        .await;
    }

    /// What jogterm sent, as text, in order.
    pub fn sent(&self) -> Vec<String> {
        sent_after(&self.seen, 0)
    }

    /// What jogterm sent after the first `from` events seen.
    pub fn sent_since(&self, from: usize) -> Vec<String> {
        sent_after(&self.seen, from)
    }

    pub fn link_states(&self) -> Vec<LinkState> {
        self.seen
            .iter()
            .filter_map(|e| match e {
                Event::Link(l) => Some(l.clone()),
                _ => None,
            })
            .collect()
    }
}

/// The device task's sent traffic among `seen` from `from` on, readable.
pub fn sent_after(seen: &[Event], from: usize) -> Vec<String> {
    seen[from..]
        .iter()
        .filter_map(|e| match e {
            Event::Traffic(r) if r.direction == Direction::Sent => {
                Some(jogterm::traffic::readable(&r.bytes))
            }
            _ => None,
        })
        .collect()
}
