//! The physical side of one drive: the axis, its switches and what it is
//! doing (following a set-point, positioning, homing). Positions here are
//! physical, in encoder counts from machine 0; the drive's position counter is
//! kept by [`super::drive`].
//!
//! Switches (EMP manual, introduction: "automatische Bremsung, sobald die
//! Schalter angesprochen haben und die Position kann nur in der
//! entgegengesetzten Richtung wieder verlassen werden"):
//! - limit + is on from `limit_plus` upwards, limit - from `limit_minus`
//!   downwards; reaching one while moving towards it brakes the axis, which
//!   comes to rest inside the switch.
//! - the reference switch is on over its cam `[-reference_cam, 0)`, just
//!   below machine 0; its upper edge, where it goes off when the axis leaves
//!   it upwards, is the reference point (EMP manual "26 : Referenzfahrt").

use std::time::Instant;

use super::kinematics::Trajectory;
use crate::proto::emp::Limits;

/// Where the switches sit, in physical counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Switches {
    pub limit_plus: f64,
    pub limit_minus: f64,
    /// Length of the reference switch's cam below machine 0.
    pub reference_cam: f64,
}

impl Switches {
    pub(crate) fn at(&self, x: f64) -> Limits {
        Limits {
            plus: x >= self.limit_plus,
            minus: x <= self.limit_minus,
            reference: (-self.reference_cam..0.0).contains(&x),
        }
    }

    /// Whether a limit switch forbids moving in `dir` from `x`.
    pub(crate) fn blocks(&self, x: f64, dir: f64) -> bool {
        (dir > 0.0 && x >= self.limit_plus) || (dir < 0.0 && x <= self.limit_minus)
    }

    /// The limit switch edge ahead in direction `dir`.
    fn limit_ahead(&self, dir: f64) -> Option<f64> {
        if dir > 0.0 {
            Some(self.limit_plus)
        } else if dir < 0.0 {
            Some(self.limit_minus)
        } else {
            None
        }
    }
}

/// The two actions that report their end on their own (`55`, then `22` or
/// `EE`; `docs/decisions.md` EMP decision 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LongAction {
    Positioning,
    Homing,
}

/// What the drive must be told about an event of the axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// A long action ended: in position / at the reference point (`ok`), or
    /// stopped by a limit switch (not `ok`).
    Finished { action: LongAction, ok: bool },
    /// A set-point move ran into a limit switch and was braked.
    StoppedAtLimit,
}

/// The phases of a homing run (EMP manual "26 : Referenzfahrt": towards the
/// switch with Vfast, reverse, off it with Vslow; "Auch bei Überlaufen des
/// Referenzschalters wird die Achse umgesteuert").
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Searching the switch at Vfast in direction +1 or -1.
    Seek(f64),
    /// Braking after the switch was found or a limit reversed the search.
    Overrun(Next),
    /// Creeping up at Vslow out of the switch to its edge.
    Creep,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Next {
    Seek(f64),
    Creep,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Homing {
    fast: f64,
    slow: f64,
    phase: Phase,
    /// Reversals at a limit switch; a second one means there is no switch
    /// between the limits and the run fails.
    reversals: u8,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Activity {
    /// At rest, or braking to rest.
    Idle,
    /// Following a velocity or torque set-point.
    SetPoint,
    Positioning,
    Homing(Homing),
    /// `fault stall`: a long action that stays busy at rest and never ends
    /// on its own (`docs/simulator.md`, "Faults").
    Stalled,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Event {
    /// The reference switch's edge at machine 0 (homing only).
    ReferenceEdge,
    /// The limit switch ahead.
    Limit,
    /// The trajectory comes to rest.
    Rest,
}

/// One axis with its switches.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Servo {
    switches: Switches,
    /// Deceleration of automatic braking (limit switches) and of homing's
    /// reversals, counts/s².
    brake_decel: f64,
    trajectory: Trajectory,
    activity: Activity,
}

impl Servo {
    pub(crate) fn new(x: f64, switches: Switches, brake_decel: f64) -> Servo {
        Servo {
            switches,
            brake_decel,
            trajectory: Trajectory::rest(x),
            activity: Activity::Idle,
        }
    }

    pub(crate) fn position(&self, t: Instant) -> f64 {
        self.trajectory.position(t)
    }

    pub(crate) fn velocity(&self, t: Instant) -> f64 {
        self.trajectory.velocity(t)
    }

    pub(crate) fn switches(&self, t: Instant) -> Limits {
        self.switches.at(self.position(t))
    }

    pub(crate) fn blocks(&self, t: Instant, dir: f64) -> bool {
        self.switches.blocks(self.position(t), dir)
    }

    /// Whether a set-point is being followed (not stopped by a switch).
    pub(crate) fn follows_set_point(&self) -> bool {
        self.activity == Activity::SetPoint
    }

    /// Brake to rest at `decel` (or harder if a harder brake runs); whatever
    /// ran is over and reports nothing.
    pub(crate) fn brake(&mut self, t: Instant, decel: f64) {
        self.trajectory = self.trajectory.braked(t, decel);
        self.activity = Activity::Idle;
    }

    /// Run at `speed` counts/s (signed) from now on; 0 stands still. The
    /// caller has checked the limit switches.
    pub(crate) fn run(&mut self, t: Instant, speed: f64) {
        self.trajectory = Trajectory::cruise(t, self.position(t), speed);
        self.activity = if speed == 0.0 {
            Activity::Idle
        } else {
            Activity::SetPoint
        };
    }

    /// Position to `target` at up to `speed` with ramps of `accel`. Returns
    /// `true` when the axis is already there (the action is finished at once).
    pub(crate) fn position_to(&mut self, t: Instant, target: f64, speed: f64, accel: f64) -> bool {
        self.trajectory = Trajectory::move_to(t, self.position(t), target, speed, accel);
        let done = matches!(self.trajectory, Trajectory::Rest { .. });
        self.activity = if done {
            Activity::Idle
        } else {
            Activity::Positioning
        };
        done
    }

    /// Start homing with the given speeds. Returns `true` when the axis stands
    /// on the reference point already.
    pub(crate) fn home(&mut self, t: Instant, fast: f64, slow: f64) -> bool {
        let x = self.position(t);
        let mut homing = Homing {
            fast,
            slow,
            phase: Phase::Creep,
            reversals: 0,
        };
        if x == 0.0 {
            self.trajectory = Trajectory::rest(0.0);
            self.activity = Activity::Idle;
            return true;
        }
        if (-self.switches.reference_cam..0.0).contains(&x) {
            // "Steht die Achse in dem Referenzschalter, fährt die Achse im
            // Schleichgang solange, bis der Referenzschalter ausgelöst hat."
            self.trajectory = Trajectory::cruise(t, x, slow);
        } else {
            // The search goes down (towards the switch below the working
            // range) unless limit - forbids it.
            let dir = if self.switches.blocks(x, -1.0) {
                homing.reversals = 1;
                1.0
            } else {
                -1.0
            };
            homing.phase = Phase::Seek(dir);
            self.trajectory = Trajectory::cruise(t, x, dir * fast);
        }
        self.activity = Activity::Homing(homing);
        false
    }

    /// A long action starts stalled: the axis stands where it is, and
    /// nothing ends the action but a request that brakes (`brake`).
    pub(crate) fn stall(&mut self, t: Instant) {
        self.trajectory = Trajectory::rest(self.position(t));
        self.activity = Activity::Stalled;
    }

    /// When the axis next needs attention, if ever.
    pub(crate) fn next_event(&self) -> Option<Instant> {
        self.next().map(|(t, _)| t)
    }

    fn next(&self) -> Option<(Instant, Event)> {
        let traj = &self.trajectory;
        let dir = traj.direction();
        let limit = || {
            self.switches
                .limit_ahead(dir)
                .and_then(|edge| traj.reaches(edge))
                .map(|t| (t, Event::Limit))
        };
        let rest = || traj.end().map(|t| (t, Event::Rest));
        let reference = || traj.reaches(0.0).map(|t| (t, Event::ReferenceEdge));
        // Candidates in order of precedence: on a tie the first one wins, so a
        // reference edge on a limit edge still homes.
        let candidates = match self.activity {
            Activity::Idle => [rest(), None, None],
            Activity::SetPoint => [limit(), None, None],
            Activity::Positioning => [limit(), rest(), None],
            Activity::Homing(h) => match h.phase {
                Phase::Seek(_) | Phase::Creep => [reference(), limit(), None],
                Phase::Overrun(_) => [rest(), None, None],
            },
            Activity::Stalled => [None, None, None],
        };
        candidates.into_iter().flatten().fold(
            None,
            |best: Option<(Instant, Event)>, c| match best {
                Some(b) if b.0 <= c.0 => Some(b),
                _ => Some(c),
            },
        )
    }

    /// Handle the next event if it is due at `t`.
    pub(crate) fn on_event(&mut self, t: Instant) -> Option<Outcome> {
        let (at, event) = self.next().filter(|(at, _)| *at <= t)?;
        match (self.activity, event) {
            (_, Event::Rest) => self.on_rest(at),
            (Activity::SetPoint, Event::Limit) => {
                self.brake(at, self.brake_decel);
                Some(Outcome::StoppedAtLimit)
            }
            (Activity::Positioning, Event::Limit) => {
                self.brake(at, self.brake_decel);
                Some(Outcome::Finished {
                    action: LongAction::Positioning,
                    ok: false,
                })
            }
            (Activity::Homing(h), _) => self.on_homing_edge(at, h, event),
            // `next` offers idle axes only their rest, the reference edge
            // only to homing, and a stalled axis nothing.
            (
                Activity::Idle | Activity::SetPoint | Activity::Positioning | Activity::Stalled,
                _,
            ) => None,
        }
    }

    fn on_rest(&mut self, at: Instant) -> Option<Outcome> {
        let x = self
            .trajectory
            .rest_position()
            .unwrap_or_else(|| self.position(at));
        self.trajectory = Trajectory::rest(x);
        match self.activity {
            Activity::Positioning => {
                self.activity = Activity::Idle;
                Some(Outcome::Finished {
                    action: LongAction::Positioning,
                    ok: true,
                })
            }
            Activity::Homing(mut h) => {
                if let Phase::Overrun(next) = h.phase {
                    let (phase, speed) = match next {
                        Next::Seek(dir) => (Phase::Seek(dir), dir * h.fast),
                        Next::Creep => (Phase::Creep, h.slow),
                    };
                    h.phase = phase;
                    self.trajectory = Trajectory::cruise(at, x, speed);
                    self.activity = Activity::Homing(h);
                }
                None
            }
            Activity::Idle | Activity::SetPoint | Activity::Stalled => {
                self.activity = Activity::Idle;
                None
            }
        }
    }

    fn on_homing_edge(&mut self, at: Instant, mut h: Homing, event: Event) -> Option<Outcome> {
        let failed = Some(Outcome::Finished {
            action: LongAction::Homing,
            ok: false,
        });
        match (h.phase, event) {
            (Phase::Creep, Event::ReferenceEdge) => {
                // The switch went off: this is the reference point. The drive
                // latches the edge and holds the axis on it.
                self.trajectory = Trajectory::rest(0.0);
                self.activity = Activity::Idle;
                Some(Outcome::Finished {
                    action: LongAction::Homing,
                    ok: true,
                })
            }
            (Phase::Seek(dir), Event::ReferenceEdge) => {
                // Going down, the axis has entered the switch: brake, then
                // creep up out of it. Going up it has left the switch at full
                // speed (it came from below): brake, search down again.
                let next = if dir < 0.0 {
                    Next::Creep
                } else {
                    Next::Seek(-1.0)
                };
                self.overrun(at, 0.0, h, next);
                None
            }
            (Phase::Seek(dir), Event::Limit) => {
                h.reversals += 1;
                if h.reversals >= 2 {
                    self.brake(at, self.brake_decel);
                    return failed;
                }
                let edge = self.switches.limit_ahead(dir).unwrap_or(0.0);
                self.overrun(at, edge, h, Next::Seek(-dir));
                None
            }
            (Phase::Creep, Event::Limit) => {
                self.brake(at, self.brake_decel);
                failed
            }
            // Overrun waits only for rest, handled in `on_rest`.
            (Phase::Overrun(_), _) | (_, Event::Rest) => None,
        }
    }

    /// Brake from the edge at `x` (placed exactly, so the next search starts
    /// from the switch position and not a rounding error beside it).
    fn overrun(&mut self, at: Instant, x: f64, mut h: Homing, next: Next) {
        let v = self.velocity(at);
        self.trajectory = Trajectory::cruise(at, x, v).braked(at, self.brake_decel);
        h.phase = Phase::Overrun(next);
        self.activity = Activity::Homing(h);
    }

    /// Short name of what the axis does, for `describe`.
    pub(crate) fn activity_name(&self) -> &'static str {
        match self.activity {
            Activity::Idle => "idle",
            Activity::SetPoint => "running",
            Activity::Positioning => "positioning",
            Activity::Homing(_) => "homing",
            Activity::Stalled => "stalled",
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    const SWITCHES: Switches = Switches {
        limit_plus: 10_000.0,
        limit_minus: -2_000.0,
        reference_cam: 1_000.0,
    };

    /// Run the axis' events up to `until`, collecting outcomes.
    fn run(s: &mut Servo, until: Instant) -> Vec<Outcome> {
        let mut out = Vec::new();
        for _ in 0..1000 {
            match s.next_event() {
                Some(t) if t <= until => out.extend(s.on_event(t)),
                _ => break,
            }
        }
        out
    }

    fn secs(v: u64) -> Duration {
        Duration::from_secs(v)
    }

    #[test]
    fn switch_zones() {
        let l = SWITCHES.at(10_000.0);
        assert!(l.plus && !l.minus && !l.reference);
        assert!(SWITCHES.at(-2_000.0).minus);
        assert!(SWITCHES.at(-1.0).reference);
        assert!(SWITCHES.at(-1_000.0).reference);
        assert!(!SWITCHES.at(0.0).reference, "the edge itself is off");
        assert!(SWITCHES.blocks(10_001.0, 1.0) && !SWITCHES.blocks(10_001.0, -1.0));
    }

    #[test]
    fn a_set_point_brakes_into_the_limit_switch() {
        let t0 = Instant::now();
        let mut s = Servo::new(9_000.0, SWITCHES, 100_000.0);
        s.run(t0, 1_000.0);
        let out = run(&mut s, t0 + secs(5));
        assert_eq!(out, [Outcome::StoppedAtLimit]);
        // Reached 10000 after 1 s, braked 1000^2 / 200000 = 5 counts further.
        assert!((s.position(t0 + secs(5)) - 10_005.0).abs() < 1e-6);
        assert!(s.blocks(t0 + secs(5), 1.0));
        assert!(!s.follows_set_point());
    }

    #[test]
    fn homing_from_above_from_below_and_inside_the_switch() {
        for start in [5_000.0, -1_500.0, -500.0, 20_000.0, -3_000.0] {
            let t0 = Instant::now();
            let mut s = Servo::new(start, SWITCHES, 50_000.0);
            assert!(!s.home(t0, 2_000.0, 100.0));
            let out = run(&mut s, t0 + secs(600));
            assert_eq!(
                out,
                [Outcome::Finished {
                    action: LongAction::Homing,
                    ok: true
                }],
                "from {start}"
            );
            assert_eq!(s.position(t0 + secs(600)), 0.0, "from {start}");
        }
    }

    #[test]
    fn a_stalled_action_stands_until_braked() {
        let t0 = Instant::now();
        let mut s = Servo::new(5_000.0, SWITCHES, 50_000.0);
        s.stall(t0);
        assert_eq!(s.next_event(), None);
        assert_eq!(run(&mut s, t0 + secs(600)), []);
        assert_eq!(s.position(t0 + secs(600)), 5_000.0);
        assert_eq!(s.activity_name(), "stalled");
        s.brake(t0 + secs(600), 50_000.0);
        assert_eq!(s.activity_name(), "idle");
    }

    #[test]
    fn homing_without_a_switch_between_the_limits_fails() {
        let t0 = Instant::now();
        let switches = Switches {
            limit_plus: 10_000.0,
            limit_minus: 2_000.0,
            reference_cam: 500.0,
        };
        let mut s = Servo::new(5_000.0, switches, 50_000.0);
        s.home(t0, 2_000.0, 100.0);
        let out = run(&mut s, t0 + secs(600));
        assert_eq!(
            out,
            [Outcome::Finished {
                action: LongAction::Homing,
                ok: false
            }]
        );
        assert!(s.switches(t0 + secs(600)).plus);
    }
}
