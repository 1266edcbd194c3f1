//! The probing cycle (`Request::Probe`, `docs/probing.md`), written once
//! for every family: what is refused before anything moves, and the passes
//! a probe makes, as a state machine fed with where each pass ended. A
//! family only says how one pass ("seek") is carried out on its wire: isel
//! with one `@0Z` (manual 2.2.30), which ends when the input trips; EMP,
//! which has no move that ends on an input, with short moves and a read of
//! the input between them.
//!
//! Why two passes: a controller stops a move that an input ends by ramping
//! down from the speed it had at the trip, so it stands past the trip
//! point by the ramp-down (isel 2.2.15/2.2.16; grbl#1436 measured 0.47 mm
//! at 400 mm/min). So the first pass approaches fast, backs off slowly
//! until the input releases, and the second pass runs at a speed the
//! controller stops from within a step (isel: at most the start-stop
//! frequency `@0j`, from which it starts and stops without a ramp). The
//! position after the second pass is the touched point. Then the axis goes
//! back to where the probe started, the way it came.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    ControllerFault, Dir, InputKey, InputSource, MachineState, PerAxis, ProbeEnd, ProbeMove,
    Refusal,
};
use crate::device::inputs::channels::key_of;
use crate::wiring::{BitKind, Level, Role, Wiring};

use super::gate;
use super::limits::{AxisLimits, invalid, machine_has, soft_limit};

/// The input a probe watches: the profile's wired input with role `probe`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProbeInput {
    pub key: InputKey,
    pub address: String,
    pub name: String,
    /// The input reads 1 when the probe touches.
    pub active_high: bool,
}

impl ProbeInput {
    /// Whether `byte` (the port or input word it is read in) says the probe
    /// touches.
    pub fn touched(&self, byte: u8) -> bool {
        let level = (byte >> self.key.bit) & 1 == 1;
        level == self.active_high
    }
}

/// The profile's probe input, or why a probe cannot run: none wired, or
/// one that no command of the family reads.
pub fn probe_input(wiring: &Wiring) -> Result<ProbeInput, Refusal> {
    let bit = wiring
        .bits()
        .iter()
        .find(|b| b.kind == BitKind::Input && b.role == Role::Probe && b.wired)
        .ok_or_else(|| {
            invalid(
                "no probe input is wired: give an input the role `probe` in the profile's [io] \
                 (docs/probing.md)",
            )
        })?;
    let key = key_of(&bit.address)
        .ok_or_else(|| invalid(format!("the probe input {} cannot be read", bit.address)))?;
    if key.source == InputSource::EmcuStatus {
        return Err(invalid("the EMCU reads no input a probe could use"));
    }
    Ok(ProbeInput {
        key,
        address: bit.address.clone(),
        name: bit.name.clone(),
        active_high: bit.active == Level::High,
    })
}

/// What is refused before a probe moves, in the order of every move
/// (`docs/device.md`, "Refusals"), then the probe's own: every axis of the
/// machine referenced (a touched point is only worth its machine
/// coordinates), no test mode (it lets a move run over the limit
/// switches), speeds and travel that make sense, and the whole travel
/// within the soft limits from `start` (the probe does not stop at them).
#[allow(clippy::too_many_arguments)]
pub fn check(
    state: &MachineState,
    ready: bool,
    machine: AxisSet,
    limits: &PerAxis<AxisLimits>,
    probe: &ProbeMove,
    start: Option<i64>,
    is_limit: impl Fn(&ControllerFault) -> bool,
) -> Result<(), Refusal> {
    machine_has(machine, AxisSet::EMPTY.with(probe.axis))?;
    gate::motion_allowed(state, ready, machine, false, is_limit)?;
    if state.test_mode {
        return Err(invalid(
            "test mode is on (@0T1): the limit switches would not stop a probe; switch it off first",
        ));
    }
    if probe.travel <= 0 {
        return Err(invalid("the probe's travel must be more than 0"));
    }
    if !(probe.fast_hz >= 1.0 && probe.slow_hz >= 1.0) {
        return Err(invalid("the probe's speeds must be at least 1 step/s"));
    }
    let start = start.ok_or(Refusal::NotConnected)?;
    soft_limit(limits, probe.axis, end_of(start, probe.dir, probe.travel))
}

fn end_of(from: i64, dir: Dir, steps: i64) -> i64 {
    from.saturating_add(dir.sign().saturating_mul(steps))
}

/// Until what a pass runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Until {
    /// The input trips.
    Touched,
    /// The input releases.
    Released,
}

/// One pass: `steps` (> 0) of the probe's axis in `dir` at `hz`, ending
/// early when the input is `until`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pass {
    pub axis: Axis,
    pub dir: Dir,
    pub steps: i64,
    pub hz: f64,
    pub until: Until,
}

/// What the family does next.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    Pass(Pass),
    /// A plain move of the axis back to `to` (where the probe started), at
    /// `hz`: away from the surface, the way it came.
    Return {
        axis: Axis,
        to: i64,
        hz: f64,
    },
    /// Done: report `end`.
    End(ProbeEnd),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Fast,
    Backoff,
    Slow,
    Return,
    Ended,
}

/// The cycle of one probe.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    probe: ProbeMove,
    from: i64,
    phase: Phase,
    fast_stop: Option<i64>,
    /// The end the return reports.
    end: Option<ProbeEnd>,
}

impl Cycle {
    /// A probe from `from` (the axis's position, read before it moves),
    /// the input read free there. Its first pass.
    pub fn start(probe: ProbeMove, from: i64) -> (Cycle, Step) {
        let cycle = Cycle {
            probe,
            from,
            phase: Phase::Fast,
            fast_stop: None,
            end: None,
        };
        let first = Step::Pass(Pass {
            axis: probe.axis,
            dir: probe.dir,
            steps: probe.travel,
            hz: probe.fast_hz,
            until: Until::Touched,
        });
        (cycle, first)
    }

    /// Refused when the input reads touched before anything moves: the
    /// probe would report the point it stands at, or drive on into it.
    pub fn tripped_at_start(input: &ProbeInput) -> Refusal {
        invalid(format!(
            "the probe input {} ({}) reads touched before the probe moves: free it first \
             (a probe resting on the surface, or wired at the wrong level)",
            input.name, input.address
        ))
    }

    fn back(&mut self, end: ProbeEnd) -> Step {
        self.end = Some(end);
        self.phase = Phase::Return;
        Step::Return {
            axis: self.probe.axis,
            to: self.from,
            hz: self.probe.fast_hz,
        }
    }

    /// A pass ended with the input `touched` or not, the axes standing at
    /// `at` (read after it).
    pub fn pass_ended(&mut self, touched: bool, at: &PerAxis<i64>) -> Step {
        let axis = self.probe.axis;
        let here = at.get(axis).unwrap_or(self.from);
        let toward = self.probe.dir;
        let away = toward.reverse();
        match self.phase {
            Phase::Fast if touched => {
                self.fast_stop = Some(here);
                self.phase = Phase::Backoff;
                // Back at most to where it started: a probe still touched
                // there touches something else.
                Step::Pass(Pass {
                    axis,
                    dir: away,
                    steps: (here - self.from).abs().max(1),
                    hz: self.probe.slow_hz,
                    until: Until::Released,
                })
            }
            Phase::Fast => self.back(ProbeEnd::NoTrip {
                travel: self.probe.travel,
            }),
            Phase::Backoff if touched => {
                let text = format!(
                    "the probe input still reads touched after backing off {} steps to where \
                     the probe started: it is stuck or touches something else",
                    (here - self.fast_stop.unwrap_or(here)).abs()
                );
                self.phase = Phase::Ended;
                Step::End(ProbeEnd::Fault(probe_fault(text)))
            }
            Phase::Backoff => {
                self.phase = Phase::Slow;
                // As far as the fast pass went past this point, and a
                // step: the surface lies within it (the fast pass touched
                // it), and never beyond the travel.
                let to_fast_stop = (self.fast_stop.unwrap_or(here) - here).abs();
                let left = self.probe.travel - (here - self.from).abs();
                Step::Pass(Pass {
                    axis,
                    dir: toward,
                    steps: (to_fast_stop + 1).min(left).max(1),
                    hz: self.probe.slow_hz,
                    until: Until::Touched,
                })
            }
            Phase::Slow if touched => {
                let end = ProbeEnd::Touched {
                    at: *at,
                    fast_stop: self.fast_stop.unwrap_or(here),
                };
                self.back(end)
            }
            Phase::Slow => {
                let text = "the slow pass did not touch where the fast pass had: the surface \
                            moved, or the probe input bounces"
                    .to_owned();
                self.back(ProbeEnd::Fault(probe_fault(text)))
            }
            Phase::Return | Phase::Ended => {
                Step::End(self.end.clone().unwrap_or(ProbeEnd::Stopped))
            }
        }
    }

    /// Where a family's probe goes once the position is read (`at`, the
    /// probe's axis at `here`), after the input was read `touched`: its
    /// first pass when `cycle` has not started, the end after the return
    /// (`last` is the step it carried out), else what the cycle says.
    pub fn advance(
        cycle: &mut Option<Cycle>,
        probe: ProbeMove,
        last: Option<&Step>,
        touched: bool,
        at: &PerAxis<i64>,
        here: i64,
    ) -> Step {
        match (cycle.as_mut(), last) {
            (None, _) => {
                let (started, first) = Cycle::start(probe, here);
                *cycle = Some(started);
                first
            }
            (Some(c), Some(Step::Return { .. })) => Step::End(c.returned()),
            (Some(c), _) => c.pass_ended(touched, at),
        }
    }

    /// The return ended.
    pub fn returned(&mut self) -> ProbeEnd {
        self.phase = Phase::Ended;
        self.end.clone().unwrap_or(ProbeEnd::Stopped)
    }
}

fn probe_fault(text: String) -> ControllerFault {
    ControllerFault {
        command: "probe".to_owned(),
        code: "probe".to_owned(),
        meaning: text,
        recovery: crate::device::api::Recovery::None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probe() -> ProbeMove {
        ProbeMove {
            axis: Axis::Z,
            dir: Dir::Minus,
            travel: 4000,
            fast_hz: 4000.0,
            slow_hz: 300.0,
        }
    }

    fn z(v: i64) -> PerAxis<i64> {
        PerAxis::new().with(Axis::X, 100).with(Axis::Z, v)
    }

    #[test]
    fn a_probe_approaches_fast_backs_off_slow_and_touches_slowly() {
        let (mut cycle, first) = Cycle::start(probe(), 10_000);
        assert_eq!(
            first,
            Step::Pass(Pass {
                axis: Axis::Z,
                dir: Dir::Minus,
                steps: 4000,
                hz: 4000.0,
                until: Until::Touched
            })
        );
        // The fast pass tripped at 8000 and stopped 80 steps past it.
        let backoff = cycle.pass_ended(true, &z(7920));
        assert_eq!(
            backoff,
            Step::Pass(Pass {
                axis: Axis::Z,
                dir: Dir::Plus,
                steps: 2080,
                hz: 300.0,
                until: Until::Released
            })
        );
        let slow = cycle.pass_ended(false, &z(8001));
        assert_eq!(
            slow,
            Step::Pass(Pass {
                axis: Axis::Z,
                dir: Dir::Minus,
                steps: 82,
                hz: 300.0,
                until: Until::Touched
            })
        );
        let back = cycle.pass_ended(true, &z(8000));
        assert_eq!(
            back,
            Step::Return {
                axis: Axis::Z,
                to: 10_000,
                hz: 4000.0
            }
        );
        assert_eq!(
            cycle.returned(),
            ProbeEnd::Touched {
                at: z(8000),
                fast_stop: 7920
            }
        );
    }

    #[test]
    fn no_trip_within_the_travel_goes_back_and_says_so() {
        let (mut cycle, _) = Cycle::start(probe(), 10_000);
        let back = cycle.pass_ended(false, &z(6000));
        assert!(matches!(back, Step::Return { to: 10_000, .. }));
        assert_eq!(cycle.returned(), ProbeEnd::NoTrip { travel: 4000 });
    }

    #[test]
    fn a_probe_that_does_not_release_ends_where_it_stands() {
        let (mut cycle, _) = Cycle::start(probe(), 10_000);
        cycle.pass_ended(true, &z(7920));
        let end = cycle.pass_ended(true, &z(10_000));
        assert!(matches!(end, Step::End(ProbeEnd::Fault(_))), "{end:?}");
    }

    #[test]
    fn the_slow_pass_never_goes_beyond_the_travel() {
        let (mut cycle, _) = Cycle::start(probe(), 10_000);
        // Tripped at the very end of the travel.
        cycle.pass_ended(true, &z(6000));
        let slow = cycle.pass_ended(false, &z(6010));
        assert!(
            matches!(slow, Step::Pass(Pass { steps: 10, .. })),
            "{slow:?}"
        );
    }

    #[test]
    fn a_slow_pass_without_a_touch_is_a_fault_and_goes_back() {
        let (mut cycle, _) = Cycle::start(probe(), 10_000);
        cycle.pass_ended(true, &z(7920));
        cycle.pass_ended(false, &z(8001));
        let back = cycle.pass_ended(false, &z(7919));
        assert!(matches!(back, Step::Return { .. }));
        assert!(matches!(cycle.returned(), ProbeEnd::Fault(_)));
    }

    fn state() -> MachineState {
        MachineState {
            link_up: true,
            initialised: AxisSet::XYZ,
            referenced: AxisSet::XYZ,
            ..MachineState::default()
        }
    }

    fn limits() -> PerAxis<AxisLimits> {
        PerAxis::new().with(
            Axis::Z,
            AxisLimits {
                min: 0,
                max: 32_000,
                max_hz: 6000.0,
                max_overrun: 1200.0,
            },
        )
    }

    fn checked(state: &MachineState, probe: &ProbeMove, start: i64) -> Result<(), Refusal> {
        check(
            state,
            true,
            AxisSet::XYZ,
            &limits(),
            probe,
            Some(start),
            |_| false,
        )
    }

    #[test]
    fn refusals_come_before_anything_moves() {
        assert_eq!(checked(&state(), &probe(), 10_000), Ok(()));
        let unreferenced = MachineState {
            referenced: AxisSet::EMPTY.with(Axis::Z),
            ..state()
        };
        assert!(matches!(
            checked(&unreferenced, &probe(), 10_000),
            Err(Refusal::NotReferenced { .. })
        ));
        // 4000 steps down from 3000 leaves the soft limits at 0.
        assert!(matches!(
            checked(&state(), &probe(), 3000),
            Err(Refusal::SoftLimit { target: -1000, .. })
        ));
        let test_mode = MachineState {
            test_mode: true,
            ..state()
        };
        assert!(checked(&test_mode, &probe(), 10_000).is_err());
        let estop = MachineState {
            estop: true,
            ..state()
        };
        assert_eq!(
            checked(&estop, &probe(), 10_000),
            Err(Refusal::EmergencyStop)
        );
    }

    #[test]
    fn the_probe_input_is_the_profiles_wired_probe() {
        let wiring = Wiring::defaults(crate::proto::Protocol::Isel, AxisSet::XYZ, &[]);
        let input = probe_input(&wiring).expect("isel wires in1.5");
        assert_eq!(input.address, "in1.5");
        assert!(input.touched(0b0010_0000));
        assert!(!input.touched(0b1101_1111));
        let emcu = Wiring::defaults(crate::proto::Protocol::Emcu, AxisSet::XYZ, &[]);
        assert!(probe_input(&emcu).is_err());
    }
}
