//! Shared by the jog wire tests and `benches/jog.rs`: the isel simulator
//! behind a socket pair with a probe that records when each byte reached
//! it (the shell's modelled arrival time at 19200 baud), the device task in
//! front of it, and the keypad logic (`jog::Jogger`) turning key events into
//! requests, the way the console does.
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use jogterm::axis::Axis;
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Dir, Event, LinkState, MachineState, Request};
use jogterm::device::isel::{IselDriver, IselSettings, PollRate};
use jogterm::device::{Connector, DeviceHandle, EventReceiver, TaskOptions, spawn_with};
use jogterm::jog::{Gate, JogKind, JogSettings, Jogger, KeyPhase, Selection, Vector};
use jogterm::sim::isel::IselSim;
use jogterm::sim::shell::{Shell, serve_socket};
use jogterm::sim::{InputControl, SimDevice};
use jogterm::transport::PortSpec;
use jogterm::wire::LineSettings;

/// isel's stop sequence: break (253), then delete the rest (255).
pub const BREAK: u8 = 0xFD;
pub const DISCARD: u8 = 0xFF;

pub fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("default profile")
}

/// What the probe holds: the simulated controller (isel unless said
/// otherwise: `benches/jog.rs` also probes EMCU and EMP) and every byte that
/// reached it, with its arrival time.
pub struct Probe<S = IselSim> {
    pub sim: S,
    pub arrivals: Vec<(Instant, u8)>,
}

pub type Shared<S = IselSim> = Arc<Mutex<Probe<S>>>;

pub fn lock<S>(shared: &Shared<S>) -> MutexGuard<'_, Probe<S>> {
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

/// The simulator, recording arrivals on the way in.
pub struct Recorder<S = IselSim>(pub Shared<S>);

impl<S: SimDevice> SimDevice for Recorder<S> {
    fn line(&self) -> LineSettings {
        lock(&self.0).sim.line()
    }
    fn on_byte(&mut self, byte: u8, now: Instant) {
        let mut p = lock(&self.0);
        p.arrivals.push((now, byte));
        p.sim.on_byte(byte, now);
    }
    fn advance(&mut self, now: Instant) {
        lock(&self.0).sim.advance(now);
    }
    fn next_deadline(&self) -> Option<Instant> {
        lock(&self.0).sim.next_deadline()
    }
    fn poll_output(&mut self) -> Option<Vec<u8>> {
        lock(&self.0).sim.poll_output()
    }
    fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
        lock(&self.0).sim.control(control, now)
    }
    fn input_names(&self) -> Vec<&'static str> {
        lock(&self.0).sim.input_names()
    }
    fn input_level(&self, name: &str) -> Option<bool> {
        lock(&self.0).sim.input_level(name)
    }
    fn describe(&self, now: Instant) -> String {
        lock(&self.0).sim.describe(now)
    }
}

pub struct WireRig {
    /// Kept for its `Drop`: the simulator serves while the rig lives.
    pub _shell: Shell,
    pub handle: DeviceHandle,
    pub events: EventReceiver,
    pub probe: Shared,
    pub settings: JogSettings,
    pub jogger: Jogger<u8>,
    pub link: LinkState,
    pub machine: MachineState,
    pub seen: Vec<Event>,
}

impl WireRig {
    /// The default profile's isel simulator and the device task, polling
    /// at `rate`; the keypad in `kind` with the profile's mode.
    pub fn start(rate: PollRate, kind: JogKind) -> WireRig {
        let profile = profile();
        let mut settings = IselSettings::from_profile(&profile).expect("settings");
        settings.poll.rate = rate;
        // A loaded test machine: a late thread must not declare the link dead.
        settings.timing.reply_margin = Duration::from_millis(400);
        let sim = IselSim::from_profile(&profile).expect("simulator");
        let probe = Arc::new(Mutex::new(Probe {
            sim,
            arrivals: Vec::new(),
        }));
        let (shell, stream) =
            serve_socket(Box::new(Recorder(probe.clone()))).expect("serve the simulator");
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
        let jog = JogSettings::from_profile(&profile);
        let mut jogger = Jogger::new(jog.clone());
        let now = Instant::now();
        let _ = jogger.set_kind(kind, now);
        WireRig {
            _shell: shell,
            handle,
            events,
            probe,
            settings: jog,
            jogger,
            link: LinkState::Connecting,
            machine: MachineState::default(),
            seen: Vec::new(),
        }
    }

    fn take(&mut self, e: Event) {
        match &e {
            Event::Link(l) => self.link = l.clone(),
            Event::State(s) => self.machine = s.clone(),
            Event::JogEnded { id, end } => self.jogger.ended(*id, end, Instant::now()),
            _ => {}
        }
        self.seen.push(e);
    }

    /// Take the events that are there, without waiting.
    pub fn pump(&mut self) {
        while let Ok(e) = self.events.try_recv() {
            self.take(e);
        }
    }

    /// Wait for an event matching `pred`.
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
                    self.take(e.clone());
                    if pred(&e) {
                        return e;
                    }
                }
                Ok(None) => panic!("the device task ended while waiting for {what}"),
                Err(_) => panic!(
                    "no {what} within {within:?}; seen: {:#?}",
                    self.seen.iter().rev().take(20).collect::<Vec<_>>()
                ),
            }
        }
    }

    /// Events for a while.
    pub async fn run_for(&mut self, d: Duration) {
        let deadline = tokio::time::Instant::now() + d;
        while let Ok(Some(e)) = tokio::time::timeout_at(deadline, self.events.recv()).await {
            self.take(e);
        }
    }

    /// Connected, initialised, referenced (`@0N7`: the simulator's reference
    /// without travel), and the state to say so.
    pub async fn ready(&mut self) {
        self.wait_for(
            "the read-back",
            Duration::from_secs(10),
            |e| matches!(e, Event::Notice(n) if n.starts_with("state read back")),
        )
        .await;
        self.request(Request::Initialise);
        self.request(Request::Raw {
            line: "@0N7".into(),
        });
        self.wait_for(
            "@0N7 answered",
            Duration::from_secs(10),
            |e| matches!(e, Event::Reply { command, .. } if command == "@0N7"),
        )
        .await;
        let deadline = Instant::now() + Duration::from_secs(10);
        while self.machine.referenced.is_empty() || self.machine.fault.is_some() {
            assert!(
                Instant::now() < deadline,
                "never referenced: {:?}",
                self.machine
            );
            self.run_for(Duration::from_millis(20)).await;
        }
    }

    pub fn request(&self, r: Request) {
        self.handle.request(r).expect("request taken");
    }

    /// A key event through the keypad logic; what it asks for goes to the
    /// device task at once. Returns the requests.
    pub fn key(
        &mut self,
        key: u8,
        vector: &[(Axis, Dir)],
        phase: KeyPhase,
        speed: f64,
    ) -> Vec<Request> {
        self.pump();
        let gate = Gate {
            link: &self.link,
            machine: &self.machine,
            axes: self.settings.axis_set(),
            allow_unreferenced: false,
        };
        let selection = Selection { step: 1.0, speed };
        let out = self.jogger.key(
            &gate,
            key,
            Vector::new(vector),
            phase,
            selection,
            Instant::now(),
        );
        for r in &out {
            self.request(r.clone());
        }
        out
    }

    /// Steps with `step` units per press.
    pub fn step_key(
        &mut self,
        key: u8,
        vector: &[(Axis, Dir)],
        step: f64,
        speed: f64,
    ) -> Vec<Request> {
        self.pump();
        let gate = Gate {
            link: &self.link,
            machine: &self.machine,
            axes: self.settings.axis_set(),
            allow_unreferenced: false,
        };
        let out = self.jogger.key(
            &gate,
            key,
            Vector::new(vector),
            KeyPhase::Press,
            Selection { step, speed },
            Instant::now(),
        );
        for r in &out {
            self.request(r.clone());
        }
        out
    }

    /// Bytes that reached the simulator at or after `t`.
    pub fn arrivals_since(&self, t: Instant) -> Vec<(Instant, u8)> {
        lock(&self.probe)
            .arrivals
            .iter()
            .filter(|(at, _)| *at >= t)
            .copied()
            .collect()
    }

    /// The simulated controller's step counters now.
    pub fn counters(&self) -> [f64; 4] {
        lock(&self.probe).sim.counters_at(Instant::now())
    }

    /// Steps per unit of `axis` (the profile's).
    pub fn steps_per_unit(&self, axis: Axis) -> f64 {
        self.settings
            .axis(axis)
            .map(|a| a.steps_per_unit)
            .unwrap_or(1.0)
    }

    /// The highest jog speed of the profile, units per second.
    pub fn top_speed(&self) -> f64 {
        self.settings.speeds.iter().copied().fold(0.0, f64::max)
    }
}

/// When the first move command (`@0A`, `@0M`, `@0a`) at or after `t` began
/// to arrive: its `@` (complete after one byte time).
pub fn first_move(arrivals: &[(Instant, u8)]) -> Option<Instant> {
    arrivals.windows(3).find_map(|w| match w {
        [(at, b'@'), (_, b'0'), (_, b'A' | b'a' | b'M' | b'm')] => Some(*at),
        _ => None,
    })
}

/// How many move commands (`@0A`, `@0M`, `@0a`, `@0m`) began to arrive.
pub fn moves(arrivals: &[(Instant, u8)]) -> usize {
    arrivals
        .windows(3)
        .filter(|w| matches!(w, [(_, b'@'), (_, b'0'), (_, b'A' | b'a' | b'M' | b'm')]))
        .count()
}

/// When the first break byte (253) at or after `t` arrived.
pub fn first_break(arrivals: &[(Instant, u8)]) -> Option<Instant> {
    arrivals
        .iter()
        .find(|(_, b)| *b == BREAK)
        .map(|(at, _)| *at)
}

/// `d` in milliseconds, for reports.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}
