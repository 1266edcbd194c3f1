//! The machine the SMC3000 drives: per axis the interface's step counter and
//! the carriage it is meant to follow, the end stops and the reference switch,
//! and the one linearly interpolated motion that may be under way.
//!
//! The counter counts every step the interface puts out. The carriage follows
//! it until it runs into an end stop; there it stays while the counter counts
//! on (step loss), so the two differ until the next reference run. Positions
//! are computed from the motion when asked, so nothing needs to tick.

use std::time::{Duration, Instant};

use crate::motion::{Motion, Ramp};
use crate::proto::emcu::EmcuAxis;

use super::config::{EmcuSimConfig, EndStops};

/// Machine position of every reference switch. The switch is actuated at this
/// position and below it, where the carriage comes from when it searches the
/// switch in the negative direction (manual 1.5.8).
pub(super) const REFERENCE_SWITCH: i64 = 0;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct AxisState {
    /// 32 bits that wrap, like the interface's own counter.
    counter: i32,
    /// Machine position of the carriage, in steps.
    physical: i64,
    end_stops: Option<EndStops>,
}

impl AxisState {
    fn clamp(&self, position: i64) -> i64 {
        self.end_stops.map_or(position, |s| s.clamp(position))
    }

    /// The state after `travelled` more steps: the counter takes them all,
    /// the carriage only as far as the end stops let it. One motion moves an
    /// axis in one direction only, so clamping the end point is exact.
    fn after(&self, travelled: i64) -> AxisState {
        AxisState {
            counter: wrap(i64::from(self.counter).saturating_add(travelled)),
            physical: self.clamp(self.physical.saturating_add(travelled)),
            end_stops: self.end_stops,
        }
    }
}

/// The low 32 bits, as a 32-bit step counter wraps.
fn wrap(value: i64) -> i32 {
    value as i32
}

/// One interpolated motion of one to three axes: the axis with the longest
/// way leads along `motion`, the others follow in proportion (manual 1.5.10).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    started: Instant,
    motion: Motion,
    /// Steps of the leading axis; never 0.
    lead: u64,
    /// Signed steps of each axis.
    delta: [i64; 3],
}

impl Segment {
    fn elapsed(&self, at: Instant) -> Duration {
        at.saturating_duration_since(self.started)
    }

    fn end(&self) -> Instant {
        self.started + self.motion.end_time()
    }

    /// Whole steps each axis has made by `at`, signed.
    fn travelled(&self, at: Instant) -> [i64; 3] {
        let t = self.elapsed(at);
        if self.motion.is_done(t) && !self.motion.is_cut_short() {
            return self.delta;
        }
        let lead = self.motion.position_at(t);
        self.delta.map(|d| {
            let share = lead * d.unsigned_abs() as f64 / self.lead as f64;
            // A step counts once it is made; the epsilon keeps 99.999999 from
            // being one step short of 100 after the division.
            let steps = ((share + 1e-9).floor() as i64).clamp(0, d.saturating_abs());
            steps * d.signum()
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct Mechanics {
    axes: [AxisState; 3],
    segment: Option<Segment>,
}

impl Mechanics {
    /// Power-up: counters 0, carriages where the machine was left.
    pub fn new(config: &EmcuSimConfig) -> Mechanics {
        Mechanics {
            axes: config.axes.map(|a| AxisState {
                counter: 0,
                physical: a.start_position(),
                end_stops: a.end_stops,
            }),
            segment: None,
        }
    }

    fn state(&self, axis: EmcuAxis, at: Instant) -> Option<AxisState> {
        let index = axis.index();
        let base = self.axes.get(index).copied()?;
        Some(match &self.segment {
            Some(seg) => base.after(seg.travelled(at).get(index).copied().unwrap_or(0)),
            None => base,
        })
    }

    /// The interface's counter at `at`, as `@L` reports it.
    pub fn counter(&self, axis: EmcuAxis, at: Instant) -> i32 {
        self.state(axis, at).map_or(0, |s| s.counter)
    }

    /// The carriage's machine position at `at`.
    pub fn physical(&self, axis: EmcuAxis, at: Instant) -> i64 {
        self.state(axis, at).map_or(0, |s| s.physical)
    }

    pub fn counters(&self, at: Instant) -> [i32; 3] {
        EmcuAxis::ALL.map(|a| self.counter(a, at))
    }

    /// A motion is under way (also while it ramps down).
    pub fn is_moving(&self) -> bool {
        self.segment.is_some()
    }

    /// When the motion under way comes to rest.
    pub fn segment_end(&self) -> Option<Instant> {
        self.segment.as_ref().map(Segment::end)
    }

    /// Starts moving every axis by its `delta` steps from `at`, the longest
    /// way along `ramp`. False when there is nothing to move.
    pub fn start(&mut self, delta: [i64; 3], ramp: Ramp, at: Instant) -> bool {
        self.settle(at);
        let lead = delta.iter().map(|d| d.unsigned_abs()).max().unwrap_or(0);
        if lead == 0 {
            return false;
        }
        self.segment = Some(Segment {
            started: at,
            motion: Motion::new(lead, ramp),
            lead,
            delta,
        });
        true
    }

    /// Starts moving one axis by `steps` (signed).
    pub fn start_single(&mut self, axis: EmcuAxis, steps: i64, ramp: Ramp, at: Instant) -> bool {
        let mut delta = [0; 3];
        if let Some(cell) = delta.get_mut(axis.index()) {
            *cell = steps;
        }
        self.start(delta, ramp, at)
    }

    /// Ramp down from `at` (manual 1.5.11, 1.5.13); no effect once a stop is
    /// under way.
    pub fn brake(&mut self, at: Instant) {
        if let Some(seg) = &mut self.segment {
            let t = seg.elapsed(at);
            seg.motion.brake(t);
        }
    }

    /// Stop without a ramp at `at` (manual 1.5.1, 1.5.12).
    pub fn halt(&mut self, at: Instant) {
        if let Some(seg) = &mut self.segment {
            let t = seg.elapsed(at);
            seg.motion.halt(t);
        }
        self.settle(at);
    }

    /// Books the motion up to `at` into the axes and forgets it.
    pub fn settle(&mut self, at: Instant) {
        if let Some(seg) = self.segment.take() {
            let travelled = seg.travelled(at);
            for (axis, steps) in self.axes.iter_mut().zip(travelled) {
                *axis = axis.after(steps);
            }
        }
    }

    /// Only at rest (`settle` first).
    pub fn set_counter(&mut self, axis: EmcuAxis, value: i32) {
        if let Some(a) = self.axes.get_mut(axis.index()) {
            a.counter = value;
        }
    }

    /// Every counter 0 (manual 1.5.1); only at rest.
    pub fn zero_counters(&mut self) {
        for a in &mut self.axes {
            a.counter = 0;
        }
    }

    /// Whether the reference switch of the axis is actuated (at rest).
    pub fn on_reference_switch(&self, axis: EmcuAxis) -> bool {
        self.axes
            .get(axis.index())
            .is_some_and(|a| a.physical <= REFERENCE_SWITCH)
    }

    /// Steps from the carriage (at rest) down to the reference switch, or
    /// `None` when the low end stop keeps it from ever getting there.
    pub fn steps_down_to_switch(&self, axis: EmcuAxis) -> Option<i64> {
        let a = self.axes.get(axis.index())?;
        let reachable = a.end_stops.is_none_or(|s| s.low <= REFERENCE_SWITCH);
        reachable.then(|| a.physical.saturating_sub(REFERENCE_SWITCH).max(0))
    }

    /// Steps up from the carriage (at rest) until the switch releases.
    pub fn steps_off_switch(&self, axis: EmcuAxis) -> i64 {
        self.axes.get(axis.index()).map_or(0, |a| {
            (REFERENCE_SWITCH + 1).saturating_sub(a.physical).max(0)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::emcu::config::AxisTravel;

    fn ramp() -> Ramp {
        Ramp {
            start_hz: 200.0,
            max_hz: 600.0,
            accel_hz_per_s: 800.0,
        }
    }

    fn machine(low: i64, high: i64, start: i64) -> Mechanics {
        let axis = AxisTravel {
            end_stops: Some(EndStops::new(low, high)),
            start,
        };
        Mechanics::new(&EmcuSimConfig { axes: [axis; 3] })
    }

    #[test]
    fn the_followers_move_in_proportion_and_all_arrive_together() {
        let t0 = Instant::now();
        let mut m = machine(-1_000_000, 1_000_000, 0);
        assert!(m.start([1000, -500, 0], ramp(), t0));
        let end = m.segment_end().unwrap();
        let mid = t0 + (end - t0) / 2;
        let x = m.counter(EmcuAxis::X, mid);
        let y = m.counter(EmcuAxis::Y, mid);
        assert!((x / 2 + y).abs() <= 1, "x {x} y {y}");
        assert_eq!(m.counters(end), [1000, -500, 0]);
        m.settle(end);
        assert!(!m.is_moving());
        assert_eq!(m.counters(end), [1000, -500, 0]);
    }

    #[test]
    fn an_end_stop_holds_the_carriage_while_the_counter_counts_on() {
        let t0 = Instant::now();
        let mut m = machine(-100, 100, 50);
        assert!(m.start_single(EmcuAxis::X, 300, ramp(), t0));
        let end = m.segment_end().unwrap();
        assert_eq!(m.counter(EmcuAxis::X, end), 300);
        assert_eq!(m.physical(EmcuAxis::X, end), 100);
        m.settle(end);
        assert!(m.start_single(EmcuAxis::X, -300, ramp(), end));
        let back = m.segment_end().unwrap();
        assert_eq!(m.counter(EmcuAxis::X, back), 0);
        assert_eq!(m.physical(EmcuAxis::X, back), -100);
    }

    #[test]
    fn the_switch_is_out_of_reach_behind_a_high_low_end_stop() {
        let m = machine(10, 100, 50);
        assert_eq!(m.steps_down_to_switch(EmcuAxis::X), None);
        let m = machine(-10, 100, 50);
        assert_eq!(m.steps_down_to_switch(EmcuAxis::X), Some(50));
        assert_eq!(m.steps_off_switch(EmcuAxis::X), 0);
        let m = machine(-10, 100, -7);
        assert!(m.on_reference_switch(EmcuAxis::X));
        assert_eq!(m.steps_off_switch(EmcuAxis::X), 8);
    }

    #[test]
    fn counters_wrap_at_32_bits() {
        let t0 = Instant::now();
        let mut m = machine(-10, 10, 0);
        m.set_counter(EmcuAxis::Z, i32::MAX);
        assert!(m.start_single(EmcuAxis::Z, 2, ramp(), t0));
        let end = m.segment_end().unwrap();
        assert_eq!(m.counter(EmcuAxis::Z, end), i32::MIN + 1);
    }
}
