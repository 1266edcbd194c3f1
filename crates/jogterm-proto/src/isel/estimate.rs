//! Where the axes are while an isel move runs. The controller cannot be
//! asked during a move (it answers only when the move is done, manual 2.2.2
//! and 2.2.21), so the driver computes the position from what it commanded:
//! distances, speeds, the start-stop frequency and the acceleration it set
//! (`@0j`, `@0J`), with the same trapezoid the controller runs
//! ([`crate::motion`]).
//!
//! How the controller sequences the axes (manual 2.2.2, 2.2.29):
//! - 2.5D (the default): X and Y (and A with 4 axes) are interpolated
//!   linearly, the axis with the longest path at its own speed (X before Y
//!   on a tie) and the others scaled to it; then Z, first by z1 and then by
//!   z2 with 3 axes (`docs/protocols.md`, isel).
//! - 3D (`@0z1`): all axes together along the X/Y/Z vector at the speed given
//!   for X; a 4th axis follows in proportion.
//!
//! Each group is one [`Motion`]; a stop (0xFD/0xFF) brakes the group that is
//! running and drops the rest (the break discards the remainder).

use std::time::{Duration, Instant};

use crate::axis::{Axis, PerAxis};
use crate::isel::{AxisConfig, MovePair};
use crate::motion::{Motion, Ramp};

/// The ramp parameters the controller runs with (`@0j` Hz, `@0J` Hz/ms).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RampParams {
    pub start_stop_hz: u32,
    pub accel_hz_per_ms: u32,
}

impl RampParams {
    /// The controller's power-up values (manual 2.2.15, 2.2.16).
    pub const CONTROLLER_DEFAULT: RampParams = RampParams {
        start_stop_hz: 300,
        accel_hz_per_ms: 100,
    };

    pub fn ramp(self, max_hz: f64) -> Ramp {
        Ramp {
            start_hz: f64::from(self.start_stop_hz),
            max_hz,
            accel_hz_per_s: f64::from(self.accel_hz_per_ms) * 1000.0,
        }
    }
}

/// One group of axes that move together.
#[derive(Debug, Clone, PartialEq)]
struct Group {
    deltas: Vec<(Axis, i64)>,
    /// Steps of the leading axis (2.5D) or of the path (3D).
    length: f64,
    motion: Motion,
}

impl Group {
    fn new(deltas: Vec<(Axis, i64)>, length: f64, speed_hz: f64, ramp: RampParams) -> Group {
        let steps = length.round().max(0.0) as u64;
        Group {
            deltas,
            length,
            motion: Motion::new(steps, ramp.ramp(speed_hz.max(1.0))),
        }
    }

    /// Steps each axis has covered `t` after the group started.
    fn offsets_at(&self, t: Duration) -> impl Iterator<Item = (Axis, f64)> + '_ {
        let s = self.motion.position_at(t);
        let fraction = if self.length > 0.0 {
            (s / self.length).clamp(0.0, 1.0)
        } else {
            1.0
        };
        self.deltas
            .iter()
            .map(move |(axis, d)| (*axis, *d as f64 * fraction))
    }
}

/// A running move's estimated position over time.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveEstimate {
    start: PerAxis<i64>,
    groups: Vec<Group>,
    started: Option<Instant>,
}

impl MoveEstimate {
    /// `@0A` / CNC `0`: `pairs` as sent for `config`, from `start` (machine steps).
    pub fn relative(
        config: AxisConfig,
        pairs: &[MovePair],
        start: PerAxis<i64>,
        ramp: RampParams,
        three_d: bool,
    ) -> MoveEstimate {
        let moves = pair_moves(config, pairs, |_, steps| i64::from(steps));
        MoveEstimate::from_moves(moves, start, ramp, three_d)
    }

    /// `@0M`: positions as sent (relative to the virtual zero `zero`, manual
    /// 2.2.19). With 3 axes the second z pair is ignored (manual 2.2.18).
    pub fn absolute(
        config: AxisConfig,
        pairs: &[MovePair],
        start: PerAxis<i64>,
        zero: PerAxis<i64>,
        ramp: RampParams,
        three_d: bool,
    ) -> MoveEstimate {
        let mut moves = pair_moves(config, pairs, |axis, target| {
            let machine = i64::from(target) + zero.get(axis).unwrap_or(0);
            machine - start.get(axis).unwrap_or(0)
        });
        if config == AxisConfig::XYZ {
            moves.truncate(3);
        }
        MoveEstimate::from_moves(moves, start, ramp, three_d)
    }

    fn from_moves(
        moves: Vec<(Axis, i64, u32)>,
        start: PerAxis<i64>,
        ramp: RampParams,
        three_d: bool,
    ) -> MoveEstimate {
        let mut groups = Vec::new();
        if three_d {
            let path = moves
                .iter()
                .filter(|(a, _, _)| *a != Axis::A)
                .map(|(_, d, _)| (*d as f64).powi(2))
                .sum::<f64>()
                .sqrt();
            let a_only = moves
                .iter()
                .filter(|(a, _, _)| *a == Axis::A)
                .map(|(_, d, _)| d.unsigned_abs() as f64)
                .fold(0.0, f64::max);
            let length = if path > 0.0 { path } else { a_only };
            let speed = moves
                .iter()
                .find(|(a, _, _)| *a == Axis::X)
                .map_or(1, |(_, _, v)| *v);
            let deltas = moves.iter().map(|(a, d, _)| (*a, *d)).collect();
            groups.push(Group::new(deltas, length, f64::from(speed), ramp));
        } else {
            let (planar, rest): (Vec<_>, Vec<_>) =
                moves.iter().partition(|(a, _, _)| *a != Axis::Z);
            if let Some(group) = lead_group(&planar, ramp) {
                groups.push(group);
            }
            // Z: z1, then z2 with 3 axes, one after the other.
            for m in rest {
                if let Some(group) = lead_group(&[m], ramp) {
                    groups.push(group);
                }
            }
        }
        MoveEstimate {
            start,
            groups,
            started: None,
        }
    }

    /// The last byte of the command has gone out: the move starts.
    pub fn start(&mut self, at: Instant) {
        if self.started.is_none() {
            self.started = Some(at);
        }
    }

    pub fn started(&self) -> Option<Instant> {
        self.started
    }

    /// How long the move takes as planned (or, after a stop, until it rests).
    pub fn duration(&self) -> Duration {
        self.groups.iter().map(|g| g.motion.end_time()).sum()
    }

    /// The planned change per axis.
    pub fn deltas(&self) -> PerAxis<i64> {
        let mut out = PerAxis::new();
        for g in &self.groups {
            for (axis, d) in &g.deltas {
                out.set(*axis, out.get(*axis).unwrap_or(0) + d);
            }
        }
        out
    }

    /// Where the move ends as planned: the start plus its change per axis.
    pub fn end(&self) -> PerAxis<i64> {
        let deltas = self.deltas();
        let mut out = self.start;
        for axis in deltas.axes().iter() {
            let delta = deltas.get(axis).unwrap_or(0);
            out.set(axis, self.start.get(axis).unwrap_or(0) + delta);
        }
        out
    }

    /// The group running `t` after the start and the time since it began.
    fn locate(&self, t: Duration) -> Option<(usize, Duration)> {
        let mut begin = Duration::ZERO;
        for (i, g) in self.groups.iter().enumerate() {
            let end = begin + g.motion.end_time();
            if t < end {
                return Some((i, t - begin));
            }
            begin = end;
        }
        None
    }

    /// Ramp down from `now` (0xFD/0xFF, manual 2.2.31): the running group
    /// brakes, the groups after it never start.
    pub fn brake(&mut self, now: Instant) {
        let t = self.elapsed(now);
        if let Some((i, local)) = self.locate(t) {
            if let Some(g) = self.groups.get_mut(i) {
                g.motion.brake(local);
            }
            self.groups.truncate(i + 1);
        }
    }

    /// Stop without a ramp (a limit switch or E-stop, manual chapter 5 code 2).
    pub fn halt(&mut self, now: Instant) {
        let t = self.elapsed(now);
        if let Some((i, local)) = self.locate(t) {
            if let Some(g) = self.groups.get_mut(i) {
                g.motion.halt(local);
            }
            self.groups.truncate(i + 1);
        }
    }

    /// Time the move needs from `now` until it rests.
    pub fn remaining(&self, now: Instant) -> Duration {
        self.duration().saturating_sub(self.elapsed(now))
    }

    fn elapsed(&self, now: Instant) -> Duration {
        self.started
            .map_or(Duration::ZERO, |s| now.saturating_duration_since(s))
    }

    /// The estimated machine position at `now`.
    pub fn position_at(&self, now: Instant) -> PerAxis<i64> {
        let mut t = self.elapsed(now);
        let mut offsets = [0.0f64; 4];
        for g in &self.groups {
            let end = g.motion.end_time();
            let local = t.min(end);
            for (axis, s) in g.offsets_at(local) {
                if let Some(o) = offsets.get_mut(axis.index()) {
                    *o += s;
                }
            }
            if t <= end {
                break;
            }
            t -= end;
        }
        let mut out = self.start;
        for axis in self.deltas().axes().iter() {
            let base = self.start.get(axis).unwrap_or(0);
            let moved = offsets.get(axis.index()).copied().unwrap_or(0.0);
            out.set(axis, base + moved.round() as i64);
        }
        out
    }
}

/// The axis, signed steps and speed of each pair, in the order the pairs
/// are sent: X, Y, then Z (z1, z2) or Z, A (manual 2.2.2).
fn pair_moves(
    config: AxisConfig,
    pairs: &[MovePair],
    steps_of: impl Fn(Axis, i32) -> i64,
) -> Vec<(Axis, i64, u32)> {
    let axes: &[Axis] = match config {
        AxisConfig::X => &[Axis::X],
        AxisConfig::XY => &[Axis::X, Axis::Y],
        AxisConfig::XYZ => &[Axis::X, Axis::Y, Axis::Z, Axis::Z],
        AxisConfig::XYZA => &[Axis::X, Axis::Y, Axis::Z, Axis::A],
    };
    axes.iter()
        .zip(pairs)
        .map(|(axis, p)| (*axis, steps_of(*axis, p.steps), p.speed))
        .collect()
}

/// Axes interpolated together: the longest path runs at its own speed, the
/// others are scaled to it (manual 2.2.2, 2.5D).
fn lead_group(moves: &[&(Axis, i64, u32)], ramp: RampParams) -> Option<Group> {
    // The first of equally long paths leads (X before Y).
    let lead = moves.iter().filter(|(_, d, _)| *d != 0).fold(
        None,
        |best: Option<&&(Axis, i64, u32)>, m| match best {
            Some(b) if b.1.unsigned_abs() >= m.1.unsigned_abs() => Some(b),
            _ => Some(m),
        },
    )?;
    let deltas = moves
        .iter()
        .filter(|(_, d, _)| *d != 0)
        .map(|(a, d, _)| (*a, *d))
        .collect();
    Some(Group::new(
        deltas,
        lead.1.unsigned_abs() as f64,
        f64::from(lead.2),
        ramp,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    const RAMP: RampParams = RampParams::CONTROLLER_DEFAULT;

    fn origin() -> PerAxis<i64> {
        PerAxis::new()
            .with(Axis::X, 0)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0)
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_single_axis_follows_the_trapezoid() {
        let t0 = Instant::now();
        let pairs = [
            MovePair::new(10_000, 5_300),
            MovePair::new(0, 300),
            MovePair::new(0, 300),
            MovePair::new(0, 300),
        ];
        let mut e = MoveEstimate::relative(AxisConfig::XYZ, &pairs, origin(), RAMP, false);
        e.start(t0);
        // 300 -> 5300 Hz at 100 Hz/ms: 50 ms, 140 steps (see motion.rs).
        assert_eq!(e.position_at(t0 + ms(50)).get(Axis::X), Some(140));
        let end = t0 + e.duration();
        assert_eq!(e.position_at(end).get(Axis::X), Some(10_000));
        assert_eq!(e.position_at(end + ms(500)).get(Axis::X), Some(10_000));
        assert_eq!(e.position_at(end).get(Axis::Y), Some(0));
        let expected = 0.1 + (10_000.0 - 280.0) / 5_300.0;
        assert!((e.duration().as_secs_f64() - expected).abs() < 1e-6);
    }

    #[test]
    fn xy_is_interpolated_and_z_follows_afterwards() {
        let t0 = Instant::now();
        let pairs = [
            MovePair::new(-4_000, 2_000),
            MovePair::new(2_000, 1_000),
            MovePair::new(1_000, 1_000),
            MovePair::new(-1_000, 1_000),
        ];
        let mut e = MoveEstimate::relative(AxisConfig::XYZ, &pairs, origin(), RAMP, false);
        e.start(t0);
        // Half way through the XY group, Y has done half of its 2000 steps.
        let xy = Motion::new(4_000, RAMP.ramp(2_000.0)).end_time();
        let half = e.position_at(t0 + xy / 2);
        assert_eq!(half.get(Axis::X), Some(-2_000));
        assert_eq!(half.get(Axis::Y), Some(1_000));
        assert_eq!(half.get(Axis::Z), Some(0));
        // After XY and z1, Z stands at +1000; after z2 back at 0.
        let z = Motion::new(1_000, RAMP.ramp(1_000.0)).end_time();
        let after_z1 = e.position_at(t0 + xy + z);
        assert_eq!(after_z1.get(Axis::Z), Some(1_000));
        assert_eq!(e.position_at(t0 + e.duration()).get(Axis::Z), Some(0));
        assert_eq!(e.duration(), xy + z + z);
        assert_eq!(e.deltas().get(Axis::Z), Some(0));
    }

    #[test]
    fn absolute_targets_are_shifted_by_the_virtual_zero() {
        let start = origin().with(Axis::X, 1_000);
        let zero = PerAxis::new()
            .with(Axis::X, 500)
            .with(Axis::Y, 0)
            .with(Axis::Z, 0);
        let pairs = [
            MovePair::new(1_500, 1_000),
            MovePair::new(0, 1_000),
            MovePair::new(0, 1_000),
            MovePair::new(0, 1_000),
        ];
        let e = MoveEstimate::absolute(AxisConfig::XYZ, &pairs, start, zero, RAMP, false);
        // Target 1500 in the work frame = 2000 in machine steps.
        assert_eq!(e.deltas().get(Axis::X), Some(1_000));
        assert_eq!(e.deltas().get(Axis::Z), None, "z2 of M is ignored");
    }

    #[test]
    fn a_brake_ramps_down_and_drops_the_rest() {
        let t0 = Instant::now();
        let pairs = [
            MovePair::new(1_000_000, 5_300),
            MovePair::new(0, 300),
            MovePair::new(1_000, 1_000),
            MovePair::new(0, 300),
        ];
        let mut e = MoveEstimate::relative(AxisConfig::XYZ, &pairs, origin(), RAMP, false);
        e.start(t0);
        let at = t0 + ms(500);
        let before = e.position_at(at).get(Axis::X).unwrap_or(0);
        e.brake(at);
        // Braking from 5300 Hz at 100 Hz/ms takes 50 ms and 140 steps.
        assert_eq!(e.remaining(at), ms(50));
        let rest = e.position_at(at + ms(200));
        assert_eq!(rest.get(Axis::X), Some(before + 140));
        assert_eq!(rest.get(Axis::Z), Some(0), "z never starts");
    }

    #[test]
    fn a_halt_stops_at_once() {
        let t0 = Instant::now();
        let pairs = [MovePair::new(100_000, 4_000)];
        let start = PerAxis::new().with(Axis::X, 0);
        let mut e = MoveEstimate::relative(AxisConfig::X, &pairs, start, RAMP, false);
        e.start(t0);
        let at = t0 + ms(300);
        let there = e.position_at(at);
        e.halt(at);
        assert_eq!(e.position_at(at + ms(100)), there);
        assert_eq!(e.remaining(at), Duration::ZERO);
    }

    #[test]
    fn three_d_moves_along_the_vector_at_the_x_speed() {
        let t0 = Instant::now();
        let pairs = [
            MovePair::new(3_000, 1_000),
            MovePair::new(4_000, 9_000),
            MovePair::new(0, 1_000),
            MovePair::new(0, 1_000),
        ];
        let mut e = MoveEstimate::relative(AxisConfig::XYZ, &pairs, origin(), RAMP, true);
        e.start(t0);
        let expected = Motion::new(5_000, RAMP.ramp(1_000.0)).end_time();
        assert_eq!(e.duration(), expected);
        let half = e.position_at(t0 + expected / 2);
        assert_eq!(half.get(Axis::X), Some(1_500));
        assert_eq!(half.get(Axis::Y), Some(2_000));
    }

    #[test]
    fn with_four_axes_a_runs_with_x_and_y_then_z() {
        let t0 = Instant::now();
        let pairs = [
            MovePair::new(1_000, 1_000),
            MovePair::new(1_000, 4_000),
            MovePair::new(500, 1_000),
            MovePair::new(2_000, 1_000),
        ];
        let start = origin().with(Axis::A, 0);
        let mut e = MoveEstimate::relative(AxisConfig::XYZA, &pairs, start, RAMP, false);
        e.start(t0);
        // A has the longest way and leads; X and Y follow in proportion.
        let lead = Motion::new(2_000, RAMP.ramp(1_000.0)).end_time();
        let half = e.position_at(t0 + lead / 2);
        assert_eq!(half.get(Axis::A), Some(1_000));
        assert_eq!(half.get(Axis::X), Some(500));
        assert_eq!(half.get(Axis::Z), Some(0));
        let z = Motion::new(500, RAMP.ramp(1_000.0)).end_time();
        assert_eq!(e.duration(), lead + z);
    }

    #[test]
    fn on_a_tie_x_leads_with_its_speed() {
        let pairs = [MovePair::new(1_000, 1_000), MovePair::new(-1_000, 4_000)];
        let start = PerAxis::new().with(Axis::X, 0).with(Axis::Y, 0);
        let e = MoveEstimate::relative(AxisConfig::XY, &pairs, start, RAMP, false);
        assert_eq!(
            e.duration(),
            Motion::new(1_000, RAMP.ramp(1_000.0)).end_time()
        );
    }

    #[test]
    fn before_the_start_nothing_has_moved() {
        let pairs = [MovePair::new(1_000, 1_000)];
        let start = PerAxis::new().with(Axis::X, 7);
        let e = MoveEstimate::relative(AxisConfig::X, &pairs, start, RAMP, false);
        assert_eq!(e.position_at(Instant::now()).get(Axis::X), Some(7));
        assert!(e.started().is_none());
    }
}
