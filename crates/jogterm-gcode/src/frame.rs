//! The frame of a job (`jogterm frame`, the console's frame keys): the
//! rectangle of its X/Y extents in machine coordinates, traced at its safe
//! height, so that the operator sees before the first cut whether the job
//! lies on the stock. The plan only: where the tool goes, leg by leg, from
//! where it stands; the moves are the application's.

use crate::check::arc_extreme_points;
use crate::toolpath::{Op, Point, Toolpath};

/// The rectangle and the height it is traced at, machine mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub min_x: f64,
    pub min_y: f64,
    pub max_x: f64,
    pub max_y: f64,
    /// The safe height: the job's highest Z, or the height asked for.
    pub z: f64,
}

/// Why a job has no frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// The job does not name both X and Y.
    NoArea,
    /// The job names no Z and no height was given.
    NoHeight,
}

impl std::fmt::Display for FrameError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FrameError::NoArea => {
                "the job does not move in both X and Y: there is no rectangle to trace"
            }
            FrameError::NoHeight => "the job names no Z: give the height to trace at (--z)",
        })
    }
}

/// One move of the trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    /// Where it ends, machine mm.
    pub to: Point,
    pub kind: LegKind,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LegKind {
    /// Z alone up to the safe height, where the tool stands.
    Up,
    /// To corner 1-4 (1 again at the end), X and Y only.
    Corner(u8),
}

/// The frame of `path`: its X/Y extents in machine coordinates (the
/// points it moves to and its arcs' bulges, as the import's extents), at
/// `z_work` (work coordinates of the first offset in force) or, without
/// it, the highest Z the job reaches.
pub fn of(path: &Toolpath, z_work: Option<f64>) -> Result<Frame, FrameError> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut zero_z = None;
    let mut add = |index: usize, p: Point| {
        for (axis, v) in [p.x, p.y, p.z].into_iter().enumerate() {
            // Only what the file names: an axis it never moves stays where
            // the tool stands, which is no extent of the job.
            if path.named(axis, index)
                && let (Some(l), Some(h)) = (lo.get_mut(axis), hi.get_mut(axis))
            {
                *l = l.min(v);
                *h = h.max(v);
            }
        }
    };
    for (index, op) in path.ops.iter().enumerate() {
        match op {
            Op::Rapid(m) => add(index, m.to),
            Op::Line(m) => add(index, m.to),
            Op::Arc(a) => arc_extreme_points(a)
                .into_iter()
                .for_each(|p| add(index, p)),
            Op::WorkOffset { zero, .. } => {
                zero_z.get_or_insert(zero.z);
            }
            _ => {}
        }
    }
    let [min_x, min_y, min_z] = lo;
    let [max_x, max_y, max_z] = hi;
    // An axis the job never names has no extent: where that side of the
    // rectangle lies is not the job's to say.
    if !(min_x.is_finite() && min_y.is_finite()) {
        return Err(FrameError::NoArea);
    }
    let z = match z_work {
        Some(z) => z + zero_z.unwrap_or(0.0),
        None if min_z.is_finite() => max_z,
        None => return Err(FrameError::NoHeight),
    };
    Ok(Frame {
        min_x,
        min_y,
        max_x,
        max_y,
        z,
    })
}

impl Frame {
    /// The corners in the order they are traced: from the lowest X and Y
    /// counter-clockwise seen from above.
    pub fn corners(&self) -> [(f64, f64); 4] {
        [
            (self.min_x, self.min_y),
            (self.max_x, self.min_y),
            (self.max_x, self.max_y),
            (self.min_x, self.max_y),
        ]
    }

    /// The first place the trace leaves `limits` (machine min and max of
    /// X, Y, Z), said; `None` when it stays within them.
    pub fn outside(&self, limits: [(f64, f64); 3]) -> Option<String> {
        let [x, y, z] = limits;
        let within = |(lo, hi): (f64, f64), v: f64| v >= lo && v <= hi;
        for (cx, cy) in self.corners() {
            for (name, range, v) in [("X", x, cx), ("Y", y, cy)] {
                if !within(range, v) {
                    return Some(format!(
                        "the corner X {cx:.3} Y {cy:.3} lies outside the soft limits of {name} ({:.3} to {:.3})",
                        range.0, range.1
                    ));
                }
            }
        }
        (!within(z, self.z)).then(|| {
            format!(
                "the safe height Z {:.3} lies outside the soft limits of Z ({:.3} to {:.3})",
                self.z, z.0, z.1
            )
        })
    }

    /// The trace from `here` (machine mm): Z alone up to the safe height
    /// when the tool stands below it (never down: above the job is where
    /// the tool is safe), then the four corners at that height and back to
    /// the first.
    pub fn legs(&self, here: Point) -> Vec<Leg> {
        let mut legs = Vec::with_capacity(6);
        let z = if here.z < self.z {
            legs.push(Leg {
                to: Point { z: self.z, ..here },
                kind: LegKind::Up,
            });
            self.z
        } else {
            here.z
        };
        let corners = self.corners();
        for (n, (x, y)) in corners.iter().chain(corners.first()).enumerate() {
            legs.push(Leg {
                to: Point { x: *x, y: *y, z },
                kind: LegKind::Corner(n as u8 % 4 + 1),
            });
        }
        legs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Setup;

    fn path(text: &str, zero: Point) -> Toolpath {
        let setup = Setup {
            zeros: [zero; 6],
            ..Setup::default()
        };
        crate::interpret(text, &setup).expect("the job reads")
    }

    const ZERO: Point = Point {
        x: 50.0,
        y: 40.0,
        z: 30.0,
    };

    #[test]
    fn the_rectangle_is_the_extents_in_machine_coordinates_at_the_highest_z() {
        let p = path(
            "G21 G90\nG0 Z5\nG0 X10 Y20\nG1 Z-1 F100\nG1 X30\nG1 Y25\nG0 Z8\nM2\n",
            ZERO,
        );
        let f = of(&p, None).expect("frame");
        assert_eq!(
            f,
            Frame {
                min_x: 60.0,
                min_y: 60.0,
                max_x: 80.0,
                max_y: 65.0,
                z: 38.0
            }
        );
        // --z is work Z, through the offset.
        assert_eq!(of(&p, Some(12.0)).expect("frame").z, 42.0);
    }

    #[test]
    fn arcs_count_with_their_bulges() {
        // A half circle from X0 to X20 around X10 Y0 bulges to Y10.
        let p = path("G21 G90\nG0 X0 Y0 Z2\nG2 X20 Y0 I10 J0 F100\n", ZERO);
        let f = of(&p, None).expect("frame");
        assert!((f.max_y - 50.0).abs() < 1e-9, "{f:?}");
        assert!((f.min_x - 50.0).abs() < 1e-9 && (f.max_x - 70.0).abs() < 1e-9);
    }

    #[test]
    fn a_job_without_x_and_y_or_without_z_has_no_frame() {
        let p = path("G21 G90\nG0 Z5\nG1 Z-1 F100\n", ZERO);
        assert_eq!(of(&p, None), Err(FrameError::NoArea));
        let p = path("G21 G90\nG0 X1 Y2\nG1 X5 Y6 F100\n", ZERO);
        assert_eq!(
            of(&path("G21 G90\nG0 X1 Z2\nG1 X5 F100\n", ZERO), None),
            Err(FrameError::NoArea)
        );
        assert_eq!(of(&p, None), Err(FrameError::NoHeight));
        assert_eq!(of(&p, Some(3.0)).expect("frame").z, 33.0);
    }

    #[test]
    fn the_trace_goes_up_first_then_round_the_corners_and_back() {
        let f = Frame {
            min_x: 10.0,
            min_y: 20.0,
            max_x: 30.0,
            max_y: 40.0,
            z: 15.0,
        };
        let below = f.legs(Point {
            x: 1.0,
            y: 2.0,
            z: 5.0,
        });
        let to: Vec<(f64, f64, f64)> = below.iter().map(|l| (l.to.x, l.to.y, l.to.z)).collect();
        assert_eq!(
            to,
            [
                (1.0, 2.0, 15.0),
                (10.0, 20.0, 15.0),
                (30.0, 20.0, 15.0),
                (30.0, 40.0, 15.0),
                (10.0, 40.0, 15.0),
                (10.0, 20.0, 15.0),
            ]
        );
        let kinds: Vec<LegKind> = below.iter().map(|l| l.kind).collect();
        assert_eq!(
            kinds,
            [
                LegKind::Up,
                LegKind::Corner(1),
                LegKind::Corner(2),
                LegKind::Corner(3),
                LegKind::Corner(4),
                LegKind::Corner(1),
            ]
        );
        // Above the safe height the tool stays where it is, never lower.
        let above = f.legs(Point {
            x: 1.0,
            y: 2.0,
            z: 25.0,
        });
        assert_eq!(above.len(), 5);
        assert!(above.iter().all(|l| l.to.z == 25.0));
    }

    #[test]
    fn a_trace_outside_the_soft_limits_is_named() {
        let f = Frame {
            min_x: 10.0,
            min_y: 20.0,
            max_x: 330.0,
            max_y: 40.0,
            z: 15.0,
        };
        let limits = [(0.0, 300.0), (0.0, 200.0), (0.0, 80.0)];
        let why = f.outside(limits).expect("outside");
        assert!(why.contains("X 330.000") && why.contains("of X"), "{why}");
        let inside = Frame { max_x: 300.0, ..f };
        assert_eq!(inside.outside(limits), None);
        let high = Frame { z: 81.0, ..inside };
        assert!(
            high.outside(limits)
                .expect("outside")
                .contains("safe height")
        );
    }
}
