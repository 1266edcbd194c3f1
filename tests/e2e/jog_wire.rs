//! Jogging measured on the wire: the keypad logic and the device task
//! against the isel simulator over a socket pair, with the time each byte
//! reached the simulator (the shell's modelled arrivals at 19200 baud).
//! The bounds here are generous so a loaded 2-core machine does not make
//! them flake; `cargo bench --bench jog` prints the exact figures, and the
//! tests print what they measured.

use crate::jog_support;

use std::time::{Duration, Instant};

use jog_support::{WireRig, first_break, first_move, ms};
use jogterm::axis::Axis;
use jogterm::device::api::{Dir, Event, JogEnd, Request};
use jogterm::device::isel::PollRate;
use jogterm::jog::{JogKind, KeyPhase};

// Timing tests one at a time: they share two cores.
use crate::timing::SERIAL;

/// CI bound on press → first motion byte, and on release / late repeat →
/// stop byte beyond the dead-man timeout (the requirement is 5 ms; the
/// bench measures it).
const SLACK: Duration = Duration::from_millis(60);

const X_PLUS: &[(Axis, Dir)] = &[(Axis::X, Dir::Plus)];
const KEY: u8 = 1;

async fn sleep_until(t: Instant) {
    tokio::time::sleep_until(tokio::time::Instant::from_std(t)).await;
}

/// Hold a key without release events: a press, the terminal's first repeat
/// after `first`, then repeats every `every` for `hold`. Returns when the
/// last repeat went out.
async fn hold(
    rig: &mut WireRig,
    first: Duration,
    every: Duration,
    hold: Duration,
    speed: f64,
) -> Instant {
    let start = Instant::now();
    let out = rig.key(KEY, X_PLUS, KeyPhase::Press, speed);
    assert!(matches!(out.as_slice(), [Request::Jog { .. }]), "{out:?}");
    let mut next = start + first;
    let mut last = start;
    while next < start + first + hold {
        sleep_until(next).await;
        last = Instant::now();
        let out = rig.key(KEY, X_PLUS, KeyPhase::Press, speed);
        assert!(
            matches!(out.as_slice(), [Request::JogRenew { .. }]),
            "repeat at {:?}: {out:?}",
            last - start
        );
        next += every;
    }
    last
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_held_key_moves_at_once_and_stops_within_the_timeout_after_the_last_repeat() {
    let _serial = SERIAL.lock().await;
    let mut rig = WireRig::start(PollRate::Off, JogKind::Continuous);
    rig.ready().await;
    let speed = rig.top_speed();
    let spu = rig.steps_per_unit(Axis::X);
    let timeout = rig.settings.repeat_timeout;
    let x0 = rig.counters()[0];

    let pressed = Instant::now();
    // The first repeat comes after the terminal's delay (500 ms), then 30 Hz.
    let last = hold(
        &mut rig,
        Duration::from_millis(500),
        Duration::from_millis(33),
        Duration::from_secs(1),
        speed,
    )
    .await;
    let x_last = rig.counters()[0];
    rig.wait_for("the jog's end", Duration::from_secs(10), |e| {
        matches!(e, Event::JogEnded { .. })
    })
    .await;
    rig.run_for(Duration::from_millis(300)).await;
    let x_end = rig.counters()[0];

    let arrivals = rig.arrivals_since(pressed);
    let moved = first_move(&arrivals).expect("a move command reached the controller");
    let press_latency = moved.saturating_duration_since(pressed);
    let stop_at = first_break(&rig.arrivals_since(last)).expect("the stop reached the controller");
    let after_last = stop_at.saturating_duration_since(last);
    let overrun = (x_end - x_last) / spu;
    println!(
        "press -> move: {:.2} ms; last repeat -> break: {:.2} ms (timeout {} ms); \
         travel after the last repeat {overrun:.3} mm (bound {} mm); moved {:.1} mm",
        ms(press_latency),
        ms(after_last),
        timeout.as_millis(),
        rig.settings.axes[0].max_overrun_steps / spu,
        (x_end - x0) / spu,
    );
    assert!(press_latency < SLACK, "{press_latency:?}");
    assert!(
        after_last >= timeout.saturating_sub(Duration::from_millis(5)),
        "{after_last:?}"
    );
    assert!(after_last < timeout + SLACK, "{after_last:?}");
    // It kept moving through the first repeat's delay: no stop, no stutter.
    let ends: Vec<&JogEnd> = rig
        .seen
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { end, .. } => Some(end),
            _ => None,
        })
        .collect();
    assert_eq!(ends, [&JogEnd::DeadMan]);
    assert!(
        (x_last - x0) / spu > 0.5 * speed.min(5.0),
        "{x0} -> {x_last}"
    );
    // The bound, plus what the CI slack on the stop's latency allows at the
    // speed asked for (a late wake-up on a loaded host; the bench has the
    // exact figures).
    let bound = rig.settings.axes[0].max_overrun_steps / spu + speed * SLACK.as_secs_f64();
    assert!(overrun <= bound, "{overrun} mm past the last repeat");

    // The break discarded the rest of the move: a start resumes nothing.
    rig.request(Request::Raw { line: "@0S".into() });
    rig.run_for(Duration::from_millis(500)).await;
    assert_eq!(rig.counters()[0], x_end);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_key_releases_the_release_stops_at_once() {
    let _serial = SERIAL.lock().await;
    let mut rig = WireRig::start(PollRate::Off, JogKind::Continuous);
    rig.jogger.set_releases(true);
    rig.ready().await;
    let speed = rig.top_speed();
    let out = rig.key(KEY, X_PLUS, KeyPhase::Press, speed);
    assert!(matches!(out.as_slice(), [Request::Jog { .. }]), "{out:?}");
    tokio::time::sleep(Duration::from_millis(300)).await;
    let released = Instant::now();
    let out = rig.key(KEY, X_PLUS, KeyPhase::Release, speed);
    assert!(
        matches!(out.as_slice(), [Request::JogRelease { .. }]),
        "{out:?}"
    );
    let end = rig
        .wait_for("the jog's end", Duration::from_secs(10), |e| {
            matches!(e, Event::JogEnded { .. })
        })
        .await;
    assert!(
        matches!(
            end,
            Event::JogEnded {
                end: JogEnd::Released,
                ..
            }
        ),
        "{end:?}"
    );
    let stop_at = first_break(&rig.arrivals_since(released)).expect("the stop reached the wire");
    let latency = stop_at.saturating_duration_since(released);
    println!("release -> break: {:.2} ms", ms(latency));
    assert!(latency < SLACK, "{latency:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn holding_a_step_key_leaves_no_queue_behind() {
    let _serial = SERIAL.lock().await;
    let mut rig = WireRig::start(PollRate::Off, JogKind::Step);
    rig.ready().await;
    let spu = rig.steps_per_unit(Axis::X);
    // 1 mm steps at 2 mm/s: each takes about half a second, so a 30 Hz
    // repeat presses 15 times per step.
    let (step, speed) = (1.0, 2.0);
    let start = Instant::now();
    let mut next = start;
    let mut presses = 0;
    while next < start + Duration::from_secs(3) {
        sleep_until(next).await;
        let out = rig.step_key(KEY, X_PLUS, step, speed);
        assert!(matches!(out.as_slice(), [Request::Step { .. }]), "{out:?}");
        presses += 1;
        next += Duration::from_millis(33);
    }
    let released = Instant::now();
    let x_release = rig.counters()[0];
    rig.run_for(Duration::from_secs(3)).await;
    let x_end = rig.counters()[0];
    let past = (x_end - x_release) / spu;
    // The coalescing bound: the move running at the release (one step, or
    // up to `step_queue` presses coalesced into one) and at most
    // `step_queue` presses remembered behind it (`docs/jogging.md`).
    let bound = 2.0 * rig.settings.step_queue as f64 * step;
    let dropped = rig
        .seen
        .iter()
        .filter(|e| matches!(e, Event::Refused { .. }))
        .count();
    println!(
        "{presses} presses in 3 s: {:.2} mm travelled, {past:.3} mm after the release \
         (bound {bound} mm), {dropped} presses dropped, settled {:?} after the release",
        (x_end) / spu,
        released.elapsed()
    );
    assert!(past <= bound + 1e-6, "{past} mm after the release");
    assert!(
        dropped > presses / 2,
        "most presses dropped, not queued: {dropped}"
    );
}

/// Ten step presses that reach the device task together (a burst the
/// console did not catch, or fast taps), with polling at line speed, so a
/// poll is usually being answered when they arrive: at most
/// `1 + step_queue` steps move, the rest are refused (issue 13: all ten
/// waited in the request queue and ran, 10 mm for ten 1 mm presses).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ten_presses_at_once_move_at_most_one_plus_the_step_queue() {
    let _serial = SERIAL.lock().await;
    for rate in [PollRate::LineSpeed, PollRate::Off] {
        let mut rig = WireRig::start(rate, JogKind::Step);
        rig.ready().await;
        rig.run_for(Duration::from_millis(200)).await;
        let spu = rig.steps_per_unit(Axis::X);
        let x0 = rig.counters()[0];
        let start = Instant::now();
        for _ in 0..10 {
            let out = rig.step_key(KEY, X_PLUS, 1.0, 10.0);
            assert!(matches!(out.as_slice(), [Request::Step { .. }]), "{out:?}");
        }
        rig.run_for(Duration::from_secs(3)).await;
        let moved = (rig.counters()[0] - x0) / spu;
        let moves = rig
            .arrivals_since(start)
            .iter()
            .filter(|(_, b)| matches!(b, b'A' | b'a'))
            .count();
        let bound = (1 + rig.settings.step_queue) as f64;
        println!("{rate:?}: {moved:.3} mm in {moves} moves (bound {bound} mm)");
        assert!(moved <= bound + 1e-6, "{rate:?}: {moved} mm");
        assert!(
            moved >= 1.0 - 1e-6,
            "{rate:?}: the first press moved {moved} mm"
        );
    }
}
