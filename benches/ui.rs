//! What the UI costs over a slow link: bytes written to the terminal per
//! second while a moving axis is polled, and the time one frame takes to
//! render, at 80x24 and 200x60. Frames go through ratatui's
//! `CrosstermBackend` into a writer that only counts, so the figures are the
//! escape sequences and text an SSH session would carry.
//!
//! Run: `cargo bench --bench ui` (optimised) or
//! `cargo bench --bench ui --profile dev` (debug build, slower frames,
//! same bytes). Results and their reading: `docs/performance.md`, "UI".
//!
//! Hand-written, not on divan: its bar is a byte count over 20 s of a
//! modelled session (no timing at all), and its frame times are those of
//! the frames of that session, each after its own updates, not of one
//! closure repeated.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, load_profile, load_theme};
use jogterm::device::api::{
    Activity, Event, IoBit, IoGroup, IoSnapshot, LinkState, MachineState, PerAxis, PollStats,
    PositionSample, PositionSource,
};
use jogterm::proto::Protocol;
use jogterm::traffic::{Direction, Owner, TrafficRecord};
use jogterm::ui::keymap::Keymap;
use jogterm::ui::palette::Palette;
use jogterm::ui::{Model, Msg, Screen, Setup, update};
use ratatui::backend::CrosstermBackend;
use ratatui::layout::Rect;
use ratatui::{Terminal, TerminalOptions, Viewport};

/// A writer that keeps nothing but the count (shared, since the backend
/// owns the writer).
#[derive(Default, Clone)]
struct Counter {
    bytes: Arc<AtomicU64>,
}

impl Counter {
    fn get(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }
}

impl Write for Counter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.bytes.fetch_add(buf.len() as u64, Ordering::Relaxed);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

fn model(protocol: Protocol, t0: Instant) -> Model {
    let dirs = ConfigDirs::builtin_only();
    let profile = load_profile(protocol.name(), &dirs).expect("shipped profile");
    let theme = load_theme("dark", &dirs).expect("shipped theme");
    let mut m = Model::new(
        Setup::from_profile(&profile, None),
        Keymap::builtin().expect("built-in keys"),
        Palette::from(&theme),
        t0,
    );
    let axes: AxisSet = m.setup.axis_set();
    for e in [
        Event::Link(LinkState::Connected),
        Event::State(MachineState {
            link_up: true,
            initialised: axes,
            referenced: axes,
            activity: Activity::Jogging,
            ..MachineState::default()
        }),
    ] {
        update(&mut m, Msg::Device(e));
    }
    m
}

fn ports(at: Instant, k: u64) -> IoSnapshot {
    // A limit switch that flickers now and then, so highlights come and go.
    let bits = (0..8)
        .map(|i| IoBit {
            name: format!(
                "limit {}",
                ["X1", "X2", "Y1", "Y2", "Z1", "Z2", "A1", "A2"][i]
            ),
            value: i == 1 && k % 40 < 2,
            output: None,
            hazardous: false,
            wiring: None,
        })
        .collect();
    IoSnapshot {
        at,
        groups: vec![IoGroup {
            name: "in3".into(),
            raw: Some(0),
            bits,
            read: None,
        }],
    }
}

/// One poll cycle of traffic as each family's driver would send it.
fn poll_traffic(protocol: Protocol, steps: i64) -> Vec<TrafficRecord> {
    let (ask, answer): (Vec<u8>, Vec<u8>) = match protocol {
        Protocol::Isel => (
            b"@0P\r".to_vec(),
            format!("0{:06X}004E20FFFFFF", steps & 0xFF_FFFF).into_bytes(),
        ),
        Protocol::Emcu => (b"@LX\r".to_vec(), format!("@LX{steps}\r").into_bytes()),
        Protocol::Emp => (
            b"2C11000000000000\x1a".to_vec(),
            format!("2D110022{:08X}\x1a", steps & 0x1FF_FFFF).into_bytes(),
        ),
    };
    // Whole messages the driver owns as polls, as the device task reports
    // them: the console keeps them apart.
    let (sent, received) = (ask.len(), answer.len());
    vec![
        TrafficRecord::messages(Direction::Sent, ask, Owner::Poll, &[sent]),
        TrafficRecord::messages(Direction::Received, answer, Owner::Poll, &[received]),
    ]
}

struct Run {
    bytes_per_second: f64,
    mean_frame: Duration,
    worst_frame: Duration,
}

/// `seconds` of an axis jogging at 5 units/s with `updates` position
/// samples per second (each with its poll traffic, ports every 4th),
/// rendered after every update.
fn run(protocol: Protocol, (w, h): (u16, u16), updates: u32, seconds: u32) -> Run {
    let t0 = Instant::now();
    let mut m = model(protocol, t0);
    let spu = m
        .setup
        .axis(Axis::X)
        .map(|p| p.steps_per_unit)
        .unwrap_or(1.0);
    let counter = Counter::default();
    let mut terminal = Terminal::with_options(
        CrosstermBackend::new(counter.clone()),
        TerminalOptions {
            viewport: Viewport::Fixed(Rect::new(0, 0, w, h)),
        },
    )
    .expect("terminal");
    let draw = |terminal: &mut Terminal<CrosstermBackend<Counter>>, m: &Model| {
        let start = Instant::now();
        terminal
            .draw(|f| f.render_widget(Screen(m), f.area()))
            .expect("draw");
        start.elapsed()
    };
    // The first frame paints everything; the steady state is what counts.
    draw(&mut terminal, &m);
    let before = counter.get();
    let period = Duration::from_secs(1) / updates;
    let mut total = Duration::ZERO;
    let mut worst = Duration::ZERO;
    let frames = u64::from(updates * seconds);
    for k in 1..=frames {
        let at = t0 + period * k as u32;
        let steps = (5.0 * spu * at.duration_since(t0).as_secs_f64()) as i64;
        let source = if protocol == Protocol::Isel {
            PositionSource::Estimated
        } else {
            PositionSource::Measured
        };
        let mut events = vec![Event::Position(PositionSample {
            at,
            steps: PerAxis::new()
                .with(Axis::X, steps)
                .with(Axis::Y, 20_000)
                .with(Axis::Z, 0),
            source,
        })];
        events.extend(
            poll_traffic(protocol, steps)
                .into_iter()
                .map(Event::Traffic),
        );
        if k % 4 == 0 {
            events.push(Event::Io(ports(at, k)));
        }
        if k % u64::from(updates) == 0 {
            events.push(Event::Stats(PollStats {
                position_rate_hz: 79.0 + (k % 3) as f64,
                wire_limit_hz: 83.5,
            }));
        }
        for e in events {
            update(&mut m, Msg::Device(e));
        }
        update(&mut m, Msg::Tick(at));
        let took = draw(&mut terminal, &m);
        total += took;
        worst = worst.max(took);
    }
    let bytes = counter.get() - before;
    Run {
        bytes_per_second: bytes as f64 / f64::from(seconds),
        mean_frame: total / frames as u32,
        worst_frame: worst,
    }
}

fn main() {
    println!("jogterm UI: terminal bytes while jogging one axis, polls hidden (default)");
    println!(
        "{:<6} {:>7} {:>10} {:>10} {:>12} {:>12}",
        "family", "size", "updates/s", "bytes/s", "frame mean", "frame worst"
    );
    for protocol in Protocol::ALL {
        for size in [(80, 24), (200, 60)] {
            for updates in [10, 20] {
                let r = run(protocol, size, updates, 20);
                println!(
                    "{:<6} {:>7} {:>10} {:>10.0} {:>10.0}us {:>10.0}us",
                    protocol.name(),
                    format!("{}x{}", size.0, size.1),
                    updates,
                    r.bytes_per_second,
                    r.mean_frame.as_secs_f64() * 1e6,
                    r.worst_frame.as_secs_f64() * 1e6,
                );
            }
        }
    }
}
