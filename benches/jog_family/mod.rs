//! The per-family rows of `benches/jog.rs`: the device task in front of
//! the family's simulator behind a socket pair (the shell models the wire
//! both ways), jog requests as the keypad sends them, and the overrun read
//! from the simulated axis: a tap (press, no repeat, no release: travel
//! from the press) and a hold (first repeat after 500 ms, then 30 Hz for
//! 1 s: travel from the last repeat), at the axis's top speed. During the
//! hold a sampler thread reads the simulated axis every millisecond: the
//! longest time it stood still between its first movement and the last
//! repeat is the standstill of the speed-up at the first repeat.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::device::api::{Activity, Dir, Event, JogEnd, JogId, MachineState, PerAxis, Request};
use jogterm::device::{
    Connector, DeviceHandle, EventReceiver, TaskOptions, driver_for, spawn_with,
};
use jogterm::motion::standstill::standstill;
use jogterm::proto::emcu::EmcuAxis;
use jogterm::proto::emp::DriveAddress;
use jogterm::sim::SimDevice;
use jogterm::sim::emcu::EmcuSim;
use jogterm::sim::emp::EmpSim;
use jogterm::sim::isel::IselSim;
use jogterm::sim::shell::{Shell, serve_socket};
use jogterm::transport::PortSpec;

use crate::jog_support::{Probe, Recorder, Shared, lock};

/// The X counter of a family's simulator.
pub trait XCounter: SimDevice + Send + 'static {
    fn x(&mut self, now: Instant) -> f64;
}

impl XCounter for IselSim {
    fn x(&mut self, now: Instant) -> f64 {
        self.counters_at(now)[0]
    }
}

impl XCounter for EmcuSim {
    fn x(&mut self, now: Instant) -> f64 {
        f64::from(self.counter(EmcuAxis::X, now))
    }
}

impl XCounter for EmpSim {
    fn x(&mut self, now: Instant) -> f64 {
        self.snapshot(DriveAddress::SINGLE, now)
            .map_or(f64::NAN, |s| f64::from(s.counter.increments()))
    }
}

pub struct FamilyRig<S: XCounter> {
    pub name: &'static str,
    _shell: Shell,
    handle: DeviceHandle,
    events: EventReceiver,
    probe: Shared<S>,
    machine: MachineState,
    pub spu: f64,
    pub bound_mm: f64,
    pub top_hz: f64,
    pub grace: Duration,
    pub repeat: Duration,
    axes: AxisSet,
    next_id: u64,
}

/// The shipped profile `name`, the simulated axis starting next to its
/// reference switch (a short reference run).
pub fn profile(name: &str) -> Profile {
    let mut p = load_profile(name, &ConfigDirs::builtin_only()).expect("profile");
    p.sim.start_position = 0.5;
    p
}

impl<S: XCounter> FamilyRig<S> {
    pub fn start(name: &'static str, profile: &Profile, sim: S) -> FamilyRig<S> {
        let probe = Arc::new(Mutex::new(Probe {
            sim,
            arrivals: Vec::new(),
        }));
        let (shell, stream) =
            serve_socket(Box::new(Recorder(probe.clone()))).expect("serve the simulator");
        let spec = PortSpec::InProcess {
            stream,
            line: shell.line(),
            name: format!("{name} simulator"),
        };
        let driver = driver_for(profile, None).expect("driver");
        let (handle, events) =
            spawn_with(driver, Connector::from(spec), TaskOptions::default()).expect("task");
        let x = profile.axes.get(&Axis::X).expect("X");
        FamilyRig {
            name,
            _shell: shell,
            handle,
            events,
            probe,
            machine: MachineState::default(),
            spu: x.steps_per_unit,
            bound_mm: profile.jog.max_overrun,
            top_hz: x.max_speed * x.steps_per_unit,
            grace: Duration::from_millis(profile.jog.first_repeat_grace_ms),
            repeat: Duration::from_millis(profile.jog.repeat_timeout_ms),
            axes: profile.axes.keys().copied().collect(),
            next_id: 100,
        }
    }

    fn x(&self) -> f64 {
        lock(&self.probe).sim.x(Instant::now())
    }

    fn request(&self, r: Request) {
        self.handle.request(r).expect("request taken");
    }

    /// Events until `done` holds for the machine state (at most `within`).
    async fn until(&mut self, within: Duration, done: impl Fn(&MachineState) -> bool) {
        let deadline = tokio::time::Instant::now() + within;
        self.drain();
        while !done(&self.machine) {
            match tokio::time::timeout_at(deadline, self.events.recv()).await {
                Ok(Some(Event::State(s))) => self.machine = s,
                Ok(Some(_)) => {}
                Ok(None) => panic!("{}: the device task ended", self.name),
                Err(_) => panic!("{}: not reached: {:?}", self.name, self.machine),
            }
        }
    }

    /// Connected, initialised, referenced, X parked at 20 mm.
    pub async fn ready(&mut self) {
        self.until(Duration::from_secs(10), |m| m.link_up).await;
        self.request(Request::Initialise);
        self.until(Duration::from_secs(10), |m| m.initialised.contains(Axis::X))
            .await;
        // Every axis: the EMCU's one "position unknown" flag covers them all.
        self.request(Request::Home { axes: self.axes });
        let axes = self.axes;
        tokio::time::sleep(Duration::from_millis(200)).await;
        self.until(Duration::from_secs(60), |m| {
            m.referenced == axes && m.activity == Activity::Idle
        })
        .await;
        self.request(Request::MoveTo {
            target: PerAxis::new().with(Axis::X, (20.0 * self.spu).round() as i64),
            frame: jogterm::device::api::Frame::Machine,
            speed_hz: PerAxis::new().with(Axis::X, self.top_hz),
        });
        tokio::time::sleep(Duration::from_millis(200)).await;
        self.until(Duration::from_secs(30), |m| m.activity == Activity::Idle)
            .await;
    }

    fn jog(&mut self, dir: Dir) -> JogId {
        self.next_id += 1;
        let id = JogId(self.next_id);
        self.request(Request::Jog {
            id,
            axes: vec![(Axis::X, dir)],
            speed_hz: PerAxis::new().with(Axis::X, self.top_hz),
            lease: self.grace,
        });
        id
    }

    /// Jog `id` has ended (a refusal or fault is no measurement: it
    /// panics) and the axis stands.
    async fn settled(&mut self, id: JogId) {
        let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
        loop {
            match tokio::time::timeout_at(deadline, self.events.recv()).await {
                Ok(Some(Event::State(s))) => self.machine = s,
                Ok(Some(Event::JogEnded { id: ended, end })) if ended == id => {
                    assert!(
                        matches!(end, JogEnd::DeadMan),
                        "{}: the jog ended {end:?}",
                        self.name
                    );
                    break;
                }
                Ok(Some(_)) => {}
                Ok(None) => panic!("{}: the device task ended", self.name),
                Err(_) => panic!("{}: the jog never ended: {:?}", self.name, self.machine),
            }
        }
        self.until(Duration::from_secs(10), |m| m.activity == Activity::Idle)
            .await;
        // The servo's brake or the `#R` ramp: at rest well within this.
        tokio::time::sleep(Duration::from_millis(600)).await;
        self.drain();
    }

    /// The events there are, without waiting.
    fn drain(&mut self) {
        while let Ok(e) = self.events.try_recv() {
            if let Event::State(s) = e {
                self.machine = s;
            }
        }
    }

    /// Travel (mm) after a tap: from the press to rest.
    pub async fn tap(&mut self, dir: Dir) -> f64 {
        let from = self.x();
        let id = self.jog(dir);
        self.settled(id).await;
        (self.x() - from).abs() / self.spu
    }

    /// Travel (mm) after the last repeat of a hold, and the longest time
    /// the axis stood still between its first movement and the last repeat.
    pub async fn hold(&mut self, dir: Dir) -> (f64, Duration) {
        let sampler = Sampler::start(self.probe.clone());
        let start = Instant::now();
        let id = self.jog(dir);
        let mut next = start + Duration::from_millis(500);
        let mut last = self.x();
        while next < start + Duration::from_millis(1500) {
            tokio::time::sleep_until(tokio::time::Instant::from_std(next)).await;
            self.request(Request::JogRenew {
                id,
                lease: self.repeat,
            });
            last = self.x();
            next += Duration::from_millis(33);
        }
        let trace = sampler.finish();
        self.settled(id).await;
        ((self.x() - last).abs() / self.spu, standstill(&trace))
    }

    pub async fn shutdown(self) {
        self.handle.shutdown().await;
    }
}

/// Reads the simulated axis every millisecond on a thread of its own, so
/// a late wake-up of the async side cannot hide a standstill.
struct Sampler {
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<Vec<(Instant, f64)>>,
}

impl Sampler {
    fn start<S: XCounter>(probe: Shared<S>) -> Sampler {
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut trace = Vec::new();
            while !flag.load(std::sync::atomic::Ordering::Relaxed) {
                let mut p = lock(&probe);
                let now = Instant::now();
                let x = p.sim.x(now);
                drop(p);
                trace.push((now, x));
                std::thread::sleep(Duration::from_millis(1));
            }
            trace
        });
        Sampler { stop, thread }
    }

    fn finish(self) -> Vec<(Instant, f64)> {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.thread.join().expect("sampler")
    }
}

/// isel, EMCU and EMP: the simulator for the shipped profile.
pub fn isel() -> FamilyRig<IselSim> {
    let p = profile("default");
    let sim = IselSim::from_profile(&p).expect("isel simulator");
    FamilyRig::start("isel", &p, sim)
}

pub fn emcu() -> FamilyRig<EmcuSim> {
    let p = profile("emcu");
    let sim = EmcuSim::from_profile(&p).expect("EMCU simulator");
    FamilyRig::start("EMCU", &p, sim)
}

pub fn emp() -> FamilyRig<EmpSim> {
    let p = profile("emp");
    let sim = EmpSim::from_profile(&p).expect("EMP simulator");
    FamilyRig::start("EMP", &p, sim)
}
