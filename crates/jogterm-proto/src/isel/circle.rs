//! Circle and helix parameters (isel manual 2.3, `docs/decisions.md`
//! isel 12): from radius, start and end angle, direction and speed to the
//! `f` direction and the `y`/`w` parameters, and back from `y`/`w`
//! parameters to where the arc leaves the tool.
//!
//! Conventions (`docs/protocols.md`, isel):
//! - Angles are in degrees, counter-clockwise from axis 1 of the plane (the
//!   X axis in the XY plane). The sweep runs from the start angle to the end
//!   angle in the given direction and lies in (0°, 360°]: equal start and end
//!   angles make a full circle, and 300° → 30° CCW crosses 0° (a 90° arc).
//! - `B` is the number of iterations of the controller's walk
//!   ([`ArcWalk`], manual 2.3.1/2.3.2: one step of one axis each) from the
//!   start point to the walk's point nearest the arc's end. The manual's
//!   `4 R (E − A) / π` is exact only for quarter, half and full circles
//!   (any 90° of a circle is 2 R single-axis steps); on other arcs it is off
//!   by up to 10 % of the arc.
//! - `Xs`, `Ys` are `R cos A`, `R sin A` rounded half away from zero.
//! - `Rx`, `Ry` are the signs of the motion at the rounded start point. A
//!   start point on an axis (quadrant boundary) belongs to the quadrant the
//!   arc enters, so the coordinate that is 0 moves away from 0 and the other
//!   one moves towards the centre.
//! - `D` follows the worked example 2.3.6 (decision 12); its halving
//!   truncates towards zero.

use thiserror::Error;

use super::check::{SPEED_HZ, STEPS};
use super::cnc::CncCommand;
use super::command::{CircleDirection, CircleParams, Command, HelixParams, Sign};
use super::walk::ArcWalk;

/// Why no circle parameters can be computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CircleError {
    #[error("the radius must be at least 1 step")]
    ZeroRadius,
    #[error("the radius must be at most {max} steps (24-bit start point), got {0}", max = STEPS.end())]
    RadiusTooLarge(u32),
    #[error("the {which} angle must be a finite number of degrees, got {value}")]
    BadAngle { which: &'static str, value: f64 },
    #[error("the speed must be {min}-{max} Hz, got {0}", min = SPEED_HZ.start(), max = SPEED_HZ.end())]
    BadSpeed(u32),
    #[error("the arc is shorter than one step (B rounds to 0)")]
    ArcTooShort,
    #[error(
        "the interpolation parameter D = {0} does not fit 32 bits: the radius is too large for this start point"
    )]
    ParameterTooLarge(i64),
    #[error("the third axis' steps must be 24-bit, got {0}")]
    BadThirdAxisSteps(i32),
}

/// The two commands of a circle: direction `f` and parameters `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CircleMove {
    pub direction: CircleDirection,
    pub params: CircleParams,
}

impl CircleMove {
    /// `@0f…` then `@0y…`.
    pub fn commands(&self) -> [Command; 2] {
        [
            Command::SetCircleDirection(self.direction),
            Command::Circle(self.params),
        ]
    }

    /// `f…` then `y…` for a stored program.
    pub fn cnc_lines(&self) -> [CncCommand; 2] {
        [
            CncCommand::SetCircleDirection(self.direction),
            CncCommand::Circle(self.params),
        ]
    }
}

/// The two commands of a helix: direction `f` and parameters `w`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HelixMove {
    pub direction: CircleDirection,
    pub params: HelixParams,
}

impl HelixMove {
    /// `@0f…` then `@0w…`.
    pub fn commands(&self) -> [Command; 2] {
        [
            Command::SetCircleDirection(self.direction),
            Command::Helix(self.params),
        ]
    }

    /// `f…` then `w…` for a stored program.
    pub fn cnc_lines(&self) -> [CncCommand; 2] {
        [
            CncCommand::SetCircleDirection(self.direction),
            CncCommand::Helix(self.params),
        ]
    }
}

/// The parameters of a circular arc of `radius` steps from `start_deg` to
/// `end_deg` in `direction` at `speed` Hz.
///
/// ```
/// use jogterm_proto::isel::{circle, CircleDirection, Frame};
///
/// let arc = circle(200, 135.0, 225.0, CircleDirection::Ccw, 1500).unwrap();
/// let [f, y] = arc.commands().map(|c| Frame::default_device(c).to_string());
/// assert_eq!((f.as_str(), y.as_str()), ("@0f-1", "@0y400,1500,119,-141,141,-1,-1"));
/// ```
pub fn circle(
    radius: u32,
    start_deg: f64,
    end_deg: f64,
    direction: CircleDirection,
    speed: u32,
) -> Result<CircleMove, CircleError> {
    if !start_deg.is_finite() {
        return Err(CircleError::BadAngle {
            which: "start",
            value: start_deg,
        });
    }
    if !end_deg.is_finite() {
        return Err(CircleError::BadAngle {
            which: "end",
            value: end_deg,
        });
    }
    if radius == 0 {
        return Err(CircleError::ZeroRadius);
    }
    if i64::from(radius) > i64::from(*STEPS.end()) {
        return Err(CircleError::RadiusTooLarge(radius));
    }
    if !SPEED_HZ.contains(&speed) {
        return Err(CircleError::BadSpeed(speed));
    }
    let r = f64::from(radius);
    let sweep = sweep_deg(start_deg, end_deg, direction);
    let start = start_deg.to_radians();
    // |R cos A| <= R <= 2^23, so the rounded values fit i32.
    let xs = (r * start.cos()).round() as i32;
    let ys = (r * start.sin()).round() as i32;
    let walk = ArcWalk::new(i64::from(radius), (i64::from(xs), i64::from(ys)), direction);
    let arc_length = steps_to_end(walk, r, start_deg, sweep, direction);
    if arc_length == 0 {
        return Err(CircleError::ArcTooShort);
    }
    let (rx, ry) = start_signs(xs, ys, direction);
    let d = interpolation_parameter(i64::from(radius), xs, ys, rx, ry);
    let d = i32::try_from(d).map_err(|_| CircleError::ParameterTooLarge(d))?;
    Ok(CircleMove {
        direction,
        params: CircleParams {
            // About 8 R <= 2^26: fits u32.
            arc_length: u32::try_from(arc_length).unwrap_or(u32::MAX),
            speed,
            d,
            xs,
            ys,
            rx,
            ry,
        },
    })
}

/// A helix: the arc as for [`circle`] plus `s3` steps of the third axis of
/// the plane (isel manual 2.2.27).
pub fn helix(
    radius: u32,
    start_deg: f64,
    end_deg: f64,
    direction: CircleDirection,
    speed: u32,
    s3: i32,
) -> Result<HelixMove, CircleError> {
    if !STEPS.contains(&s3) {
        return Err(CircleError::BadThirdAxisSteps(s3));
    }
    let arc = circle(radius, start_deg, end_deg, direction, speed)?;
    Ok(HelixMove {
        direction,
        params: HelixParams {
            circle: arc.params,
            s3,
        },
    })
}

/// The sweep in degrees, in (0, 360].
fn sweep_deg(start_deg: f64, end_deg: f64, direction: CircleDirection) -> f64 {
    let raw = match direction {
        CircleDirection::Ccw => end_deg - start_deg,
        CircleDirection::Cw => start_deg - end_deg,
    };
    let sweep = raw.rem_euclid(360.0);
    // Equal angles (up to rounding noise) mean a full circle.
    if sweep < 1e-9 || 360.0 - sweep < 1e-9 {
        360.0
    } else {
        sweep
    }
}

/// The Manhattan length of the arc of `radius` from `start_deg` over
/// `sweep_deg` in `direction`: the total travel of both axes, which is what
/// the walk's step count follows.
fn manhattan_length(
    radius: f64,
    start_deg: f64,
    sweep_deg: f64,
    direction: CircleDirection,
) -> f64 {
    use std::f64::consts::FRAC_PI_2;
    // The same points as the arc swept counter-clockwise from its lower end.
    let from = match direction {
        CircleDirection::Ccw => start_deg,
        CircleDirection::Cw => start_deg - sweep_deg,
    }
    .to_radians();
    let to = from + sweep_deg.to_radians();
    let first = (from / FRAC_PI_2).floor();
    let mut total = 0.0;
    // Both coordinates are monotonic within a quadrant; a sweep of at most
    // 360° touches at most 5 quadrants.
    for k in 0..6 {
        let lo = from.max((first + f64::from(k)) * FRAC_PI_2);
        let hi = to.min((first + f64::from(k + 1)) * FRAC_PI_2);
        if hi > lo {
            total += (hi.cos() - lo.cos()).abs() + (hi.sin() - lo.sin()).abs();
        }
    }
    radius * total
}

/// How many steps of `walk` bring it nearest the end of the arc from
/// `start_deg` over `sweep_deg` (manual 2.3.2, "Berechnung mittels
/// Softwareroutine"). The walk's step count stays within a few steps of the
/// arc's Manhattan length, so only a window around it is searched; the
/// window is narrower than half a lap, so a full circle cannot end on its
/// start point.
fn steps_to_end(
    walk: ArcWalk,
    radius: f64,
    start_deg: f64,
    sweep_deg: f64,
    direction: CircleDirection,
) -> u64 {
    let expected = manhattan_length(radius, start_deg, sweep_deg, direction);
    let end = match direction {
        CircleDirection::Ccw => start_deg + sweep_deg,
        CircleDirection::Cw => start_deg - sweep_deg,
    }
    .to_radians();
    let target = (radius * end.cos(), radius * end.sin());
    let distance = |(x, y): (i64, i64)| (x as f64 - target.0).hypot(y as f64 - target.1);
    let margin = (2.0 * radius).min(WINDOW);
    let first = (expected - margin).max(0.0).floor() as u64;
    let last = (expected + margin).ceil() as u64;
    let mut walk = walk;
    walk.advance(first);
    // The window walked twice: first for the least squared distance from
    // the end, then taking `hypot` (what decides) only of the points whose
    // square is within a relative 1e-9 of that least one. A square is
    // within a few units in the last place of the exact one and `hypot`
    // within one, so a point left out is farther than the nearest by
    // `hypot` too, and the choice among the rest is the one among all; a
    // step of the walk costs less than a `hypot`.
    let square = |(x, y): (i64, i64)| {
        let (dx, dy) = (x as f64 - target.0, y as f64 - target.1);
        dx * dx + dy * dy
    };
    // The window's points are kept for the second look (it holds at most
    // 2 WINDOW + 2 of them); were it ever longer, the walk is walked again.
    let at_first = walk;
    let mut kept = [(0i64, 0i64); 64];
    let count = usize::try_from(last - first + 1).unwrap_or(usize::MAX);
    let all_kept = count <= kept.len();
    let mut least = f64::INFINITY;
    let n = if all_kept {
        kept[0] = walk.point();
        walk.fill(&mut kept[1..count]);
        for &point in &kept[..count] {
            least = least.min(square(point));
        }
        count
    } else {
        for k in first..=last {
            if k > first {
                walk.step();
            }
            least = least.min(square(walk.point()));
        }
        0
    };
    let bound = least * (1.0 + 1e-9);
    // Each case its own loop: through a `dyn` iterator the kept points
    // were a call each, some fifty an arc.
    let best = if all_kept {
        let kept = (first..).zip(kept[..n].iter().copied());
        nearest(kept, bound, expected, square, distance)
    } else {
        let walked = (first..=last).scan(at_first, |w, k| {
            if k > first {
                w.step();
            }
            Some((k, w.point()))
        });
        nearest(walked, bound, expected, square, distance)
    };
    best.map_or(first, |(_, k)| k)
}

/// The point of `points` nearest the end by `distance` (`hypot`), of
/// those whose `square` is within `bound`; of equally near ones, the one
/// whose step count is nearest `expected`. Its distance and step count.
fn nearest(
    points: impl Iterator<Item = (u64, (i64, i64))>,
    bound: f64,
    expected: f64,
    square: impl Fn((i64, i64)) -> f64,
    distance: impl Fn((i64, i64)) -> f64,
) -> Option<(f64, u64)> {
    let mut best: Option<(f64, u64)> = None;
    for (k, point) in points {
        if square(point) > bound {
            continue;
        }
        let d = distance(point);
        let nearer = best.is_none_or(|(bd, bk)| {
            d < bd || (d == bd && (k as f64 - expected).abs() < (bk as f64 - expected).abs())
        });
        if nearer {
            best = Some((d, k));
        }
    }
    best
}

/// Half the window [`steps_to_end`] searches: the walk and the arc part by
/// at most a step or two at each axis they cross.
const WINDOW: f64 = 24.0;

fn sign(v: i32) -> Sign {
    if v < 0 { Sign::Minus } else { Sign::Plus }
}

fn flip(s: Sign) -> Sign {
    match s {
        Sign::Minus => Sign::Plus,
        Sign::Plus => Sign::Minus,
    }
}

/// `Rx`, `Ry`: the direction of each coordinate at the start point (manual
/// 2.3.5). CCW motion at (x, y) is (−y, x), CW is (y, −x); a coordinate that
/// is 0 there moves towards the centre along the other one's sign.
fn start_signs(xs: i32, ys: i32, direction: CircleDirection) -> (Sign, Sign) {
    let towards_centre_x = flip(sign(xs));
    let towards_centre_y = flip(sign(ys));
    match direction {
        CircleDirection::Ccw => (
            if ys != 0 {
                flip(sign(ys))
            } else {
                towards_centre_x
            },
            if xs != 0 { sign(xs) } else { towards_centre_y },
        ),
        CircleDirection::Cw => (
            if ys != 0 { sign(ys) } else { towards_centre_x },
            if xs != 0 {
                flip(sign(xs))
            } else {
                towards_centre_y
            },
        ),
    }
}

/// `Summe(n) = |n| (n + 1)` of the manual's worked example 2.3.6.
fn summe(n: i64) -> i64 {
    n.abs() * (n + 1)
}

/// `D = (Rx Ry R + Rx Ry Summe(R−1) − Rx Summe(Xs + (Rx−Ry)/2)
///      + Ry Summe(Ys + (Rx−Ry)/2)) / 2` (decision 12: the example's Y term).
fn interpolation_parameter(r: i64, xs: i32, ys: i32, rx: Sign, ry: Sign) -> i64 {
    let (rx, ry) = (i64::from(rx.value()), i64::from(ry.value()));
    let k = (rx - ry) / 2;
    let total = rx * ry * r + rx * ry * summe(r - 1) - rx * summe(i64::from(xs) + k)
        + ry * summe(i64::from(ys) + k);
    total / 2
}

/// The radius `D` was computed for. `D = (Rx Ry (R + Summe(R − 1)) − Rx
/// Summe(Xs + (Rx−Ry)/2) + Ry Summe(Ys + (Rx−Ry)/2)) / 2` and
/// `R + Summe(R − 1) = R²`, so solving for `R²` gives it back up to the
/// truncated half step. `None` when the parameters give no positive `R²`
/// (hand-made parameters).
pub fn radius_from_parameters(params: &CircleParams) -> Option<f64> {
    let (rx, ry) = (i64::from(params.rx.value()), i64::from(params.ry.value()));
    let k = (rx - ry) / 2;
    let square = rx
        * ry
        * (2 * i64::from(params.d) + rx * summe(i64::from(params.xs) + k)
            - ry * summe(i64::from(params.ys) + k));
    (square > 0).then(|| (square as f64).sqrt())
}

/// Where an arc ends, in steps of the plane's two axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArcEnd {
    /// The end point relative to the circle's centre.
    pub from_centre: (i32, i32),
    /// The end point relative to the start point: the move the tool makes.
    pub from_start: (i32, i32),
}

/// The geometry a `y`/`w` command describes, reconstructed from its
/// parameters: the radius from `D` (which holds `R²`, see
/// [`radius_from_parameters`]) or, if `D` does not fit the start point, from
/// the start point; the end where the controller's walk ([`ArcWalk`]) stands
/// after `B` steps, and the sweep to that end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcGeometry {
    /// Start point relative to the centre, in steps.
    pub start: (f64, f64),
    pub radius: f64,
    /// Start angle in radians.
    pub start_angle: f64,
    /// Signed sweep in radians: positive counter-clockwise.
    pub sweep: f64,
    /// Where the walk ends, relative to the centre.
    pub walk_end: (i64, i64),
}

impl ArcGeometry {
    /// The geometry of `params` run in `direction`. Steps the walk `B`
    /// times (whole laps are skipped, see [`ArcWalk::advance`]).
    pub fn of(params: &CircleParams, direction: CircleDirection) -> ArcGeometry {
        let start = (f64::from(params.xs), f64::from(params.ys));
        let rounded = start.0.hypot(start.1);
        let radius = radius_from_parameters(params)
            .filter(|r| (r - rounded).abs() <= 2.0_f64.max(rounded * 0.01))
            .unwrap_or(rounded);
        let first = ArcWalk::new(
            radius.round() as i64,
            (i64::from(params.xs), i64::from(params.ys)),
            direction,
        );
        let mut walk = first;
        walk.advance(u64::from(params.arc_length));
        let magnitude = walk.swept_since(&first);
        let sweep = match direction {
            CircleDirection::Ccw => magnitude,
            CircleDirection::Cw => -magnitude,
        };
        ArcGeometry {
            start,
            radius,
            start_angle: start.1.atan2(start.0),
            sweep,
            walk_end: walk.point(),
        }
    }

    /// The point a fraction `t` (0 = start, 1 = end) along the arc, relative
    /// to the centre; for previews. It follows the circle, which the walk
    /// keeps within a step of.
    pub fn point_at(&self, t: f64) -> (f64, f64) {
        let angle = self.start_angle + self.sweep * t.clamp(0.0, 1.0);
        (self.radius * angle.cos(), self.radius * angle.sin())
    }

    /// Where the walk ends.
    pub fn end(&self) -> ArcEnd {
        let narrow = |v: i64| i32::try_from(v).unwrap_or(if v < 0 { i32::MIN } else { i32::MAX });
        let (x, y) = (narrow(self.walk_end.0), narrow(self.walk_end.1));
        let (sx, sy) = (self.start.0 as i32, self.start.1 as i32);
        ArcEnd {
            from_centre: (x, y),
            from_start: (x.saturating_sub(sx), y.saturating_sub(sy)),
        }
    }
}

impl CircleParams {
    /// Where this arc leaves the tool when run in `direction` (the direction
    /// of the last `f`): where the controller's walk stands after `B` steps.
    /// That is within a step of the arc's end when `B` came from
    /// [`circle`]; the manual still advises an absolute move after a circle
    /// (2.3.2) to land on the exact end.
    pub fn end_point(&self, direction: CircleDirection) -> ArcEnd {
        ArcGeometry::of(self, direction).end()
    }
}

/// Where an arc of `radius` from `start_deg` to `end_deg` ends, from the
/// angles themselves (the intended end, before `B` is rounded).
pub fn arc_end(radius: u32, start_deg: f64, end_deg: f64) -> ArcEnd {
    let r = f64::from(radius);
    let point = |deg: f64| {
        let a = deg.to_radians();
        ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
    };
    let (sx, sy) = point(start_deg);
    let (ex, ey) = point(end_deg);
    ArcEnd {
        from_centre: (ex, ey),
        from_start: (ex - sx, ey - sy),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(r: u32, a: f64, e: f64, dir: CircleDirection) -> CircleParams {
        match circle(r, a, e, dir, 1000) {
            Ok(m) => m.params,
            Err(err) => panic!("{r} {a} {e}: {err}"),
        }
    }

    /// `B` as the walk gives it step by step, with no leap (the reference
    /// for [`steps_to_end`], which leaps to its window's first step): the
    /// same window and the same choice of its nearest step.
    fn steps_to_end_stepped(r: u32, start_deg: f64, end_deg: f64, dir: CircleDirection) -> u64 {
        let radius = f64::from(r);
        let sweep = sweep_deg(start_deg, end_deg, dir);
        let a = start_deg.to_radians();
        let start = (
            (radius * a.cos()).round() as i64,
            (radius * a.sin()).round() as i64,
        );
        let mut walk = ArcWalk::new(i64::from(r), start, dir);
        let expected = manhattan_length(radius, start_deg, sweep, dir);
        let end = match dir {
            CircleDirection::Ccw => start_deg + sweep,
            CircleDirection::Cw => start_deg - sweep,
        }
        .to_radians();
        let target = (radius * end.cos(), radius * end.sin());
        let distance = |(x, y): (i64, i64)| (x as f64 - target.0).hypot(y as f64 - target.1);
        let margin = (2.0 * radius).min(WINDOW);
        let first = (expected - margin).max(0.0).floor() as u64;
        let last = (expected + margin).ceil() as u64;
        let mut best: Option<(f64, u64)> = None;
        for k in 0..=last {
            if k > 0 {
                walk.step();
            }
            if k < first {
                continue;
            }
            let d = distance(walk.point());
            let nearer = best.is_none_or(|(bd, bk)| {
                d < bd || (d == bd && (k as f64 - expected).abs() < (bk as f64 - expected).abs())
            });
            if nearer {
                best = Some((d, k));
            }
        }
        best.map_or(0, |b| b.1)
    }

    #[test]
    fn small_circles_give_the_stepped_walks_b_at_every_start_and_sweep() {
        // Every radius up to 60 steps, where ties between window points
        // are most common: starts every 7.5 degrees, sweeps from a hair to
        // a full turn, both ways.
        for radius in 1..=60u32 {
            for s in 0..48 {
                let start = f64::from(s) * 7.5;
                for sweep in [
                    0.3, 1.0, 10.0, 45.0, 89.9, 90.0, 135.5, 180.0, 271.0, 359.99, 360.0,
                ] {
                    for dir in [CircleDirection::Ccw, CircleDirection::Cw] {
                        let end = match dir {
                            CircleDirection::Ccw => start + sweep,
                            CircleDirection::Cw => start - sweep,
                        };
                        let b = steps_to_end_stepped(radius, start, end, dir);
                        let got = circle(radius, start, end, dir, 1000)
                            .map_or(0, |arc| u64::from(arc.params.arc_length));
                        assert_eq!(got, b, "R {radius} from {start} to {end} {dir:?}");
                    }
                }
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(3000))]

        /// `circle`'s `B`, found by leaping to its window, is the one the
        /// walk gives step by step, and `end_point` (which leaps `B` steps)
        /// ends where `B` single steps do: tiny radii and large ones, arcs
        /// within a quadrant and across several, full circles.
        #[test]
        fn leaping_gives_the_stepped_walks_b_and_end(
            radius in proptest::prop_oneof![1u32..=12, 13u32..=400, 401u32..=200_000],
            start in -360.0f64..360.0,
            sweep in proptest::prop_oneof![0.0f64..5.0, 0.0f64..360.0, proptest::prelude::Just(360.0)],
            ccw in proptest::bool::ANY,
        ) {
            let dir = if ccw { CircleDirection::Ccw } else { CircleDirection::Cw };
            let end = if ccw { start + sweep } else { start - sweep };
            let b = steps_to_end_stepped(radius, start, end, dir);
            match circle(radius, start, end, dir, 1000) {
                Err(CircleError::ArcTooShort) => proptest::prop_assert_eq!(b, 0),
                // D overflows for radii above about 46 340 at some starts.
                Err(CircleError::ParameterTooLarge(_)) => proptest::prop_assert!(radius > 46_000),
                Err(e) => proptest::prop_assert!(false, "{}", e),
                Ok(arc) => {
                    proptest::prop_assert_eq!(u64::from(arc.params.arc_length), b);
                    let mut walk = ArcWalk::new(
                        i64::from(radius),
                        (i64::from(arc.params.xs), i64::from(arc.params.ys)),
                        dir,
                    );
                    for _ in 0..b {
                        walk.step();
                    }
                    let (x, y) = walk.point();
                    proptest::prop_assert_eq!(
                        arc.params.end_point(dir).from_centre,
                        (x as i32, y as i32)
                    );
                }
            }
        }
    }

    #[test]
    fn the_manuals_worked_example_comes_out_exactly() {
        let arc = circle(200, 135.0, 225.0, CircleDirection::Ccw, 1500);
        let expected = CircleParams {
            arc_length: 400,
            speed: 1500,
            d: 119,
            xs: -141,
            ys: 141,
            rx: Sign::Minus,
            ry: Sign::Minus,
        };
        assert_eq!(
            arc,
            Ok(CircleMove {
                direction: CircleDirection::Ccw,
                params: expected
            })
        );
        assert_eq!(
            CncCommand::Circle(expected).to_string(),
            "y400,1500,119,-141,141,-1,-1"
        );
    }

    #[test]
    fn signs_follow_the_quadrant_diagrams() {
        // Manual 2.3.5: CCW, Rx = -1 in quadrants I and II, +1 in III and IV;
        // CW the other way round. Ry is the sign of the y motion.
        use CircleDirection::{Ccw, Cw};
        let s = |a: f64, dir| {
            let p = params(1000, a, a + 10.0, dir);
            (p.rx.value(), p.ry.value())
        };
        assert_eq!(s(45.0, Ccw), (-1, 1));
        assert_eq!(s(135.0, Ccw), (-1, -1));
        assert_eq!(s(225.0, Ccw), (1, -1));
        assert_eq!(s(315.0, Ccw), (1, 1));
        assert_eq!(s(45.0, Cw), (1, -1));
        assert_eq!(s(135.0, Cw), (1, 1));
        assert_eq!(s(225.0, Cw), (-1, 1));
        assert_eq!(s(315.0, Cw), (-1, -1));
        // On the boundaries the arc's next quadrant decides.
        assert_eq!(s(0.0, Ccw), (-1, 1)); // into I
        assert_eq!(s(90.0, Ccw), (-1, -1)); // into II
        assert_eq!(s(180.0, Ccw), (1, -1)); // into III
        assert_eq!(s(270.0, Ccw), (1, 1)); // into IV
        assert_eq!(s(0.0, Cw), (-1, -1)); // into IV
        assert_eq!(s(90.0, Cw), (1, -1)); // into I
        assert_eq!(s(180.0, Cw), (1, 1)); // into II
        assert_eq!(s(270.0, Cw), (-1, 1)); // into III
    }

    #[test]
    fn arcs_crossing_zero_and_full_circles() {
        let p = params(100, 300.0, 30.0, CircleDirection::Ccw);
        assert_eq!(p.arc_length, 200); // 90 degrees = 2 R
        let p = params(100, 30.0, 300.0, CircleDirection::Cw);
        assert_eq!(p.arc_length, 200);
        let full = params(100, 45.0, 45.0, CircleDirection::Cw);
        assert_eq!(full.arc_length, 800);
        let full = params(100, 0.0, 360.0, CircleDirection::Ccw);
        assert_eq!(full.arc_length, 800);
        let p = params(100, -90.0, 0.0, CircleDirection::Ccw);
        assert_eq!((p.xs, p.ys, p.arc_length), (0, -100, 200));
    }

    #[test]
    fn nonsense_is_refused() {
        use CircleDirection::Ccw;
        assert_eq!(circle(0, 0.0, 90.0, Ccw, 100), Err(CircleError::ZeroRadius));
        assert_eq!(
            circle(100, 0.0, 90.0, Ccw, 0),
            Err(CircleError::BadSpeed(0))
        );
        assert_eq!(
            circle(100, 0.0, 90.0, Ccw, 40_001),
            Err(CircleError::BadSpeed(40_001))
        );
        assert!(matches!(
            circle(100, f64::NAN, 90.0, Ccw, 100),
            Err(CircleError::BadAngle { which: "start", .. })
        ));
        assert!(matches!(
            circle(100, 0.0, f64::INFINITY, Ccw, 100),
            Err(CircleError::BadAngle { which: "end", .. })
        ));
        assert_eq!(circle(1, 0.0, 1.0, Ccw, 100), Err(CircleError::ArcTooShort));
        assert_eq!(
            circle(9_000_000, 0.0, 90.0, Ccw, 100),
            Err(CircleError::RadiusTooLarge(9_000_000))
        );
        // Decision 12's D is near R² - Xs² - Ys² for some start quadrants and
        // near R² for others, where a radius above about 46340 overflows it.
        assert!(circle(8_388_607, 30.0, 200.0, Ccw, 100).is_ok());
        assert_eq!(
            circle(46_342, 0.0, 0.0, CircleDirection::Cw, 1),
            Err(CircleError::ParameterTooLarge(2_147_604_135))
        );
        assert_eq!(
            helix(100, 0.0, 90.0, Ccw, 100, 9_000_000),
            Err(CircleError::BadThirdAxisSteps(9_000_000))
        );
    }

    #[test]
    fn helix_adds_the_third_axis() {
        let h = helix(200, 135.0, 225.0, CircleDirection::Ccw, 1500, 6000);
        assert_eq!(
            h.map(|h| Command::Helix(h.params).to_string()),
            Ok("w400,1500,119,-141,141,-1,-1,6000".to_string())
        );
    }

    #[test]
    fn end_points_from_angles_and_from_parameters_agree() {
        let p = params(200, 135.0, 225.0, CircleDirection::Ccw);
        let end = p.end_point(CircleDirection::Ccw);
        assert_eq!(end, arc_end(200, 135.0, 225.0));
        assert_eq!(end.from_centre, (-141, -141));
        assert_eq!(end.from_start, (0, -282));
        let quarter = params(1000, 0.0, 270.0, CircleDirection::Cw);
        assert_eq!(
            quarter.end_point(CircleDirection::Cw).from_centre,
            (0, -1000)
        );
        let full = params(500, 10.0, 10.0, CircleDirection::Ccw);
        assert_eq!(full.end_point(CircleDirection::Ccw).from_start, (0, 0));
        assert_eq!(radius_from_parameters(&p), Some(200.0));
        // The manual's helix example was made for a radius of about 2000.
        let example = CircleParams {
            arc_length: 32000,
            speed: 600,
            d: -1000,
            xs: -2000,
            ys: 0,
            rx: Sign::Plus,
            ry: Sign::Minus,
        };
        assert!(radius_from_parameters(&example).is_some_and(|r| (r - 2000.0).abs() < 2.0));
        let g = ArcGeometry::of(&p, CircleDirection::Ccw);
        let mid = g.point_at(0.5);
        assert!((mid.0 + 200.0).abs() < 0.5 && mid.1.abs() < 0.5);
    }
}
