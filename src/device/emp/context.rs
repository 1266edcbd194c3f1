//! What the EMP driver knows about the drives and the machine, updated from
//! every reply whoever asked for it: switched on, operating mode, sample
//! rate, position, limit switches, inputs, outputs. Operations read it to
//! decide what to send; `MachineState` is derived from it.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::config::profile::{EmpJog, EmpStop};
use crate::device::api::{
    ControllerFault, Event, MachineState, PerAxis, PositionSample, PositionSource, Recovery,
    Refusal,
};
use crate::device::common::{Sink, gate};
use crate::proto::emp::{
    Command, DriveAddress, ErrorCode, OnScope, OperatingMode, ReplyBody, Request,
};

pub use super::drive::DriveState;
use super::io;
use super::settings::EmpSettings;

#[derive(Debug)]
pub struct Context {
    pub settings: EmpSettings,
    pub state: MachineState,
    pub drives: Vec<DriveState>,
    pub events: VecDeque<Event>,
    /// The last complete position sample (every drive), machine counts.
    pub position: Option<PerAxis<i64>>,
    /// About how often the poller reads a switched-on drive's position;
    /// `None` when positions are not polled (kept by the driver).
    pub position_poll: Option<Duration>,
}

crate::device::common::core::family_context!(Context);

impl Context {
    pub fn new(settings: EmpSettings) -> Context {
        let drives = settings
            .drives
            .iter()
            .map(|d| DriveState::new(d.ds, d.axis))
            .collect();
        Context {
            settings,
            state: MachineState::default(),
            drives,
            events: VecDeque::new(),
            position: None,
            position_poll: None,
        }
    }

    pub fn drive(&self, ds: DriveAddress) -> Option<&DriveState> {
        self.drives.iter().find(|d| d.ds == ds)
    }

    pub fn drive_mut(&mut self, ds: DriveAddress) -> Option<&mut DriveState> {
        self.drives.iter_mut().find(|d| d.ds == ds)
    }

    pub fn addresses(&self) -> Vec<DriveAddress> {
        self.drives.iter().map(|d| d.ds).collect()
    }

    /// The scope of `02`: a single drive, or a module on a link of several
    /// (manual "02 : Mehrere Baugruppen EIN", docs/protocols.md EMP).
    pub fn on_scope(&self) -> OnScope {
        if self.drives.len() > 1 {
            OnScope::Link
        } else {
            OnScope::Single
        }
    }

    /// The mode jogs run in, from `emp.jog`: IV for velocity jogs, TPWM for
    /// positioning (manual "22").
    pub fn jog_mode(&self) -> OperatingMode {
        match self.settings.jog_style {
            EmpJog::Velocity => OperatingMode::Iv,
            EmpJog::Position => OperatingMode::Tpwm,
        }
    }

    /// The stop frame for a drive, from `emp.stop`: `08` holds the position,
    /// `2A 03` brakes hard and leaves the motor without current.
    pub fn stop_request(&self, ds: DriveAddress) -> Request {
        Request::new(
            ds,
            match self.settings.stop {
                EmpStop::Hold => Command::Hold,
                EmpStop::Fast => Command::FastStop,
            },
        )
    }

    /// The link is gone or new: what the drives do now is unknown.
    pub fn forget(&mut self) {
        for d in &mut self.drives {
            d.unknown();
        }
        self.position = None;
        self.state.initialised = AxisSet::EMPTY;
    }

    /// Drive `ds` is known to be switched off (`04`, or "not switched on").
    pub fn known_off(&self, ds: DriveAddress) -> bool {
        self.drive(ds).is_some_and(|d| d.on == Some(false))
    }

    /// Every drive is switched on.
    pub fn ready(&self) -> bool {
        self.drives.iter().all(|d| d.on == Some(true))
    }

    /// Whether a move of `axes` may start now (`common::gate`).
    pub fn motion_allowed(&self, axes: AxisSet, unreferenced_ok: bool) -> Result<(), Refusal> {
        gate::motion_allowed(&self.state, self.ready(), axes, unreferenced_ok, is_limit)
    }

    /// Only the emergency stop and faults (raw motion, reference runs).
    pub fn faults_allow(&self) -> Result<(), Refusal> {
        if !self.state.link_up {
            return Err(Refusal::NotConnected);
        }
        gate::faults(&self.state, is_limit)
    }

    /// Bring `state.initialised` in line with the drives.
    pub fn refresh(&mut self) {
        self.state.initialised = self
            .drives
            .iter()
            .filter(|d| d.on == Some(true))
            .map(|d| d.axis)
            .collect();
        if self
            .state
            .fault
            .as_ref()
            .is_some_and(|f| f.recovery == Recovery::SwitchOn)
            && self.ready()
        {
            self.state.fault = None;
        }
        if gate::reference_fault_cleared(&self.state, self.settings.axes) {
            self.state.fault = None;
        }
        self.state.limit = self
            .drives
            .iter()
            .any(|d| d.limits.is_some_and(|l| l.plus || l.minus));
        // An input the profile wires as an E-stop or power contact
        // (`[io."11.I1"] role = "estop"`); none by default (decision 5).
        let wiring = &self.settings.wiring;
        self.state.estop = self
            .drives
            .iter()
            .enumerate()
            .any(|(i, d)| !io::interlocks(i, d, wiring).is_empty());
    }

    /// A reply (first answer or completion) to `request` carried `body`;
    /// it arrived `at`.
    pub fn observe(&mut self, request: &Request, body: &ReplyBody, at: Instant) {
        let axis = self.settings.axis_of(request.ds);
        let Some(d) = self.drive_mut(request.ds) else {
            return;
        };
        if !matches!(request.command, Command::LastError | Command::Identify(_)) {
            d.on = Some(true);
        }
        if let Some(p) = body.position() {
            d.position = Some(i64::from(p.increments()));
        }
        let mut unreference = false;
        match (&request.command, body) {
            (Command::Off, _) => {
                d.on = Some(false);
                d.mode = None;
                // Its `2C` is rejected from now on: no stale position in
                // the samples of the other drives' poll cycles.
                d.position = None;
            }
            (Command::MotorEnable(mode), _) => d.mode = Some(*mode),
            (Command::MotorDisable | Command::FastStop, _) => d.mode = None,
            (Command::SetPosition(_), _) => {
                // "Der Regler wird abgeschaltet" (manual "20 05"), and the
                // counter no longer counts from the reference point.
                d.mode = None;
                unreference = true;
            }
            (Command::SampleRate(r), _) => d.reload = Some(*r),
            (_, ReplyBody::Inputs { limits, inputs }) => {
                d.limits = Some(*limits);
                d.inputs = Some(*inputs);
                d.inputs_read = Some(at);
            }
            (_, ReplyBody::Outputs { limits, outputs }) => {
                d.limits = Some(*limits);
                d.outputs = Some(*outputs);
            }
            _ => {}
        }
        if unreference && let Some(a) = axis {
            self.unreference(a);
        }
        self.refresh();
    }

    pub fn unreference(&mut self, axis: Axis) {
        self.state.referenced = self
            .state
            .referenced
            .iter()
            .filter(|a| *a != axis)
            .collect();
    }

    /// The position counter of every drive, if all are known.
    pub fn positions(&self) -> Option<PerAxis<i64>> {
        let mut out = PerAxis::new();
        for d in &self.drives {
            out.set(d.axis, d.position?);
        }
        Some(out)
    }

    /// A poll cycle has read every drive's position.
    pub fn position_complete(&mut self, now: Instant) {
        if let Some(steps) = self.positions() {
            self.position = Some(steps);
            self.emit(Event::Position(PositionSample {
                at: now,
                steps,
                source: PositionSource::Measured,
            }));
        }
    }

    /// `0A` told why `rejected` was not taken (or why a long action failed):
    /// the fault with its meaning, and what it means for the machine.
    pub fn error_read(&mut self, rejected: &Request, code: ErrorCode, quiet_not_on: bool) {
        if code == ErrorCode::NOT_ON {
            let meaning = code.meaning().unwrap_or("not switched on");
            self.switched_off(
                rejected,
                &format!("EE {:02X}", code.0),
                meaning,
                quiet_not_on,
            );
            return;
        }
        let axis = self.settings.axis_of(rejected.ds);
        let recovery = match code {
            ErrorCode::LIMIT_SWITCH => {
                if let Some(a) = axis {
                    self.unreference(a);
                }
                Recovery::Reference
            }
            _ => Recovery::None,
        };
        let fault = ControllerFault {
            // The frame as sent, as `Event::Reply` names it (`jogterm send`
            // matches the two); the meaning names the drive.
            command: rejected.to_frame().to_string(),
            code: format!("EE {:02X}", code.0),
            meaning: match code.meaning() {
                Some(m) => format!("drive {}: {m}", rejected.ds),
                None => format!(
                    "drive {}: error {:02X} (not documented)",
                    rejected.ds, code.0
                ),
            },
            recovery,
        };
        if recovery != Recovery::None {
            self.state.fault = Some(fault.clone());
        }
        self.refresh();
        self.emit(Event::Fault(fault));
    }

    /// `rejected` was answered `EE` and so was the `0A` that asked why: only
    /// a drive that is not switched on rejects `0A` (manual "02", "0A").
    pub fn rejected_while_off(&mut self, rejected: &Request, quiet: bool) {
        self.switched_off(
            rejected,
            "EE",
            "switched off (it rejects every request, 0A included)",
            quiet,
        );
    }

    /// Drive `rejected.ds` is not switched on: known off from now on (its
    /// polls slow down, `poll::OffDrives`), no position. What jogterm sent on
    /// its own (`quiet`) is a notice, given once while the drive stays off;
    /// what the operator asked for is a fault.
    fn switched_off(&mut self, rejected: &Request, code: &str, meaning: &str, quiet: bool) {
        let ds = rejected.ds;
        let was_off = self.known_off(ds);
        if let Some(d) = self.drive_mut(ds) {
            d.on = Some(false);
            d.mode = None;
            d.position = None;
        }
        if quiet {
            self.refresh();
            if !was_off {
                self.notice(format!("drive {ds} is switched off: switch it on (i)"));
            }
            return;
        }
        let fault = ControllerFault {
            command: rejected.to_frame().to_string(),
            code: code.to_owned(),
            meaning: format!("drive {ds}: {meaning}"),
            recovery: Recovery::SwitchOn,
        };
        self.state.fault = Some(fault.clone());
        self.refresh();
        self.emit(Event::Fault(fault));
    }
}

/// The fault of a frame of jogterm's own that drive `request.ds` rejected
/// (`EE`); `what` names the frame.
pub fn rejected(request: &Request, what: &str) -> ControllerFault {
    ControllerFault {
        command: request.to_string(),
        code: "EE".into(),
        meaning: format!("drive {} rejected {what}", request.ds),
        recovery: Recovery::None,
    }
}

/// The fault of drive `ds` braking at a limit switch on its own during
/// `what` of jogterm's.
pub fn limit_hit(ds: DriveAddress, what: &str) -> ControllerFault {
    ControllerFault {
        command: format!("{ds}: {what}"),
        code: "limit".into(),
        meaning: format!("drive {ds}: limit switch hit"),
        recovery: Recovery::Reference,
    }
}

/// The fault a limit switch caused (refused as such by `gate`).
pub fn is_limit(fault: &ControllerFault) -> bool {
    fault.code == format!("EE {:02X}", ErrorCode::LIMIT_SWITCH.0) || fault.code == "limit"
}
