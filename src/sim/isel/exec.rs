//! Received lines: DNC frames (chapter 2), stored program lines while a
//! transfer is open (chapter 3), and what each DNC command does. Stored
//! program lines run through the same code (`CncCommand::as_dnc`).

use std::time::Instant;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    AxisConfig, Command, DiagnosisKind, InitCommand, OutputPort, Reply, ReplyCode, TextEnd,
    check_with, parse_cnc, parse_frame,
};

use super::io::PortCondition;
use super::mechanics::NEG;
use super::plan::{self, LegSpec, MoveContext, Until};
use super::program::{Stored, store_line};
use super::run::{JobKind, MotionJob, Step};
use super::text::{self, AxisSwitches, Status};
use super::{Activity, IselSim, ReplyTo, StoredProgram};

/// What a command does at once: answer, or start something that answers
/// when it is done.
#[derive(Debug, Clone)]
pub enum Exec {
    Reply(Reply),
    Step(Step),
}

fn code(code: ReplyCode) -> Exec {
    Exec::Reply(Reply::Code(code))
}

fn ok() -> Exec {
    code(ReplyCode::Ok)
}

/// Reference runs go Z, Y, X, then A (manual 2.2.22, decision 4).
const REFERENCE_ORDER: [Axis; 4] = [Axis::Z, Axis::Y, Axis::X, Axis::A];

impl IselSim {
    /// A complete line arrived while nothing runs.
    pub(super) fn received_line(&mut self, line: &[u8], t: Instant) {
        if self.storing {
            self.store(line);
            return;
        }
        match parse_frame(line) {
            // A broken frame for another device is not ours to answer.
            Err(e) if e.device.is_some_and(|d| d != self.device) => {}
            Err(e) => self.answer_code(e.code),
            Ok(parsed) if parsed.value.device != self.device => {}
            Ok(parsed) => self.dnc(&parsed.value.command, t),
        }
    }

    fn dnc(&mut self, command: &Command, t: Instant) {
        if *command == Command::Start {
            if let Err(code) = self.start(ReplyTo::Host, t) {
                self.answer_code(code);
            }
            return;
        }
        match self.execute(command, t) {
            Exec::Reply(reply) => self.answer(reply),
            Exec::Step(step) => {
                self.activity = Some(Activity {
                    reply: ReplyTo::Host,
                    program: None,
                    step,
                })
            }
        }
    }

    /// A line of an open program transfer (manual 2.2.13, 3.1, decision 9):
    /// `0` or the error, after which the transfer is over and the program
    /// stays invalid.
    fn store(&mut self, line: &[u8]) {
        if let [b'@', digit, ..] = line
            && digit.is_ascii_digit()
            && *digit != self.device.ascii()
        {
            return;
        }
        let config = self.axis_config;
        let capacity = self.config.program_capacity;
        let speeds = self.reference_speeds;
        let result = match parse_cnc(line) {
            Err(e) => Err(e.code),
            Ok(parsed) => match self.flash.program.as_mut() {
                Some(program) => {
                    store_line(program, parsed.value, config, capacity).inspect(|stored| {
                        if *stored == Stored::Closed {
                            program.reference_speeds = speeds;
                        }
                    })
                }
                None => Err(ReplyCode::InvalidDataField),
            },
        };
        match result {
            Ok(Stored::More) => self.answer_code(ReplyCode::Ok),
            Ok(Stored::Closed) => {
                self.storing = false;
                self.answer_code(ReplyCode::Ok);
            }
            Err(code) => {
                self.storing = false;
                self.answer_code(code);
            }
        }
    }

    /// Run a DNC command (from the host or a stored program).
    pub(super) fn execute(&mut self, command: &Command, t: Instant) -> Exec {
        if let Err(e) = check_with(command, self.axis_config) {
            return code(e.code);
        }
        let config = self.axis_config;
        match command {
            Command::SetAxes(setting) => {
                if self.init.io_only {
                    // IO-only mode (manual 4.2.5): the controller drives no axes.
                    return code(ReplyCode::BadAxis);
                }
                match AxisConfig::after_setting(config, *setting) {
                    Ok(c) => {
                        self.axis_config = Some(c);
                        self.paused = None;
                        ok()
                    }
                    Err(c) => code(c),
                }
            }
            Command::MoveRelative(pairs) | Command::MoveAbsolute(pairs) => {
                let absolute = matches!(command, Command::MoveAbsolute(_));
                match self.move_context() {
                    Some(ctx) => self.begin_move(plan::plan_pairs(pairs, absolute, &ctx), None, t),
                    None => code(ReplyCode::NoAxes),
                }
            }
            Command::MoveUntilPort(m) => match self.move_context() {
                Some(ctx) => {
                    let condition = PortCondition {
                        port: m.port,
                        mask: m.mask,
                        value: m.value,
                    };
                    self.begin_move(plan::plan_port_move(m, &ctx), Some(condition), t)
                }
                None => code(ReplyCode::NoAxes),
            },
            Command::Circle(params) => match self.move_context() {
                Some(ctx) => match plan::plan_arc(params, None, &ctx) {
                    Ok(legs) => self.begin_move(legs, None, t),
                    Err(c) => code(c),
                },
                None => code(ReplyCode::NoAxes),
            },
            Command::Helix(h) => match self.move_context() {
                Some(ctx) => match plan::plan_arc(&h.circle, Some(h.s3), &ctx) {
                    Ok(legs) => self.begin_move(legs, None, t),
                    Err(c) => code(c),
                },
                None => code(ReplyCode::NoAxes),
            },
            // A controller without port 2 answers it like any port it has
            // not got (manual 2.2.3, chapter 5 `1`).
            Command::ReadPort(crate::proto::isel::InputPort::Status2) if !self.config.port2 => {
                code(ReplyCode::BadNumber)
            }
            Command::ReadPort(port) => Exec::Reply(Reply::Byte(self.port(*port))),
            Command::WritePort { port, value } => match self.write_output(*port, *value) {
                Ok(()) => ok(),
                Err(c) => code(c),
            },
            Command::SetReferenceSpeeds(speeds) => {
                let axes = config.map_or(AxisSet::EMPTY, AxisConfig::axes);
                for (axis, speed) in axes.iter().zip(speeds) {
                    if let Some(s) = self.reference_speeds.get_mut(axis.index()) {
                        *s = *speed;
                    }
                }
                ok()
            }
            Command::Diagnose(d) => {
                let input = match d.kind() {
                    DiagnosisKind::PositiveLimitSwitches => Some(1),
                    DiagnosisKind::NegativeLimitSwitches => Some(0),
                    // Undocumented codes read 0 (docs/protocols.md, isel).
                    DiagnosisKind::Undocumented => None,
                };
                let byte = input.map_or(0, |input| {
                    (0..4)
                        .filter(|&axis| self.input_seen(axis, input))
                        .fold(0u8, |b, axis| b | 1 << axis)
                });
                Exec::Reply(Reply::Byte(byte))
            }
            Command::SetPlane(p) => {
                self.plane = *p;
                ok()
            }
            Command::SetCircleDirection(d) => {
                self.direction = *d;
                ok()
            }
            Command::ClearLimitSwitch(axis) => self.begin_clear(*axis, t),
            Command::SetBrake(on) => {
                self.outputs.write(OutputPort::Brake, u8::from(*on));
                ok()
            }
            Command::SetDeviceNumber(d) => {
                self.device = *d;
                ok()
            }
            Command::LimitSwitchStatus => Exec::Reply(Reply::Text {
                lines: text::limit_switches(&self.switch_report()),
                end: TextEnd::Code(ReplyCode::Ok),
            }),
            Command::Status => Exec::Reply(Reply::Text {
                lines: text::status(&self.status_report()),
                end: TextEnd::Code(ReplyCode::Ok),
            }),
            Command::StoreProgram => {
                if self.flash.program.is_some() {
                    // Decision 9: a program, even a broken one, is stored.
                    return code(ReplyCode::InvalidDataField);
                }
                self.flash.program = Some(StoredProgram {
                    lines: Vec::new(),
                    valid: false,
                    reference_speeds: self.reference_speeds,
                });
                self.storing = true;
                ok()
            }
            Command::Init(init) => self.init_command(init),
            Command::SetStartStop(hz) => {
                self.start_stop = *hz;
                ok()
            }
            Command::SetAcceleration(a) => {
                self.acceleration = *a;
                ok()
            }
            Command::EraseProgram => Exec::Step(Step::Erase {
                until: t + self.config.erase_time,
            }),
            Command::SetZero(mask) => {
                let counters = self.counters();
                for axis in mask.iter() {
                    self.virtual_zero[axis.index()] = counters[axis.index()];
                }
                ok()
            }
            Command::SimulateReference(mask) => {
                self.reference_here(*mask);
                ok()
            }
            Command::ReadPosition => Exec::Reply(Reply::Positions(self.positions())),
            Command::Reference(mask) => self.begin_reference(*mask, t),
            // Answered by `dnc`; a stored program has no `S`.
            Command::Start => code(ReplyCode::NotStorable),
            Command::SetTestMode(on) => {
                self.test_mode = *on;
                ok()
            }
            Command::ReadUserInfo => Exec::Reply(Reply::Text {
                lines: vec![self.init.user_info.clone()],
                end: TextEnd::Silence,
            }),
            Command::ReadVersion => Exec::Reply(Reply::Text {
                lines: text::version(),
                end: TextEnd::Silence,
            }),
            Command::Set3dInterpolation(on) => {
                self.three_d = *on;
                ok()
            }
        }
    }

    fn move_context(&self) -> Option<MoveContext> {
        Some(MoveContext {
            config: self.axis_config?,
            three_d: self.three_d,
            current: self.counters(),
            virtual_zero: self.virtual_zero,
            plane: self.plane,
            direction: self.direction,
        })
    }

    /// Whether a command may move the axes now; the code it answers if not.
    /// Order: machine fault `9`, hood `H` (as the `@0IH` watch sees it,
    /// manual 4.2.13), and for moves (not for reference runs and `@0F`,
    /// which start from inside a switch) reference `R` and a limit switch
    /// that is already active `2` (chapter 5, decision 4).
    pub(super) fn motion_gate(&mut self, is_move: bool) -> Result<(), ReplyCode> {
        if self.inputs.machine_fault() {
            return Err(ReplyCode::MachineFault);
        }
        if self.hood_watch_open() {
            return Err(ReplyCode::HoodOpen);
        }
        let all = self.axis_config.map_or(AxisSet::EMPTY, AxisConfig::axes);
        let referenced = all.iter().all(|a| self.referenced.contains(a));
        if is_move && !self.test_mode && !referenced {
            return Err(ReplyCode::ReferenceRequired);
        }
        if is_move && !self.test_mode && self.monitored_byte() != 0 {
            self.lose_reference();
            return Err(ReplyCode::LimitSwitch);
        }
        Ok(())
    }

    fn begin_move(
        &mut self,
        legs: Vec<LegSpec>,
        condition: Option<PortCondition>,
        t: Instant,
    ) -> Exec {
        if let Err(c) = self.motion_gate(true) {
            return code(c);
        }
        // A new move forgets the rest a soft stop kept.
        self.paused = None;
        let condition = self.next_move_condition.take().or(condition);
        if condition.is_some_and(|c| c.met(self.port(c.port))) {
            return ok();
        }
        let mut job = MotionJob::new(JobKind::Move, legs, !self.test_mode);
        job.condition = condition;
        match self.begin_job(job, t) {
            Some(step) => Exec::Step(step),
            None => ok(),
        }
    }

    /// Counter 0 here for the masked axes: `@0N` (manual 2.2.20) and `@0R`
    /// in test mode (2.2.24).
    fn reference_here(&mut self, mask: AxisSet) {
        for axis in mask.iter() {
            let i = axis.index();
            self.axes[i].set_counter(0);
            self.virtual_zero[i] = 0;
        }
        self.referenced = AxisSet::from_mask(self.referenced.mask() | mask.mask());
    }

    /// `@0R` (manual 2.2.22, 4.2.2): per axis in the order Z, Y, X, A, into
    /// the reference switch at the reference speed, step out until it
    /// closes, travel the `@0IF` steps, counter 0.
    fn begin_reference(&mut self, mask: AxisSet, t: Instant) -> Exec {
        // Manual 2.2.22: a reference run switches 3D interpolation off.
        self.three_d = false;
        if let Err(c) = self.motion_gate(false) {
            return code(c);
        }
        self.paused = None;
        if self.test_mode {
            self.reference_here(mask);
            return ok();
        }
        self.referenced = AxisSet::from_mask(self.referenced.mask() & !mask.mask());
        let mut legs = Vec::new();
        for axis in REFERENCE_ORDER.into_iter().filter(|a| mask.contains(*a)) {
            let i = axis.index();
            let towards_positive = self.init.invert_reference.contains(axis);
            let direction = if towards_positive { 1 } else { -1 };
            // The switch on the reference side: input 1 towards negative
            // counts, input 2 towards positive (manual 4.2.9).
            let input = usize::from(towards_positive);
            let speed = self.reference_speeds[i];
            let step_out = speed.min(self.start_stop);
            let clear = i64::from(self.init.clear_steps[i]);
            legs.push(LegSpec::Seek {
                axis: i,
                direction,
                speed,
                constant: false,
                until: Until::Active { axis: i, input },
            });
            legs.push(LegSpec::Seek {
                axis: i,
                direction: -direction,
                speed: step_out,
                constant: true,
                until: Until::Released { axis: i, input },
            });
            legs.push(LegSpec::Steps {
                axis: i,
                steps: -direction * clear,
                speed,
            });
            legs.push(LegSpec::Act(plan::Action::Reference(i)));
        }
        let job = MotionJob::new(JobKind::Reference, legs, false);
        match self.begin_job(job, t) {
            Some(step) => Exec::Step(step),
            None => ok(),
        }
    }

    /// `@0F` (manual 2.2.9): step out of the switch the axis stands in until
    /// it closes, then the `@0IF` steps; a reference run is needed after.
    fn begin_clear(&mut self, axis: Axis, t: Instant) -> Exec {
        if let Err(c) = self.motion_gate(false) {
            return code(c);
        }
        let i = axis.index();
        let Some(side) = self.pressed_side(i) else {
            return ok();
        };
        self.paused = None;
        self.referenced = AxisSet::from_mask(self.referenced.mask() & !axis.mask_bit());
        // Away from the switch, physically; in counts per the direction.
        let physical = if side == NEG { 1 } else { -1 };
        let direction = physical * self.axes[i].dir();
        let swapped = self.init.swap_limits.contains(axis);
        let input = side ^ usize::from(swapped);
        let speed = self.reference_speeds[i];
        let legs = vec![
            LegSpec::Seek {
                axis: i,
                direction,
                speed: speed.min(self.start_stop),
                constant: true,
                until: Until::Released { axis: i, input },
            },
            LegSpec::Steps {
                axis: i,
                steps: direction * i64::from(self.init.clear_steps[i]),
                speed,
            },
        ];
        let job = MotionJob::new(JobKind::Clear, legs, !self.test_mode);
        match self.begin_job(job, t) {
            Some(step) => Exec::Step(step),
            None => ok(),
        }
    }

    /// Write an output port (`@0B`, CNC `p`). Switching the spindle on with
    /// the hood open answers `H` (`docs/protocols.md`, isel).
    pub(super) fn write_output(&mut self, port: OutputPort, value: u8) -> Result<(), ReplyCode> {
        if self.config.hood_circuit
            && self.outputs.starts_spindle(port, value)
            && !self.inputs.hood_closed
        {
            return Err(ReplyCode::HoodOpen);
        }
        self.outputs.write(port, value);
        Ok(())
    }

    /// The error signal of `@0Ia` (manual 4.2.12): the set value under the
    /// mask on an error, its complement otherwise.
    pub(super) fn signal_error(&mut self, error: bool) {
        let s = self.init.error_output;
        if s.mask == 0 {
            return;
        }
        let wanted = if error { s.value } else { !s.value };
        let mut value = (self.outputs.read(s.port) & !s.mask) | (wanted & s.mask);
        if s.port.max_value() == 1 {
            value &= 1;
        }
        self.outputs.write(s.port, value);
    }

    fn init_command(&mut self, init: &InitCommand) -> Exec {
        match init {
            InitCommand::LoadFromFlash => {
                self.init = self.flash.init.clone();
                self.load_working_values();
            }
            InitCommand::WriteToFlash => self.flash.init = self.init.clone(),
            InitCommand::RestoreDefaults => {
                self.init = self.config.factory.clone();
                self.load_working_values();
                // Decision 4: the reference is lost.
                self.referenced = AxisSet::EMPTY;
                self.paused = None;
            }
            other => {
                self.init.apply(other);
                // A new default is also the value in use until it is
                // changed (docs/protocols.md, isel).
                match other {
                    InitCommand::DefaultReferenceSpeeds(v) => self.reference_speeds = *v,
                    InitCommand::DefaultAcceleration(v) => self.acceleration = *v,
                    InitCommand::DefaultStartStop(v) => self.start_stop = *v,
                    InitCommand::InvertDirections(_) | InitCommand::IoOnly(_) => {
                        self.apply_axis_settings()
                    }
                    _ => {}
                }
            }
        }
        ok()
    }

    fn switch_report(&self) -> Vec<AxisSwitches> {
        Axis::ALL
            .iter()
            .map(|&axis| AxisSwitches {
                axis,
                active: [
                    self.input_active(axis.index(), 0),
                    self.input_active(axis.index(), 1),
                ],
                settings: [1, 2].map(|n| self.init.limit_switches.get(axis, n).unwrap_or_default()),
            })
            .collect()
    }

    fn status_report(&self) -> Status {
        Status {
            axes: self.axis_config.map(AxisConfig::axes),
            referenced: self.referenced,
            test_mode: self.test_mode,
            three_d: self.three_d,
            start_stop: self.start_stop,
            acceleration: self.acceleration,
            reference_speeds: self.reference_speeds,
            ports: self.ports(),
            outputs: [
                self.outputs.user,
                self.outputs.analog,
                self.outputs.control,
                self.outputs.signal,
            ],
            program: match &self.flash.program {
                None => "none",
                Some(p) if p.valid => "stored",
                Some(_) => "invalid (erase with @0k)",
            },
            device: self.device.get(),
            hood_closed: self.inputs.hood_closed,
        }
    }
}
