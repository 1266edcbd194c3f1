//! From a motion command to the legs the controller travels one after the
//! other (isel manual 2.2.2, 2.2.18, 2.2.27-2.2.30, 2.3):
//!
//! - 2.5D (the default): X and Y linearly interpolated, the axis with the
//!   longer way at its own speed and the other in proportion; then Z1, then
//!   Z2 (3 axes). With 4 axes, A is interpolated with X and Y and Z follows
//!   (`docs/protocols.md`, isel).
//! - 3D (`@0z1`, manual 2.2.29): X, Y, Z on one straight line at the x speed
//!   as path speed; z2 is ignored; A follows in proportion.
//! - `@0Z`: every axis on one line, the longest at the given speed.
//! - `y`/`w`: the controller's walk (the core's `ArcWalk`) from the start
//!   point, `B` iterations at the path speed `V`, ending where the walk
//!   ends; a helix's third axis follows.
//!
//! Legs carry absolute counter targets, so what is left of a move after a
//! soft stop is simply its remaining legs (decision 6).

use crate::proto::isel::{
    ArcGeometry, ArcWalk, AxisConfig, CircleDirection, CircleParams, MovePair, Plane, PortMove,
    ReplyCode,
};

use super::path::{ArcPath, Path, Point};

/// Distance of a reference run's seek: farther than any machine, so the leg
/// ends only on its switch (manual 2.2.22: without a switch the axis runs on).
pub const FAR: i64 = 1 << 40;

/// How the speed profile measures a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// The axis with the longest way leads at its own speed (2.5D, `@0Z`).
    Leading,
    /// X, Y, Z on a straight line at the x speed; A follows (3D).
    Path3d,
}

/// When a seek leg ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Until {
    /// Switch input `input` (0 = switch 1) of `axis` reads active.
    Active { axis: usize, input: usize },
    /// Switch input `input` of `axis` no longer reads active.
    Released { axis: usize, input: usize },
}

/// Something the controller does at a point of a job, without moving.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// The carriage stands on the reference point of `axis`: counter 0.
    Reference(usize),
}

/// One leg of a job, as planned.
#[derive(Debug, Clone, PartialEq)]
pub enum LegSpec {
    /// Straight to absolute counter targets; `speeds` per axis in Hz.
    Line {
        target: [i64; 4],
        speeds: [u32; 4],
        metric: Metric,
    },
    /// An arc, computed when the move was planned (boxed: the walk's index
    /// makes it much larger than the other legs).
    Arc {
        arc: Box<ArcPath>,
        end: [i64; 4],
        distance: u64,
        speed: u32,
    },
    /// One axis in `direction` (+1/-1) until a switch input changes; at a
    /// constant speed (no ramp) when `constant`.
    Seek {
        axis: usize,
        direction: i64,
        speed: u32,
        constant: bool,
        until: Until,
    },
    /// One axis by `steps`, with a ramp.
    Steps { axis: usize, steps: i64, speed: u32 },
    /// An action between legs.
    Act(Action),
}

/// What a leg looks like from where the axes stand.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub path: Path,
    pub end: [i64; 4],
    pub distance: u64,
    /// Cruise speed (Hz); with `constant` the whole leg runs at it.
    pub speed: u32,
    pub constant: bool,
}

fn as_point(counters: [i64; 4]) -> Point {
    counters.map(|v| v as f64)
}

impl LegSpec {
    /// The leg from `current`; `None` when it moves nothing (or is an action).
    pub fn layout(&self, current: [i64; 4]) -> Option<Layout> {
        match self {
            LegSpec::Line {
                target,
                speeds,
                metric,
            } => {
                let delta: Vec<i64> = (0..4).map(|i| target[i] - current[i]).collect();
                let longest = (0..4).max_by_key(|&i| (delta[i].unsigned_abs(), usize::MAX - i))?;
                let (distance, speed) = match metric {
                    Metric::Leading => (delta[longest].unsigned_abs(), speeds[longest]),
                    Metric::Path3d => {
                        let xyz = delta
                            .iter()
                            .take(3)
                            .map(|d| (*d as f64).powi(2))
                            .sum::<f64>();
                        let length = xyz.sqrt().round() as u64;
                        let length = if length == 0 {
                            delta[3].unsigned_abs()
                        } else {
                            length
                        };
                        (length, speeds[0])
                    }
                };
                (distance > 0).then(|| Layout {
                    path: Path::Line {
                        from: as_point(current),
                        to: as_point(*target),
                    },
                    end: *target,
                    distance,
                    speed,
                    constant: false,
                })
            }
            LegSpec::Arc {
                arc,
                end,
                distance,
                speed,
            } => Some(Layout {
                path: Path::Arc(arc.starting_at(as_point(current))),
                end: *end,
                distance: *distance,
                speed: *speed,
                constant: false,
            }),
            LegSpec::Seek {
                axis,
                direction,
                speed,
                constant,
                ..
            } => {
                let mut end = current;
                *end.get_mut(*axis)? += direction * FAR;
                Some(Layout {
                    path: Path::Line {
                        from: as_point(current),
                        to: as_point(end),
                    },
                    end,
                    distance: FAR as u64,
                    speed: *speed,
                    constant: *constant,
                })
            }
            LegSpec::Steps { axis, steps, speed } => {
                let mut end = current;
                *end.get_mut(*axis)? += steps;
                (*steps != 0).then(|| Layout {
                    path: Path::Line {
                        from: as_point(current),
                        to: as_point(end),
                    },
                    end,
                    distance: steps.unsigned_abs(),
                    speed: *speed,
                    constant: false,
                })
            }
            LegSpec::Act(_) => None,
        }
    }
}

/// The state a move is planned in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MoveContext {
    pub config: AxisConfig,
    pub three_d: bool,
    pub current: [i64; 4],
    /// Counter readings of the virtual zero (`@0n`, manual 2.2.19).
    pub virtual_zero: [i64; 4],
    pub plane: Plane,
    pub direction: CircleDirection,
}

/// Which axis each pair of `A`/`M` drives (decision 5): with 3 axes the
/// fourth pair is z2.
fn pair_axes(config: AxisConfig) -> &'static [usize] {
    match config {
        AxisConfig::X => &[0],
        AxisConfig::XY => &[0, 1],
        AxisConfig::XYZ => &[0, 1, 2, 2],
        AxisConfig::XYZA => &[0, 1, 2, 3],
    }
}

/// The legs of `A`/`M` (and CNC `0`/`m`). The pair count was checked.
pub fn plan_pairs(pairs: &[MovePair], absolute: bool, ctx: &MoveContext) -> Vec<LegSpec> {
    let axes = pair_axes(ctx.config);
    let mut targets = ctx.current;
    let mut speeds = [0u32; 4];
    // Pair index groups in the order they run.
    let groups: Vec<Vec<usize>> = match (ctx.config, ctx.three_d) {
        (AxisConfig::X, _) => vec![vec![0]],
        (AxisConfig::XY, _) => vec![vec![0, 1]],
        (AxisConfig::XYZ, false) if absolute => vec![vec![0, 1], vec![2]],
        (AxisConfig::XYZ, false) => vec![vec![0, 1], vec![2], vec![3]],
        (AxisConfig::XYZ, true) => vec![vec![0, 1, 2]],
        (AxisConfig::XYZA, false) => vec![vec![0, 1, 3], vec![2]],
        (AxisConfig::XYZA, true) => vec![vec![0, 1, 2, 3]],
    };
    let metric = if ctx.three_d {
        Metric::Path3d
    } else {
        Metric::Leading
    };
    let mut legs = Vec::new();
    for group in groups {
        for &k in &group {
            let (Some(&axis), Some(pair)) = (axes.get(k), pairs.get(k)) else {
                continue;
            };
            let steps = i64::from(pair.steps);
            targets[axis] = if absolute {
                ctx.virtual_zero[axis] + steps
            } else {
                targets[axis] + steps
            };
            // In 3D the x speed is the path speed (manual 2.2.29).
            speeds[axis] = if ctx.three_d {
                pairs.first().map_or(pair.speed, |p| p.speed)
            } else {
                pair.speed
            };
        }
        legs.push(LegSpec::Line {
            target: targets,
            speeds,
            metric,
        });
    }
    legs
}

/// The leg of `@0Z` (manual 2.2.30): every initialised axis relative, on
/// one line, the longest way at the given speed.
pub fn plan_port_move(m: &PortMove, ctx: &MoveContext) -> Vec<LegSpec> {
    let mut target = ctx.current;
    for (i, steps) in m.steps.iter().enumerate().take(4) {
        target[i] += i64::from(*steps);
    }
    vec![LegSpec::Line {
        target,
        speeds: [m.speed; 4],
        metric: Metric::Leading,
    }]
}

/// The leg of a circle `y` or (with `s3`) a helix `w`, in the plane of
/// `@0e` and the direction of `@0f`. `3` when an axis of the plane (or the
/// helix axis) is not initialised.
pub fn plan_arc(
    params: &CircleParams,
    s3: Option<i32>,
    ctx: &MoveContext,
) -> Result<Vec<LegSpec>, ReplyCode> {
    let (a1, a2) = ctx.plane.axes();
    let axes = ctx.config.axes();
    let third = ctx.plane.third_axis();
    if !axes.contains(a1) || !axes.contains(a2) || (s3.is_some() && !axes.contains(third)) {
        return Err(ReplyCode::BadAxis);
    }
    let (i1, i2) = (a1.index(), a2.index());
    // The controller walks its circle B iterations and stops wherever that
    // leaves it (manual 2.3.2), so the leg ends where the walk does.
    let geometry = ArcGeometry::of(params, ctx.direction);
    let start = (i64::from(params.xs), i64::from(params.ys));
    let walk = ArcWalk::new(geometry.radius.round() as i64, start, ctx.direction);
    let mut end = ctx.current;
    end[i1] += geometry.walk_end.0 - start.0;
    end[i2] += geometry.walk_end.1 - start.1;
    let helix = s3.map(|steps| (third.index(), f64::from(steps)));
    if let Some((i, steps)) = helix {
        end[i] += steps as i64;
    }
    let centre = (ctx.current[i1] - start.0, ctx.current[i2] - start.1);
    let steps = u64::from(params.arc_length);
    let arc = ArcPath::new(as_point(ctx.current), (i1, i2), centre, walk, steps, helix);
    Ok(vec![LegSpec::Arc {
        arc: Box::new(arc),
        end,
        distance: steps,
        speed: params.speed,
    }])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::isel::Sign;

    fn ctx(config: AxisConfig, three_d: bool) -> MoveContext {
        MoveContext {
            config,
            three_d,
            current: [100, 200, 300, 400],
            virtual_zero: [1000, 0, 0, 0],
            plane: Plane::XY,
            direction: CircleDirection::Ccw,
        }
    }

    fn pairs(v: &[(i32, u32)]) -> Vec<MovePair> {
        v.iter().map(|&(s, v)| MovePair::new(s, v)).collect()
    }

    #[test]
    fn two_and_a_half_d_runs_xy_then_z1_then_z2() {
        let legs = plan_pairs(
            &pairs(&[(10, 800), (20, 900), (4, 90), (-4, 30)]),
            false,
            &ctx(AxisConfig::XYZ, false),
        );
        let targets: Vec<_> = legs
            .iter()
            .map(|l| match l {
                LegSpec::Line { target, .. } => *target,
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(
            targets,
            [
                [110, 220, 300, 400],
                [110, 220, 304, 400],
                [110, 220, 300, 400]
            ]
        );
        // The longer way (Y) leads at its speed.
        let layout = legs[0].layout([100, 200, 300, 400]).expect("moves");
        assert_eq!((layout.distance, layout.speed), (20, 900));
        // The z2 leg runs at gz2.
        let z2 = legs[2].layout([110, 220, 304, 400]).expect("moves");
        assert_eq!((z2.distance, z2.speed), (4, 30));
    }

    #[test]
    fn absolute_moves_count_from_the_virtual_zero_and_ignore_z2() {
        let legs = plan_pairs(
            &pairs(&[(5, 800), (20, 900), (4, 90), (0, 30)]),
            true,
            &ctx(AxisConfig::XYZ, false),
        );
        assert_eq!(legs.len(), 2);
        assert!(matches!(legs[0], LegSpec::Line { target, .. } if target == [1005, 20, 300, 400]));
    }

    #[test]
    fn three_d_is_one_line_at_the_x_speed() {
        let legs = plan_pairs(
            &pairs(&[(300, 1000), (400, 5), (0, 5), (7, 5)]),
            false,
            &ctx(AxisConfig::XYZ, true),
        );
        assert_eq!(legs.len(), 1);
        let layout = legs[0].layout([100, 200, 300, 400]).expect("moves");
        assert_eq!((layout.distance, layout.speed), (500, 1000));
        assert_eq!(layout.end, [400, 600, 300, 400], "z2 is ignored");
    }

    #[test]
    fn the_manuals_circle_leaves_the_tool_at_its_end_point() {
        let params = CircleParams {
            arc_length: 400,
            speed: 1500,
            d: 119,
            xs: -141,
            ys: 141,
            rx: Sign::Minus,
            ry: Sign::Minus,
        };
        let legs = plan_arc(&params, None, &ctx(AxisConfig::XY, false)).expect("arc");
        let layout = legs[0].layout([100, 200, 300, 400]).expect("moves");
        // 135 to 225 degrees CCW on R = 200: from (-141, 141) to (-141, -141).
        assert_eq!(layout.end, [100, -82, 300, 400]);
        assert_eq!(layout.distance, 400);
        let mid = layout.path.at(0.5);
        assert!((mid[0] - (100.0 + 141.4 - 200.0)).abs() < 1.0, "{mid:?}");
        let xz = MoveContext {
            plane: Plane::XZ,
            ..ctx(AxisConfig::XY, false)
        };
        assert_eq!(plan_arc(&params, None, &xz), Err(ReplyCode::BadAxis));
    }

    #[test]
    fn a_seek_runs_far_and_nothing_moves_nowhere() {
        let seek = LegSpec::Seek {
            axis: 2,
            direction: -1,
            speed: 2000,
            constant: false,
            until: Until::Active { axis: 2, input: 0 },
        };
        let layout = seek.layout([0, 0, 5, 0]).expect("seek");
        assert_eq!(layout.end[2], 5 - FAR);
        let still = LegSpec::Line {
            target: [1, 2, 3, 4],
            speeds: [100; 4],
            metric: Metric::Leading,
        };
        assert!(still.layout([1, 2, 3, 4]).is_none());
        assert!(LegSpec::Act(Action::Reference(0)).layout([0; 4]).is_none());
    }
}
