//! The jog off a limit switch (`Request::LimitJog`, `docs/jogging.md`,
//! "Jog off a limit switch"): what every family checks before it moves an
//! axis out of the switch it stands in, and how it tells where the axis
//! stands after each reading of the switches.
//!
//! The refusals are those of any move (`gate::motion_allowed`), with two
//! overridden for the one axis and direction asked for: the active limit
//! switch itself (and the controller's fault that it caused: isel `2`, an
//! EMP `05` or a `40` that shows the switch), and the reference (the axis
//! cannot be referenced while it stands in the switch). The switches are
//! judged as the profile's `[io]` wires them (`IoSnapshot::active_limits`):
//! the switch's `side` says which way leads out of it.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{ActiveLimit, ControllerFault, Dir, MachineState, Refusal};
use crate::wiring::Side;

use super::gate;
use super::limits::invalid;

fn names(limits: &[ActiveLimit]) -> String {
    limits
        .iter()
        .map(|l| format!("{} {} ({}, {})", l.axis, l.side, l.name, l.address))
        .collect::<Vec<_>>()
        .join(", ")
}

fn dir_text(axis: Axis, dir: Dir) -> String {
    format!("{axis}{}", dir.symbol())
}

/// Whether a jog of `axis` in `dir` off its limit switch may start, given
/// the machine state, whether the controller is `ready` (initialised as the
/// profile says), the limit switches that read `active` now, and
/// `is_limit`, which tells the family's limit-switch fault. The switch it
/// leaves, or the first reason it may not start, in the order of every move
/// (`docs/device.md`, "Refusals"), the limit's own checks last.
pub fn check(
    state: &MachineState,
    ready: bool,
    axis: Axis,
    dir: Dir,
    active: &[ActiveLimit],
    is_limit: impl Fn(&ControllerFault) -> bool,
) -> Result<ActiveLimit, Refusal> {
    // What blocks every move (`gate::motion_allowed`; no axis asks for
    // its reference), but the fault the switch caused: that is what this
    // jog overrides.
    match gate::motion_allowed(state, ready, AxisSet::EMPTY, true, &is_limit) {
        Ok(()) => {}
        Err(Refusal::LimitSwitch) if !ready => return Err(Refusal::NotInitialised),
        Err(Refusal::LimitSwitch) => {}
        Err(other) => return Err(other),
    }
    let own: Vec<ActiveLimit> = active.iter().filter(|l| l.axis == axis).cloned().collect();
    match own.as_slice() {
        [] if active.is_empty() => Err(invalid(format!(
            "no limit switch reads active: {axis} has nothing to be jogged off (reference it, h)"
        ))),
        [] => Err(invalid(format!(
            "no limit switch of {axis} reads active (active: {}): only the axis that stands in \
             its switch is jogged off it",
            names(active)
        ))),
        [one] if dir == one.away() => Ok(one.clone()),
        [one] => Err(invalid(format!(
            "{} leads into the switch, not out of it: {axis} stands in {} and leaves it in {}",
            dir_text(axis, dir),
            names(std::slice::from_ref(one)),
            dir_text(axis, one.away())
        ))),
        _ => Err(invalid(format!(
            "both limit switches of {axis} read active ({}): which end {axis} stands at is \
             unknown; check the switches and the profile's [io] wiring",
            names(&own)
        ))),
    }
}

/// Where a jog off the `side` switch of `axis` stands after a reading of
/// the switches (`active`, as the profile wires them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reading {
    /// No switch of the axis reads active: it is off the switch.
    Off,
    /// The switch it leaves still reads active.
    Still,
    /// The switch it leaves released, but the other one of the axis reads
    /// active: the wiring is not what the profile says. It stops.
    Other,
}

pub fn reading(axis: Axis, side: Side, active: &[ActiveLimit]) -> Reading {
    let own: Vec<&ActiveLimit> = active.iter().filter(|l| l.axis == axis).collect();
    if own.is_empty() {
        Reading::Off
    } else if own.iter().any(|l| l.side == side) {
        Reading::Still
    } else {
        Reading::Other
    }
}

/// What the jog reports when it has ended.
pub fn end_notice(axis: Axis, left: &ActiveLimit, travelled: f64, end: &Reading) -> String {
    match end {
        Reading::Off => format!(
            "{axis} is off its limit switch {} after {travelled:.0} steps: reference the axes (h)",
            left.name
        ),
        Reading::Still => format!(
            "{axis} travelled {travelled:.0} steps (jog.limit_jog_distance) and {} ({}) still \
             reads active: stopped. Check the switch and the profile's [io] wiring (side, \
             active level)",
            left.name, left.address
        ),
        Reading::Other => format!(
            "{} ({}) released but the other limit switch of {axis} reads active after \
             {travelled:.0} steps: stopped. Check the profile's [io] wiring (side)",
            left.name, left.address
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::Recovery;

    fn limit(axis: Axis, side: Side) -> ActiveLimit {
        ActiveLimit {
            axis,
            side,
            name: format!("limit {axis}{side}"),
            address: "in3.0".into(),
        }
    }

    fn ready() -> MachineState {
        MachineState {
            link_up: true,
            initialised: AxisSet::XYZ,
            limit: true,
            ..MachineState::default()
        }
    }

    fn fault(code: &str, recovery: Recovery) -> Option<ControllerFault> {
        Some(ControllerFault {
            command: "@0A".into(),
            code: code.into(),
            meaning: String::new(),
            recovery,
        })
    }

    fn isel_limit(f: &ControllerFault) -> bool {
        f.code == "2"
    }

    #[test]
    fn the_axis_in_its_switch_may_leave_it_away_from_the_switch_only() {
        let x_min = [limit(Axis::X, Side::Min)];
        let s = ready();
        assert_eq!(
            check(&s, true, Axis::X, Dir::Plus, &x_min, isel_limit),
            Ok(x_min[0].clone())
        );
        let towards = check(&s, true, Axis::X, Dir::Minus, &x_min, isel_limit);
        assert!(
            matches!(&towards, Err(Refusal::Invalid { reason }) if reason.contains("X- leads into the switch") && reason.contains("leaves it in X+")),
            "{towards:?}"
        );
        let other = check(&s, true, Axis::Y, Dir::Plus, &x_min, isel_limit);
        assert!(
            matches!(&other, Err(Refusal::Invalid { reason }) if reason.contains("no limit switch of Y reads active")),
            "{other:?}"
        );
        let none = check(&s, true, Axis::X, Dir::Plus, &[], isel_limit);
        assert!(
            matches!(&none, Err(Refusal::Invalid { reason }) if reason.contains("no limit switch reads active")),
            "{none:?}"
        );
        let max = [limit(Axis::Z, Side::Max)];
        assert!(check(&s, true, Axis::Z, Dir::Minus, &max, isel_limit).is_ok());
        assert!(check(&s, true, Axis::Z, Dir::Plus, &max, isel_limit).is_err());
        let both = [limit(Axis::X, Side::Min), limit(Axis::X, Side::Max)];
        let ambiguous = check(&s, true, Axis::X, Dir::Plus, &both, isel_limit);
        assert!(
            matches!(&ambiguous, Err(Refusal::Invalid { reason }) if reason.contains("both limit switches of X")),
            "{ambiguous:?}"
        );
    }

    #[test]
    fn every_other_refusal_of_motion_stays() {
        let x_min = [limit(Axis::X, Side::Min)];
        let check_with =
            |s: &MachineState, ready: bool| check(s, ready, Axis::X, Dir::Plus, &x_min, isel_limit);
        let mut s = ready();
        s.link_up = false;
        assert_eq!(check_with(&s, true), Err(Refusal::NotConnected));
        let mut s = ready();
        s.estop = true;
        assert_eq!(check_with(&s, true), Err(Refusal::EmergencyStop));
        let mut s = ready();
        s.fault = fault("9", Recovery::ClearEmergencyStop);
        assert_eq!(check_with(&s, true), Err(Refusal::EmergencyStop));
        s.fault = fault("9", Recovery::ReinitialiseAndReference);
        assert_eq!(
            check_with(&s, true),
            Err(Refusal::Fault {
                recovery: Recovery::ReinitialiseAndReference
            })
        );
        s.fault = fault("H", Recovery::CloseHood);
        assert_eq!(
            check_with(&s, true),
            Err(Refusal::Fault {
                recovery: Recovery::CloseHood
            })
        );
        // The limit switch's own fault is overridden, but the controller
        // must be initialised (isel: after `2` it has forgotten its axes).
        s.fault = fault("2", Recovery::ReinitialiseAndReference);
        assert_eq!(check_with(&s, false), Err(Refusal::NotInitialised));
        assert!(check_with(&s, true).is_ok());
        s.fault = fault("2", Recovery::Reference);
        assert!(check_with(&s, true).is_ok());
        // Nothing referenced: no matter.
        assert!(s.referenced.is_empty());
    }

    #[test]
    fn a_reading_tells_off_still_and_a_wrong_wiring() {
        let x_min = limit(Axis::X, Side::Min);
        let y_max = limit(Axis::Y, Side::Max);
        assert_eq!(reading(Axis::X, Side::Min, &[]), Reading::Off);
        assert_eq!(
            reading(Axis::X, Side::Min, std::slice::from_ref(&y_max)),
            Reading::Off
        );
        assert_eq!(
            reading(Axis::X, Side::Min, &[x_min.clone(), y_max]),
            Reading::Still
        );
        assert_eq!(
            reading(Axis::X, Side::Min, &[limit(Axis::X, Side::Max)]),
            Reading::Other
        );
        assert!(end_notice(Axis::X, &x_min, 40.0, &Reading::Off).contains("reference"));
    }
}
