//! One leg of motion in progress: its geometry in counter coordinates, its
//! trapezoidal timing (`crate::motion`), and the search for the moment a
//! limit switch changes while the carriage travels along it.
//!
//! A leg is parameterised by the fraction `f` of its distance: the speed
//! profile says how far along the leg the axes are at a time, the path says
//! where that is. Lines move every axis in proportion (the controller's
//! linear interpolation, manual 2.2.2); arcs follow the circle of a `y`/`w`
//! command (manual 2.3) with a helix's third axis in proportion.

use std::cell::Cell;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::motion::{Motion, Ramp};
use crate::proto::isel::ArcWalk;

use super::mechanics::{AxisState, NEG, POS, surface_touched};
use crate::config::ProbeSurface;

/// Axis positions X, Y, Z, A.
pub type Point = [f64; 4];

/// The geometry of a leg, from its start (`f` = 0) to its end (`f` = 1).
#[derive(Debug, Clone, PartialEq)]
pub enum Path {
    Line { from: Point, to: Point },
    Arc(ArcPath),
}

impl Path {
    pub fn at(&self, f: f64) -> Point {
        let f = f.clamp(0.0, 1.0);
        match self {
            Path::Line { from, to } => {
                let mut p = *from;
                for (i, v) in p.iter_mut().enumerate() {
                    *v += (to[i] - from[i]) * f;
                }
                p
            }
            Path::Arc(arc) => arc.at(f),
        }
    }

    /// The counters at fraction `f`: rounded on a line, the walk's point on
    /// an arc.
    pub fn counters_at(&self, f: f64) -> [i64; 4] {
        match self {
            Path::Line { .. } => self.at(f).map(|v| v.round() as i64),
            Path::Arc(arc) => arc.counters_at(f),
        }
    }

    /// Every axis moves monotonically along a line, so a switch predicate
    /// along it changes at most once.
    fn is_line(&self) -> bool {
        matches!(self, Path::Line { .. })
    }
}

/// A circular arc in the plane of two axes, travelled as the controller's
/// walk (`ArcWalk`, manual 2.3: one step of one axis per iteration), and a
/// third axis that moves in proportion (a helix).
#[derive(Debug, Clone, PartialEq)]
pub struct ArcPath {
    /// Every axis at the start; axes outside the arc stay there.
    pub from: Point,
    /// Indices of the plane's axis 1 and axis 2.
    pub plane: (usize, usize),
    /// The centre, in counters.
    pub centre: (i64, i64),
    /// The walk at the start of this path.
    pub walk: ArcWalk,
    /// Iterations of the walk this path runs (`B`).
    pub steps: u64,
    /// The helix axis and its travel over the whole arc.
    pub third: Option<(usize, f64)>,
    index: WalkIndex,
}

/// Random access into a walk: a state every `spacing` steps, and the last
/// state asked for, since the simulator mostly asks for later and later
/// points (playback, the search for a switch).
#[derive(Clone)]
struct WalkIndex {
    spacing: u64,
    checkpoints: Arc<[ArcWalk]>,
    cursor: Cell<(u64, ArcWalk)>,
}

/// At most this many checkpoints per arc; at least [`MIN_SPACING`] steps
/// between two, so a short arc keeps a short list.
const CHECKPOINTS: u64 = 4096;
const MIN_SPACING: u64 = 1024;

impl WalkIndex {
    fn new(walk: ArcWalk, steps: u64) -> WalkIndex {
        let spacing = steps.div_ceil(CHECKPOINTS).max(MIN_SPACING);
        let mut at = walk;
        let mut checkpoints = vec![walk];
        for _ in 0..steps / spacing {
            at.advance(spacing);
            checkpoints.push(at);
        }
        WalkIndex {
            spacing,
            checkpoints: checkpoints.into(),
            cursor: Cell::new((0, walk)),
        }
    }

    /// The walk after `k` steps.
    fn walk_to(&self, k: u64) -> ArcWalk {
        let j = k / self.spacing;
        let (mut done, mut walk) = self
            .checkpoints
            .get(usize::try_from(j).unwrap_or(usize::MAX))
            .or(self.checkpoints.last())
            .map_or(self.cursor.get(), |w| (j * self.spacing, *w));
        let (at, cursor) = self.cursor.get();
        if at <= k && at >= done {
            (done, walk) = (at, cursor);
        }
        walk.advance(k.saturating_sub(done));
        self.cursor.set((k, walk));
        walk
    }
}

impl std::fmt::Debug for WalkIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WalkIndex")
            .field("spacing", &self.spacing)
            .field("checkpoints", &self.checkpoints.len())
            .finish()
    }
}

/// A cache: two indices of the same walk are equal.
impl PartialEq for WalkIndex {
    fn eq(&self, _: &WalkIndex) -> bool {
        true
    }
}

impl ArcPath {
    pub fn new(
        from: Point,
        plane: (usize, usize),
        centre: (i64, i64),
        walk: ArcWalk,
        steps: u64,
        third: Option<(usize, f64)>,
    ) -> ArcPath {
        ArcPath {
            from,
            plane,
            centre,
            walk,
            steps,
            third,
            index: WalkIndex::new(walk, steps),
        }
    }

    /// The same arc from other start counters (the axes outside the plane).
    pub fn starting_at(&self, from: Point) -> ArcPath {
        ArcPath {
            from,
            ..self.clone()
        }
    }

    /// The iteration the walk has reached at fraction `f`.
    fn step_at(&self, f: f64) -> u64 {
        ((f.clamp(0.0, 1.0) * self.steps as f64).round() as u64).min(self.steps)
    }

    /// Every axis at fraction `f`: between two iterations the stepping axis
    /// is part way to its next step.
    pub fn at(&self, f: f64) -> Point {
        let s = f.clamp(0.0, 1.0) * self.steps as f64;
        let k = (s.floor() as u64).min(self.steps);
        let walk = self.index.walk_to(k);
        let (x, y) = walk.point();
        let (mut x, mut y) = (x as f64, y as f64);
        if k < self.steps {
            let mut next = walk;
            next.step();
            let (nx, ny) = next.point();
            let part = s - k as f64;
            x += (nx as f64 - x) * part;
            y += (ny as f64 - y) * part;
        }
        self.place((x, y), f)
    }

    /// The counters at fraction `f`: the walk's point at the iteration
    /// reached, the helix axis on its nearest step.
    pub fn counters_at(&self, f: f64) -> [i64; 4] {
        let (x, y) = self.index.walk_to(self.step_at(f)).point();
        self.place((x as f64, y as f64), f)
            .map(|v| v.round() as i64)
    }

    fn place(&self, (x, y): (f64, f64), f: f64) -> Point {
        let mut p = self.from;
        let (a1, a2) = self.plane;
        if let Some(v) = p.get_mut(a1) {
            *v = self.centre.0 as f64 + x;
        }
        if let Some(v) = p.get_mut(a2) {
            *v = self.centre.1 as f64 + y;
        }
        if let Some((axis, delta)) = self.third
            && let Some(v) = p.get_mut(axis)
        {
            *v = self.from[axis] + delta * f.clamp(0.0, 1.0);
        }
        p
    }

    /// What is left of this arc from fraction `f` on: the rest of the walk.
    pub fn remainder(&self, f: f64, from: Point) -> ArcPath {
        let k = self.step_at(f);
        ArcPath::new(
            from,
            self.plane,
            self.centre,
            self.index.walk_to(k),
            self.steps - k,
            self.third.map(|(axis, delta)| (axis, delta * (1.0 - f))),
        )
    }
}

/// A leg being travelled.
#[derive(Debug, Clone, PartialEq)]
pub struct LegRun {
    pub path: Path,
    /// The counters when the leg completes as planned.
    pub end: [i64; 4],
    /// Steps along the leg the speed profile covers (> 0).
    pub distance: u64,
    pub t0: Instant,
    pub motion: Motion,
}

/// Bisection rounds: fractions to 2^-64, times to the nanosecond.
const BISECTIONS: u32 = 64;

impl LegRun {
    pub fn new(path: Path, end: [i64; 4], distance: u64, ramp: Ramp, t0: Instant) -> LegRun {
        LegRun {
            path,
            end,
            distance: distance.max(1),
            t0,
            motion: Motion::new(distance.max(1), ramp),
        }
    }

    pub fn elapsed(&self, t: Instant) -> Duration {
        t.saturating_duration_since(self.t0)
    }

    pub fn fraction_at(&self, t: Instant) -> f64 {
        self.motion.position_at(self.elapsed(t)) / self.distance as f64
    }

    pub fn position_at(&self, t: Instant) -> Point {
        self.path.at(self.fraction_at(t))
    }

    /// When the carriage comes to rest on this leg.
    pub fn end_time(&self) -> Instant {
        self.t0 + self.motion.end_time()
    }

    /// Where the counters stand once the leg is over: the planned end, or,
    /// for a leg cut short, the step each axis had reached.
    pub fn final_counters(&self) -> [i64; 4] {
        if self.motion.is_cut_short() {
            self.path.counters_at(self.fraction_at(self.end_time()))
        } else {
            self.end
        }
    }

    /// The first moment at or after `from` when the leg has covered the
    /// fraction `f`.
    pub fn time_of_fraction(&self, f: f64, from: Instant) -> Instant {
        let target = f * self.distance as f64;
        let mut lo = self.elapsed(from);
        let mut hi = self.motion.end_time().max(lo);
        if self.motion.position_at(lo) >= target {
            return self.t0 + lo;
        }
        for _ in 0..BISECTIONS {
            if hi.saturating_sub(lo) <= Duration::from_nanos(1) {
                break;
            }
            let mid = lo + (hi - lo) / 2;
            if self.motion.position_at(mid) >= target {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        self.t0 + hi
    }

    /// The first switch that changes after `from` on this leg, with the
    /// fraction where it does: `(fraction, axis, side)`.
    pub fn next_switch_change(
        &self,
        axes: &[AxisState; 4],
        from: Instant,
    ) -> Option<(f64, usize, usize)> {
        let fa = self.fraction_at(from);
        let fb = self.fraction_at(self.end_time());
        let mut best: Option<(f64, usize, usize)> = None;
        for (i, axis) in axes.iter().enumerate() {
            if axis.layout.is_none() {
                continue;
            }
            for side in [NEG, POS] {
                let pressed = axis.pressed.get(side).copied().unwrap_or(false);
                let crossed = |f: f64| {
                    let counter = self.path.at(f).get(i).copied().unwrap_or(0.0);
                    axis.threshold_crossed(side, axis.phys_of(counter), pressed)
                };
                let found = if crossed(fa) {
                    Some(fa)
                } else if fb > fa {
                    self.first_crossing(fa, fb, true, &crossed)
                } else {
                    None
                };
                if let Some(f) = found
                    && best.is_none_or(|(b, _, _)| f < b)
                {
                    best = Some((f, i, side));
                }
            }
        }
        best
    }

    /// The first fraction at or after `from` where the probe's contact with
    /// `surface` differs from `touching`: where the tip enters or leaves
    /// the material along the leg, on the steps the axes make (a plane
    /// crossed once on a line; sampled like a switch on an arc, and on any
    /// leg past a block or a bore, which a line can enter and leave).
    pub fn next_surface_change(
        &self,
        surface: &ProbeSurface,
        axes: &[AxisState; 4],
        touching: bool,
        from: Instant,
    ) -> Option<f64> {
        let fa = self.fraction_at(from);
        let fb = self.fraction_at(self.end_time());
        let crossed = |f: f64| surface_touched(surface, axes, self.path.counters_at(f)) != touching;
        if crossed(fa) {
            Some(fa)
        } else if fb > fa {
            self.first_crossing(fa, fb, surface.is_plane(), &crossed)
        } else {
            None
        }
    }

    /// The smallest fraction in (`fa`, `fb`] where `crossed` holds, given
    /// that it does not at `fa`; `once`: on a line it changes at most once.
    fn first_crossing(
        &self,
        fa: f64,
        fb: f64,
        once: bool,
        crossed: &dyn Fn(f64) -> bool,
    ) -> Option<f64> {
        // Changing once on a line: one look at the end. Else about one
        // sample per step of travel, so nothing is entered and left unseen.
        let samples = if once && self.path.is_line() {
            1
        } else {
            (((fb - fa) * self.distance as f64).ceil() as usize).clamp(8, 20_000)
        };
        let mut lo = fa;
        for k in 1..=samples {
            let hi = fa + (fb - fa) * k as f64 / samples as f64;
            if crossed(hi) {
                return Some(bisect(lo, hi, crossed));
            }
            lo = hi;
        }
        None
    }
}

/// Narrow `(lo, hi]` down to the first fraction where `crossed` holds.
fn bisect(mut lo: f64, mut hi: f64, crossed: &dyn Fn(f64) -> bool) -> f64 {
    for _ in 0..BISECTIONS {
        let mid = lo + (hi - lo) / 2.0;
        if mid <= lo || mid >= hi {
            break;
        }
        if crossed(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::isel::config::AxisMechanics;

    fn ramp(max_hz: f64) -> Ramp {
        Ramp {
            start_hz: 300.0,
            max_hz,
            accel_hz_per_s: 100_000.0,
        }
    }

    fn axes() -> [AxisState; 4] {
        let m = AxisMechanics {
            start: 0,
            switch_neg: -800,
            switch_pos: 4000,
            hysteresis: 40,
        };
        [
            AxisState::power_up(Some(m)),
            AxisState::power_up(Some(m)),
            AxisState::power_up(None),
            AxisState::power_up(None),
        ]
    }

    #[test]
    fn a_line_finds_the_switch_where_it_is() {
        let t0 = Instant::now();
        let run = LegRun::new(
            Path::Line {
                from: [0.0; 4],
                to: [10_000.0, 5_000.0, 0.0, 0.0],
            },
            [10_000, 5_000, 0, 0],
            10_000,
            ramp(2000.0),
            t0,
        );
        let (f, axis, side) = run.next_switch_change(&axes(), t0).expect("switch");
        assert_eq!((axis, side), (0, POS));
        assert!((f - 0.4).abs() < 1e-12);
        let t = run.time_of_fraction(f, t0);
        let at = run.position_at(t);
        assert!((at[0] - 4000.0).abs() < 1e-3, "{at:?}");
        assert!((at[1] - 2000.0).abs() < 1e-3);
    }

    #[test]
    fn a_line_through_a_block_and_out_again_touches_at_its_near_face() {
        // X from 0 to 10000 through a block 3000..4000: clear at both ends,
        // so one look at the end would miss it.
        let t0 = Instant::now();
        let run = LegRun::new(
            Path::Line {
                from: [0.0; 4],
                to: [10_000.0, 0.0, 0.0, 0.0],
            },
            [10_000, 0, 0, 0],
            10_000,
            ramp(2000.0),
            t0,
        );
        let block = ProbeSurface::block(3000.0, 4000.0, -100.0, 100.0, 100.0).expect("a block");
        let f = run
            .next_surface_change(&block, &axes(), false, t0)
            .expect("the block");
        assert_eq!(run.path.counters_at(f)[0], 3000, "{f}");
        // Inside it, the way out is its far face's next step.
        let t = run.time_of_fraction(0.35, t0);
        let out = run
            .next_surface_change(&block, &axes(), true, t)
            .expect("out of the block");
        assert_eq!(run.path.counters_at(out)[0], 4001, "{out}");
    }

    #[test]
    fn an_arc_finds_the_switch_it_touches() {
        use crate::proto::isel::CircleDirection;
        let t0 = Instant::now();
        // Full circle of radius 1000 around (0, 0) starting at (1000, 0):
        // the walk reaches x = -800 (switch 1 of X) after 1000 + 1000 steps
        // to (0, 1000), then 800 in X and 400 in Y: step 3200 of 8000.
        let walk = ArcWalk::new(1000, (1000, 0), CircleDirection::Ccw);
        let arc = ArcPath::new([1000.0, 0.0, 0.0, 0.0], (0, 1), (0, 0), walk, 8000, None);
        let run = LegRun::new(Path::Arc(arc), [1000, 0, 0, 0], 8000, ramp(2000.0), t0);
        let mut a = axes();
        a[0].phys = 1000;
        a[0].set_counter(1000);
        let (f, axis, side) = run.next_switch_change(&a, t0).expect("switch");
        assert_eq!((axis, side), (0, NEG));
        let step = f * 8000.0;
        assert!((step - 3200.0).abs() <= 1.0, "{step}");
        let at = run.path.at(f);
        assert!(
            (at[0] + 800.0).abs() < 1.0 && (at[1] - 600.0).abs() <= 1.0,
            "{at:?}"
        );
    }

    #[test]
    fn an_arc_runs_the_walk_and_its_remainder_goes_on_from_the_stop() {
        use crate::proto::isel::CircleDirection;
        // The manual's example: 400 iterations from (-141, 141) around
        // (0, 0), 59 + 59 in X and 282 in Y.
        let walk = ArcWalk::new(200, (-141, 141), CircleDirection::Ccw);
        let arc = ArcPath::new([-141.0, 141.0, 0.0, 0.0], (0, 1), (0, 0), walk, 400, None);
        assert_eq!(arc.counters_at(1.0), [-141, -141, 0, 0]);
        // Each iteration moves one axis by one step.
        let mut last = arc.counters_at(0.0);
        for k in 1..=400 {
            let now = arc.counters_at(f64::from(k) / 400.0);
            let moved: i64 = (0..4).map(|i| (now[i] - last[i]).abs()).sum();
            assert_eq!(moved, 1, "iteration {k}: {last:?} -> {now:?}");
            last = now;
        }
        let rest = arc.remainder(0.25, [0.0; 4]);
        assert_eq!(rest.steps, 300);
        assert_eq!(rest.counters_at(1.0), [-141, -141, 0, 0]);
        assert_eq!(rest.counters_at(0.0), arc.counters_at(0.25));
    }

    #[test]
    fn a_leg_cut_short_ends_on_the_step_it_reached() {
        let t0 = Instant::now();
        let mut run = LegRun::new(
            Path::Line {
                from: [0.0; 4],
                to: [1000.0, 0.0, 0.0, 0.0],
            },
            [1000, 0, 0, 0],
            1000,
            ramp(300.0),
            t0,
        );
        assert_eq!(run.final_counters(), [1000, 0, 0, 0]);
        run.motion.halt(Duration::from_millis(1000));
        assert_eq!(run.final_counters(), [300, 0, 0, 0]);
        assert_eq!(run.end_time(), t0 + Duration::from_secs(1));
    }
}
