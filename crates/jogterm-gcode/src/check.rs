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
pub fn check_limits_ops<O: Borrow<Op>>(
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
    let mut first_system = None;
    let mut length = 0.0;
    let mut moves = 0;
    let mut arcs = 0;
    let mut time = 0.0;
    for (index, op) in path.ops.iter().enumerate() {
        match op {
            Op::WorkOffset {
                system, zero: z, ..
            } => {
                zero = *z;
                first_system.get_or_insert((*system, *z));
            }
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
    let (system, zero) = first_system.unwrap_or((System::G54, Point::default()));
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
