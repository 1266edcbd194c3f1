//! The machine, before anything moves: every point of the toolpath (arc
//! bulges included) against the axes' soft limits, and the figures the
//! import prints: extents in the file's own work coordinates, path length,
//! moves, arcs and the estimated time.

use std::borrow::Borrow;
use std::f64::consts::PI;
use std::ops::RangeInclusive;
use std::sync::LazyLock;

use crate::offsets::System;
use jogterm_proto::axis::Axis;

use super::interp::{end_angles, get, plane_axes, radius, sweep_between};
use super::toolpath::{Arc, Diagnostic, Op, Origin, Point, Severity, Toolpath};

/// Soft limits of X, Y and Z in machine mm, and their speeds.
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    /// `(axis, min, max, max_speed mm/s)` for each axis the machine has.
    pub axes: Vec<(Axis, f64, f64, f64)>,
    /// G0's path speed, mm/s (`None`: each axis at its own `max_speed`).
    pub rapid_speed: Option<f64>,
    /// Steps per mm of each axis, for the controller's position counter.
    pub steps_per_mm: Vec<(Axis, f64)>,
    /// The positions in steps the controller's counter holds (isel 24-bit,
    /// EMCU ±999999): a point beyond is refused at its G-code line, not by
    /// the controller at a line of the converted program (issue 37).
    pub counter: RangeInclusive<i64>,
    /// Whose counter it is, for the message.
    pub controller: &'static str,
}

impl Machine {
    fn max_speed(&self, axis: Axis) -> f64 {
        self.axes
            .iter()
            .find(|(a, ..)| *a == axis)
            .map_or(f64::INFINITY, |(.., s)| *s)
    }
}

/// Extents per axis, min and max.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extents {
    pub min: Point,
    pub max: Point,
}

impl Extents {
    fn empty() -> Extents {
        Extents {
            min: Point {
                x: f64::INFINITY,
                y: f64::INFINITY,
                z: f64::INFINITY,
            },
            max: Point {
                x: f64::NEG_INFINITY,
                y: f64::NEG_INFINITY,
                z: f64::NEG_INFINITY,
            },
        }
    }

    /// Adds the coordinates of `p` the file has named by op `index`.
    fn add(&mut self, path: &Toolpath, index: usize, p: Point) {
        for (axis, v) in [p.x, p.y, p.z].into_iter().enumerate() {
            if !path.named(axis, index) {
                continue;
            }
            let (min, max) = match axis {
                0 => (&mut self.min.x, &mut self.max.x),
                1 => (&mut self.min.y, &mut self.max.y),
                _ => (&mut self.min.z, &mut self.max.z),
            };
            *min = min.min(v);
            *max = max.max(v);
        }
    }

    /// Whether the file moves no axis at all.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x && self.min.y > self.max.y && self.min.z > self.max.z
    }

    /// An axis' range, if the file moves it.
    pub fn range(&self, axis: usize) -> Option<(f64, f64)> {
        let (min, max) = match axis {
            0 => (self.min.x, self.max.x),
            1 => (self.min.y, self.max.y),
            _ => (self.min.z, self.max.z),
        };
        (min <= max).then_some((min, max))
    }
}

/// What the import reports of a toolpath.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// In the file's work coordinates (each point less the zero in force).
    pub extents: Extents,
    pub length_mm: f64,
    pub moves: usize,
    pub arcs: usize,
    /// Motion at the programmed feeds and rapid speeds, plus dwells; no
    /// ramps (the controller's acceleration adds to it).
    pub estimated_s: f64,
    pub system: System,
    pub zero: Point,
}

/// The points of an arc that decide its extents: both ends and every
/// quadrant point it passes (the bulges).
pub fn arc_extreme_points(arc: &Arc) -> Vec<Point> {
    let (points, len) = extreme_points(arc);
    points.get(..len).unwrap_or_default().to_vec()
}

/// [`arc_extreme_points`] on the stack: the first `len` of the array (at
/// most six: both ends and four quadrant points). The check and the
/// summary take it for every arc of the file, without a Vec each.
fn extreme_points(arc: &Arc) -> ([Point; 6], usize) {
    let e = extremes(arc);
    (e.points, e.len)
}

/// An arc's extreme points with the radius and sweep they were found
/// with, which the summary needs too (each is two or three calls into
/// libm, and the summary takes them for every arc of the file).
struct Extremes {
    points: [Point; 6],
    len: usize,
    radius: f64,
    sweep: f64,
}

/// The quadrant angles 0, π/2, π, 3π/2 with their cosine and sine, as
/// `extremes` computed them for every arc: once.
static QUADRANTS: LazyLock<[(f64, f64, f64); 4]> = LazyLock::new(|| {
    [0u8, 1, 2, 3].map(|k| {
        let q = f64::from(k) * PI / 2.0;
        (q, q.cos(), q.sin())
    })
});

fn extremes(arc: &Arc) -> Extremes {
    let (u, v, n) = plane_axes(arc.plane);
    let mut points = [arc.from; 6];
    points[1] = arc.to;
    let mut len = 2;
    let r = radius(arc);
    let (cu, cv) = (get(arc.centre, u), get(arc.centre, v));
    // The start's angle is the one the sweep is taken from.
    let (a0, a1) = end_angles(arc);
    let total = sweep_between(arc, a0, a1);
    let dir = if arc.clockwise { -1.0 } else { 1.0 };
    for &(q, cos, sin) in QUADRANTS.iter() {
        // The sweep from the start to this quadrant angle, in the arc's direction.
        let d = (dir * (q - a0)).rem_euclid(2.0 * PI);
        if d <= total {
            let t = d / total;
            let mut p = arc.from;
            super::interp::set(&mut p, u, cu + r * cos);
            super::interp::set(&mut p, v, cv + r * sin);
            super::interp::set(
                &mut p,
                n,
                get(arc.from, n) + (get(arc.to, n) - get(arc.from, n)) * t,
            );
            if let Some(slot) = points.get_mut(len) {
                *slot = p;
                len += 1;
            }
        }
    }
    Extremes {
        points,
        len,
        radius: r,
        sweep: total,
    }
}

fn distance(a: Point, b: Point) -> f64 {
    ((a.x - b.x).powi(2) + (a.y - b.y).powi(2) + (a.z - b.z).powi(2)).sqrt()
}

fn sub(a: Point, b: Point) -> Point {
    Point {
        x: a.x - b.x,
        y: a.y - b.y,
        z: a.z - b.z,
    }
}

/// The soft-limit check: the first point of the first op that leaves a
/// limit, as an error at that op's line.
pub fn check_limits(path: &Toolpath, machine: &Machine) -> Result<(), Diagnostic> {
    check_limits_ops(&path.ops, machine)
}

/// [`check_limits`] of ops given one at a time (the import's whole job,
/// the slices of `Plan::expanded_slices`, is not collected into a toolpath).
///
/// A job inside its limits, as nearly every job is, is known to be so
/// from a box around its points (`job_box`, `box_within`), without each
/// arc's extreme points (two arc tangents and a root an arc) and the tests
/// of every point; only a job whose box reaches a limit is walked point by
/// point (`first_beyond`) for the first point beyond.
pub fn check_limits_ops<O, I>(ops: I, machine: &Machine) -> Result<(), Diagnostic>
where
    O: Borrow<Op>,
    I: IntoIterator<Item = O>,
    I::IntoIter: Clone,
{
    let ops = ops.into_iter();
    if job_box(ops.clone()).is_some_and(|b| box_within(&b, machine)) {
        return Ok(());
    }
    first_beyond(ops, machine)
}

/// Per axis (X, Y, Z) the least and the greatest coordinate a point of a
/// job can have, for [`box_within`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct JobBox {
    lo: [f64; 3],
    hi: [f64; 3],
}

/// A box that holds every point [`first_beyond`] tests: the ends of the
/// straight moves, and of each arc the box of its whole circle (centre ±
/// a bound of the radius, in its plane) and its ends; `None` where a
/// coordinate is not finite (the walk says what of it).
fn job_box<O: Borrow<Op>>(ops: impl Iterator<Item = O>) -> Option<JobBox> {
    let mut b = JobBox {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };
    let mut finite = true;
    let mut add = |p: Point| {
        for (k, v) in [p.x, p.y, p.z].into_iter().enumerate() {
            b.lo[k] = b.lo[k].min(v);
            b.hi[k] = b.hi[k].max(v);
        }
        // A sum of finite numbers may overflow: then the walk decides.
        finite &= (p.x + p.y + p.z).is_finite();
    };
    for op in ops {
        match op.borrow() {
            Op::Rapid(m) => add(m.to),
            Op::Line(m) => add(m.to),
            Op::Arc(a) => {
                add(a.from);
                add(a.to);
                let (lo, hi) = circle_box(a);
                add(lo);
                add(hi);
            }
            _ => {}
        }
    }
    // The interpolated coordinate of a helix' quadrant points may round a
    // few units in the last place beyond its ends: the box is widened by
    // a thousand times more, still well within the check's 1e-9 mm of
    // slack (a job may stand exactly on a limit, as at machine zero).
    for k in 0..3 {
        let margin = 1e-12 * (1.0 + b.lo[k].abs().max(b.hi[k].abs()));
        b.lo[k] -= margin;
        b.hi[k] += margin;
    }
    finite.then_some(b)
}

/// Two corners of a box around an arc's circle: in its plane its centre
/// ± `|du| + |dv|` (no less than the radius `hypot(du, dv)`, raised by a
/// relative 1e-12 for the roundings; a quadrant point is the centre plus
/// the radius times a cosine or sine, a rounded product never beyond the
/// radius), along its normal the start's (its quadrant points lie between
/// its ends there, which the box holds besides).
fn circle_box(arc: &Arc) -> (Point, Point) {
    let (u, v, _) = plane_axes(arc.plane);
    let (cu, cv) = (get(arc.centre, u), get(arc.centre, v));
    let bound = ((get(arc.from, u) - cu).abs() + (get(arc.from, v) - cv).abs()) * (1.0 + 1e-12);
    let (mut lo, mut hi) = (arc.from, arc.from);
    super::interp::set(&mut lo, u, cu - bound);
    super::interp::set(&mut lo, v, cv - bound);
    super::interp::set(&mut hi, u, cu + bound);
    super::interp::set(&mut hi, v, cv + bound);
    (lo, hi)
}

/// Whether every point in the box passes [`first_beyond`]'s tests: the
/// soft limits (with their 1e-9 mm of slack) and the position counter
/// (steps rise or fall with the coordinate, so the box's ends bound them).
fn box_within(b: &JobBox, machine: &Machine) -> bool {
    // The box is of X, Y and Z; any other axis is left to the walk.
    let xyz = |axis: Axis| match axis {
        Axis::X => Some(0),
        Axis::Y => Some(1),
        Axis::Z => Some(2),
        _ => None,
    };
    let limits = machine.axes.iter().all(|(axis, min, max, _)| {
        xyz(*axis).is_some_and(|k| b.lo[k] >= min - 1e-9 && b.hi[k] <= max + 1e-9)
    });
    let (lo, hi) = (
        *machine.counter.start() as f64,
        *machine.counter.end() as f64,
    );
    let counter = machine.steps_per_mm.iter().all(|(axis, spu)| {
        xyz(*axis).is_some_and(|k| {
            [b.lo[k], b.hi[k]].into_iter().all(|v| {
                let steps = super::num::round(v * spu);
                steps >= lo && steps <= hi
            })
        })
    });
    limits && counter
}

/// The soft-limit check point by point: the first point beyond a limit
/// or the counter, as an error at its op's line.
fn first_beyond<O: Borrow<Op>>(
    ops: impl IntoIterator<Item = O>,
    machine: &Machine,
) -> Result<(), Diagnostic> {
    let mut system = (System::G54, Point::default());
    for op in ops {
        let op: &Op = op.borrow();
        // A straight move's one point is borrowed, not put into a Vec of
        // its own: this runs for every move of the file.
        let arc_points;
        let (points, origin): (&[Point], Origin) = match op {
            Op::Rapid(m) => (std::slice::from_ref(&m.to), m.origin),
            Op::Line(m) => (std::slice::from_ref(&m.to), m.origin),
            Op::Arc(a) => {
                arc_points = extreme_points(a);
                (
                    arc_points.0.get(..arc_points.1).unwrap_or_default(),
                    a.origin,
                )
            }
            Op::WorkOffset {
                system: s, zero, ..
            } => {
                system = (*s, *zero);
                continue;
            }
            _ => continue,
        };
        for &p in points {
            for (axis, min, max, _) in &machine.axes {
                let v = get(p, *axis);
                let (side, limit) = if v < min - 1e-9 {
                    ("below", *min)
                } else if v > max + 1e-9 {
                    ("above", *max)
                } else {
                    continue;
                };
                let zero = get(system.1, *axis);
                return Err(Diagnostic {
                    severity: Severity::Error,
                    origin,
                    message: format!(
                        "{axis} {v:.3} mm is {side} the soft limit {limit:.3} mm of axis {axis} (work offset {}: {axis} zero at machine {zero:.3} mm, so the file's {axis} {:.3})",
                        system.0,
                        v - zero
                    ),
                });
            }
            for (axis, spu) in &machine.steps_per_mm {
                let v = get(p, *axis);
                let steps = super::num::round(v * spu);
                let (lo, hi) = (machine.counter.start(), machine.counter.end());
                if steps >= *lo as f64 && steps <= *hi as f64 {
                    continue;
                }
                return Err(Diagnostic {
                    severity: Severity::Error,
                    origin,
                    message: format!(
                        "{axis} {v:.3} mm is {steps:.0} steps from the reference point: beyond the {} controller's position counter ({lo}..{hi} steps); lower the axis' max or its steps_per_unit in the profile",
                        machine.controller
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Extents, length, counts and the time estimate. Extents hold the points
/// the file moves to (and arcs' bulges), not where the tool stood before
/// its first move.
pub fn summarise(path: &Toolpath, machine: &Machine) -> Summary {
    let mut extents = Extents::empty();
    let mut zero = Point::default();
    let mut length = 0.0;
    let mut moves = 0;
    let mut arcs = 0;
    let mut time = 0.0;
    for (index, op) in path.ops.iter().enumerate() {
        match op {
            Op::WorkOffset { zero: z, .. } => zero = *z,
            Op::Rapid(m) => {
                moves += 1;
                extents.add(path, index, sub(m.to, zero));
                let d = distance(m.from, m.to);
                length += d;
                time += rapid_time(m.from, m.to, machine);
            }
            Op::Line(m) => {
                moves += 1;
                extents.add(path, index, sub(m.to, zero));
                let d = distance(m.from, m.to);
                length += d;
                time += d / (m.feed / 60.0);
            }
            Op::Arc(a) => {
                arcs += 1;
                let e = extremes(a);
                for &p in e.points.get(..e.len).unwrap_or_default() {
                    extents.add(path, index, sub(p, zero));
                }
                let (_, _, n) = plane_axes(a.plane);
                let planar = e.radius * e.sweep;
                let rise = get(a.to, n) - get(a.from, n);
                let d = planar.hypot(rise);
                length += d;
                time += d / (a.feed / 60.0);
            }
            Op::Dwell(d) => time += d.seconds,
            _ => {}
        }
    }
    let (system, zero) = first_system(path);
    Summary {
        extents,
        length_mm: length,
        moves,
        arcs,
        estimated_s: time,
        system,
        zero,
    }
}

/// The work offset a toolpath starts in, as its summary says it
/// ([`Summary::system`], [`Summary::zero`]): its first work offset op's,
/// G54 at the origin for a toolpath that makes none.
pub fn first_system(path: &Toolpath) -> (System, Point) {
    path.ops
        .iter()
        .find_map(|op| match op {
            Op::WorkOffset { system, zero, .. } => Some((*system, *zero)),
            _ => None,
        })
        .unwrap_or((System::G54, Point::default()))
}

fn rapid_time(from: Point, to: Point, machine: &Machine) -> f64 {
    let d = distance(from, to);
    if let Some(speed) = machine.rapid_speed {
        return d / speed;
    }
    // Each axis at most its own speed: the slowest one decides.
    [Axis::X, Axis::Y, Axis::Z]
        .into_iter()
        .map(|a| (get(to, a) - get(from, a)).abs() / machine.max_speed(a))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    //! The box of a job against the walk it stands in for: wherever the
    //! box says a job is inside, the walk finds no point beyond.

    use proptest::prelude::*;

    use super::*;
    use crate::toolpath::{Line, Plane, Rapid};

    const ORIGIN: Origin = Origin { line: 1, col: 1 };

    fn in_plane(plane: Plane, (u, v): (f64, f64), n: f64) -> Point {
        let (ua, va, na) = plane_axes(plane);
        let mut p = Point::default();
        super::super::interp::set(&mut p, ua, u);
        super::super::interp::set(&mut p, va, v);
        super::super::interp::set(&mut p, na, n);
        p
    }

    fn arc_op(
        plane: Plane,
        centre: (f64, f64),
        r: f64,
        (a0, a1): (f64, f64),
        (n0, n1): (f64, f64),
        clockwise: bool,
        extra_turns: u32,
    ) -> Op {
        let at = |a: f64| (centre.0 + r * a.cos(), centre.1 + r * a.sin());
        Op::Arc(Box::new(Arc {
            from: in_plane(plane, at(a0), n0),
            to: in_plane(plane, at(a1), n1),
            centre: in_plane(plane, centre, n0),
            plane,
            clockwise,
            extra_turns,
            feed: 100.0,
            origin: ORIGIN,
        }))
    }

    fn op() -> impl Strategy<Value = Op> {
        let point = (-500.0..500.0f64, -500.0..500.0f64, -500.0..500.0f64)
            .prop_map(|(x, y, z)| Point { x, y, z });
        let plane = prop_oneof![Just(Plane::Xy), Just(Plane::Zx), Just(Plane::Yz)];
        prop_oneof![
            point.clone().prop_map(|to| Op::Rapid(Rapid {
                from: Point::default(),
                to,
                origin: ORIGIN,
            })),
            point.prop_map(|to| Op::Line(Line {
                from: Point::default(),
                to,
                feed: 100.0,
                origin: ORIGIN,
            })),
            (
                plane,
                (-300.0..300.0f64, -300.0..300.0f64),
                prop_oneof![0.001..1.0f64, 1.0..200.0f64],
                (-7.0..7.0f64, -7.0..7.0f64),
                (-100.0..100.0f64, -100.0..100.0f64),
                any::<bool>(),
                0u32..3,
            )
                .prop_map(|(plane, c, r, a, n, cw, turns)| arc_op(plane, c, r, a, n, cw, turns)),
        ]
    }

    /// Per axis the least and greatest coordinate of the points the walk
    /// tests.
    fn walked_extent(ops: &[Op]) -> ([f64; 3], [f64; 3]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for op in ops {
            let points = match op {
                Op::Rapid(m) => vec![m.to],
                Op::Line(m) => vec![m.to],
                Op::Arc(a) => arc_extreme_points(a),
                _ => vec![],
            };
            for p in points {
                for (k, v) in [p.x, p.y, p.z].into_iter().enumerate() {
                    lo[k] = lo[k].min(v);
                    hi[k] = hi[k].max(v);
                }
            }
        }
        (lo, hi)
    }

    /// Limits at the walked extent, moved out by `common` or, on the sides
    /// `edge` names, by its own amount (some in, some out, some exactly on
    /// it); a counter at its steps likewise.
    fn machine_at(
        ops: &[Op],
        common: f64,
        edge: [Option<f64>; 6],
        spu: f64,
        counter_slack: i64,
    ) -> Machine {
        let (lo, hi) = walked_extent(ops);
        let axes = [Axis::X, Axis::Y, Axis::Z];
        let out = |k: usize| edge[k].unwrap_or(common);
        let steps = |v: f64| super::super::num::round(v * spu) as i64;
        let lo_steps = (0..3)
            .map(|k| steps(lo[k]).min(steps(hi[k])))
            .min()
            .unwrap_or(0);
        let hi_steps = (0..3)
            .map(|k| steps(lo[k]).max(steps(hi[k])))
            .max()
            .unwrap_or(0);
        Machine {
            axes: (0..3)
                .map(|k| (axes[k], lo[k] - out(2 * k), hi[k] + out(2 * k + 1), 100.0))
                .collect(),
            rapid_speed: None,
            steps_per_mm: axes.iter().map(|&a| (a, spu)).collect(),
            counter: (lo_steps - counter_slack)..=(hi_steps + counter_slack),
            controller: "test",
        }
    }

    fn edge() -> impl Strategy<Value = Option<f64>> {
        prop_oneof![
            12 => Just(None),
            1 => Just(Some(0.0)),
            1 => Just(Some(-1e-9)),
            1 => Just(Some(1e-9)),
            1 => (-1e-6..1e-6f64).prop_map(Some),
            1 => (-1.0..0.0f64).prop_map(Some),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn the_box_says_inside_only_where_the_walk_finds_nothing_beyond(
            ops in prop::collection::vec(op(), 1..8),
            common in prop_oneof![1e-7..1e-5f64, 1e-5..10.0f64],
            edge in prop::array::uniform6(edge()),
            spu in prop_oneof![Just(1.0), Just(80.0), Just(-80.0), 0.5..400.0f64],
            counter_slack in prop_oneof![
                4 => Just(1_000_000_000i64),
                1 => Just(0),
                1 => Just(-1),
                1 => Just(1),
            ],
        ) {
            let machine = machine_at(&ops, common, edge, spu, counter_slack);
            let walked = first_beyond(ops.iter(), &machine);
            if job_box(ops.iter()).is_some_and(|b| box_within(&b, &machine)) {
                prop_assert!(walked.is_ok(), "{walked:?}");
            }
            prop_assert_eq!(check_limits_ops(ops.iter(), &machine), walked);
        }
    }

    #[test]
    fn a_point_not_finite_is_left_to_the_walk() {
        let ops = [Op::Line(Line {
            from: Point::default(),
            to: Point {
                x: f64::NAN,
                y: 0.0,
                z: 0.0,
            },
            feed: 100.0,
            origin: ORIGIN,
        })];
        assert_eq!(job_box(ops.iter()), None);
        let machine = Machine {
            axes: vec![(Axis::X, -10.0, 10.0, 100.0)],
            rapid_speed: None,
            steps_per_mm: vec![(Axis::X, 80.0)],
            counter: -1_000_000..=1_000_000,
            controller: "test",
        };
        assert!(check_limits_ops(ops.iter(), &machine).is_err());
    }
}
