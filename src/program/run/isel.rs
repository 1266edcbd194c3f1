//! What an isel controller does with a stored program (manual chapter 3,
//! `docs/decisions.md` isel 11-12, `docs/protocols.md` isel "Running
//! stored programs").
//!
//! Coordinates: the controller's counters (what `@0P` reports) per axis, the
//! counter value of the virtual zero point of `n` (which only absolute moves
//! use, manual 3.2.17), and the machine coordinate of counter 0 (0 until an
//! `N` makes the current point the reference point, manual 3.2.18). Soft
//! limits are in machine coordinates = counter + origin.

use std::collections::HashSet;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    ArcGeometry, AxisConfig, CircleDirection, CircleParams, CncCommand, MovePair, Plane,
};

use super::value::{Iv, Reach, Val};
use super::{ArcMotion, Finish, Mode, Motion, MotionKind, Observer, Outcome};
use crate::program::flow::{self, Flow};
use crate::program::model::Program;

/// The loop counters of a running program (manual 3.2.5: nesting depth 7).
/// A loop that needs one more stops the run (`docs/protocols.md`, isel).
const LOOP_SLOTS: usize = 7;

/// States remembered to find endless repetitions; beyond this the budget
/// alone ends a run.
const SEEN_LIMIT: usize = 50_000;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
struct LoopStack {
    /// (index of the `3`, repetitions left)
    entries: [(u32, u16); LOOP_SLOTS],
    len: u8,
}

impl LoopStack {
    fn position(&self, index: u32) -> Option<usize> {
        self.entries
            .get(..usize::from(self.len))
            .and_then(|live| live.iter().rposition(|(i, _)| *i == index))
    }
}

/// Everything of the controller that a program's motions depend on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct State {
    pc: usize,
    counter: [Val; 4],
    zero: [Val; 4],
    origin: [Val; 4],
    plane: Plane,
    direction: Option<CircleDirection>,
    interp3d: bool,
    port_condition: bool,
    loops: LoopStack,
}

impl State {
    /// The state when `@0S` starts the program: counters at `position`
    /// (unknown when `None`), no virtual zero (it is counter 0) and the
    /// counters equal to machine coordinates (the controller was referenced
    /// by a reference run, not an `N`), XY plane (manual 3.2.11), 2.5D
    /// interpolation, circle direction unknown.
    pub fn start(position: Option<[i64; 4]>) -> State {
        State {
            pc: 0,
            counter: position.map_or([None; 4], |p| p.map(|v| Some(Iv::exact(v)))),
            zero: [Some(Iv::ZERO); 4],
            origin: [Some(Iv::ZERO); 4],
            plane: Plane::XY,
            direction: None,
            interp3d: false,
            port_condition: false,
            loops: LoopStack::default(),
        }
    }

    /// The same state with the virtual zero point at the counter values
    /// `zero` (an `@0n` before the program started, manual 2.2.19).
    pub fn with_zero(mut self, zero: [i64; 4]) -> State {
        self.zero = zero.map(|v| Some(Iv::exact(v)));
        self
    }
}

enum Step {
    Go(usize),
    /// Conditional: on with `fall`, or to `taken` (`None` if outside).
    Fork {
        fall: usize,
        taken: Option<usize>,
    },
    /// Unconditional jump back or forward.
    Jump(usize),
    Stop(Finish),
}

pub(crate) struct Runner<'p> {
    commands: Vec<Option<&'p CncCommand>>,
    config: AxisConfig,
    mode: Mode,
    budget: usize,
}

impl<'p> Runner<'p> {
    pub fn new(program: &'p Program, config: AxisConfig, mode: Mode, budget: usize) -> Runner<'p> {
        Runner {
            commands: flow::commands(program),
            config,
            mode,
            budget,
        }
    }

    /// Run from `start`, telling `observer` every motion.
    pub fn run(&self, start: State, observer: &mut dyn Observer) -> Outcome {
        let len = self.commands.len();
        let mut work = vec![start];
        let mut seen: Seen = HashSet::default();
        let mut executed = 0usize;
        let mut finish = Finish::RanOff;
        'paths: while let Some(mut state) = work.pop() {
            loop {
                if state.pc >= len {
                    finish = Finish::RanOff;
                    continue 'paths;
                }
                if executed >= self.budget {
                    return Outcome {
                        executed,
                        finish: Finish::Bound(state.pc),
                        bound: Some(state.pc),
                    };
                }
                let command = self.commands.get(state.pc).copied().flatten();
                // Paths that meet at a jump in the same state have the same
                // future: follow it once. On one path, meeting it again means
                // the program repeats for ever.
                if matches!(
                    command,
                    Some(
                        CncCommand::Loop { count: 0, .. }
                            | CncCommand::WaitSync { .. }
                            | CncCommand::BranchOnPort { .. }
                    )
                ) && !remember(&mut seen, state)
                {
                    finish = Finish::Endless(state.pc);
                    continue 'paths;
                }
                executed += 1;
                if self.mode == Mode::Explore
                    && state.direction.is_none()
                    && matches!(command, Some(CncCommand::Circle(_) | CncCommand::Helix(_)))
                {
                    // Without an `f` the controller's direction is unknown:
                    // follow both.
                    let mut other = state;
                    other.direction = Some(CircleDirection::Ccw);
                    work.push(other);
                    state.direction = Some(CircleDirection::Cw);
                }
                match self.step(&mut state, command, observer) {
                    Step::Go(next) => state.pc = next,
                    Step::Jump(target) => state.pc = target,
                    Step::Fork { fall, taken } => {
                        if let (Mode::Explore, Some(target)) = (self.mode, taken) {
                            let mut other = state;
                            other.pc = target;
                            work.push(other);
                        }
                        state.pc = fall;
                    }
                    Step::Stop(why) => {
                        finish = why;
                        continue 'paths;
                    }
                }
            }
        }
        Outcome {
            executed,
            finish,
            bound: None,
        }
    }

    fn step(
        &self,
        s: &mut State,
        command: Option<&CncCommand>,
        observer: &mut dyn Observer,
    ) -> Step {
        let index = s.pc;
        let next = Step::Go(index + 1);
        let Some(command) = command else {
            return next;
        };
        match command {
            CncCommand::MoveRelative(pairs) => self.linear(s, pairs, false, observer),
            CncCommand::MoveAbsolute(pairs) => self.linear(s, pairs, true, observer),
            CncCommand::Circle(params) => self.arc(s, params, None, observer),
            CncCommand::Helix(h) => self.arc(s, &h.circle, Some(h.s3), observer),
            CncCommand::Reference(mask) => self.reference(s, *mask, observer),
            CncCommand::SimulateReference(mask) => {
                let axes = self.axes(*mask);
                let from = s.counter;
                for a in axes.iter() {
                    let i = a.index();
                    // The current point becomes the reference point.
                    s.origin[i] = machine(s.counter[i], s.origin[i]);
                    s.counter[i] = Some(Iv::ZERO);
                    s.zero[i] = Some(Iv::ZERO);
                }
                observer.motion(&Motion {
                    index,
                    kind: MotionKind::SimulatedReference(axes),
                    from,
                    to: s.counter,
                    reach: [None; 4],
                    until_port: false,
                });
            }
            CncCommand::SetZero(mask) => {
                for a in self.axes(*mask).iter() {
                    s.zero[a.index()] = s.counter[a.index()];
                }
            }
            CncCommand::SetPlane(p) => s.plane = *p,
            CncCommand::SetCircleDirection(d) => s.direction = Some(*d),
            CncCommand::Set3dInterpolation(on) => s.interp3d = *on,
            CncCommand::PortCondition { .. } => s.port_condition = true,
            CncCommand::End => return Step::Stop(Finish::End(index)),
            CncCommand::Loop { .. }
            | CncCommand::WaitSync { .. }
            | CncCommand::BranchOnPort { .. } => {
                return self.jump(s, command);
            }
            CncCommand::SendSync(_)
            | CncCommand::Delay(_)
            | CncCommand::SetReferenceSpeeds(_)
            | CncCommand::SetBrake(_)
            | CncCommand::SetStartStop(_)
            | CncCommand::SetAcceleration(_)
            | CncCommand::SetPort { .. }
            | CncCommand::SetTestMode(_) => {}
        }
        next
    }

    fn jump(&self, s: &mut State, command: &CncCommand) -> Step {
        let index = s.pc;
        let len = self.commands.len();
        match flow::flow_of(Some(command), index) {
            Flow::Jump(t) => match flow::inside(t, len) {
                Some(t) => Step::Jump(t),
                None => Step::Stop(Finish::OutOfProgram(index)),
            },
            Flow::Branch(t) => Step::Fork {
                fall: index + 1,
                taken: flow::inside(t, len),
            },
            Flow::Loop { start } => {
                let Some(start) = flow::inside(start, len).filter(|s| *s <= index) else {
                    // A forward loop is refused by the controller; the
                    // linter says so. As flow it goes on.
                    return Step::Go(index + 1);
                };
                let count = match command {
                    CncCommand::Loop { count, .. } => *count,
                    _ => 0,
                };
                let key = index as u32;
                let stack = &mut s.loops;
                match stack.position(key) {
                    Some(pos) => {
                        // Counters of inner loops left by a jump are dropped.
                        stack.len = (pos + 1) as u8;
                        match stack.entries.get_mut(pos) {
                            Some(entry) if entry.1 > 0 => {
                                entry.1 -= 1;
                                Step::Jump(start)
                            }
                            _ => {
                                stack.len = pos as u8;
                                Step::Go(index + 1)
                            }
                        }
                    }
                    None => match stack.entries.get_mut(usize::from(stack.len)) {
                        // `3 n,-k` runs the body n more times
                        // (`docs/decisions.md` isel 11).
                        Some(slot) => {
                            *slot = (key, count.saturating_sub(1));
                            stack.len += 1;
                            Step::Jump(start)
                        }
                        None => Step::Stop(Finish::LoopStack(index)),
                    },
                }
            }
            Flow::Next | Flow::End => Step::Go(index + 1),
        }
    }

    /// The axes of a mask that the controller has.
    fn axes(&self, mask: AxisSet) -> AxisSet {
        AxisSet::from_mask(mask.mask() & self.config.axes().mask())
    }

    /// `0` and `m` (manual 3.2.2, 3.2.16, 3.2.24).
    fn linear(
        &self,
        s: &mut State,
        pairs: &[MovePair],
        absolute: bool,
        observer: &mut dyn Observer,
    ) {
        if pairs.len() != self.config.move_pairs() {
            // Refused by the check (`7`); the controller stores nothing.
            return;
        }
        let conditioned = std::mem::take(&mut s.port_condition);
        let mut visited = s.counter;
        for phase in phases(self.config, s.interp3d, absolute) {
            let from = s.counter;
            let mut to = from;
            for &(axis, pair) in *phase {
                let steps = pairs.get(pair).map_or(0, |p| i64::from(p.steps));
                let i = axis.index();
                to[i] = if absolute {
                    s.zero[i].map(|z| z.offset(steps))
                } else {
                    from[i].map(|v| v.offset(steps))
                };
            }
            if to == from && to.iter().all(Option::is_some) {
                continue;
            }
            let mut reach = [None; 4];
            for &(axis, _) in *phase {
                let i = axis.index();
                reach[i] = line_reach(from[i], to[i], s.origin[i]);
                visited[i] = hull(visited[i], to[i]);
            }
            s.counter = to;
            observer.motion(&Motion {
                index: s.pc,
                kind: MotionKind::Line,
                from,
                to,
                reach,
                until_port: conditioned,
            });
        }
        if conditioned && self.mode == Mode::Explore {
            // The move may have ended anywhere on its way.
            s.counter = visited;
        }
    }

    /// `y` and `w` (manual 3.2.22, 3.2.23, 2.3).
    fn arc(
        &self,
        s: &mut State,
        params: &CircleParams,
        helix: Option<i32>,
        observer: &mut dyn Observer,
    ) {
        let conditioned = std::mem::take(&mut s.port_condition);
        let (a1, a2) = s.plane.axes();
        let (i1, i2) = (a1.index(), a2.index());
        let (direction, assumed) = match s.direction {
            Some(d) => (d, false),
            // Path mode only: exploring forks both directions before this.
            None => (CircleDirection::Cw, true),
        };
        let geometry = ArcGeometry::of(params, direction);
        let (dx, dy) = geometry.end().from_start;
        let from = s.counter;
        let mut to = from;
        to[i1] = from[i1].map(|v| v.offset(i64::from(dx)));
        to[i2] = from[i2].map(|v| v.offset(i64::from(dy)));
        let centre = (
            from[i1].map(|v| v.offset(-i64::from(params.xs))),
            from[i2].map(|v| v.offset(-i64::from(params.ys))),
        );
        let ((lo1, hi1), (lo2, hi2)) = extents(&geometry);
        let mut reach = [None; 4];
        reach[i1] = machine(centre.0, s.origin[i1]).map(|c| Reach::around(c, lo1, hi1));
        reach[i2] = machine(centre.1, s.origin[i2]).map(|c| Reach::around(c, lo2, hi2));
        let third = s.plane.third_axis();
        if let Some(steps) = helix {
            let i3 = third.index();
            to[i3] = from[i3].map(|v| v.offset(i64::from(steps)));
            reach[i3] = line_reach(from[i3], to[i3], s.origin[i3]);
        }
        s.counter = to;
        if conditioned && self.mode == Mode::Explore {
            // The arc may have ended anywhere on its way.
            let around = |c: Val, lo: i64, hi: i64| {
                c.map(|c| Iv {
                    lo: c.lo.saturating_add(lo),
                    hi: c.hi.saturating_add(hi),
                })
            };
            s.counter[i1] = around(centre.0, lo1, hi1);
            s.counter[i2] = around(centre.1, lo2, hi2);
            if helix.is_some() {
                s.counter[third.index()] = hull(from[third.index()], to[third.index()]);
            }
        }
        observer.motion(&Motion {
            index: s.pc,
            kind: MotionKind::Arc(ArcMotion {
                plane: s.plane,
                direction,
                assumed,
                geometry,
                centre,
                helix: helix.map(|steps| (third, steps)),
            }),
            from,
            to,
            reach,
            until_port: conditioned,
        });
    }

    /// `7`: the axes go to their reference switches in the order Z, Y, X, A
    /// (manual 3.2.8); the counters, the virtual zero and the machine origin
    /// become 0, and 3D interpolation is switched off.
    fn reference(&self, s: &mut State, mask: AxisSet, observer: &mut dyn Observer) {
        let axes = self.axes(mask);
        s.interp3d = false;
        for axis in [Axis::Z, Axis::Y, Axis::X, Axis::A] {
            if !axes.contains(axis) {
                continue;
            }
            let i = axis.index();
            let from = s.counter;
            s.counter[i] = Some(Iv::ZERO);
            s.zero[i] = Some(Iv::ZERO);
            s.origin[i] = Some(Iv::ZERO);
            observer.motion(&Motion {
                index: s.pc,
                kind: MotionKind::Reference(AxisSet::EMPTY.with(axis)),
                from,
                to: s.counter,
                reach: [None; 4],
                until_port: false,
            });
        }
    }
}

/// States seen at jumps. Hashed with rustc's FxHash: a state is some hundred
/// bytes and the default hasher would be a good part of a run's time. Not
/// proof against crafted collisions, which here could only slow a run down
/// (the set is bounded by `SEEN_LIMIT`).
type Seen = rustc_hash::FxHashSet<State>;

/// Whether `state` is new (then it is remembered).
fn remember(seen: &mut Seen, state: State) -> bool {
    if seen.len() >= SEEN_LIMIT {
        return !seen.contains(&state);
    }
    seen.insert(state)
}

fn machine(counter: Val, origin: Val) -> Val {
    Some(counter?.add(origin?))
}

fn hull(a: Val, b: Val) -> Val {
    Some(a?.hull(b?))
}

fn line_reach(from: Val, to: Val, origin: Val) -> Option<Reach> {
    let (from, to, origin) = (from?, to?, origin?);
    (from != to).then(|| Reach::line(from, to).shifted(origin))
}

/// The phases of a `0`/`m`: which axes move together, in order, with the
/// index of their steps,speed pair (manual 3.2.2, 3.2.16, 3.2.24). In 2.5D
/// mode X and Y (and A) move first, interpolated, then Z (with 3 axes: z1,
/// then z2 for relative moves; z2 of an absolute move is ignored). In 3D
/// mode all axes move together and z2 is ignored.
fn phases(
    config: AxisConfig,
    interp3d: bool,
    absolute: bool,
) -> &'static [&'static [(Axis, usize)]] {
    use Axis::{A, X, Y, Z};
    match (config, interp3d, absolute) {
        (AxisConfig::X, ..) => &[&[(X, 0)]],
        (AxisConfig::XY, ..) => &[&[(X, 0), (Y, 1)]],
        (AxisConfig::XYZ, true, _) => &[&[(X, 0), (Y, 1), (Z, 2)]],
        (AxisConfig::XYZ, false, true) => &[&[(X, 0), (Y, 1)], &[(Z, 2)]],
        (AxisConfig::XYZ, false, false) => &[&[(X, 0), (Y, 1)], &[(Z, 2)], &[(Z, 3)]],
        (AxisConfig::XYZA, true, _) => &[&[(X, 0), (Y, 1), (Z, 2), (A, 3)]],
        (AxisConfig::XYZA, false, _) => &[&[(X, 0), (Y, 1), (A, 3)], &[(Z, 2)]],
    }
}

/// The lowest and highest coordinate of each plane axis along the arc,
/// relative to the centre: the ends, and the points at 0°, 90°, 180°, 270°
/// the arc passes.
pub(crate) fn extents(g: &ArcGeometry) -> ((i64, i64), (i64, i64)) {
    use std::f64::consts::{FRAC_PI_2, TAU};
    let end = g.end().from_centre;
    let start = (g.start.0.round() as i64, g.start.1.round() as i64);
    let mut x = (start.0.min(i64::from(end.0)), start.0.max(i64::from(end.0)));
    let mut y = (start.1.min(i64::from(end.1)), start.1.max(i64::from(end.1)));
    let r = g.radius.round() as i64;
    for k in 0..4 {
        let angle = f64::from(k) * FRAC_PI_2;
        let passed = if g.sweep.abs() >= TAU {
            true
        } else if g.sweep >= 0.0 {
            (angle - g.start_angle).rem_euclid(TAU) <= g.sweep
        } else {
            (g.start_angle - angle).rem_euclid(TAU) <= -g.sweep
        };
        if passed {
            match k {
                0 => x.1 = x.1.max(r),
                1 => y.1 = y.1.max(r),
                2 => x.0 = x.0.min(-r),
                _ => y.0 = y.0.min(-r),
            }
        }
    }
    (x, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::isel::circle;

    fn extents_of(
        radius: u32,
        start: f64,
        end: f64,
        direction: CircleDirection,
    ) -> ((i64, i64), (i64, i64)) {
        let arc = circle(radius, start, end, direction, 1000).expect("an arc");
        extents(&ArcGeometry::of(&arc.params, direction))
    }

    #[test]
    fn arc_extents_include_the_axis_crossings_they_pass() {
        use CircleDirection::{Ccw, Cw};
        // A quarter from 0° to 90°: no crossing between the ends.
        assert_eq!(extents_of(1000, 0.0, 90.0, Ccw), ((0, 1000), (0, 1000)));
        // The same ends the long way round pass 180° and 270°.
        assert_eq!(
            extents_of(1000, 0.0, 90.0, Cw),
            ((-1000, 1000), (-1000, 1000))
        );
        // 135° to 225° CCW passes 180° only.
        assert_eq!(
            extents_of(200, 135.0, 225.0, Ccw),
            ((-200, -141), (-141, 141))
        );
        // A full circle.
        assert_eq!(extents_of(50, 30.0, 30.0, Ccw), ((-50, 50), (-50, 50)));
    }
}
