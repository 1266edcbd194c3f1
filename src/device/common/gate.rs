//! Whether the machine state lets a move start, and the first reason it
//! does not, in the order every family uses: the link, the emergency stop,
//! a fault and its recovery, the controller not set up as the profile says,
//! axes not referenced (`docs/device.md`, "Refusals").

use crate::axis::AxisSet;
use crate::config::StartUnreferenced;
use crate::device::api::{ControllerFault, MachineState, Recovery, Refusal};

/// The emergency stop and faults: what blocks every move, also a raw one.
/// A fault that only needs a reference run does not block here (the
/// reference check comes after, and a reference run must be possible).
/// `is_limit` tells a fault that a limit switch caused, which is refused as
/// such.
pub fn faults(
    state: &MachineState,
    is_limit: impl Fn(&ControllerFault) -> bool,
) -> Result<(), Refusal> {
    if state.estop {
        return Err(Refusal::EmergencyStop);
    }
    match &state.fault {
        None => Ok(()),
        Some(f) => match f.recovery {
            Recovery::Reference => Ok(()),
            Recovery::ClearEmergencyStop => Err(Refusal::EmergencyStop),
            _ if is_limit(f) => Err(Refusal::LimitSwitch),
            recovery => Err(Refusal::Fault { recovery }),
        },
    }
}

/// Everything a move of `axes` needs: the link, no emergency stop or fault,
/// the controller `ready` (initialised as the profile says), and every axis
/// referenced unless `unreferenced_ok` (a jog with `jog.allow_unreferenced`,
/// a reference run, test mode).
pub fn motion_allowed(
    state: &MachineState,
    ready: bool,
    axes: AxisSet,
    unreferenced_ok: bool,
    is_limit: impl Fn(&ControllerFault) -> bool,
) -> Result<(), Refusal> {
    if !state.link_up {
        return Err(Refusal::NotConnected);
    }
    faults(state, is_limit)?;
    if !ready {
        return Err(Refusal::NotInitialised);
    }
    let missing: AxisSet = axes
        .iter()
        .filter(|a| !state.referenced.contains(*a))
        .collect();
    if !missing.is_empty() && !unreferenced_ok {
        return Err(Refusal::NotReferenced { axes: missing });
    }
    Ok(())
}

/// What jogterm knows of the program stored in the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoredProgram {
    /// Stored before this session or by someone else: its lines are not
    /// known.
    Unknown,
    /// Stored by jogterm in this session; the axes its leading reference
    /// runs cover (empty when it does not begin with one).
    Known { leading_reference: AxisSet },
}

/// Whether a stored program may start, given what the move gate said
/// (`motion_allowed` with `unreferenced_ok` false). Only a refusal for axes
/// not referenced is lifted (issue 24, `docs/protocols.md`, "Assumptions"):
/// - a program jogterm stored in this session whose first commands are
///   reference runs covering every one of those axes (before any move,
///   wait, branch, port or brake command: only settings may come before,
///   each family says which) references them itself and may start;
/// - a program jogterm does not know may start only when the profile says
///   so (`start_unreferenced = "allow"`);
/// - everything else stays refused.
pub fn program_start(
    gate: Result<(), Refusal>,
    stored: StoredProgram,
    policy: StartUnreferenced,
) -> Result<(), Refusal> {
    match gate {
        Err(Refusal::NotReferenced { axes }) => {
            let lifted = match stored {
                StoredProgram::Known { leading_reference } => {
                    axes.iter().all(|a| leading_reference.contains(a))
                }
                StoredProgram::Unknown => policy == StartUnreferenced::Allow,
            };
            if lifted {
                Ok(())
            } else {
                Err(Refusal::NotReferenced { axes })
            }
        }
        other => other,
    }
}

/// Whether a fault that asks for a reference run is over: every one of
/// `axes` is referenced now.
pub fn reference_fault_cleared(state: &MachineState, axes: AxisSet) -> bool {
    state
        .fault
        .as_ref()
        .is_some_and(|f| f.recovery == Recovery::Reference)
        && axes.iter().all(|a| state.referenced.contains(a))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fault(code: &str, recovery: Recovery) -> ControllerFault {
        ControllerFault {
            command: "x".into(),
            code: code.into(),
            meaning: String::new(),
            recovery,
        }
    }

    fn up() -> MachineState {
        MachineState {
            link_up: true,
            referenced: AxisSet::XYZ,
            ..MachineState::default()
        }
    }

    #[test]
    fn the_reasons_come_in_order() {
        let never = |_: &ControllerFault| false;
        assert_eq!(
            motion_allowed(&MachineState::default(), true, AxisSet::XYZ, false, never),
            Err(Refusal::NotConnected)
        );
        let mut s = up();
        s.estop = true;
        s.fault = Some(fault("9", Recovery::ClearEmergencyStop));
        assert_eq!(
            motion_allowed(&s, false, AxisSet::XYZ, false, never),
            Err(Refusal::EmergencyStop)
        );
        s.estop = false;
        assert_eq!(faults(&s, never), Err(Refusal::EmergencyStop));
        s.fault = Some(fault("2", Recovery::ReinitialiseAndReference));
        assert_eq!(faults(&s, |f| f.code == "2"), Err(Refusal::LimitSwitch));
        assert_eq!(
            faults(&s, never),
            Err(Refusal::Fault {
                recovery: Recovery::ReinitialiseAndReference
            })
        );
        s.fault = Some(fault("R", Recovery::Reference));
        assert_eq!(
            motion_allowed(&s, false, AxisSet::XYZ, false, never),
            Err(Refusal::NotInitialised)
        );
        s.referenced = AxisSet::from_mask(0b001);
        assert_eq!(
            motion_allowed(&s, true, AxisSet::XYZ, false, never),
            Err(Refusal::NotReferenced {
                axes: AxisSet::from_mask(0b110)
            })
        );
        assert_eq!(motion_allowed(&s, true, AxisSet::XYZ, true, never), Ok(()));
        assert!(!reference_fault_cleared(&s, AxisSet::XYZ));
        s.referenced = AxisSet::XYZ;
        assert!(reference_fault_cleared(&s, AxisSet::XYZ));
    }

    #[test]
    fn a_program_that_references_its_axes_first_may_start_unreferenced() {
        let yz = AxisSet::from_mask(0b110);
        let missing = || Err(Refusal::NotReferenced { axes: yz });
        let known = |mask| StoredProgram::Known {
            leading_reference: AxisSet::from_mask(mask),
        };
        let refuse = StartUnreferenced::Refuse;
        assert_eq!(program_start(missing(), known(0b111), refuse), Ok(()));
        assert_eq!(program_start(missing(), known(0b110), refuse), Ok(()));
        // One axis left out, or no reference run first: refused.
        assert_eq!(program_start(missing(), known(0b100), refuse), missing());
        assert_eq!(program_start(missing(), known(0), refuse), missing());
        // A program jogterm does not know: as the profile says.
        let unknown = StoredProgram::Unknown;
        assert_eq!(program_start(missing(), unknown, refuse), missing());
        assert_eq!(
            program_start(missing(), unknown, StartUnreferenced::Allow),
            Ok(())
        );
        // Every other refusal stays, whatever the program does.
        assert_eq!(
            program_start(Err(Refusal::EmergencyStop), known(0b111), refuse),
            Err(Refusal::EmergencyStop)
        );
        assert_eq!(
            program_start(
                Err(Refusal::NotInitialised),
                unknown,
                StartUnreferenced::Allow
            ),
            Err(Refusal::NotInitialised)
        );
    }
}
