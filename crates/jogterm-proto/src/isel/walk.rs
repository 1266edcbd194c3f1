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
//! allocation; [`ArcWalk::advance`] skips whole laps once it has found the
//! walk's period, so a hand-made `B` of billions stays cheap.

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

    /// `steps` iterations of [`ArcWalk::step`], the same walk: the point
    /// and the error term kept in locals and the quadrant's signs taken
    /// once per quadrant, the step chosen without a branch. This loop is
    /// what `circle` spends its time in (every arc of a G-code import
    /// walks to its end, thousands of steps), and the choice between the
    /// x and the y step follows no pattern a branch predictor could learn.
    fn run(&mut self, steps: u64) {
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
