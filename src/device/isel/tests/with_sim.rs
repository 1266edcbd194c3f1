//! The driver against the isel simulator model in memory: no I/O, synthetic
//! time, both directions of the wire modelled at 19200 baud. What the driver
//! believes is compared with what the simulated controller holds.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{
    Dir, Event, JogEnd, JogId, PerAxis, PositionSource, ProgramState, Recovery, Request,
    UploadEvent,
};
use crate::device::driver::Driver;
use crate::device::isel::{IselDriver, IselSettings, PollRate};
use crate::sim::isel::IselSim;
use crate::sim::{InputControl, SimDevice};
use crate::wire::LineSettings;

use super::harness::{ms, speeds};

/// Driver and simulator joined by a modelled wire.
struct Bench {
    driver: IselDriver,
    sim: IselSim,
    now: Instant,
    byte: Duration,
    /// Bytes on their way to the controller: when each has arrived.
    to_sim: VecDeque<(Instant, u8)>,
    /// When the writer reports a message written (its last byte starts).
    written_at: VecDeque<Instant>,
    to_driver: VecDeque<(Instant, u8)>,
    events: Vec<Event>,
}

impl Bench {
    fn new(rate: PollRate) -> Bench {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        let mut settings = IselSettings::from_profile(&profile).expect("settings");
        settings.poll.rate = rate;
        let sim = IselSim::from_profile(&profile).expect("simulator");
        let now = Instant::now();
        let mut bench = Bench {
            driver: IselDriver::new(settings),
            sim,
            now,
            byte: LineSettings::new(19200).byte_time(),
            to_sim: VecDeque::new(),
            written_at: VecDeque::new(),
            to_driver: VecDeque::new(),
            events: Vec::new(),
        };
        bench.sim.advance(now);
        bench.driver.connected(now);
        bench
    }

    fn wire_free(queue: &VecDeque<(Instant, u8)>, now: Instant) -> Instant {
        queue.back().map_or(now, |(t, _)| (*t).max(now))
    }

    /// Hand whatever the driver and the controller want to send to the wire.
    fn pump(&mut self) {
        while let Some(out) = self.driver.poll_transmit(self.now) {
            let mut at = Bench::wire_free(&self.to_sim, self.now);
            for b in out.bytes {
                at += self.byte;
                self.to_sim.push_back((at, b));
            }
            self.written_at.push_back(at - self.byte);
        }
        while let Some(msg) = self.sim.poll_output() {
            let mut at = Bench::wire_free(&self.to_driver, self.now);
            for b in msg {
                at += self.byte;
                self.to_driver.push_back((at, b));
            }
        }
        while let Some(e) = self.driver.poll_event() {
            self.events.push(e);
        }
    }

    /// The stop lane: the stop bytes go right after the byte on the wire.
    fn stop(&mut self) {
        let out = self.driver.stop(self.now);
        let started = self
            .to_sim
            .iter()
            .take_while(|(t, _)| *t - self.byte <= self.now)
            .count();
        let rest: Vec<u8> = self.to_sim.drain(started..).map(|(_, b)| b).collect();
        let mut at = Bench::wire_free(&self.to_sim, self.now);
        for b in out.bytes.into_iter().chain(rest) {
            at += self.byte;
            self.to_sim.push_back((at, b));
        }
        self.pump();
    }

    fn request(&mut self, r: Request) {
        self.driver.request(r, self.now);
        self.pump();
    }

    fn control(&mut self, name: &str, level: bool) {
        let control = InputControl::Set {
            name: name.into(),
            level,
        };
        self.sim.control(&control, self.now).expect("input");
        self.pump();
    }

    /// Run the wire, the controller and the driver until `d` has passed.
    fn run(&mut self, d: Duration) {
        let end = self.now + d;
        loop {
            self.pump();
            let next = [
                self.to_sim.front().map(|(t, _)| *t),
                self.to_driver.front().map(|(t, _)| *t),
                self.written_at.front().copied(),
                self.sim.next_deadline(),
                self.driver.next_timeout(),
            ]
            .into_iter()
            .flatten()
            .min();
            let Some(t) = next.filter(|t| *t <= end) else {
                break;
            };
            self.now = self.now.max(t);
            while self.to_sim.front().is_some_and(|(t, _)| *t <= self.now) {
                if let Some((t, b)) = self.to_sim.pop_front() {
                    self.sim.on_byte(b, t);
                }
            }
            while self.written_at.front().is_some_and(|t| *t <= self.now) {
                self.written_at.pop_front();
                self.driver.transmitted(self.now);
            }
            self.sim.advance(self.now);
            while self.to_driver.front().is_some_and(|(t, _)| *t <= self.now) {
                if let Some((t, b)) = self.to_driver.pop_front() {
                    self.driver.received(&[b], t);
                }
            }
            if self.driver.next_timeout().is_some_and(|t| t <= self.now) {
                self.driver.handle_timeout(self.now);
            }
        }
        self.now = end;
        self.sim.advance(end);
        self.pump();
    }

    fn counters(&self) -> [f64; 4] {
        self.sim.counters_at(self.now)
    }

    fn last_measured(&self) -> Option<PerAxis<i64>> {
        self.events.iter().rev().find_map(|e| match e {
            Event::Position(p) if p.source == PositionSource::Measured => Some(p.steps),
            _ => None,
        })
    }

    /// Initialise and reference a fresh controller.
    fn homed(rate: PollRate) -> Bench {
        let mut b = Bench::new(rate);
        b.run(ms(500));
        b.request(Request::Initialise);
        b.run(ms(500));
        b.request(Request::Home { axes: AxisSet::XYZ });
        b.run(Duration::from_secs(120));
        assert_eq!(b.driver.state().referenced, AxisSet::XYZ, "{:?}", b.events);
        b.events.clear();
        b
    }
}

#[test]
fn a_fresh_controller_reads_back_uninitialised_and_its_positions() {
    let mut b = Bench::new(PollRate::Off);
    b.run(ms(500));
    let s = b.driver.state().clone();
    assert!(s.link_up);
    assert_eq!(s.initialised, AxisSet::EMPTY);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    // The simulator reports its counters even without axes.
    let p = b.last_measured().expect("position");
    assert_eq!(p.get(Axis::X), Some(b.counters()[0] as i64));
    assert!(b.sim.physical_positions(b.now)[0] > 15_000.0);
}

#[test]
fn initialise_and_home_reference_the_axes_at_zero() {
    let mut b = Bench::homed(PollRate::Off);
    b.run(ms(100));
    assert_eq!(b.counters()[..3], [0.0, 0.0, 0.0]);
    let s = b.driver.state();
    assert_eq!(s.initialised, AxisSet::XYZ);
    assert!(s.fault.is_none());
}

#[test]
fn the_estimate_follows_the_controllers_counters() {
    let mut b = Bench::homed(PollRate::Off);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 20_000).with(Axis::Y, 8_000),
        speed_hz: speeds(8_000.0),
    });
    for _ in 0..30 {
        b.run(ms(40));
        let estimate = b.events.iter().rev().find_map(|e| match e {
            Event::Position(p) if p.source == PositionSource::Estimated => Some(*p),
            _ => None,
        });
        if let Some(p) = estimate {
            let real = b.sim.counters_at(p.at);
            let dx = (p.steps.get(Axis::X).unwrap_or(0) as f64 - real[0]).abs();
            let dy = (p.steps.get(Axis::Y).unwrap_or(0) as f64 - real[1]).abs();
            // The estimate starts when the command's last byte goes out, the
            // controller when its CR has arrived: one byte time at most.
            assert!(
                dx <= 8.0 && dy <= 4.0,
                "estimate {p:?} vs counters {real:?}"
            );
        }
    }
    b.run(Duration::from_secs(2));
    assert_eq!(
        b.last_measured(),
        Some(
            PerAxis::new()
                .with(Axis::X, 20_000)
                .with(Axis::Y, 8_000)
                .with(Axis::Z, 0)
        )
    );
}

#[test]
fn a_jog_left_without_renewal_stops_and_cannot_be_resumed() {
    let mut b = Bench::homed(PollRate::LineSpeed);
    b.request(Request::Jog {
        id: JogId(1),
        axes: vec![(Axis::Y, Dir::Plus)],
        speed_hz: speeds(4_000.0),
        lease: ms(300),
    });
    b.run(ms(600));
    let ended = b.events.iter().find_map(|e| match e {
        Event::JogEnded { id, end } => Some((*id, end.clone())),
        _ => None,
    });
    assert_eq!(ended, Some((JogId(1), JogEnd::DeadMan)));
    let stopped = b.counters()[1];
    assert!(stopped > 500.0 && stopped < 1_500.0, "{stopped}");
    assert_eq!(
        b.last_measured().and_then(|p| p.get(Axis::Y)),
        Some(stopped as i64)
    );
    // The break discarded the rest: a start finds nothing to resume.
    b.request(Request::Raw { line: "@0S".into() });
    b.run(ms(200));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Fault(f) if f.code == "G"))
    );
    assert_eq!(b.counters()[1], stopped);
}

#[test]
fn stop_during_polling_ends_a_move_and_the_position_is_read() {
    let mut b = Bench::homed(PollRate::LineSpeed);
    b.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 100_000),
        frame: crate::device::api::Frame::Machine,
        speed_hz: speeds(10_000.0),
    });
    b.run(ms(700));
    b.stop();
    b.run(ms(300));
    let x = b.counters()[0];
    assert!(x > 1_000.0 && x < 100_000.0, "{x}");
    assert_eq!(
        b.last_measured().and_then(|p| p.get(Axis::X)),
        Some(x as i64)
    );
    assert!(b.driver.state().fault.is_none());
}

#[test]
fn a_limit_switch_during_a_move_answers_2_and_costs_init_and_reference() {
    let mut b = Bench::homed(PollRate::Off);
    b.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 40_000),
        speed_hz: speeds(4_000.0),
    });
    b.run(ms(500));
    b.control("limit-x2", true);
    b.run(ms(200));
    let s = b.driver.state().clone();
    assert_eq!(s.fault.as_ref().map(|f| f.code.as_str()), Some("2"));
    assert_eq!(s.initialised, AxisSet::EMPTY);
    b.control("limit-x2", false);
    b.events.clear();
    b.request(Request::Initialise);
    b.run(ms(500));
    assert_eq!(
        b.driver.state().fault.as_ref().map(|f| f.recovery),
        Some(Recovery::Reference)
    );
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(Duration::from_secs(120));
    assert!(b.driver.state().fault.is_none());
}

#[test]
fn a_program_is_stored_and_run() {
    let mut b = Bench::homed(PollRate::Off);
    b.request(Request::Upload {
        lines: vec![
            "0400,1000,0,1000,0,1000,0,1000".into(),
            "133".into(),
            "0-400,1000,0,1000,0,1000,0,1000".into(),
        ],
        erase_first: true,
    });
    b.run(Duration::from_secs(5));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Upload(UploadEvent::Finished { total: 3, .. }))),
        "{:?}",
        b.events
    );
    assert_eq!(b.driver.state().program, ProgramState::Stored);
    b.request(Request::RunProgram);
    b.run(Duration::from_secs(3));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Notice(n) if n == "program sync character `!`"))
    );
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Notice(n) if n == "the program has ended"))
    );
    assert_eq!(b.last_measured().and_then(|p| p.get(Axis::X)), Some(0));
}

#[test]
fn a_stopped_upload_leaves_an_invalid_program() {
    let mut b = Bench::homed(PollRate::Off);
    let lines: Vec<String> = (0..200).map(|i| format!("1{}", 33 + i % 60)).collect();
    b.request(Request::Upload {
        lines,
        erase_first: true,
    });
    b.run(ms(300));
    b.stop();
    b.run(ms(300));
    let aborted = b.events.iter().find_map(|e| match e {
        Event::Upload(UploadEvent::Aborted { done, .. }) => Some(*done),
        _ => None,
    });
    assert!(aborted.is_some_and(|d| d > 0 && d < 200), "{:?}", b.events);
    assert_eq!(b.driver.state().program, ProgramState::Invalid);
    let stored = b.sim.flash().program.clone().expect("a partial program");
    assert!(!stored.valid, "never a valid-looking partial program");
    // Back in DNC mode: a poll is answered.
    b.request(Request::Raw { line: "@0P".into() });
    b.run(ms(100));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Reply { command, .. } if command == "@0P"))
    );
}

#[test]
fn polling_at_line_speed_reaches_the_wire_limit() {
    let mut b = Bench::homed(PollRate::LineSpeed);
    b.run(Duration::from_secs(3));
    let stats: Vec<_> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Stats(s) => Some(*s),
            _ => None,
        })
        .collect();
    let last = stats.last().expect("stats");
    // @0P and ports 1, 3, 2 every 4th cycle: 23 + 24 / 4 = 29 bytes a cycle.
    assert!(
        last.position_rate_hz > 0.97 * last.wire_limit_hz,
        "{last:?}"
    );
}
