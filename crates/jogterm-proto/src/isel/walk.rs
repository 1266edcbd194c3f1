//! The controller's circle walk (isel manual 2.3.1, 2.3.2; decision 12 in
//! `docs/protocols.md`): a difference algorithm after Bresenham that moves
//! one axis by one step per iteration, so the arc length `B` of `y`/`w` is
//! the number of single-axis steps from the start point to the end point.
//!
//! Each iteration takes the step of one axis, in the direction of travel,
//! whose point lies closer to the circle: the error term `R² − x² − y²` of
//! both candidates decides (a tie takes the point on or outside the
//! circle, which keeps a circle of radius 1 off its centre). The direction
//! signs are those of 2.3.5 and flip when the walk reaches an axis: a
//! point on an axis belongs to the quadrant the arc enters, so the
//! coordinate that is 0 moves away from 0 and the other one towards the
//! centre.
//!
//! Both ends use this one walk: [`circle`](super::circle) counts its steps
//! from the start point to the point nearest the arc's end to compute `B`,
//! and the simulator and every preview step it `B` times to find where a
//! `y`/`w` leaves the tool. A step costs a few integer operations and no
//! allocation; [`ArcWalk::advance`] computes where the walk stands after
//! many steps within a quadrant instead of stepping them (`leap`: exact,
//! checked against [`ArcWalk::step`] by property tests), and skips whole
//! laps once it has found the walk's period, so a hand-made `B` of billions
//! stays cheap.

use super::command::CircleDirection;

/// The walk's state: a lattice point relative to the centre, its error term
/// and the quarter turns made so far.
///
/// Clockwise walks run mirrored (y negated) as counter-clockwise ones: the
/// error term is symmetric, so the mirrored walk is the same walk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArcWalk {
    /// The point in the counter-clockwise frame.
    x: i64,
    y: i64,
    /// `R² − x² − y²`: positive inside the circle.
    error: i64,
    clockwise: bool,
    /// The quadrant of travel in the counter-clockwise frame (0 = I).
    quadrant: u8,
    /// Quadrant changes since the start.
    quarter_turns: u64,
}

/// The quadrant of travel at a point of the counter-clockwise frame; a
/// point on an axis belongs to the quadrant the walk enters there.
fn quadrant_of(x: i64, y: i64) -> u8 {
    match (x.signum(), y.signum()) {
        (1, 0..) => 0,
        (0 | -1, 1) => 1,
        (-1, 0 | -1) => 2,
        (0, -1) | (1, -1) => 3,
        // The centre itself: only reachable from a radius of 0.
        _ => 0,
    }
}

/// The signs of the x and y motion in a quadrant, counter-clockwise.
fn signs_of(quadrant: u8) -> (i64, i64) {
    match quadrant {
        0 => (-1, 1),
        1 => (-1, -1),
        2 => (1, -1),
        _ => (1, 1),
    }
}

impl ArcWalk {
    /// A walk on the circle of `radius` steps from `start` (relative to the
    /// centre) in `direction`.
    pub fn new(radius: i64, start: (i64, i64), direction: CircleDirection) -> ArcWalk {
        let clockwise = direction == CircleDirection::Cw;
        let (x, y) = (start.0, if clockwise { -start.1 } else { start.1 });
        ArcWalk {
            x,
            y,
            error: radius * radius - x * x - y * y,
            clockwise,
            quadrant: quadrant_of(x, y),
            quarter_turns: 0,
        }
    }

    /// The current point relative to the centre.
    pub fn point(&self) -> (i64, i64) {
        (self.x, if self.clockwise { -self.y } else { self.y })
    }

    /// How many times the walk changed quadrant: a full circle makes 4.
    pub fn quarter_turns(&self) -> u64 {
        self.quarter_turns
    }

    /// The angle the walk has swept from `from`, in radians, positive in its
    /// direction of travel. `from` is the walk at its start.
    pub fn swept_since(&self, from: &ArcWalk) -> f64 {
        use std::f64::consts::FRAC_PI_2;
        // The angle of a point from the start of its quadrant of travel.
        let within = |w: &ArcWalk| {
            let angle = (w.y as f64).atan2(w.x as f64) - f64::from(w.quadrant) * FRAC_PI_2;
            // Points near an axis may sit a hair before their quadrant.
            (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        };
        let turns = self.quarter_turns.saturating_sub(from.quarter_turns);
        turns as f64 * FRAC_PI_2 + within(self) - within(from)
    }

    /// One iteration: one step of one axis.
    pub fn step(&mut self) {
        let (sx, sy) = signs_of(self.quadrant);
        let after_x = self.error - (2 * self.x * sx + 1);
        let after_y = self.error - (2 * self.y * sy + 1);
        let x_is_closer =
            after_x.abs() < after_y.abs() || (after_x.abs() == after_y.abs() && after_x <= after_y);
        if x_is_closer {
            self.x += sx;
            self.error = after_x;
        } else {
            self.y += sy;
            self.error = after_y;
        }
        let quadrant = quadrant_of(self.x, self.y);
        if quadrant != self.quadrant {
            self.quadrant = quadrant;
            self.quarter_turns += 1;
        }
    }

    /// `steps` iterations. Long walks run one lap to settle on the walk's
    /// cycle, measure its period and skip whole laps.
    pub fn advance(&mut self, steps: u64) {
        let mut left = steps;
        let radius = (self.error + self.x * self.x + self.y * self.y)
            .max(0)
            .isqrt();
        // A lap of the walk is its Manhattan length, 8 R, give or take a
        // few steps at the axes.
        let lap = 8 * radius.unsigned_abs() + 64;
        if left > 3 * lap {
            for _ in 0..lap {
                self.step();
            }
            left -= lap;
            let mark = *self;
            let mut period = 0;
            while period < 2 * lap && left > 0 {
                self.step();
                left -= 1;
                period += 1;
                if (self.x, self.y) == (mark.x, mark.y) {
                    let turns = self.quarter_turns - mark.quarter_turns;
                    self.quarter_turns += left / period * turns;
                    left %= period;
                    break;
                }
            }
        }
        self.run(left);
    }

    /// `steps` iterations of [`ArcWalk::step`], the same walk, by leaps
    /// ([`leap`]) within a quadrant wherever the walk is locked on the
    /// circle, and step by step ([`ArcWalk::walk`]) where it is not (a
    /// start point off the circle, the few steps at an axis).
    fn run(&mut self, steps: u64) {
        let mut left = steps;
        while left > 0 {
            if left >= LEAP_MIN
                && let Some(done) = self.leap(left)
            {
                left -= done;
                continue;
            }
            let n = left.min(LEAP_MIN);
            self.walk(n);
            left -= n;
        }
    }

    /// Up to `steps` iterations at once within the current quadrant (see
    /// [`leap`]); how many, or `None` where the walk cannot leap from here.
    fn leap(&mut self, steps: u64) -> Option<u64> {
        // Far beyond any radius a controller takes (24-bit start points):
        // keep the squares below overflow.
        const LIMIT: i64 = 1 << 30;
        if self.x.abs() >= LIMIT || self.y.abs() >= LIMIT {
            return None;
        }
        let r2 = self.error + self.x * self.x + self.y * self.y;
        if !(1..1 << 60).contains(&r2) {
            return None;
        }
        let (a, b) = to_first(self.quadrant, (self.x, self.y));
        let (done, a, b) = leap(r2, (a, b), steps)?;
        let (x, y) = from_first(self.quadrant, (a, b));
        self.x = x;
        self.y = y;
        self.error = r2 - x * x - y * y;
        Some(done)
    }

    /// `steps` iterations of [`ArcWalk::step`], the same walk.
    fn walk(&mut self, steps: u64) {
        self.walk_each(steps, |_| {});
    }

    /// The points after each of the next `out.len()` iterations, in order:
    /// what [`ArcWalk::step`] then [`ArcWalk::point`] give one by one
    /// (`circle` looks at some fifty points around every arc's end, and a
    /// call of `step` a point was most of that).
    pub fn fill(&mut self, out: &mut [(i64, i64)]) {
        let steps = out.len() as u64;
        let mut slots = out.iter_mut();
        self.walk_each(steps, |point| {
            if let Some(slot) = slots.next() {
                *slot = point;
            }
        });
    }

    /// `steps` iterations of [`ArcWalk::step`], `each` told the point
    /// after each: the point and the error term kept in locals and the
    /// quadrant's signs taken once per quadrant, the step chosen without a
    /// branch (the choice between the x and the y step follows no pattern
    /// a branch predictor could learn).
    fn walk_each(&mut self, steps: u64, mut each: impl FnMut((i64, i64))) {
        let mirror = if self.clockwise { -1 } else { 1 };
        let mut left = steps;
        while left > 0 {
            let quadrant = self.quadrant;
            let (sx, sy) = signs_of(quadrant);
            let (mut x, mut y, mut error) = (self.x, self.y, self.error);
            let mut turned = false;
            while left > 0 {
                left -= 1;
                let after_x = error - (2 * x * sx + 1);
                let after_y = error - (2 * y * sy + 1);
                let x_is_closer = after_x.abs() < after_y.abs()
                    || (after_x.abs() == after_y.abs() && after_x <= after_y);
                let take_x = i64::from(x_is_closer);
                x += sx * take_x;
                y += sy * (1 - take_x);
                error = if x_is_closer { after_x } else { after_y };
                each((x, y * mirror));
                if quadrant_of(x, y) != quadrant {
                    turned = true;
                    break;
                }
            }
            self.x = x;
            self.y = y;
            self.error = error;
            if turned {
                self.quadrant = quadrant_of(x, y);
                self.quarter_turns += 1;
            }
        }
    }
}

/// Below this many steps left the walk steps rather than leaps; it also
/// steps this many at a time where it cannot leap.
const LEAP_MIN: u64 = 8;

/// A point of quadrant `q` turned into the first quadrant (x > 0, y >= 0),
/// where the walk's steps are x − 1 and y + 1: the walk is the same in
/// every quadrant turned by a multiple of 90°, since its choice compares the
/// error terms of the two candidate points, which a turn keeps.
fn to_first(q: u8, (x, y): (i64, i64)) -> (i64, i64) {
    match q {
        0 => (x, y),
        1 => (y, -x),
        2 => (-x, -y),
        _ => (-y, x),
    }
}

/// The inverse of [`to_first`].
fn from_first(q: u8, (a, b): (i64, i64)) -> (i64, i64) {
    match q {
        0 => (a, b),
        1 => (-b, a),
        2 => (-a, -b),
        _ => (b, -a),
    }
}

/// Where the walk stands after up to `steps` iterations from `(x, y)` of
/// the first quadrant on the circle of `r2` = R², without leaving the
/// quadrant: `(iterations, x, y)`, or `None` where this cannot be computed
/// (then the caller steps).
///
/// In the first quadrant a step goes to (x − 1, y) or (x, y + 1). The two
/// candidates' error terms `A`, `B` differ by `A − B = 2 (x + y) > 0`, so
/// `|A| < |B|` (the x step; a tie takes the y step) comes down to `A + B <
/// 0`, and `A + B >= 0` is, times two, `(x + y)² + (x − y − 1)² <= 2 R² − 1`:
/// the y step is taken when the midpoint of the two candidates lies within
/// √(R² − ½) of the centre. On the anti-diagonal `d = x − y` (each step
/// lowers it by one) that reads `y < t(d)` with `t(d) = ⌊(Q(d − 1) − d) / 2⌋
/// + 1`, `Q(m) = ⌊√(2 R² − 1 − m²)⌋`: the walk's next y is `y + [y < t(d)]`.
///
/// Where `2 m² <= 2 R² − 1` for m = d − 1 and d − 2, `Q` changes by at most
/// one from d to d − 1 (the circle's slope is below one there), so `t(d − 1)
/// − t(d)` is 0 or 1. A walk that stands at `t(d) − 1` or `t(d)` on its
/// diagonal d therefore goes to `t(d)` on d − 1, and from there on stands at
/// `t(d' + 1)` on every diagonal `d'` the condition holds for: after `j`
/// steps at `(t(d − j + 1) + d − j, t(d − j + 1))`. x never grows, so the
/// walk stays in the quadrant as long as that x is at least 1; the largest
/// such `j` is found by bisection. Everything is exact integer arithmetic;
/// the tests below check it against the step-by-step walk.
fn leap(r2: i64, (x, y): (i64, i64), steps: u64) -> Option<(u64, i64, i64)> {
    if x < 1 || y < 0 {
        return None;
    }
    let k = 2 * r2 - 1;
    let d = x - y;
    if 2 * (d - 1) * (d - 1) > k {
        return None;
    }
    let t = |d: i64| {
        let m = d - 1;
        let q = (k - m * m).isqrt();
        (q - m - 1).div_euclid(2) + 1
    };
    let target = t(d);
    if y != target && y != target - 1 {
        return None;
    }
    // The lowest diagonal the condition holds for: |m| <= l.
    let l = (k / 2).isqrt();
    let most = steps.min(u64::try_from(d + l).ok()?);
    let land = |j: u64| {
        // j <= d + l <= 2^31: fits.
        let d_end = d - j as i64;
        let y = t(d_end + 1);
        (y + d_end, y)
    };
    let (x_end, y_end) = land(most);
    if x_end >= 1 {
        return Some((most, x_end, y_end));
    }
    // The walk reaches the axis (x = 0) before `most`: the last j that
    // keeps x >= 1 (x does not grow with j).
    let (mut inside, mut outside) = (0, most);
    while outside - inside > 1 {
        let mid = inside + (outside - inside) / 2;
        if land(mid).0 >= 1 {
            inside = mid;
        } else {
            outside = mid;
        }
    }
    if inside == 0 {
        return None;
    }
    let (x_end, y_end) = land(inside);
    Some((inside, x_end, y_end))
}

impl Iterator for ArcWalk {
    type Item = (i64, i64);

    /// The point after the next step; the walk never ends.
    fn next(&mut self) -> Option<(i64, i64)> {
        self.step();
        Some(self.point())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use CircleDirection::{Ccw, Cw};

    #[test]
    fn the_manuals_example_is_400_single_axis_steps() {
        // 135 to 225 degrees CCW at R = 200: 59 + 59 steps in X, 282 in Y.
        let mut walk = ArcWalk::new(200, (-141, 141), Ccw);
        let (mut in_x, mut in_y) = (0, 0);
        let mut at = walk.point();
        for _ in 0..400 {
            let next = walk.next().unwrap_or(at);
            in_x += (next.0 - at.0).abs();
            in_y += (next.1 - at.1).abs();
            assert_eq!((next.0 - at.0).abs() + (next.1 - at.1).abs(), 1);
            at = next;
        }
        assert_eq!((in_x, in_y), (118, 282));
        assert_eq!(at, (-141, -141));
        assert_eq!(walk.quarter_turns(), 1);
    }

    #[test]
    fn a_circle_of_radius_1_is_eight_steps_round_its_centre() {
        for direction in [Ccw, Cw] {
            let mut walk = ArcWalk::new(1, (1, 0), direction);
            let points: Vec<_> = walk.by_ref().take(8).collect();
            assert!(!points.contains(&(0, 0)), "{points:?}");
            assert_eq!(points.last(), Some(&(1, 0)));
            assert_eq!(walk.quarter_turns(), 4);
        }
    }

    #[test]
    fn the_walk_keeps_within_a_step_of_the_circle_in_every_quadrant() {
        for direction in [Ccw, Cw] {
            let r = 1000;
            let mut walk = ArcWalk::new(r, (r, 0), direction);
            let start = walk;
            for (n, (x, y)) in walk.by_ref().take(8000).enumerate() {
                let off = ((x * x + y * y) as f64).sqrt() - r as f64;
                assert!(off.abs() < 0.75, "step {n}: ({x}, {y}) is {off} off");
            }
            assert_eq!(walk.point(), (r, 0));
            assert_eq!(walk.quarter_turns(), 4);
            let swept = walk.swept_since(&start);
            assert!((swept - std::f64::consts::TAU).abs() < 1e-9, "{swept}");
        }
        // CW goes the other way: the first steps from (R, 0) go down.
        let mut cw = ArcWalk::new(10, (10, 0), Cw);
        cw.advance(3);
        assert!(cw.point().1 < 0, "{:?}", cw.point());
    }

    /// The walk one [`ArcWalk::step`] at a time: the reference every
    /// faster way must agree with.
    fn stepped(mut walk: ArcWalk, steps: u64) -> ArcWalk {
        for _ in 0..steps {
            walk.step();
        }
        walk
    }

    #[test]
    fn leaping_ends_where_stepping_does_on_whole_circles() {
        // Every step count of a few turns, from points on, inside and
        // outside the circle, for the small radii whose quadrants are a
        // handful of steps and some larger ones.
        for r in (1..=40).chain([99, 100, 101, 577, 1000, 4096]) {
            let starts = [
                (r, 0),
                (0, r),
                (-r, 0),
                (0, -r),
                (r, 1),
                (r + 1, 0),
                (r - 1, 0),
                (r * 7 / 10, r * 7 / 10),
                (-(r * 7 / 10) - 1, r * 7 / 10),
            ];
            for start in starts {
                for direction in [Ccw, Cw] {
                    let first = ArcWalk::new(r, start, direction);
                    let mut slow = first;
                    let lap = 9 * r as u64 + 16;
                    let counts = (0..=lap.min(600)).chain((lap.min(600)..=lap).step_by(37));
                    let mut at = 0;
                    for n in counts {
                        slow = stepped(slow, n - at);
                        at = n;
                        let mut fast = first;
                        fast.advance(n);
                        assert_eq!(fast, slow, "R {r} from {start:?} {direction:?}, {n} steps");
                    }
                }
            }
        }
    }

    #[test]
    fn a_quadrant_on_the_circle_is_one_leap() {
        // From (R, 0) the walk leaps to within a few steps of the Y axis
        // (what it cannot leap it steps): the property tests above would
        // pass as well if it never leapt.
        for r in [10_i64, 1000, 1 << 23] {
            let leapt = leap(r * r, (r, 0), u64::MAX);
            assert!(
                leapt.is_some_and(|(n, x, _)| n + 8 >= 2 * r as u64 && (1..3).contains(&x)),
                "R {r}: {leapt:?}"
            );
        }
        // Off the circle by more than a step it does not lock: it steps.
        assert_eq!(leap(1000 * 1000, (1003, 0), 100), None);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]

        /// Any radius a controller takes, any start on, near or off the
        /// circle, either direction, any number of steps up to two laps:
        /// the walk's leaps end where its steps do, in the same state
        /// (point, error term, quadrant, quarter turns).
        #[test]
        fn leaps_end_where_steps_do(
            radius_bits in 0u32..=23,
            radius_frac in 0.0f64..1.0,
            angle in 0.0f64..360.0,
            offset in (-3i64..=3, -3i64..=3),
            ccw in proptest::bool::ANY,
            laps in 0.0f64..2.0,
        ) {
            // Radii spread over every order of magnitude up to 2^23.
            let r = ((2f64.powi(radius_bits as i32) * (1.0 + radius_frac)) as i64).clamp(1, 1 << 23);
            let a = angle.to_radians();
            let start = (
                (r as f64 * a.cos()).round() as i64 + offset.0,
                (r as f64 * a.sin()).round() as i64 + offset.1,
            );
            let direction = if ccw { Ccw } else { Cw };
            // Stepping two laps of R = 2^23 is 2^27 steps: keep the count
            // within what a test stepping one by one can afford.
            let steps = ((laps * 8.0 * r as f64) as u64).min(400_000);
            let first = ArcWalk::new(r, start, direction);
            let mut fast = first;
            fast.advance(steps);
            let slow = stepped(first, steps);
            proptest::prop_assert_eq!(fast, slow, "R {} from {:?} {:?}, {} steps", r, start, direction, steps);
        }
    }

    #[test]
    fn fill_gives_the_points_of_the_steps() {
        for (r, start) in [
            (1, (1, 0)),
            (3, (3, 0)),
            (200, (-141, 141)),
            (50, (-35, 36)),
            (1000, (0, -1000)),
        ] {
            for direction in [Ccw, Cw] {
                for n in [0, 1, 7, 49, 64, 300] {
                    let mut fast = ArcWalk::new(r, start, direction);
                    let mut points = vec![(0, 0); n];
                    fast.fill(&mut points);
                    let mut slow = ArcWalk::new(r, start, direction);
                    let stepped: Vec<_> = (0..n)
                        .map(|_| {
                            slow.step();
                            slow.point()
                        })
                        .collect();
                    assert_eq!(points, stepped, "R {r} from {start:?} {direction:?}");
                    assert_eq!(fast, slow);
                }
            }
        }
    }

    #[test]
    fn skipping_laps_ends_where_stepping_does() {
        for (r, start, steps) in [(3, (3, 0), 1_000_003), (50, (-35, 35), 77_777)] {
            for direction in [Ccw, Cw] {
                let mut fast = ArcWalk::new(r, start, direction);
                fast.advance(steps);
                let mut slow = ArcWalk::new(r, start, direction);
                for _ in 0..steps {
                    slow.step();
                }
                assert_eq!(fast, slow);
            }
        }
    }
}
