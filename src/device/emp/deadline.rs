//! How long an EMP long action may stay busy before the driver stops it.
//! Positioning (`2A 01`, and `2A 00` in TPWM) and homing (`26`) answer `55`
//! at once and `22` on their own when done (`docs/decisions.md` EMP
//! decision 1); a drive that never sends the `22` would hold the line's
//! operation for ever. A positioning gets the time of its travel at its
//! speed (`common::deadline::motion`), a reference run the reference
//! deadline over the axis' soft-limit travel (`common::deadline::reference`),
//! the planned ones and the ones typed as raw frames alike.
//!
//! A raw frame's speed byte is counts per sample (manual "Berechnung der
//! Abtastrate"); the sample rate is the drive's reload value as jogterm last
//! saw it set, or the slowest there is (`FFFF`) when it has not seen one. A
//! raw positioning's travel is from the drive's last read position, or, when
//! none was read, the farthest the target lies from either soft limit
//! (docs/protocols.md EMP).

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{ControllerFault, Event, Recovery};
use crate::device::common::{Sink, deadline};
use crate::proto::emp::reload::TIMER_HZ;
use crate::proto::emp::{Command, DriveAddress, Position, Request};

use super::context::Context;
use super::script::frame_text;

/// The slowest sample rate: one sample every 65535 timer ticks.
const SLOWEST_RATE_HZ: f64 = TIMER_HZ as f64 / 65535.0;

/// The farthest a position counter can travel (25 bits, decision 3): the
/// bound for a drive jogterm knows no soft limits of.
const COUNTER_SPAN: i64 = 1 << 25;

/// No deadline is longer (about 115 days): keeps `Instant` arithmetic far
/// from overflow whatever a raw frame asks.
const LONGEST: Duration = Duration::from_secs(10_000_000);

fn seconds(secs: f64) -> Duration {
    if secs.is_finite() && secs > 0.0 {
        Duration::try_from_secs_f64(secs).map_or(LONGEST, |d| d.min(LONGEST))
    } else {
        Duration::ZERO
    }
}

/// A positioning whose longest leg takes `secs`: the margins of
/// `common::deadline::motion` and a round trip for each of the three frames
/// a leg may need (mode, sample rate, move).
pub fn positioning(cx: &Context, secs: f64, legs: usize) -> Duration {
    let frames = u32::try_from(legs.saturating_mul(3)).unwrap_or(u32::MAX);
    deadline::motion(seconds(secs))
        .saturating_add(cx.settings.timing.round_trip.saturating_mul(frames))
        .min(LONGEST)
}

/// Counts per second of speed byte `v` at the drive's sample rate.
fn speed_hz(cx: &Context, ds: DriveAddress, v: u8) -> f64 {
    let rate = cx
        .drive(ds)
        .and_then(|d| d.reload)
        .map_or(SLOWEST_RATE_HZ, |r| r.frequency_hz());
    f64::from(v.max(1)) * rate
}

fn axis_span(cx: &Context, ds: DriveAddress) -> i64 {
    cx.settings
        .axis_of(ds)
        .and_then(|a| cx.settings.limits.get(a))
        .map_or(COUNTER_SPAN, |l| l.span())
}

/// The travel of a raw positioning to `target`.
fn travel(cx: &Context, ds: DriveAddress, target: Position) -> u64 {
    let target = i64::from(target.increments());
    if let Some(here) = cx.drive(ds).and_then(|d| d.position) {
        return target.abs_diff(here);
    }
    match cx
        .settings
        .axis_of(ds)
        .and_then(|a| cx.settings.limits.get(a))
    {
        Some(l) => target
            .abs_diff(l.min)
            .max(target.abs_diff(l.max))
            .max(l.span().unsigned_abs()),
        None => COUNTER_SPAN.unsigned_abs(),
    }
}

/// What kind of long action a request may start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LongKind {
    Positioning,
    Homing,
}

/// The deadline of a raw frame that may start a long action, and which
/// kind; `None` for every other frame. `2A 00` positions only in TPWM
/// (docs/protocols.md EMP); elsewhere it answers `22` at once and the
/// deadline never matters.
pub fn raw(cx: &Context, request: &Request) -> Option<(LongKind, Duration)> {
    let ds = request.ds;
    match request.command {
        Command::MoveTo { vmax, target } => {
            let secs = travel(cx, ds, target) as f64 / speed_hz(cx, ds, vmax.value());
            Some((LongKind::Positioning, positioning(cx, secs, 1)))
        }
        Command::Drive { velocity, target } => {
            let v = u8::try_from(i16::from(velocity.value()).unsigned_abs()).unwrap_or(u8::MAX);
            let secs = travel(cx, ds, target) as f64 / speed_hz(cx, ds, v);
            Some((LongKind::Positioning, positioning(cx, secs, 1)))
        }
        Command::Home { fast, slow } => {
            let hz = speed_hz(cx, ds, fast.value().min(slow.value()));
            let timeout = deadline::reference([axis_span(cx, ds)], hz).min(LONGEST);
            Some((LongKind::Homing, timeout))
        }
        _ => None,
    }
}

/// Why a long action was given up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GivenUp {
    /// Still busy when its deadline passed.
    Deadline(Duration),
    /// Homing: the position stood still for this many reads while busy.
    Stalled { reads: u32 },
}

/// A long action of `request` was given up and its drive is being stopped
/// (the stop frame goes out ahead of everything, `EmpDriver::transmit`):
/// the fault names the drive, the frame and what to do. What the drive did
/// is unknown, so the axis counts as unreferenced and the fault blocks all
/// motion until the operator initialises (i) and references (h) again
/// (`Init` and `common::gate`), as for a move of jogterm's own.
pub fn give_up(
    cx: &mut Context,
    request: &Request,
    kind: LongKind,
    why: GivenUp,
) -> ControllerFault {
    let ds = request.ds;
    let axis = cx.settings.axis_of(ds);
    let drive = match axis {
        Some(a) => format!("drive {ds} ({a})"),
        None => format!("drive {ds}"),
    };
    let stop = match cx.stop_request(ds).command {
        Command::FastStop => "2A 03",
        _ => "08",
    };
    let meaning = match (kind, why) {
        (LongKind::Homing, GivenUp::Stalled { reads }) => format!(
            "homing stalled: {drive} stayed busy (55) while its position stood still for \
             {reads} reads; stopped with {stop}. Check the axis for a blockage and the drive \
             for an error"
        ),
        (LongKind::Homing, GivenUp::Deadline(d)) => format!(
            "{drive} stayed busy (55) and did not reach the reference point (22) within {} s; \
             stopped with {stop}. Check the reference switch and the axis",
            d.as_secs()
        ),
        (LongKind::Positioning, GivenUp::Deadline(d)) => format!(
            "{drive} stayed busy (55) and did not report in position (22) within {} ms; \
             stopped with {stop}. Check the axis for a blockage and the drive for an error",
            d.as_millis()
        ),
        (LongKind::Positioning, GivenUp::Stalled { reads }) => format!(
            "{drive} stayed busy (55) while its position stood still for {reads} reads; \
             stopped with {stop}"
        ),
    };
    let fault = ControllerFault {
        command: frame_text(request),
        code: "55".into(),
        meaning,
        recovery: Recovery::ReinitialiseAndReference,
    };
    unreference(cx, axis);
    cx.state.fault = Some(fault.clone());
    cx.emit(Event::Fault(fault.clone()));
    fault
}

fn unreference(cx: &mut Context, axis: Option<Axis>) {
    if let Some(a) = axis {
        cx.unreference(a);
    }
    cx.refresh();
}

/// When a deadline armed at `now` for `timeout` passes.
pub fn due(now: Instant, timeout: Duration) -> Instant {
    now.checked_add(timeout).unwrap_or(now + LONGEST)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::emp::EmpSettings;
    use crate::proto::emp::{ReloadValue, Speed, Velocity};

    fn cx() -> Context {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("emp profile");
        Context::new(EmpSettings::from_profile(&profile).expect("emp settings"))
    }

    fn move_to(v: u8, target: i64) -> Request {
        Request::new(
            DriveAddress::SINGLE,
            Command::MoveTo {
                vmax: Speed::new(v).expect("speed"),
                target: Position::new(target).expect("target"),
            },
        )
    }

    #[test]
    fn a_raw_positioning_gets_the_deadline_of_its_travel_at_its_speed() {
        let mut cx = cx();
        if let Some(d) = cx.drive_mut(DriveAddress::SINGLE) {
            d.position = Some(100_000);
            d.reload = Some(ReloadValue::new(0x30D4).expect("reload"));
        }
        // 100 counts per ms = 100 000 counts/s over 200 000 counts: 2 s.
        let (kind, t) = raw(&cx, &move_to(100, 300_000)).expect("long");
        assert_eq!(kind, LongKind::Positioning);
        assert_eq!(t, positioning(&cx, 2.0, 1));
        // `2A 00` with a negative velocity in TPWM: the same.
        let drive = Request::new(
            DriveAddress::SINGLE,
            Command::Drive {
                velocity: Velocity::new(-100),
                target: Position::new(-100_000).expect("target"),
            },
        );
        assert_eq!(raw(&cx, &drive).map(|r| r.1), Some(t));
    }

    #[test]
    fn without_position_or_sample_rate_the_bound_is_conservative() {
        let cx = cx();
        // Unknown position: the farthest from either soft limit (0..5.6 M);
        // unknown rate: the slowest, FFFF.
        let (_, t) = raw(&cx, &move_to(1, 0)).expect("long");
        let secs = 5_600_000.0 / SLOWEST_RATE_HZ;
        assert_eq!(t, positioning(&cx, secs, 1));
        assert!(t > Duration::from_secs(29_000), "{t:?}");
    }

    #[test]
    fn homing_gets_the_reference_deadline_and_other_frames_none() {
        let mut cx = cx();
        if let Some(d) = cx.drive_mut(DriveAddress::SINGLE) {
            d.reload = Some(ReloadValue::new(0x30D4).expect("reload"));
        }
        let s = |v| Speed::new(v).expect("speed");
        let home = Request::new(
            DriveAddress::SINGLE,
            Command::Home {
                fast: s(20),
                slow: s(4),
            },
        );
        let (kind, t) = raw(&cx, &home).expect("long");
        assert_eq!(kind, LongKind::Homing);
        assert_eq!(t, deadline::reference([5_600_000], 4000.0));
        let read = Request::new(DriveAddress::SINGLE, Command::ReadPosition);
        assert_eq!(raw(&cx, &read), None);
    }

    #[test]
    fn absurd_inputs_stay_bounded() {
        assert_eq!(seconds(f64::NAN), Duration::ZERO);
        assert_eq!(seconds(-1.0), Duration::ZERO);
        assert_eq!(seconds(1e300), LONGEST);
        let now = Instant::now();
        assert!(due(now, Duration::MAX) > now);
    }
}
