//! Height maps: the probed surface of a work piece that is not flat, and a
//! toolpath made to follow it (issue 39; `docs/gcode.md`, "Height maps").
//!
//! [`HeightMap`] is the file's format, as `jogterm probe grid` writes it and
//! `--height-map FILE` reads it (JSON through serde; the reading is the
//! application's). [`HeightMap::validate`] turns it into a [`Surface`]:
//! a regular grid of surface heights, interpolated bilinearly.
//! [`Surface::apply`] shifts every feed move of an interpreted toolpath
//! by the surface under it, so that a job's Z counts from the surface:
//!
//! - machine Z = the job's machine Z + correction(x, y), with correction =
//!   surface(x, y) − the Z of the map's work zero when it was probed. With
//!   the same Z zero, a job Z of −0.2 cuts 0.2 mm below the surface
//!   everywhere; a Z zero touched again since (another tool) moves the cut
//!   with it, as a Z zero always does.
//! - Straight feed moves are cut where they cross the grid's lines and into
//!   pieces whose X/Y length is at most the spacing; arcs (helices
//!   included) become chords within the profile's chord tolerance, each cut
//!   likewise: a controller's circle cannot follow a surface.
//! - Rapids are raised by the highest correction of the map (never
//!   lowered), at most to Z's upper soft limit: they stay at least as far
//!   above every point of the surface as the file put them above Z zero.
//! - A feed move with any point outside the map's area, or from where the
//!   job starts before the file names X and Y, is an error at its line;
//!   nothing is extrapolated or clamped.
//!
//! Sans-IO: values in, values out.

use serde::{Deserialize, Serialize};

use crate::offsets::System;
use crate::output::{MAX_COMMANDS, chords, too_many};
use crate::toolpath::{Arc, Diagnostic, Line, Op, Origin, Point, Rapid, Toolpath};

/// The format's version this code reads and writes.
pub const VERSION: u32 = 1;

/// The most grid points a map may have: a 1000 x 1000 grid, far beyond
/// what anyone probes (a point takes seconds), near enough that a wrong
/// spacing in a hand-made file is refused before it is allocated.
pub const MAX_POINTS: usize = 1_000_000;

/// How far a point's X or Y may lie from its grid position (mm): a
/// hand-made file's rounding, not another grid.
const GRID_TOLERANCE_MM: f64 = 1e-3;

/// How far outside the area a move may touch and still count as inside
/// (mm): the rounding of machine minus zero, never a real extrapolation.
const AREA_TOLERANCE_MM: f64 = 1e-6;

/// X, Y and Z of one probed point or of a work zero, mm.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Xyz {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// The probed rectangle in work coordinates, mm: corners (x0, y0) and
/// (x1, y1), x0 < x1 and y0 < y1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Area {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

/// A height map file, field for field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeightMap {
    /// [`VERSION`].
    pub version: u32,
    /// When the surface was probed: RFC 3339, UTC (`2026-12-07T09:00:00Z`).
    pub probed_at: String,
    /// The machine profile's name it was probed on.
    pub profile: String,
    /// The work offset active while probing, `G54` … `G59`.
    pub work_offset: String,
    /// That offset's zero then, machine mm.
    pub work_zero_machine_mm: Xyz,
    /// Work coordinates, mm.
    pub area: Area,
    /// The grid's pitch, mm, > 0.
    pub spacing: f64,
    /// Row-major (y outer, x inner) over [`Grid::new`]'s columns and rows:
    /// x and y in work mm, z the surface's machine Z, mm.
    pub points: Vec<Xyz>,
}

/// What is wrong with a height map: the field (`points[12].x`) and what was
/// expected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapError {
    pub field: String,
    pub message: String,
}

impl MapError {
    fn new(field: impl Into<String>, message: impl Into<String>) -> MapError {
        MapError {
            field: field.into(),
            message: message.into(),
        }
    }
}

impl std::fmt::Display for MapError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

impl std::error::Error for MapError {}

/// The grid's columns and rows, work mm: x0, x0 + spacing, … and x1 last
/// even where it is closer than the spacing to the one before; rows
/// likewise. Where `probe grid` probes, in [`Grid::points`]' order.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
}

/// The positions from `from` to `to` by `step`, `to` last: none closer to
/// `to` than the grid tolerance.
fn positions(from: f64, to: f64, step: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut k = 0.0;
    loop {
        let v = from + k * step;
        if v >= to - GRID_TOLERANCE_MM {
            break;
        }
        out.push(v);
        k += 1.0;
    }
    out.push(to);
    out
}

/// How many positions [`positions`] gives, without making them.
fn count(from: f64, to: f64, step: f64) -> f64 {
    ((to - from - GRID_TOLERANCE_MM) / step).ceil().max(0.0) + 1.0
}

impl Grid {
    /// The grid of an area at a spacing; errors name the fields.
    pub fn new(area: Area, spacing: f64) -> Result<Grid, Vec<MapError>> {
        let mut errors = Vec::new();
        for (field, v) in [
            ("area.x0", area.x0),
            ("area.y0", area.y0),
            ("area.x1", area.x1),
            ("area.y1", area.y1),
            ("spacing", spacing),
        ] {
            if !v.is_finite() {
                errors.push(MapError::new(
                    field,
                    format!("expected a number, found {v}"),
                ));
            }
        }
        if !errors.is_empty() {
            return Err(errors);
        }
        if spacing <= 0.0 {
            errors.push(MapError::new(
                "spacing",
                format!("expected more than 0 mm, found {spacing}"),
            ));
        }
        if area.x1 <= area.x0 {
            errors.push(MapError::new(
                "area.x1",
                format!("expected more than x0 ({}), found {}", area.x0, area.x1),
            ));
        }
        if area.y1 <= area.y0 {
            errors.push(MapError::new(
                "area.y1",
                format!("expected more than y0 ({}), found {}", area.y0, area.y1),
            ));
        }
        if !errors.is_empty() {
            return Err(errors);
        }
        let columns = count(area.x0, area.x1, spacing);
        let rows = count(area.y0, area.y1, spacing);
        if columns * rows > MAX_POINTS as f64 {
            return Err(vec![MapError::new(
                "spacing",
                format!(
                    "{spacing} mm over the area makes {columns} x {rows} points, more than {MAX_POINTS}: expected a larger spacing"
                ),
            )]);
        }
        Ok(Grid {
            xs: positions(area.x0, area.x1, spacing),
            ys: positions(area.y0, area.y1, spacing),
        })
    }

    /// Every point, row-major (y outer, x inner): the order of a map's
    /// `points`.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.ys
            .iter()
            .flat_map(move |&y| self.xs.iter().map(move |&x| (x, y)))
    }

    pub fn len(&self) -> usize {
        self.xs.len() * self.ys.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl HeightMap {
    /// A map from a probed grid: `surface_z` holds the machine Z of each of
    /// [`Grid::new`]`(area, spacing)`'s points in [`Grid::points`]' order.
    /// Checked as a file is ([`HeightMap::validate`]).
    pub fn new(
        probed_at_unix: i64,
        profile: &str,
        work_offset: System,
        work_zero_machine_mm: Point,
        area: Area,
        spacing: f64,
        surface_z: &[f64],
    ) -> Result<HeightMap, Vec<MapError>> {
        let grid = Grid::new(area, spacing)?;
        let map = HeightMap {
            version: VERSION,
            probed_at: rfc3339(probed_at_unix),
            profile: profile.to_owned(),
            work_offset: work_offset.to_string(),
            work_zero_machine_mm: Xyz {
                x: work_zero_machine_mm.x,
                y: work_zero_machine_mm.y,
                z: work_zero_machine_mm.z,
            },
            area,
            spacing,
            points: grid
                .points()
                .zip(surface_z)
                .map(|((x, y), &z)| Xyz { x, y, z })
                .collect(),
        };
        if surface_z.len() != grid.len() {
            return Err(vec![MapError::new(
                "points",
                format!(
                    "expected {} x {} = {} heights, found {}",
                    grid.xs.len(),
                    grid.ys.len(),
                    grid.len(),
                    surface_z.len()
                ),
            )]);
        }
        map.validate()?;
        Ok(map)
    }

    /// Every field checked; the surface to interpolate, or every problem
    /// found by its field.
    pub fn validate(&self) -> Result<Surface, Vec<MapError>> {
        let mut errors = Vec::new();
        if self.version != VERSION {
            errors.push(MapError::new(
                "version",
                format!(
                    "expected {VERSION} (the format this jogterm reads), found {}",
                    self.version
                ),
            ));
        }
        let probed_at = parse_rfc3339(&self.probed_at);
        if probed_at.is_none() {
            errors.push(MapError::new(
                "probed_at",
                format!(
                    "expected an RFC 3339 time such as 2026-12-07T09:00:00Z, found \"{}\"",
                    self.probed_at
                ),
            ));
        }
        let system = System::from_name(&self.work_offset);
        if system.is_none() {
            errors.push(MapError::new(
                "work_offset",
                format!("expected G54 … G59, found \"{}\"", self.work_offset),
            ));
        }
        let zero = self.work_zero_machine_mm;
        for (axis, v) in [("x", zero.x), ("y", zero.y), ("z", zero.z)] {
            if !v.is_finite() {
                errors.push(MapError::new(
                    format!("work_zero_machine_mm.{axis}"),
                    format!("expected a number, found {v}"),
                ));
            }
        }
        let grid = match Grid::new(self.area, self.spacing) {
            Ok(g) => Some(g),
            Err(e) => {
                errors.extend(e);
                None
            }
        };
        let mut z = Vec::new();
        if let Some(grid) = &grid {
            if self.points.len() != grid.len() {
                errors.push(MapError::new(
                    "points",
                    format!(
                        "expected {} x {} = {} points (columns x0, x0 + spacing, … x1; rows likewise), found {}",
                        grid.xs.len(),
                        grid.ys.len(),
                        grid.len(),
                        self.points.len()
                    ),
                ));
            } else {
                z = self.grid_errors(grid, &mut errors);
            }
        }
        match (errors.is_empty(), grid, probed_at, system) {
            (true, Some(grid), Some(probed_at_unix), Some(system)) => Ok(Surface {
                grid,
                spacing: self.spacing,
                z,
                zero: Point {
                    x: zero.x,
                    y: zero.y,
                    z: zero.z,
                },
                system,
                profile: self.profile.clone(),
                probed_at_unix,
            }),
            _ => Err(errors),
        }
    }

    /// The points against the grid: each where its column and row say,
    /// each Z a number. Their Z values, in order.
    fn grid_errors(&self, grid: &Grid, errors: &mut Vec<MapError>) -> Vec<f64> {
        // A file with every point wrong says so a few times, not a million.
        const SHOWN: usize = 10;
        let before = errors.len();
        let mut z = Vec::with_capacity(self.points.len());
        for (i, (p, (x, y))) in self.points.iter().zip(grid.points()).enumerate() {
            let (column, row) = (i % grid.xs.len(), i / grid.xs.len());
            for (axis, found, expected, what) in [("x", p.x, x, "column"), ("y", p.y, y, "row")] {
                let place = if what == "column" { column } else { row };
                if !(found - expected).abs().le(&GRID_TOLERANCE_MM) && errors.len() - before < SHOWN
                {
                    errors.push(MapError::new(
                        format!("points[{i}].{axis}"),
                        format!(
                            "expected {expected} ({what} {place} of the grid at spacing {}, row-major), found {found}",
                            self.spacing
                        ),
                    ));
                }
            }
            if !p.z.is_finite() && errors.len() - before < SHOWN {
                errors.push(MapError::new(
                    format!("points[{i}].z"),
                    format!("expected a number, found {}", p.z),
                ));
            }
            z.push(p.z);
        }
        z
    }
}

/// A validated map: the grid and its surface heights, interpolated
/// bilinearly inside the area and nowhere else.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    grid: Grid,
    spacing: f64,
    /// Machine Z of each grid point, row-major.
    z: Vec<f64>,
    /// The work zero while probing, machine mm.
    zero: Point,
    system: System,
    profile: String,
    probed_at_unix: i64,
}

/// What a job is applied with, from the machine profile and the work
/// offsets in force.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The profile the job is imported for (a map of another machine is
    /// refused).
    pub profile: String,
    /// One step of X and of Y, mm: how far the active work zero may lie
    /// from the map's.
    pub step_mm: (f64, f64),
    /// The largest distance of a chord from its arc, mm (the profile's
    /// `gcode.chord_tolerance`).
    pub chord_tolerance: f64,
    /// Z's upper soft limit, machine mm: rapids are raised at most to it.
    pub z_max: Option<f64>,
}

/// What applying a map did, for the summary.
#[derive(Debug, Clone, PartialEq)]
pub struct Applied {
    /// The map's smallest and largest correction, mm (its points' Z less
    /// the Z of its work zero): the bilinear surface lies between them.
    pub correction_min: f64,
    pub correction_max: f64,
    pub points: usize,
    pub probed_at_unix: i64,
    /// The active Z zero less the map's, mm: a Z zero touched again since
    /// probing moves the cut with it.
    pub z_zero_moved: f64,
    /// How far every rapid was raised, mm (at most to Z's soft limit).
    pub rapids_raised: f64,
    /// Arcs turned into segments on the surface.
    pub arcs_as_segments: usize,
    /// Feed moves of the file, and the moves they became.
    pub feed_moves: usize,
    pub feed_segments: usize,
}

impl Applied {
    /// Seconds since the map was probed (negative: a clock ahead).
    pub fn age_s(&self, now_unix: i64) -> i64 {
        now_unix.saturating_sub(self.probed_at_unix)
    }
}

fn lerp(a: Point, b: Point, t: f64) -> Point {
    if t >= 1.0 {
        return b;
    }
    Point {
        x: a.x + (b.x - a.x) * t,
        y: a.y + (b.y - a.y) * t,
        z: a.z + (b.z - a.z) * t,
    }
}

/// The cell of `v` among `lines` (ascending, at least two): the index of
/// its left line, so that `lines[i] <= v <= lines[i + 1]`.
fn cell(lines: &[f64], v: f64) -> usize {
    lines
        .partition_point(|&l| l <= v)
        .saturating_sub(1)
        .min(lines.len().saturating_sub(2))
}

impl Surface {
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    pub fn system(&self) -> System {
        self.system
    }

    pub fn profile(&self) -> &str {
        &self.profile
    }

    pub fn probed_at_unix(&self) -> i64 {
        self.probed_at_unix
    }

    /// The work zero while probing, machine mm.
    pub fn zero(&self) -> Point {
        self.zero
    }

    fn area(&self) -> (f64, f64, f64, f64) {
        let (xs, ys) = (&self.grid.xs, &self.grid.ys);
        (
            xs.first().copied().unwrap_or(0.0),
            ys.first().copied().unwrap_or(0.0),
            xs.last().copied().unwrap_or(0.0),
            ys.last().copied().unwrap_or(0.0),
        )
    }

    fn node(&self, column: usize, row: usize) -> f64 {
        self.z
            .get(row * self.grid.xs.len() + column)
            .copied()
            .unwrap_or(0.0)
    }

    /// The surface's machine Z at work (x, y), bilinear between the four
    /// grid points around it; `None` outside the area.
    pub fn z_at(&self, x: f64, y: f64) -> Option<f64> {
        let (x0, y0, x1, y1) = self.area();
        let t = AREA_TOLERANCE_MM;
        if !(x >= x0 - t && x <= x1 + t && y >= y0 - t && y <= y1 + t) {
            return None;
        }
        let (x, y) = (x.clamp(x0, x1), y.clamp(y0, y1));
        let (xs, ys) = (&self.grid.xs, &self.grid.ys);
        let (i, j) = (cell(xs, x), cell(ys, y));
        let (xa, xb) = (xs.get(i).copied()?, xs.get(i + 1).copied()?);
        let (ya, yb) = (ys.get(j).copied()?, ys.get(j + 1).copied()?);
        let (u, v) = ((x - xa) / (xb - xa), (y - ya) / (yb - ya));
        let (z00, z10) = (self.node(i, j), self.node(i + 1, j));
        let (z01, z11) = (self.node(i, j + 1), self.node(i + 1, j + 1));
        Some(z00 * (1.0 - u) * (1.0 - v) + z10 * u * (1.0 - v) + z01 * (1.0 - u) * v + z11 * u * v)
    }

    /// The correction at work (x, y): the surface less the Z of the map's
    /// work zero; `None` outside the area.
    pub fn correction(&self, x: f64, y: f64) -> Option<f64> {
        self.z_at(x, y).map(|z| z - self.zero.z)
    }

    /// The smallest and largest correction: a bilinear surface lies
    /// between its grid points' heights.
    pub fn correction_range(&self) -> (f64, f64) {
        let min = self.z.iter().copied().fold(f64::INFINITY, f64::min);
        let max = self.z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (min - self.zero.z, max - self.zero.z)
    }

    /// The toolpath shifted onto the surface (the module's rules), with
    /// what was done; errors at the G-code lines that cannot follow it.
    pub fn apply(
        &self,
        path: &Toolpath,
        fit: &Fit,
    ) -> Result<(Toolpath, Applied), Vec<Diagnostic>> {
        let (correction_min, correction_max) = self.correction_range();
        let mut job = Job {
            surface: self,
            ops: Vec::with_capacity(path.ops.len()),
            at: None,
        };
        let raise = correction_max.max(0.0);
        let mut first_of = Vec::with_capacity(path.ops.len() + 1);
        let mut z_zero_moved = 0.0;
        let (mut arcs, mut feed_moves) = (0, 0);
        // Once a move has gone where the file named X and Y, the next
        // starts where the file says; before, where the machine stood,
        // which no map knows.
        let mut from_known = false;
        for (index, op) in path.ops.iter().enumerate() {
            first_of.push(job.ops.len());
            match op {
                Op::WorkOffset {
                    system,
                    zero,
                    origin,
                } => {
                    self.fits_offset(*system, *zero, *origin, fit)?;
                    z_zero_moved = zero.z - self.zero.z;
                    job.ops.push(op.clone());
                }
                Op::Rapid(m) => {
                    let mut to = m.to;
                    // Raised, never lowered; not past the top of Z's
                    // travel (a G53 park there stays there).
                    let top = fit.z_max.unwrap_or(f64::INFINITY);
                    to.z = if to.z + raise > top {
                        to.z.max(top)
                    } else {
                        to.z + raise
                    };
                    let from = job.at.unwrap_or(m.from);
                    job.ops.push(Op::Rapid(Rapid {
                        from,
                        to,
                        origin: m.origin,
                    }));
                    job.at = Some(to);
                }
                Op::Line(m) => {
                    feed_moves += 1;
                    job.known(from_known, m.origin)?;
                    job.cut(m.from, m.to, m.feed, m.origin)?;
                }
                Op::Arc(a) => {
                    feed_moves += 1;
                    arcs += 1;
                    job.known(from_known, a.origin)?;
                    job.arc(a, fit.chord_tolerance)?;
                }
                other => job.ops.push(other.clone()),
            }
            if matches!(op, Op::Rapid(_) | Op::Line(_) | Op::Arc(_)) {
                from_known |= path.named(0, index) && path.named(1, index);
            }
            if job.ops.len() > MAX_COMMANDS {
                return Err(vec![too_many(
                    op.origin(),
                    "the job on the height map makes",
                )]);
            }
        }
        first_of.push(job.ops.len());
        let named_from = path
            .named_from
            .map(|i| first_of.get(i).copied().unwrap_or(job.ops.len()));
        let feed_segments = job
            .ops
            .iter()
            .filter(|op| matches!(op, Op::Line(_) | Op::Arc(_)))
            .count();
        Ok((
            Toolpath {
                ops: job.ops,
                lines: path.lines,
                warnings: path.warnings.clone(),
                named_from,
            },
            Applied {
                correction_min,
                correction_max,
                points: self.z.len(),
                probed_at_unix: self.probed_at_unix,
                z_zero_moved,
                rapids_raised: raise,
                arcs_as_segments: arcs,
                feed_moves,
                feed_segments,
            },
        ))
    }

    /// A job may use the map only in the work offset it was probed in, with
    /// that offset's X and Y zero where they were then (within a step): the
    /// map's work coordinates would lie elsewhere on the machine.
    fn fits_offset(
        &self,
        system: System,
        zero: Point,
        origin: Origin,
        fit: &Fit,
    ) -> Result<(), Vec<Diagnostic>> {
        if fit.profile != self.profile {
            return Err(vec![Diagnostic::error(
                origin,
                format!(
                    "the height map was probed on profile \"{}\", not \"{}\": probe the surface on this machine",
                    self.profile, fit.profile
                ),
            )]);
        }
        if system != self.system {
            return Err(vec![Diagnostic::error(
                origin,
                format!(
                    "the height map was probed in work offset {}, and the job runs in {system} here: select {} or probe the surface in {system}",
                    self.system, self.system
                ),
            )]);
        }
        let moved: Vec<String> = [
            ("X", zero.x, self.zero.x, fit.step_mm.0),
            ("Y", zero.y, self.zero.y, fit.step_mm.1),
        ]
        .into_iter()
        .filter(|(_, now, then, step)| (now - then).abs() > step + 1e-9)
        .map(|(axis, now, then, _)| {
            format!(
                "{axis} zero at machine {now:.4} mm, the map's at {then:.4} mm ({:+.4} mm)",
                now - then
            )
        })
        .collect();
        if moved.is_empty() {
            return Ok(());
        }
        Err(vec![Diagnostic::error(
            origin,
            format!(
                "the height map was probed with another {system} zero: {}; the surface would lie shifted under the job: set the zero back or probe again",
                moved.join(", ")
            ),
        )])
    }
}

/// The toolpath being made.
struct Job<'a> {
    surface: &'a Surface,
    ops: Vec<Op>,
    /// The end of the last move made, corrected.
    at: Option<Point>,
}

impl Job<'_> {
    fn known(&self, known: bool, origin: Origin) -> Result<(), Vec<Diagnostic>> {
        if known {
            return Ok(());
        }
        Err(vec![Diagnostic::error(
            origin,
            "a feed move from where the job starts, before the file names X and Y: the height map cannot say the surface under it (move to the cut's X and Y first)",
        )])
    }

    /// The correction at a machine point, or the error of a point outside
    /// the map's area.
    fn correction(&self, p: Point, origin: Origin) -> Result<f64, Vec<Diagnostic>> {
        let s = self.surface;
        let (x, y) = (p.x - s.zero.x, p.y - s.zero.y);
        s.correction(x, y).ok_or_else(|| {
            let (x0, y0, x1, y1) = s.area();
            vec![Diagnostic::error(
                origin,
                format!(
                    "X {x:.3} Y {y:.3} ({} work mm) is outside the height map's area X {x0} .. {x1}, Y {y0} .. {y1}: probe a larger area or move the job",
                    s.system
                ),
            )]
        })
    }

    /// A straight feed move from `from` to `to` (the file's machine
    /// points), cut where it crosses the grid's lines and into pieces of
    /// at most the spacing in X/Y, each end shifted onto the surface.
    fn cut(
        &mut self,
        from: Point,
        to: Point,
        feed: f64,
        origin: Origin,
    ) -> Result<(), Vec<Diagnostic>> {
        let s = self.surface;
        let zero = s.zero;
        let (ax, ay) = (from.x - zero.x, from.y - zero.y);
        let (bx, by) = (to.x - zero.x, to.y - zero.y);
        let mut ts = vec![0.0, 1.0];
        // Within a cell the surface along a line is smooth; at a grid line
        // its slope changes, so a piece ends there.
        for (lines, a, b) in [(&s.grid.xs, ax, bx), (&s.grid.ys, ay, by)] {
            let (lo, hi) = (a.min(b), a.max(b));
            let first = lines.partition_point(|&l| l <= lo + AREA_TOLERANCE_MM);
            let last = lines.partition_point(|&l| l < hi - AREA_TOLERANCE_MM);
            for &l in lines.get(first..last).unwrap_or(&[]) {
                ts.push((l - a) / (b - a));
            }
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let length = (bx - ax).hypot(by - ay);
        let spacing = s.spacing;
        // The start must be on the map too (the area is a rectangle: with
        // both ends of a piece inside, all of it is).
        self.correction(from, origin)?;
        let mut start = self.at.unwrap_or(from);
        for pair in ts.windows(2) {
            let (t0, t1) = match pair {
                [t0, t1] => (*t0, *t1),
                _ => continue,
            };
            let pieces = ((t1 - t0) * length / spacing - 1e-9).ceil().max(1.0);
            let mut k = 1.0;
            while k <= pieces {
                let t = if k >= pieces {
                    t1
                } else {
                    t0 + (t1 - t0) * k / pieces
                };
                let mut p = lerp(from, to, t);
                p.z += self.correction(p, origin)?;
                self.ops.push(Op::Line(Line {
                    from: start,
                    to: p,
                    feed,
                    origin,
                }));
                start = p;
                k += 1.0;
            }
        }
        self.at = Some(start);
        Ok(())
    }

    /// An arc as chords within the tolerance, each cut onto the surface.
    fn arc(&mut self, arc: &Arc, tolerance: f64) -> Result<(), Vec<Diagnostic>> {
        let room = MAX_COMMANDS.saturating_sub(self.ops.len());
        let points = chords(arc, tolerance, room).map_err(|_| {
            vec![too_many(
                arc.origin,
                "the arc's chords on the height map make",
            )]
        })?;
        let mut from = arc.from;
        for p in points {
            self.cut(from, p, arc.feed, arc.origin)?;
            from = p;
        }
        Ok(())
    }
}

/// Days since 1970-01-01 of a civil date (Howard Hinnant's algorithm).
fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y.rem_euclid(400);
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// `2026-12-07T09:00:00Z` of seconds since 1970.
pub fn rfc3339(unix: i64) -> String {
    let (year, month, day, rem) = civil(unix);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// Year, month, day (UTC) and the seconds into that day of seconds since
/// 1970: civil from days (Howard Hinnant's algorithm).
pub fn civil(unix: i64) -> (i64, i64, i64, i64) {
    let days = unix.div_euclid(86_400);
    let rem = unix.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (year, month, day, rem)
}

/// Seconds since 1970 of an RFC 3339 time (`2026-12-07T09:00:00Z`,
/// fractions of a second dropped, `+01:00` offsets allowed); `None` for
/// anything else.
pub fn parse_rfc3339(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    let digits = |range: std::ops::Range<usize>| -> Option<i64> {
        let part = b.get(range)?;
        if part.is_empty() || !part.iter().all(u8::is_ascii_digit) {
            return None;
        }
        std::str::from_utf8(part).ok()?.parse().ok()
    };
    let (year, month, day) = (digits(0..4)?, digits(5..7)?, digits(8..10)?);
    let (hour, minute, second) = (digits(11..13)?, digits(14..16)?, digits(17..19)?);
    let seps = [(4, b'-'), (7, b'-'), (13, b':'), (16, b':')];
    if seps.iter().any(|&(i, c)| b.get(i) != Some(&c))
        || !matches!(b.get(10), Some(b'T' | b't' | b' '))
    {
        return None;
    }
    let days_in_month = match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if (year % 4 == 0 && year % 100 != 0) || year % 400 == 0 => 29,
        2 => 28,
        _ => return None,
    };
    if day < 1 || day > days_in_month || hour > 23 || minute > 59 || second > 60 {
        return None;
    }
    let mut rest = b.get(19..)?;
    if rest.first() == Some(&b'.') {
        let n = rest
            .iter()
            .skip(1)
            .take_while(|c| c.is_ascii_digit())
            .count();
        if n == 0 {
            return None;
        }
        rest = rest.get(1 + n..)?;
    }
    let offset = match rest {
        [b'Z' | b'z'] => 0,
        [sign @ (b'+' | b'-'), h1, h2, b':', m1, m2] => {
            let text = [*h1, *h2, *m1, *m2];
            if !text.iter().all(u8::is_ascii_digit) {
                return None;
            }
            let n = |a: u8, b: u8| i64::from(a - b'0') * 10 + i64::from(b - b'0');
            let minutes = n(*h1, *h2) * 60 + n(*m1, *m2);
            if *sign == b'+' {
                minutes * 60
            } else {
                -minutes * 60
            }
        }
        _ => return None,
    };
    let local = days_from_civil(year, month, day) * 86_400 + hour * 3600 + minute * 60 + second;
    Some(local - offset)
}

#[cfg(test)]
#[path = "heightmap_tests.rs"]
mod tests;
