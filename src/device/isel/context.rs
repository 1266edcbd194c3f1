//! The isel driver's knowledge of the controller and the machine, shared by
//! all operations: what the controller was told (axes, ramp, zero), what it
//! answered (positions, ports, faults), and the events for the clients.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    ControllerFault, Event, MachineState, PerAxis, PositionSample, PositionSource, Recovery,
    Refusal,
};
use crate::device::common::{gate, link};
use crate::device::driver::Outgoing;
use crate::proto::isel::{
    AxisConfig, CncCommand, Command, ControlByte, DeviceNumber, Expect, Frame, InputPort,
    Positions, Recovery as IselRecovery, ReplyCode,
};
use crate::traffic::{Owner, readable};
use crate::wiring::Role;

use super::deadline;
use super::io::PortImage;
use super::settings::IselSettings;
use crate::proto::isel::estimate::RampParams;

/// A command ready for the wire, with what its reply looks like and how long
/// it may take.
#[derive(Debug, Clone, PartialEq)]
pub struct Cmd {
    pub bytes: Vec<u8>,
    /// The command as text, without the CR (`@0P`), for events and logs.
    pub text: String,
    pub expect: Expect,
    /// `None`: no deadline (a program run).
    pub timeout: Option<Duration>,
    /// Whether the controller may move while it is outstanding.
    pub may_move: bool,
    /// Sending it again does what sending it once does and moves nothing (a
    /// read, `@0T0`): a session that has not moved sends it again while the
    /// controller is busy (`IselDriver::reply_timeout`).
    pub repeatable: bool,
}

/// The stop sequence: soft stop, then break, so that a later start (`@0S`
/// or the start key) cannot resume what was stopped
/// (`docs/decisions.md` isel 6, manual 2.2.31).
pub const STOP_BYTES: [u8; 2] = [0xFD, 0xFF];

/// The stop sequence: each control byte is a message of its own (they act
/// at once, even between the bytes of a command, manual 2.2.31).
pub fn stop_outgoing() -> Outgoing {
    Outgoing::messages(STOP_BYTES.to_vec(), true, Owner::Stop, &[1, 2])
}

/// A control byte jogterm decides on (a jog's break, the reset).
pub fn control_outgoing(control: ControlByte) -> Outgoing {
    Outgoing::message(control.encode().to_vec(), true, Owner::Stop)
}

/// What a reply to `@0P` said ([`Context::read_position`]).
#[derive(Debug, Clone, PartialEq)]
pub enum PositionRead {
    /// A position, now the one the context holds.
    Measured,
    /// `4`: no axes initialised.
    NoAxes,
    /// Another code: for the reader to report.
    Refused(ReplyCode),
    /// Not an answer to `@0P`.
    Unexpected(crate::proto::isel::Reply),
}

/// A `2` reply: a limit switch, refused as such until the axes are
/// initialised again (manual chapter 5).
pub fn is_limit_fault(fault: &ControllerFault) -> bool {
    fault.recovery == Recovery::ReinitialiseAndReference && fault.code == "2"
}

/// The client-facing recovery for an isel reply code (manual chapter 5).
pub fn recovery_of(code: ReplyCode) -> Recovery {
    match code.recovery() {
        IselRecovery::None | IselRecovery::FixCommand => Recovery::None,
        IselRecovery::InitialiseAxes | IselRecovery::ReinitialiseAndReference => {
            Recovery::ReinitialiseAndReference
        }
        IselRecovery::Reference => Recovery::Reference,
        IselRecovery::ClearFaultReinitialiseAndReference => Recovery::ClearEmergencyStop,
        IselRecovery::CloseHood => Recovery::CloseHood,
        IselRecovery::EraseProgram | IselRecovery::ShortenProgram | IselRecovery::FixProgram => {
            Recovery::EraseProgram
        }
        IselRecovery::ResumeOrBreak => Recovery::ResumeOrDiscard,
        IselRecovery::CheckLink => Recovery::CheckLink,
    }
}

#[derive(Debug)]
pub struct Context {
    pub settings: IselSettings,
    /// The device number in use (`@0G` may change it, manual 2.2.11).
    pub device: DeviceNumber,
    pub state: MachineState,
    /// The controller's axis configuration as far as it is known; `None`
    /// while it is not initialised or unknown.
    pub config: Option<AxisConfig>,
    /// Last measured machine position, steps.
    pub position: Option<PerAxis<i64>>,
    /// Axes whose virtual zero (`@0n`, manual 2.2.19) jogterm knows.
    pub zero_known: AxisSet,
    pub ramp: RampParams,
    /// The reference speed the controller runs with (`@0d`, manual 2.2.5).
    pub reference_hz: u32,
    /// 3D interpolation switched on (`@0z1`, manual 2.2.29).
    pub three_d: bool,
    pub ports: PortImage,
    pub events: VecDeque<Event>,
    /// Control bytes to write at once, even while a command is outstanding
    /// (manual 2.2.31).
    pub control: VecDeque<Outgoing>,
    /// Quiet time an operation wants on the line after its last reply.
    pub quiet_request: Option<Duration>,
    /// The machine state is in doubt (a motion reply was garbled): read it
    /// back before anything else.
    pub readback_wanted: bool,
    /// The controller is storing a program after a raw `@0i` (manual 3.1):
    /// it takes only CNC lines until `9` or an error.
    pub cnc_store: bool,
    /// Input ports the controller answered `1` to: it does not have them
    /// (a controller without port 2). They are not read again on this link.
    pub absent_ports: Vec<InputPort>,
    /// Added to what `@0P` reports to get machine positions: zero, unless
    /// this controller was seen to report positions from the virtual zero
    /// of `@0n` ([`Context::zero_set`]).
    pub p_offset: PerAxis<i64>,
    /// A virtual zero was set: the next `@0P` shows whether the controller
    /// reports positions from it (axes, machine position before).
    pub zero_check: Option<(AxisSet, PerAxis<i64>)>,
    /// A jog off a limit switch switched test mode on (`@0T1`, manual
    /// 2.2.24) and its `@0T0` has not been answered: the next read-back
    /// sends `@0T0` first (`limit_op`).
    pub test_mode_left_on: bool,
    /// The controller was out of sight (a new link): test mode (`@0T1`)
    /// cannot be read back, and another program or a jogterm that died
    /// mid jog off a limit switch may have left it on; a controller in test
    /// mode takes a reference run for "set the reference here" (2.2.24).
    /// The read-back sends `@0T0` first unless the profile allows test mode.
    pub test_mode_unknown: bool,
    /// The session only reads (`Driver::set_reads_only`): the read-back
    /// leaves out `@0T0`, the reference probe (a move of zero steps) and the
    /// profile's ramps, which would change what the operator or a running
    /// program set.
    pub reads_only: bool,
    /// The check-out line whose paused move's rest the controller holds
    /// (`checkout_op`): taken by whatever runs next.
    pub checkout_rest: Option<crate::device::api::JogId>,
    /// The program jogterm stored in this session (`Upload`), as long as
    /// nothing else was stored or erased since: the start gate reads its
    /// first lines (`program::leading_reference`).
    pub stored: Option<Vec<crate::proto::isel::CncCommand>>,
}

crate::device::common::core::family_context!(Context);

impl Context {
    pub fn new(settings: IselSettings) -> Context {
        Context {
            device: settings.device,
            reference_hz: settings.reference_speed_hz,
            settings,
            state: MachineState::default(),
            config: None,
            position: None,
            zero_known: AxisSet::EMPTY,
            ramp: RampParams::CONTROLLER_DEFAULT,
            three_d: false,
            ports: PortImage::default(),
            events: VecDeque::new(),
            control: VecDeque::new(),
            quiet_request: None,
            readback_wanted: false,
            cnc_store: false,
            absent_ports: Vec::new(),
            p_offset: PerAxis::new(),
            zero_check: None,
            test_mode_left_on: false,
            test_mode_unknown: false,
            reads_only: false,
            checkout_rest: None,
            stored: None,
        }
    }

    pub fn emit(&mut self, event: Event) {
        self.events.push_back(event);
    }

    pub fn notice(&mut self, text: impl Into<String>) {
        self.emit(Event::Notice(text.into()));
    }

    /// Queue the stop sequence ahead of everything.
    pub fn send_stop(&mut self) {
        self.control.push_back(stop_outgoing());
    }

    /// A DNC command addressed to our device, with its reply shape and deadline.
    pub fn cmd(&self, command: Command) -> Cmd {
        let frame = Frame::new(self.device, command);
        let bytes = frame.encode();
        let expect = Expect::for_command(&frame.command, self.config);
        let timeout = deadline::for_command(
            &frame.command,
            expect,
            bytes.len(),
            &self.settings,
            self.reference_hz,
        );
        Cmd {
            text: frame.to_string(),
            may_move: frame.command.may_move(),
            repeatable: frame.command.is_read()
                || matches!(frame.command, Command::SetTestMode(false)),
            bytes,
            expect,
            timeout,
        }
    }

    /// A line of a program being stored (manual 3.1): answered `0` or a code.
    pub fn cnc(&self, command: &CncCommand) -> Cmd {
        let bytes = command.encode();
        let timeout = deadline::stored_line(command, &self.settings, bytes.len());
        Cmd {
            text: command.to_string(),
            bytes,
            expect: Expect::Handshake,
            timeout: Some(timeout),
            may_move: false,
            repeatable: false,
        }
    }

    /// A line sent as it is (the upload abort line), answered with a code.
    pub fn literal(&self, text: String) -> Cmd {
        let mut bytes = text.clone().into_bytes();
        bytes.push(b'\r');
        let timeout = deadline::exchange(
            self.settings.line,
            self.settings.timing.reply_margin,
            bytes.len(),
            1,
        ) + Duration::from_millis(400);
        Cmd {
            text,
            bytes,
            expect: Expect::Handshake,
            timeout: Some(timeout),
            may_move: false,
            repeatable: false,
        }
    }

    /// Whether the controller is initialised the way the profile says.
    pub fn profile_ready(&self) -> bool {
        self.config == Some(self.settings.config)
    }

    pub fn set_config(&mut self, config: Option<AxisConfig>) {
        self.config = config;
        self.state.initialised = config.map_or(AxisSet::EMPTY, |c| c.axes());
        self.state.referenced =
            AxisSet::from_mask(self.state.referenced.mask() & self.state.initialised.mask());
    }

    /// A position read from the controller.
    pub fn measured(&mut self, p: &Positions, now: Instant) {
        let mut steps = PerAxis::new()
            .with(Axis::X, i64::from(p.x))
            .with(Axis::Y, i64::from(p.y))
            .with(Axis::Z, i64::from(p.z));
        if let Some(a) = p.a {
            steps.set(Axis::A, i64::from(a));
        }
        if let Some((axes, before)) = self.zero_check.take() {
            self.check_positions_after_zero(axes, &before, &steps);
        }
        for (axis, offset) in self.p_offset.iter() {
            if let Some(v) = steps.get(axis) {
                steps.set(axis, v + offset);
            }
        }
        self.position = Some(steps);
        self.emit(Event::Position(PositionSample {
            at: now,
            steps,
            source: PositionSource::Measured,
        }));
    }

    pub fn estimated(&mut self, steps: PerAxis<i64>, now: Instant) {
        self.emit(Event::Position(PositionSample {
            at: now,
            steps,
            source: PositionSource::Estimated,
        }));
    }

    /// An input port was read (its reply arrived `at`): keep it and update
    /// the safety flags from the bits the profile declares wired
    /// (`crate::wiring`): an E-stop circuit or a power input that is active
    /// is a machine fault, an open hood
    /// blocks motion while it is open. A bit the profile does not declare
    /// wired is shown, never acted on: the controller's reply decides
    /// (binding rule "The controller decides what its wiring allows").
    pub fn port_read(&mut self, port: InputPort, value: u8, at: Instant) {
        self.ports.set_input(port, value, at);
        let active = self.ports.active_inputs(&self.settings.wiring);
        let labels = |role: Role| -> Vec<String> {
            active
                .iter()
                .filter(|b| b.role == role)
                .map(|b| b.label())
                .collect()
        };
        let estop = labels(Role::Estop);
        let power = labels(Role::Power);
        self.state.limit = active.iter().any(|b| b.limit().is_some());
        self.state.estop = !estop.is_empty();
        let in_port = |b: &&&crate::wiring::BitWiring| {
            b.address
                .strip_prefix(&format!("in{}.", port.number()))
                .is_some()
        };
        if active.iter().filter(in_port).any(|b| b.role == Role::Estop) {
            self.machine_fault(port, value, &format!("{} opened", estop.join(", ")));
        } else if active.iter().filter(in_port).any(|b| b.role == Role::Power) {
            let meaning = format!(
                "{}: the power supply or the power stages failed",
                power.join(", ")
            );
            self.machine_fault(port, value, &meaning);
        } else if estop.is_empty() && power.is_empty() {
            self.machine_fault_gone();
        }
        self.hood(port, value);
    }

    /// The wired hood inputs: motion is blocked while every one of them
    /// reads "hood open". isel has two (manual 2.2.3): bit 5 "hood closed and
    /// automatic" and bit 6 "hood closed or setup"; with the hood open in
    /// setup mode only bit 5 reads 0, and the controller moves (chapter 5,
    /// `H`). An open hood blocks motion as a fault with `CloseHood` for as
    /// long as it is open; it does not hide a fault that needs more.
    fn hood(&mut self, port: InputPort, value: u8) {
        let inputs = self.ports.hood_inputs(&self.settings.wiring);
        let open = !inputs.is_empty() && inputs.iter().all(|(_, active)| *active);
        let is_hood = |f: &ControllerFault| f.recovery == Recovery::CloseHood;
        match self.state.fault.as_ref() {
            None if open => {
                let names: Vec<String> = inputs.iter().map(|(b, _)| b.label()).collect();
                let fault = ControllerFault {
                    command: format!("@{}b{}", self.device, port.number()),
                    code: format!("port {} = {value:02X}", port.number()),
                    meaning: format!("The hood is open: {}.", names.join(", ")),
                    recovery: Recovery::CloseHood,
                };
                self.state.fault = Some(fault.clone());
                self.emit(Event::Fault(fault));
            }
            Some(f) if is_hood(f) && !open => self.state.fault = None,
            _ => {}
        }
    }

    /// What jogterm knows of the hood when the controller answered `H`: the
    /// controller refuses while its hood supervision (`@0IH`, manual 4.2.13)
    /// reports the hood open; the hood inputs as last read help find which
    /// circuit that is.
    fn hood_explanation(&self) -> String {
        let read: Vec<String> = self
            .ports
            .read_inputs(&self.settings.wiring)
            .into_iter()
            .filter(|(w, _)| w.role == Role::Hood)
            .map(|(w, level)| format!("{} reads {}", w.label(), u8::from(level)))
            .collect();
        let mut text = " The controller's hood supervision (@0IH, manual 4.2.13) reports the \
                        hood open."
            .to_owned();
        if !read.is_empty() {
            text.push_str(&format!(" Last read: {}.", read.join(", ")));
        }
        text
    }

    /// `@0n` made the current position the virtual zero of `axes` (manual
    /// 2.2.19): the work zero is that machine position. The next `@0P`
    /// (read right after) shows whether the controller now reports
    /// positions from the new zero, which jogterm then allows for.
    pub fn zero_set(&mut self, axes: AxisSet) {
        match self.position {
            Some(position) => {
                for axis in axes.iter() {
                    self.state
                        .work_zero
                        .set(axis, position.get(axis).unwrap_or(0));
                }
                self.zero_known = AxisSet::from_mask(self.zero_known.mask() | axes.mask());
                self.zero_check = Some((axes, position));
            }
            None => {
                self.zero_known = AxisSet::from_mask(self.zero_known.mask() & !axes.mask());
            }
        }
    }

    /// The first `@0P` after `@0n`: an axis that did not move reads what it
    /// read before, if `@0P` reports machine positions as the manual says
    /// (2.2.19, `docs/decisions.md` "isel `@0P` reports machine
    /// positions"). One that reads otherwise is reported from the virtual
    /// zero: jogterm adds it back, so positions, soft limits and taught
    /// targets stay machine coordinates.
    fn check_positions_after_zero(
        &mut self,
        axes: AxisSet,
        before: &PerAxis<i64>,
        reported: &PerAxis<i64>,
    ) {
        let mut shifted = Vec::new();
        for axis in axes.iter() {
            let (Some(was), Some(now)) = (before.get(axis), reported.get(axis)) else {
                continue;
            };
            let offset = self.p_offset.get(axis).unwrap_or(0);
            if now + offset != was {
                self.p_offset.set(axis, was - now);
                shifted.push(format!("{axis} {was} -> {}", now + offset));
            }
        }
        if !shifted.is_empty() {
            self.notice(format!(
                "this controller reports @{dev}P from the virtual zero of @{dev}n ({}), not from \
                 the reference point: jogterm adds the zero back and shows machine positions",
                shifted.join(", "),
                dev = self.device
            ));
        }
    }

    /// A machine fault seen in the ports (manual 2.2.3): whether or not a
    /// command was answered `9`, the power stages were off and the axes may
    /// have moved, so the controller must be initialised and referenced
    /// again (manual chapter 5, code 9), and it has forgotten its axes.
    fn machine_fault(&mut self, port: InputPort, value: u8, meaning: &str) {
        self.set_config(None);
        self.state.referenced = AxisSet::EMPTY;
        self.ports.forget_spindle();
        match self.state.fault.as_mut() {
            Some(f) => f.recovery = Recovery::ClearEmergencyStop,
            None => {
                let fault = ControllerFault {
                    command: format!("@{}b{}", self.device, port.number()),
                    code: format!("port {} = {value:02X}", port.number()),
                    meaning: meaning.to_owned(),
                    recovery: Recovery::ClearEmergencyStop,
                };
                self.state.fault = Some(fault.clone());
                self.emit(Event::Fault(fault));
            }
        }
    }

    /// The ports read show no machine fault any more (no wired E-stop or
    /// power input active, port 1 with the E-stop circuits read): a fault
    /// that asked to clear it now asks only for what is left, initialising
    /// and referencing (manual chapter 5, code 9); "release the emergency
    /// stop" would send the operator looking for a circuit that is closed.
    fn machine_fault_gone(&mut self) {
        let port1_read = self.ports.input(InputPort::Status1).is_some();
        if let Some(f) = self.state.fault.as_mut()
            && f.recovery == Recovery::ClearEmergencyStop
            && port1_read
        {
            f.recovery = Recovery::ReinitialiseAndReference;
        }
    }

    /// What a reply to `@0P` says, once the position it holds (if any) is
    /// taken: `4` only says that no axes are initialised (some controllers
    /// report positions anyway, `docs/decisions.md`), and the axis
    /// configuration is forgotten.
    pub fn read_position(
        &mut self,
        reply: crate::proto::isel::Reply,
        now: Instant,
    ) -> PositionRead {
        use crate::proto::isel::Reply;
        match reply {
            Reply::Positions(p) => {
                self.measured(&p, now);
                PositionRead::Measured
            }
            Reply::Code(ReplyCode::NoAxes) => {
                self.set_config(None);
                PositionRead::NoAxes
            }
            Reply::Code(code) => PositionRead::Refused(code),
            other => PositionRead::Unexpected(other),
        }
    }

    /// The reply to a `@0P` an operation sent to learn the position
    /// ([`Context::read_position`]); any other code is a fault at once.
    /// Whether a position was measured.
    pub fn position_reply(&mut self, reply: crate::proto::isel::Reply, now: Instant) -> bool {
        let text = format!("@{}P", self.device);
        match self.read_position(reply, now) {
            PositionRead::Measured => true,
            PositionRead::NoAxes => false,
            PositionRead::Refused(code) => {
                self.controller_error(&text, code);
                false
            }
            PositionRead::Unexpected(other) => {
                self.link_suspect(&text, &format!("{other:?}"));
                false
            }
        }
    }

    pub fn emit_io(&mut self, now: Instant) {
        let snapshot = self.ports.snapshot(now, &self.settings.wiring);
        self.emit(Event::Io(snapshot));
    }

    /// The controller answered `1` to a read of `port`: it has no such
    /// port. Its bits are not shown and it is not read again on this link.
    pub fn port_absent(&mut self, port: InputPort) {
        if self.absent_ports.contains(&port) {
            return;
        }
        self.absent_ports.push(port);
        self.notice(format!(
            "the controller has no input port {port} (@{}b{port} answered 1): its bits are not \
             read",
            self.device
        ));
    }

    /// The controller answered `code` to `command`: apply what the code means
    /// for the machine (manual chapter 5, `docs/decisions.md` isel 4)
    /// and tell the clients.
    pub fn controller_error(&mut self, command: &str, code: ReplyCode) -> ControllerFault {
        let mut meaning = code.meaning().to_owned();
        if code == ReplyCode::HoodOpen {
            meaning.push_str(&self.hood_explanation());
        }
        let fault = ControllerFault {
            command: command.to_owned(),
            code: code.char().to_string(),
            meaning,
            recovery: recovery_of(code),
        };
        match code {
            // After `2` or `9` the controller must be initialised and
            // referenced again (manual chapter 5): it has forgotten its axes.
            ReplyCode::LimitSwitch => {
                self.state.limit = true;
                self.set_config(None);
                self.state.referenced = AxisSet::EMPTY;
                self.state.fault = Some(fault.clone());
            }
            ReplyCode::MachineFault => {
                self.state.estop = true;
                self.ports.forget_spindle();
                self.set_config(None);
                self.state.referenced = AxisSet::EMPTY;
                self.state.fault = Some(fault.clone());
            }
            ReplyCode::ReferenceRequired => self.state.referenced = AxisSet::EMPTY,
            ReplyCode::NoAxes => self.set_config(None),
            _ => {}
        }
        self.emit(Event::Fault(fault.clone()));
        fault
    }

    /// A reply that is no reply code of the iMC (`A B C E =`), or garbage.
    pub fn link_suspect(&mut self, command: &str, what: &str) -> ControllerFault {
        let fault = link::unreadable(command, what);
        self.emit(Event::Fault(fault.clone()));
        fault
    }

    /// The axes were initialised as the profile says: a fault that needed
    /// re-initialising now only needs a reference run (manual chapter 5,
    /// codes 2 and 9).
    pub fn initialised_after_fault(&mut self) {
        let estop_clear = !self.state.estop;
        if let Some(f) = self.state.fault.as_mut() {
            let next = match f.recovery {
                Recovery::ReinitialiseAndReference => Some(Recovery::Reference),
                Recovery::ClearEmergencyStop if estop_clear => Some(Recovery::Reference),
                _ => None,
            };
            if let Some(r) = next {
                f.recovery = r;
            }
        }
    }

    /// Axes were referenced (a run, a simulated one, or the probe said so).
    pub fn referenced(&mut self, axes: AxisSet) {
        self.state.referenced = AxisSet::from_mask(
            (self.state.referenced.mask() | axes.mask()) & self.state.initialised.mask(),
        );
        if self.profile_ready()
            && gate::reference_fault_cleared(&self.state, self.settings.axis_set())
        {
            self.state.fault = None;
        }
    }

    /// The virtual zero of `axes` is back at the reference point: jogterm's
    /// reading of manual 2.2.19-2.2.22 (`docs/protocols.md`, isel).
    pub fn zero_reset(&mut self, axes: AxisSet) {
        for axis in axes.iter() {
            self.state.work_zero.set(axis, 0);
            // The controller counts from the reference point again.
            self.p_offset.clear(axis);
        }
        self.zero_known = AxisSet::from_mask(self.zero_known.mask() | axes.mask());
    }

    /// Whether a move may start; the first reason it may not. With
    /// `unreferenced_ok` (a jog with `jog.allow_unreferenced`, a reference
    /// run) the reference is not asked for. The controller moves nothing
    /// until every initialised axis is referenced (`docs/decisions.md`
    /// isel 4), so every profile axis must be.
    pub fn motion_allowed(&self, unreferenced_ok: bool) -> Result<(), Refusal> {
        gate::motion_allowed(
            &self.state,
            self.profile_ready(),
            self.settings.axis_set(),
            self.state.test_mode || unreferenced_ok,
            is_limit_fault,
        )
    }

    /// Whether a raw motion command may be sent: not in E-stop, not after a
    /// `2`/`9` before the axes were initialised again. The reference is the
    /// controller's business (it answers `R`).
    pub fn raw_motion_allowed(&self) -> Result<(), Refusal> {
        gate::faults(&self.state, is_limit_fault)
    }

    /// What 0xFE leaves behind: no axes, no reference, power-up ramp, zero
    /// at the reference point, no test mode, not storing (manual 2.2.31,
    /// `docs/decisions.md` isel 6). A program being stored is invalid.
    pub fn apply_reset(&mut self) {
        self.set_config(None);
        self.state.referenced = AxisSet::EMPTY;
        self.state.test_mode = false;
        self.test_mode_left_on = false;
        self.test_mode_unknown = false;
        self.three_d = false;
        self.ramp = RampParams::CONTROLLER_DEFAULT;
        self.reference_hz = self.settings.reference_speed_hz;
        self.position = None;
        self.zero_reset(self.settings.axis_set());
        // Power-up outputs (manual 2.2.31): jogterm did not write them.
        self.ports.forget_outputs();
        if self.cnc_store || self.state.activity == crate::device::api::Activity::Uploading {
            self.state.program = crate::device::api::ProgramState::Invalid;
        }
        self.cnc_store = false;
    }

    /// Why a position read failed: the fault its answer reported, or none
    /// came that could be read.
    pub fn position_fault(&self) -> ControllerFault {
        (self.state.fault.clone()).unwrap_or_else(|| link::unreadable("@0P", "no position"))
    }

    /// The raw bytes of a reply nobody asked for, for a notice.
    pub fn stray_bytes(&mut self, bytes: &[u8]) {
        if !bytes.is_empty() {
            self.notice(format!(
                "unexpected bytes from the controller: {}",
                readable(bytes)
            ));
        }
    }
}
