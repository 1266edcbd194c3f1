//! Whether a motion request may go out, judged from the last machine state
//! the device task reported, so the keypad can say at once why a key does
//! nothing and what to do. The driver checks again against the state it
//! knows then and has the last word; this gate only spares the operator a
//! round trip and a flood of refusals while a key repeats.
//!
//! The order is the driver's (`docs/device.md`, "Refusals"): no link, the
//! emergency stop, a limit switch or controller error until its recovery is
//! done, something else running, not initialised, not referenced. The jog
//! off a limit switch is judged the same, but the limit switch (and its
//! fault) and the reference do not block it (`device::common::limit_jog`,
//! which also checks the switch and the direction).

use crate::axis::AxisSet;
use crate::device::api::{Activity, LinkState, MachineState, Recovery, Refusal};

/// What the operator wants to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// A continuous jog (hold or toggle).
    Jog,
    /// A step jog; more steps may join one that runs (coalesced).
    Step,
    /// A move to a typed position or to the work zero.
    GoTo,
    /// A reference run.
    Home,
    /// Setting the work zero (moves nothing, needs the position).
    SetZero,
    /// The jog off a limit switch (`L`): the switch it leaves and the
    /// controller's limit fault do not count, nor the reference.
    OffLimit,
}

/// The check's inputs: the link and machine state as last reported, and
/// what the profile allows.
#[derive(Debug, Clone, Copy)]
pub struct Gate<'a> {
    pub link: &'a LinkState,
    pub machine: &'a MachineState,
    /// The profile's axes.
    pub axes: AxisSet,
    /// `jog.allow_unreferenced`.
    pub allow_unreferenced: bool,
}

impl Gate<'_> {
    /// `Ok` when `motion` may be asked for now; else the first reason not,
    /// which says what to do (`Refusal`'s `Display`).
    pub fn check(&self, motion: Motion) -> Result<(), Refusal> {
        let m = self.machine;
        if *self.link != LinkState::Connected || !m.link_up {
            return Err(Refusal::NotConnected);
        }
        if m.estop {
            return Err(Refusal::EmergencyStop);
        }
        if let Some(f) = &m.fault {
            match f.recovery {
                // After re-initialising, only the reference is missing: the
                // reference run is the recovery, and the checks below say so.
                Recovery::Reference => {}
                Recovery::ClearEmergencyStop => return Err(Refusal::EmergencyStop),
                // isel chapter 5, code 2: a limit switch was hit; what
                // the jog off a limit switch is for (after initialising).
                Recovery::ReinitialiseAndReference if f.code == "2" => {
                    if motion != Motion::OffLimit {
                        return Err(Refusal::LimitSwitch);
                    }
                }
                recovery => return Err(Refusal::Fault { recovery }),
            }
        }
        // Test mode may drive over a limit switch (isel manual 2.2.24):
        // that is what it is for.
        if m.limit && !m.test_mode && motion != Motion::OffLimit {
            return Err(Refusal::LimitSwitch);
        }
        let busy = match (m.activity, motion) {
            (Activity::Idle, _) => false,
            // A step joins the steps that run (the driver coalesces them up
            // to `jog.step_queue`).
            (Activity::Stepping, Motion::Step) => false,
            _ => true,
        };
        if busy {
            return Err(Refusal::Busy {
                activity: m.activity,
            });
        }
        let missing_init: AxisSet = self
            .axes
            .iter()
            .filter(|a| !m.initialised.contains(*a))
            .collect();
        if !missing_init.is_empty() {
            return Err(Refusal::NotInitialised);
        }
        // After a limit switch or machine fault the manual asks for a new
        // reference run (isel chapter 5, codes 2 and 9): the profile's
        // `allow_unreferenced` does not waive that one.
        let after_fault = m
            .fault
            .as_ref()
            .is_some_and(|f| f.recovery == Recovery::Reference);
        let waived = match motion {
            Motion::Jog | Motion::Step => m.test_mode || (self.allow_unreferenced && !after_fault),
            Motion::GoTo => m.test_mode,
            Motion::Home | Motion::SetZero | Motion::OffLimit => true,
        };
        let missing_ref: AxisSet = self
            .axes
            .iter()
            .filter(|a| !m.referenced.contains(*a))
            .collect();
        if !missing_ref.is_empty() && !waived {
            return Err(Refusal::NotReferenced { axes: missing_ref });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::ControllerFault;

    fn ready() -> MachineState {
        MachineState {
            link_up: true,
            initialised: AxisSet::XYZ,
            referenced: AxisSet::XYZ,
            ..MachineState::default()
        }
    }

    fn check(m: &MachineState, motion: Motion) -> Result<(), Refusal> {
        Gate {
            link: &LinkState::Connected,
            machine: m,
            axes: AxisSet::XYZ,
            allow_unreferenced: false,
        }
        .check(motion)
    }

    fn fault(code: &str, recovery: Recovery) -> Option<ControllerFault> {
        Some(ControllerFault {
            command: "@0A".into(),
            code: code.into(),
            meaning: String::new(),
            recovery,
        })
    }

    #[test]
    fn a_ready_machine_may_move() {
        for motion in [
            Motion::Jog,
            Motion::Step,
            Motion::GoTo,
            Motion::Home,
            Motion::SetZero,
        ] {
            assert_eq!(check(&ready(), motion), Ok(()));
        }
    }

    #[test]
    fn each_reason_in_the_drivers_order() {
        let lost = Gate {
            link: &LinkState::Lost {
                reason: "gone".into(),
            },
            machine: &ready(),
            axes: AxisSet::XYZ,
            allow_unreferenced: false,
        };
        assert_eq!(lost.check(Motion::Jog), Err(Refusal::NotConnected));

        let mut m = ready();
        m.estop = true;
        m.fault = fault("9", Recovery::ClearEmergencyStop);
        assert_eq!(check(&m, Motion::Home), Err(Refusal::EmergencyStop));

        let mut m = ready();
        m.fault = fault("2", Recovery::ReinitialiseAndReference);
        assert_eq!(check(&m, Motion::Jog), Err(Refusal::LimitSwitch));
        m.fault = fault("9", Recovery::ReinitialiseAndReference);
        assert_eq!(
            check(&m, Motion::Step),
            Err(Refusal::Fault {
                recovery: Recovery::ReinitialiseAndReference
            })
        );

        let mut m = ready();
        m.limit = true;
        assert_eq!(check(&m, Motion::Jog), Err(Refusal::LimitSwitch));
        m.test_mode = true;
        assert_eq!(check(&m, Motion::Jog), Ok(()));

        let mut m = ready();
        m.activity = Activity::Uploading;
        assert_eq!(
            check(&m, Motion::Jog),
            Err(Refusal::Busy {
                activity: Activity::Uploading
            })
        );
        m.activity = Activity::Stepping;
        assert_eq!(check(&m, Motion::Step), Ok(()));
        assert!(check(&m, Motion::Jog).is_err());

        let mut m = ready();
        m.initialised = AxisSet::EMPTY;
        m.referenced = AxisSet::EMPTY;
        assert_eq!(check(&m, Motion::Jog), Err(Refusal::NotInitialised));
    }

    #[test]
    fn the_jog_off_a_limit_switch_overrides_the_switch_and_the_reference_only() {
        let mut m = ready();
        m.limit = true;
        m.referenced = AxisSet::EMPTY;
        assert_eq!(check(&m, Motion::Jog), Err(Refusal::LimitSwitch));
        assert_eq!(check(&m, Motion::OffLimit), Ok(()));
        // After a `2` the controller must be initialised first.
        m.fault = fault("2", Recovery::ReinitialiseAndReference);
        m.initialised = AxisSet::EMPTY;
        assert_eq!(check(&m, Motion::OffLimit), Err(Refusal::NotInitialised));
        m.initialised = AxisSet::XYZ;
        m.fault = fault("2", Recovery::Reference);
        assert_eq!(check(&m, Motion::OffLimit), Ok(()));
        // Everything else still refuses.
        m.fault = fault("9", Recovery::ClearEmergencyStop);
        assert_eq!(check(&m, Motion::OffLimit), Err(Refusal::EmergencyStop));
        m.fault = None;
        m.activity = Activity::Homing;
        assert_eq!(
            check(&m, Motion::OffLimit),
            Err(Refusal::Busy {
                activity: Activity::Homing
            })
        );
    }

    #[test]
    fn the_reference_is_waived_only_where_the_profile_or_test_mode_allow() {
        let mut m = ready();
        m.referenced = AxisSet::EMPTY.with(crate::axis::Axis::X);
        let refused = Err(Refusal::NotReferenced {
            axes: AxisSet::from_mask(0b110),
        });
        assert_eq!(check(&m, Motion::Jog), refused);
        assert_eq!(check(&m, Motion::GoTo), refused);
        assert_eq!(check(&m, Motion::Home), Ok(()));
        let allowing = Gate {
            link: &LinkState::Connected,
            machine: &m,
            axes: AxisSet::XYZ,
            allow_unreferenced: true,
        };
        assert_eq!(allowing.check(Motion::Step), Ok(()));
        assert_eq!(allowing.check(Motion::GoTo), refused);
        m.test_mode = true;
        assert_eq!(check(&m, Motion::GoTo), Ok(()));

        // After a `9` and a new initialisation only the reference is
        // missing, and the profile cannot waive it.
        let mut m = ready();
        m.referenced = AxisSet::EMPTY;
        m.fault = fault("9", Recovery::Reference);
        let after = Gate {
            link: &LinkState::Connected,
            machine: &m,
            axes: AxisSet::XYZ,
            allow_unreferenced: true,
        };
        assert_eq!(
            after.check(Motion::Jog),
            Err(Refusal::NotReferenced { axes: AxisSet::XYZ })
        );
        assert_eq!(after.check(Motion::Home), Ok(()));
    }
}
