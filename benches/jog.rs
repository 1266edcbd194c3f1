//! Jog latencies and overrun against the isel simulator, measured where the
//! bytes arrive (the simulator shell's modelled arrival times at 19200 baud):
//!
//! - key press → first byte of the move command, with polling off and at
//!   line speed (isel answers one command at a time: a poll in flight
//!   delays the move until it has answered);
//! - key release (kitty keyboard protocol) → break byte;
//! - last key repeat → break byte, beyond the dead-man timeout;
//! - travel after the last repeat at the profile's top jog speed, against
//!   `jog.max_overrun`;
//! - travel after letting go of a step key held for 3 s at 30 Hz;
//! - per family (isel, EMCU and EMP, their simulators, `jog_family`): travel
//!   after a tap (press, no repeat, no release) and after the last repeat of
//!   a hold, at the axis's top speed, against `jog.max_overrun`; and the
//!   time the axis stands still at the hold's first repeat, where the jog
//!   speeds up from the first lease's cap to the repeats' (< 100 ms).
//!
//! `cargo bench --bench jog` (or `cargo test --bench jog` in a debug build)
//! prints a table; `docs/jogging.md` has the figures.
//!
//! Hand-written, not on divan: jog latencies and overrun are measured on
//! the wire of a simulator running in real time (percentiles of single key
//! presses, millimetres travelled), not a function timed in a loop.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

// The jog wire tests' rig; the bench uses part of it.
#[allow(dead_code)]
#[path = "../tests/e2e/jog_support.rs"]
mod jog_support;

mod jog_family;

use std::time::{Duration, Instant};

use jog_support::{WireRig, first_break, first_move, ms};
use jogterm::axis::Axis;
use jogterm::device::api::{Dir, Request};
use jogterm::device::isel::PollRate;
use jogterm::jog::{JogKind, KeyPhase};

const TRIALS: usize = 20;
const KEY: u8 = 1;

fn vector(i: usize) -> &'static [(Axis, Dir)] {
    // Back and forth, so the axis stays between its soft limits.
    if i.is_multiple_of(2) {
        &[(Axis::X, Dir::Plus)]
    } else {
        &[(Axis::X, Dir::Minus)]
    }
}

async fn sleep_until(t: Instant) {
    tokio::time::sleep_until(tokio::time::Instant::from_std(t)).await;
}

/// Move X to `units` (machine coordinates), so jogs both ways stay
/// inside the soft limits; returns once the controller is there.
async fn park_x(rig: &mut WireRig, units: f64) {
    let spu = rig.steps_per_unit(Axis::X);
    let target = (units * spu).round() as i64;
    rig.request(Request::MoveTo {
        target: jogterm::device::api::PerAxis::new().with(Axis::X, target),
        frame: jogterm::device::api::Frame::Machine,
        speed_hz: rig.settings.speeds_hz(&[(Axis::X, Dir::Plus)], 50.0),
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    while (rig.counters()[0] - target as f64).abs() > 0.5
        || rig.machine.activity != jogterm::device::api::Activity::Idle
    {
        assert!(
            Instant::now() < deadline,
            "never parked: {:?}",
            rig.counters()
        );
        rig.run_for(Duration::from_millis(20)).await;
    }
}

/// Wait until the keypad's jog has ended and the axis stands.
async fn settle(rig: &mut WireRig) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while rig.jogger.active().is_some()
        || rig.machine.activity != jogterm::device::api::Activity::Idle
    {
        assert!(
            Instant::now() < deadline,
            "the jog never ended: {:?}",
            rig.machine
        );
        rig.run_for(Duration::from_millis(10)).await;
    }
    rig.run_for(Duration::from_millis(100)).await;
}

/// The `p`th percentile (0..=100) of `values` (sorted here).
fn percentile(values: &mut [f64], p: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let i = ((p / 100.0) * (values.len() - 1) as f64).round() as usize;
    values[i.min(values.len() - 1)]
}

struct Row {
    what: String,
    unit: &'static str,
    values: Vec<f64>,
    limit: String,
}

impl Row {
    fn print(mut self) {
        let n = self.values.len();
        let p50 = percentile(&mut self.values, 50.0);
        let p99 = percentile(&mut self.values, 99.0);
        let max = percentile(&mut self.values, 100.0);
        println!(
            "{:<46} {:>4} {:>9.2} {:>9.2} {:>9.2} {:<4} {}",
            self.what, n, p50, p99, max, self.unit, self.limit
        );
    }
}

/// Press and release with release events: press → move, release → break.
async fn release_trials(rate: PollRate, what: &'static str) -> (Row, Option<Row>) {
    let mut rig = WireRig::start(rate, JogKind::Continuous);
    rig.jogger.set_releases(true);
    rig.ready().await;
    park_x(&mut rig, 100.0).await;
    let speed = rig.top_speed();
    let mut press = Vec::new();
    let mut release = Vec::new();
    for i in 0..TRIALS {
        let v = vector(i);
        let pressed = Instant::now();
        let out = rig.key(KEY, v, KeyPhase::Press, speed);
        assert!(
            matches!(out.as_slice(), [Request::Jog { .. }]),
            "{out:?} {:?} {:?}",
            rig.jogger.last(),
            rig.machine
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
        let released = Instant::now();
        rig.key(KEY, v, KeyPhase::Release, speed);
        settle(&mut rig).await;
        if let Some(t) = first_move(&rig.arrivals_since(pressed)) {
            press.push(ms(t.saturating_duration_since(pressed)));
        }
        if let Some(t) = first_break(&rig.arrivals_since(released)) {
            release.push(ms(t.saturating_duration_since(released)));
        }
    }
    rig.handle.shutdown().await;
    let press = Row {
        what: what.into(),
        unit: "ms",
        values: press,
        limit: "< 5 ms at p99".into(),
    };
    let release = (rate == PollRate::Off).then(|| Row {
        what: "release -> break".into(),
        unit: "ms",
        values: release,
        limit: "< 5 ms".into(),
    });
    (press, release)
}

/// Held without release events (first repeat after 400 ms, then 30 Hz for
/// 300 ms) at the top speed: last repeat → break beyond the timeout, and
/// travel after the last repeat.
async fn dead_man_trials() -> (Row, Row, f64) {
    let mut rig = WireRig::start(PollRate::Off, JogKind::Continuous);
    rig.ready().await;
    park_x(&mut rig, 100.0).await;
    let speed = rig.top_speed();
    let spu = rig.steps_per_unit(Axis::X);
    let timeout = rig.settings.repeat_timeout;
    let bound = rig.settings.axes[0].max_overrun_steps / spu;
    let mut late = Vec::new();
    let mut overrun = Vec::new();
    for i in 0..TRIALS {
        let v = vector(i);
        let start = Instant::now();
        rig.key(KEY, v, KeyPhase::Press, speed);
        let mut next = start + Duration::from_millis(400);
        let mut last = start;
        while next < start + Duration::from_millis(700) {
            sleep_until(next).await;
            last = Instant::now();
            rig.key(KEY, v, KeyPhase::Press, speed);
            next += Duration::from_millis(33);
        }
        let x_last = rig.counters()[0];
        settle(&mut rig).await;
        let x_end = rig.counters()[0];
        if let Some(t) = first_break(&rig.arrivals_since(last)) {
            late.push(ms(t
                .saturating_duration_since(last)
                .saturating_sub(timeout)));
        }
        overrun.push((x_end - x_last).abs() / spu);
        // Let the key count as let go before the next trial.
        tokio::time::sleep(timeout * 2).await;
    }
    rig.handle.shutdown().await;
    (
        Row {
            what: "last repeat -> break, beyond the timeout".into(),
            unit: "ms",
            values: late,
            limit: format!("< 5 ms (timeout {} ms)", timeout.as_millis()),
        },
        Row {
            what: "travel after the last repeat, top speed".into(),
            unit: "mm",
            values: overrun,
            limit: format!("<= {bound} mm (jog.max_overrun)"),
        },
        speed,
    )
}

/// A step key held for 3 s at 30 Hz: travel after the release.
async fn step_hold() -> Row {
    let mut rig = WireRig::start(PollRate::Off, JogKind::Step);
    rig.ready().await;
    park_x(&mut rig, 100.0).await;
    let spu = rig.steps_per_unit(Axis::X);
    let (step, speed) = (1.0, 2.0);
    let mut past = Vec::new();
    for i in 0..3 {
        let v = vector(i);
        let start = Instant::now();
        let mut next = start;
        while next < start + Duration::from_secs(3) {
            sleep_until(next).await;
            rig.step_key(KEY, v, step, speed);
            next += Duration::from_millis(33);
        }
        let x_release = rig.counters()[0];
        rig.run_for(Duration::from_secs(3)).await;
        past.push((rig.counters()[0] - x_release).abs() / spu);
    }
    rig.handle.shutdown().await;
    let bound = 2.0 * rig.settings.step_queue as f64 * step;
    Row {
        what: "step key held 3 s at 30 Hz: travel after release".into(),
        unit: "mm",
        values: past,
        limit: format!(
            "<= {bound} mm (1 mm steps, step_queue {})",
            rig.settings.step_queue
        ),
    }
}

/// Tap, hold and first-repeat standstill rows of one family (5 trials
/// each, back and forth).
async fn family_rows<S: jog_family::XCounter>(mut rig: jog_family::FamilyRig<S>) -> [Row; 3] {
    rig.ready().await;
    let (mut tap, mut hold, mut still) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..5 {
        let dir = vector(i).first().map_or(Dir::Plus, |(_, d)| *d);
        tap.push(rig.tap(dir).await);
        let (travel, standstill) = rig.hold(dir).await;
        hold.push(travel);
        still.push(ms(standstill));
    }
    let limit = format!("<= {} mm (jog.max_overrun)", rig.bound_mm);
    let top = rig.top_hz / rig.spu;
    let name = rig.name;
    let what = |row: &str| format!("{name} {row}");
    let rows = [
        Row {
            what: what("tap at top speed: travel after the press"),
            unit: "mm",
            values: tap,
            limit: format!("{limit}, {top} mm/s asked"),
        },
        Row {
            what: what("hold: travel after the last repeat"),
            unit: "mm",
            values: hold,
            limit,
        },
        Row {
            what: what("hold: standstill at the first repeat"),
            unit: "ms",
            values: still,
            limit: "< 100 ms".into(),
        },
    ];
    rig.shutdown().await;
    rows
}

/// The per-family rows, isel first.
async fn all_family_rows() {
    for row in family_rows(jog_family::isel()).await {
        row.print();
    }
    for row in family_rows(jog_family::emcu()).await {
        row.print();
    }
    for row in family_rows(jog_family::emp()).await {
        row.print();
    }
}

fn main() {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("tokio runtime");
    runtime.block_on(async {
        println!(
            "{:<46} {:>4} {:>9} {:>9} {:>9}",
            "jog, isel simulator at 19200 baud", "n", "p50", "p99", "max"
        );
        if std::env::var_os("JOG_BENCH_FAMILIES_ONLY").is_some() {
            all_family_rows().await;
            return;
        }
        let (press_off, release) =
            release_trials(PollRate::Off, "press -> move (polling off)").await;
        press_off.print();
        if let Some(r) = release {
            r.print();
        }
        let (press_line, _) =
            release_trials(PollRate::LineSpeed, "press -> move (polling at line speed)").await;
        press_line.print();
        let (late, overrun, speed) = dead_man_trials().await;
        late.print();
        overrun.print();
        println!("  (top jog speed asked for: {speed} mm/s; the driver caps it)");
        step_hold().await.print();
        all_family_rows().await;
    });
}
