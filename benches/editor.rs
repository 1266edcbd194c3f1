//! The program editor's performance targets (`docs/editor.md`,
//! "Performance"):
//!
//! - upload of a 1000-command isel program to the simulator with the wire
//!   modelled at 19200 baud, against the wire limit with the per-line
//!   handshake: Σ (line bytes + CR + 1 reply byte) × 10 bits / 19200;
//! - the editor's frames while typing into a 10 000-line program with live
//!   validation: the key's `update` plus a full render at 160x48 (the lint
//!   runs on its own thread; its time is shown for reference).
//!
//! Run: `cargo bench --bench editor` (optimised) or `cargo test --bench
//! editor` (debug build); `-- --quick` for a shorter run, `-- --frames` for
//! the frames alone (e.g. under a profiler).
//!
//! Hand-written, not on divan: the upload runs at the modelled wire speed
//! against the wire limit (real time), and the frame figures are
//! percentiles (p99) of single keystrokes whose model state moves on from
//! key to key; divan reports per-sample statistics of a repeated closure,
//! not the tail of a stream of distinct frames.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use jogterm::config::{ConfigDirs, Profile, load_profile, load_theme};
use jogterm::device::api::{Activity, Event, Request, UploadEvent};
use jogterm::device::isel::{IselDriver, IselSettings, PollRate};
use jogterm::device::{Connector, TaskOptions, spawn_with};
use jogterm::program::store::{Fingerprint, Loaded};
use jogterm::proto::Protocol;
use jogterm::sim::registry;
use jogterm::sim::shell::serve_socket;
use jogterm::traffic::Direction;
use jogterm::transport::PortSpec;
use jogterm::ui::editor::io::{EditorIo, EditorMsg};
use jogterm::ui::keymap::Keymap;
use jogterm::ui::palette::Palette;
use jogterm::ui::{Effect, Model, Msg, Screen, Setup, update};
use jogterm::wire::LineSettings;
use ratatui::Terminal;
use ratatui::backend::TestBackend;

fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("default profile")
}

/// `n` commands: relative moves back and forth (within the soft limits)
/// and the closing `9`.
fn program(n: usize) -> Vec<String> {
    let mut lines: Vec<String> = (0..n.saturating_sub(1))
        .map(|i| {
            let x = if i % 2 == 0 { 400 } else { -400 };
            format!("0{x},4000,0,4000,0,4000,0,4000")
        })
        .collect();
    lines.push("9".into());
    lines
}

/// Seconds the wire needs for `lines` with one reply byte each (and `@0i`).
fn wire_limit(lines: &[String], line: LineSettings) -> f64 {
    let bytes: usize = lines.iter().map(|l| l.len() + 1 + 1).sum::<usize>() + "@0i\r".len() + 1;
    bytes as f64 / line.bytes_per_second()
}

/// How an upload went: the time from `Started` to `Finished`, and the
/// median time jogterm took from a reply to the next line (from the device
/// task's traffic records).
struct Uploaded {
    took: Duration,
    /// From a reply to the next line, sorted.
    turnarounds: Vec<Duration>,
    /// From a line's first byte written to its reply read, less the wire
    /// time of both: the controller's side of the cycle (the simulator's
    /// thread and the reader's wake-up), sorted.
    answer_delays: Vec<Duration>,
}

/// Upload `lines` through the device task to the simulator.
async fn upload(lines: Vec<String>) -> Uploaded {
    let mut settings = IselSettings::from_profile(&profile()).expect("settings");
    settings.poll.rate = PollRate::Off;
    let device = registry::build(Protocol::Isel, &profile()).expect("simulator");
    let (shell, stream) = serve_socket(device).expect("serve");
    let spec = PortSpec::InProcess {
        stream,
        line: shell.line(),
        name: "isel simulator".into(),
    };
    let (handle, mut events) = spawn_with(
        Box::new(IselDriver::new(settings)),
        Connector::from(spec),
        TaskOptions::default(),
    )
    .expect("device task");
    handle.request(Request::Initialise).expect("initialise");
    loop {
        match events.recv().await {
            Some(Event::State(s)) if !s.initialised.is_empty() && s.activity == Activity::Idle => {
                break;
            }
            Some(_) => {}
            None => panic!("the device task ended"),
        }
    }
    handle
        .request(Request::Upload {
            lines,
            erase_first: true,
        })
        .expect("upload");
    let mut started = None;
    let mut last_reply: Option<std::time::SystemTime> = None;
    let mut turnarounds = Vec::new();
    let mut answer_delays = Vec::new();
    let mut line_start: Option<std::time::SystemTime> = None;
    let mut line_bytes = 0;
    let wire = LineSettings::new(19200);
    let took = loop {
        match events.recv().await {
            Some(Event::Traffic(record)) if started.is_some() => match record.direction {
                Direction::Received => {
                    last_reply = Some(record.at);
                    if let Some(start) = line_start.take() {
                        let on_wire = wire.transfer_time(line_bytes + record.bytes.len());
                        answer_delays.extend(
                            record
                                .at
                                .duration_since(start)
                                .ok()
                                .map(|d| d.saturating_sub(on_wire)),
                        );
                    }
                    line_bytes = 0;
                }
                Direction::Sent => {
                    if let Some(reply) = last_reply.take() {
                        turnarounds.extend(record.at.duration_since(reply).ok());
                    }
                    line_start.get_or_insert(record.at);
                    line_bytes += record.bytes.len();
                }
            },
            Some(Event::Upload(UploadEvent::Started { .. })) => started = Some(Instant::now()),
            Some(Event::Upload(UploadEvent::Finished { .. })) => {
                break started.map_or(Duration::ZERO, |s| s.elapsed());
            }
            Some(Event::Upload(
                other @ (UploadEvent::Failed { .. } | UploadEvent::Aborted { .. }),
            )) => {
                panic!("{other:?}")
            }
            Some(Event::Refused { reason, .. }) => panic!("refused: {reason}"),
            Some(_) => {}
            None => panic!("the device task ended"),
        }
    };
    handle.shutdown().await;
    shell.shutdown();
    turnarounds.sort();
    answer_delays.sort();
    Uploaded {
        took,
        turnarounds,
        answer_delays,
    }
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

/// A model with an `n`-line program open in the editor, linted.
fn editing(n: usize) -> Model {
    let dirs = ConfigDirs::builtin_only();
    let theme = load_theme("dark", &dirs).expect("theme");
    let t0 = Instant::now();
    let mut m = Model::new(
        Setup::from_profile(&profile(), None),
        Keymap::builtin().expect("built-in keys"),
        Palette::from(&theme),
        t0,
    );
    let text = program(n).join("\n");
    update(
        &mut m,
        Msg::Editor(EditorMsg::Open(PathBuf::from("/bench.isel"))),
    );
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::Loaded {
            path: "/bench.isel".into(),
            result: Ok(Some(Loaded {
                path: "/bench.isel".into(),
                fingerprint: Fingerprint::of(text.as_bytes()),
                text,
                lossy: false,
            })),
            recovery: None,
        }),
    );
    lint(&mut m, effects);
    let effects = update(&mut m, Msg::Tick(t0 + Duration::from_secs(5)));
    lint(&mut m, effects);
    m
}

/// Run the lint jobs among `effects` as the lint thread would; the time.
fn lint(m: &mut Model, effects: Vec<Effect>) -> Option<Duration> {
    let mut took = None;
    for e in effects {
        if let Effect::Editor(EditorIo::Lint(job)) = e {
            let t = Instant::now();
            let result = job.run();
            took = Some(t.elapsed());
            update(m, Msg::Editor(EditorMsg::Linted(Box::new(result))));
        }
    }
    took
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted.get(i).copied().unwrap_or_default()
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    let line = LineSettings::new(19200);

    let frames_only = std::env::args().any(|a| a == "--frames");
    let lines = program(1000);
    let limit = wire_limit(&lines, line);
    if !frames_only {
        upload_rate(&runtime, lines, limit);
    }
    frame_times(quick);
}

fn upload_rate(runtime: &tokio::runtime::Runtime, lines: Vec<String>, limit: f64) {
    let per_line = limit / 1000.0;
    let up = runtime.block_on(upload(lines));
    let share = 100.0 * limit / up.took.as_secs_f64();
    println!(
        "upload 1000 commands at 19200 baud: {:.2} s, wire limit {limit:.2} s: {share:.1} % \
         (target >= 95 %) {}",
        up.took.as_secs_f64(),
        if share >= 95.0 { "ok" } else { "MISSED" }
    );
    let own = percentile(&up.turnarounds, 0.5).as_secs_f64();
    println!(
        "  jogterm's turnaround (reply to next line), median {:.3} ms: {:.1} % of the wire \
         limit if it were the only overhead; the rest is the simulator's and the scheduler's",
        own * 1e3,
        100.0 * per_line / (per_line + own)
    );
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let mean = |v: &[Duration]| ms(v.iter().sum::<Duration>()) / v.len().max(1) as f64;
    for (what, v) in [
        ("turnaround (jogterm)", &up.turnarounds),
        (
            "answer beyond the wire (line written -> reply read)",
            &up.answer_delays,
        ),
    ] {
        println!(
            "  {what}: mean {:.3} ms, p50 {:.3}, p90 {:.3}, p99 {:.3}, max {:.3} ms",
            mean(v),
            ms(percentile(v, 0.5)),
            ms(percentile(v, 0.9)),
            ms(percentile(v, 0.99)),
            ms(v.last().copied().unwrap_or_default())
        );
    }
}

fn frame_times(quick: bool) {
    let mut m = editing(10_000);
    let mut terminal = Terminal::new(TestBackend::new(160, 48)).expect("terminal");
    let keys = if quick { 100 } else { 400 };
    let mut frames = Vec::with_capacity(keys);
    let mut lints = Vec::new();
    // Type in the middle of the program: a comment line, key by key.
    for _ in 0..5000 {
        update(&mut m, key(KeyCode::Down));
    }
    let t0 = m.now;
    let mut updates = Vec::with_capacity(keys);
    for i in 0..keys {
        let t = Instant::now();
        let c = if i % 40 == 39 {
            KeyCode::Enter
        } else {
            KeyCode::Char(';')
        };
        update(&mut m, key(c));
        updates.push(t.elapsed());
        terminal
            .draw(|f| f.render_widget(Screen(&m), f.area()))
            .expect("draw");
        frames.push(t.elapsed());
        // Every tenth key the quiet time has passed: the lint runs (on its
        // own thread in the console; here, outside the frame's time).
        if i % 10 == 9 {
            let effects = update(&mut m, Msg::Tick(t0 + Duration::from_secs(10 + i as u64)));
            lints.extend(lint(&mut m, effects));
        }
    }
    frames.sort();
    updates.sort();
    lints.sort();
    // The same frame without the toolpath preview (F9 to off).
    let mut bare = Vec::new();
    for _ in 0..3 {
        update(&mut m, key(KeyCode::F(9)));
    }
    for _ in 0..keys.min(100) {
        let t = Instant::now();
        update(&mut m, key(KeyCode::Char(';')));
        terminal
            .draw(|f| f.render_widget(Screen(&m), f.area()))
            .expect("draw");
        bare.push(t.elapsed());
    }
    bare.sort();
    let worst = frames.last().copied().unwrap_or_default();
    println!(
        "typing into 10 000 lines at 160x48: frame (update + render) median {:.2} ms, \
         p99 {:.2} ms, worst {:.2} ms (target < 16 ms) {}",
        percentile(&frames, 0.5).as_secs_f64() * 1e3,
        percentile(&frames, 0.99).as_secs_f64() * 1e3,
        worst.as_secs_f64() * 1e3,
        if worst < Duration::from_millis(16) {
            "ok"
        } else {
            "MISSED"
        }
    );
    println!(
        "  of which update median {:.2} ms, worst {:.2} ms; without the preview: frame median \
         {:.2} ms, worst {:.2} ms",
        percentile(&updates, 0.5).as_secs_f64() * 1e3,
        updates.last().copied().unwrap_or_default().as_secs_f64() * 1e3,
        percentile(&bare, 0.5).as_secs_f64() * 1e3,
        bare.last().copied().unwrap_or_default().as_secs_f64() * 1e3,
    );
    println!(
        "lint + toolpath of 10 000 lines (lint thread): median {:.1} ms, worst {:.1} ms",
        percentile(&lints, 0.5).as_secs_f64() * 1e3,
        lints.last().copied().unwrap_or_default().as_secs_f64() * 1e3,
    );
}
