//! The isel iMC-S8 device model: a sans-IO [`SimDevice`] that behaves like
//! the controller of the isel programming manual, with the decisions of
//! `docs/decisions.md` (isel 1-13) and `docs/protocols.md` (isel).
//!
//! Everything on the wire goes through the protocol core
//! (`crate::proto::isel`): the [`RequestFramer`] cuts lines and control
//! bytes, `parse_frame`/`parse_cnc` and `check` decide what a line is and
//! which error it gets, [`Reply::encode`] writes every answer.
//!
//! The model is split by job:
//! - [`config`]: what it is built from (a profile or a plain struct);
//! - [`flash`]: init values (chapter 4) and the stored program;
//! - `mechanics`: carriages, counters, limit switches;
//! - `plan` and `path`: from a command to legs of motion, and where the
//!   axes are at any time on a leg (`crate::motion` timing);
//! - `exec`: DNC commands and stored program lines;
//! - `run`: jobs in progress (moves, reference runs, program runs) and the
//!   events that end them;
//! - `controls`: the operator's inputs; `io`: ports; `text`: texts;
//!   `program`: storing and running CNC programs.
//!
//! Time only enters as arguments: the model keeps the latest time it was
//! given and computes the next event (a leg ends, a switch trips, a delay
//! is over) so the shell can call [`SimDevice::advance`] exactly then.

pub mod config;
mod controls;
mod exec;
pub mod flash;
mod io;
mod mechanics;
mod path;
mod plan;
mod program;
mod run;
mod text;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::time::Instant;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    AxisConfig, CircleDirection, ControlByte, DeviceNumber, InputPort, Plane, Positions, Received,
    Reply, ReplyCode, RequestFramer, SyncChar,
};
use crate::wire::LineSettings;

use super::{InputControl, SimDevice};

pub use config::{AxisMechanics, IselSimConfig, PROGRAM_CAPACITY, SimConfigError};
pub use flash::{Flash, InitValues, StoredProgram};

use io::{Inputs, Outputs, PortCondition};
use mechanics::AxisState;
use plan::LegSpec;
use program::ProgramRun;
use run::{Event, Step};

/// Who gets the answer when the current activity ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ReplyTo {
    /// A command from the host: it answers.
    Host,
    /// The start key: there was no command, nothing answers.
    Silent,
}

/// What the controller is busy with: from a command's CR (or the start
/// key) until it answers.
#[derive(Debug, Clone)]
struct Activity {
    reply: ReplyTo,
    /// Set while a stored program runs.
    program: Option<ProgramRun>,
    step: Step,
}

/// What a soft stop (0xFD, stop key) kept for `@0S` or the start key
/// (decision 6): the rest of the move, and of the program it belonged to.
#[derive(Debug, Clone, PartialEq)]
struct Paused {
    legs: Vec<LegSpec>,
    condition: Option<PortCondition>,
    program: Option<ProgramRun>,
}

/// The simulated isel iMC-S8 and the machine it drives.
#[derive(Debug, Clone)]
pub struct IselSim {
    config: IselSimConfig,
    flash: Flash,
    /// The working copy of the init values.
    init: InitValues,
    /// The line rate of this power-up (`@0IC`, manual 4.2.15).
    baud: u32,
    device: DeviceNumber,
    framer: RequestFramer,
    axes: [AxisState; 4],
    axis_config: Option<AxisConfig>,
    referenced: AxisSet,
    test_mode: bool,
    three_d: bool,
    plane: Plane,
    direction: CircleDirection,
    reference_speeds: [u32; 4],
    start_stop: u32,
    acceleration: u32,
    virtual_zero: [i64; 4],
    inputs: Inputs,
    /// The probe touches the work piece of `config.probe_surface` (port 1
    /// bit 5 then reads this): changed by `Event::Surface` as the carriage
    /// enters or leaves the material, so that a move ending on the probe (`@0Z`) stops
    /// where a real one would.
    surface_touch: bool,
    /// How much longer than the reference tool the tool in the spindle is,
    /// Z steps (`value tool <steps>`): the probe touches the work piece and
    /// the tool sensor that much higher.
    tool_length: i64,
    outputs: Outputs,
    /// A CNC program transfer is open (`@0i`, manual 2.2.13).
    storing: bool,
    activity: Option<Activity>,
    paused: Option<Paused>,
    /// The port condition of a CNC `6` for the move being started.
    next_move_condition: Option<PortCondition>,
    /// When the start and the stop key, pressed by `press`, are let go: a
    /// finger holds a key for a human instant, and a program that polls
    /// the key (a CNC `o` loop waiting for start) reads it down meanwhile.
    key_release: [Option<Instant>; 2],
    out: VecDeque<Vec<u8>>,
    /// The latest time the model was brought to.
    clock: Option<Instant>,
    next: Option<(Instant, Event)>,
}

/// Bound on events handled in one call, against a model that would
/// otherwise never stop finding work.
const MAX_EVENTS: usize = 100_000;

impl IselSim {
    /// Power up a controller built from `config`.
    pub fn new(config: IselSimConfig) -> IselSim {
        let flash = config.flash.clone();
        let axes = config.axes.map(AxisState::power_up);
        let init = flash.init.clone();
        let mut sim = IselSim {
            baud: init.baud(),
            device: config.device,
            framer: RequestFramer::new(),
            axes,
            axis_config: None,
            referenced: AxisSet::EMPTY,
            test_mode: false,
            three_d: false,
            plane: Plane::XY,
            direction: CircleDirection::Cw,
            reference_speeds: init.reference_speeds,
            start_stop: init.start_stop,
            acceleration: init.acceleration,
            virtual_zero: [0; 4],
            inputs: Inputs::power_up(),
            surface_touch: false,
            tool_length: 0,
            outputs: Outputs::power_up(),
            storing: false,
            activity: None,
            paused: None,
            next_move_condition: None,
            key_release: [None; 2],
            out: VecDeque::new(),
            clock: None,
            next: None,
            init,
            flash,
            config,
        };
        sim.power_up_state();
        sim.surface_touch = sim.surface_touched_at_rest();
        sim
    }

    /// The simulator for a machine profile.
    pub fn from_profile(profile: &crate::config::Profile) -> Result<IselSim, SimConfigError> {
        IselSimConfig::from_profile(profile).map(IselSim::new)
    }

    /// Switch the controller off and on again at `now`: the carriages stay
    /// where they are, the flash keeps its contents, everything else starts
    /// over, the line rate included (`@0IC1` + `@0IW`, manual 4.2.15).
    pub fn power_cycle(&mut self, now: Instant) {
        self.catch_up(now);
        self.halt_motion(now);
        self.baud = self.flash.init.baud();
        self.framer = RequestFramer::new();
        self.inputs.start_key = false;
        self.inputs.stop_key = false;
        self.key_release = [None; 2];
        self.power_up_state();
        self.schedule();
    }

    /// The flash as it stands (init values and program).
    pub fn flash(&self) -> &Flash {
        &self.flash
    }

    /// Where each carriage physically stands at `now`, in steps of machine
    /// coordinates (X, Y, Z, A), also during a move.
    pub fn physical_positions(&self, now: Instant) -> [f64; 4] {
        let counters = self.counters_at(now);
        let mut out = [0.0; 4];
        for (i, axis) in self.axes.iter().enumerate() {
            out[i] = axis.phys_of(counters[i]);
        }
        out
    }

    /// Whether the probe touches the work piece with the carriages where
    /// they stand at rest (false without one).
    fn surface_touched_at_rest(&self) -> bool {
        self.surface()
            .is_some_and(|s| mechanics::surface_touched(&s, &self.axes, self.counters()))
    }

    /// The probe surface as the tool in the spindle meets it: raised by
    /// the tool's length (`value tool <steps>`; a longer tool touches with
    /// the carriage higher).
    fn surface(&self) -> Option<crate::config::ProbeSurface> {
        self.config
            .probe_surface
            .map(|s| s.raised(self.tool_length as f64))
    }

    /// Port 1 bit 5, the probe: the work piece's while one is set (variant
    /// `probe-surface`), else what the operator set.
    fn probe_bit(&self) -> bool {
        match self.config.probe_surface {
            Some(_) => self.surface_touch,
            None => self.inputs.probe,
        }
    }

    /// The counters (`@0P` before wrapping) at `now`, also during a move.
    pub fn counters_at(&self, now: Instant) -> [f64; 4] {
        match self.motion_run() {
            Some(run) => run.position_at(now),
            None => self.counters().map(|c| c as f64),
        }
    }

    /// RAM state after a power-up or a software reset (manual 2.2.31):
    /// init values from flash, nothing initialised or referenced, outputs
    /// off. Carriages, operator inputs and the flash stay.
    fn power_up_state(&mut self) {
        self.init = self.flash.init.clone();
        self.device = self.config.device;
        self.axis_config = None;
        self.referenced = AxisSet::EMPTY;
        self.test_mode = false;
        self.three_d = false;
        self.plane = Plane::XY;
        self.direction = CircleDirection::Cw;
        self.virtual_zero = [0; 4];
        self.outputs = Outputs::power_up();
        self.storing = false;
        self.activity = None;
        self.paused = None;
        self.next_move_condition = None;
        self.load_working_values();
        for axis in &mut self.axes {
            axis.set_counter(0);
        }
    }

    /// Take speeds, directions and IO-only mode from the init values
    /// (`@0IL`, `@0IX`, power-up).
    fn load_working_values(&mut self) {
        self.reference_speeds = self.init.reference_speeds;
        self.start_stop = self.init.start_stop;
        self.acceleration = self.init.acceleration;
        self.apply_axis_settings();
    }

    /// Directions (`@0ID`) and IO-only mode (`@0IO`) act at once.
    fn apply_axis_settings(&mut self) {
        for axis in Axis::ALL {
            let inverted = self.init.invert_directions.contains(axis);
            if let Some(a) = self.axes.get_mut(axis.index()) {
                a.set_inverted(inverted);
            }
        }
        if self.init.io_only {
            self.axis_config = None;
        }
    }

    fn counters(&self) -> [i64; 4] {
        self.axes.each_ref().map(AxisState::counter)
    }

    /// Put the carriages where the counters say (after a leg).
    fn set_counters(&mut self, counters: [i64; 4]) {
        for (axis, c) in self.axes.iter_mut().zip(counters) {
            axis.move_to_counter(c);
        }
    }

    /// A `2` or `9` (or an E-stop while idle): the controller must be
    /// initialised and referenced again (isel manual chapter 5); whatever a
    /// soft stop kept is gone.
    fn lose_reference(&mut self) {
        self.axis_config = None;
        self.referenced = AxisSet::EMPTY;
        self.paused = None;
    }

    fn answer(&mut self, reply: Reply) {
        // Every reply the model builds is encodable (text lines are its own
        // and never start with a digit); should one not be, the host still
        // gets the handshake instead of silence.
        let bytes = reply
            .encode()
            .unwrap_or_else(|_| vec![ReplyCode::Ok.byte()]);
        self.out.push_back(bytes);
    }

    fn answer_code(&mut self, code: ReplyCode) {
        self.answer(Reply::Code(code));
    }

    /// An input port as `@0b` reads it (manual 2.2.3).
    fn port(&self, port: InputPort) -> u8 {
        match port {
            InputPort::User => self.inputs.user,
            InputPort::Status1 => {
                self.inputs.port1() & !io::PROBE_BIT
                    | if self.probe_bit() { io::PROBE_BIT } else { 0 }
            }
            // No port: nothing to read (`@0b2` answers `1`, `exec`). No
            // hood circuit: its bits 5-7 read 0.
            InputPort::Status2 if !self.config.port2 => 0,
            InputPort::Status2 if !self.config.hood_circuit => {
                self.inputs.port2(self.outputs.spindle()) & 0x1F
            }
            InputPort::Status2 => self.inputs.port2(self.outputs.spindle()),
            InputPort::LimitSwitches => {
                let mut byte = 0u8;
                for axis in 0..4 {
                    for input in 0..2 {
                        if self.input_active(axis, input) {
                            byte |= 1 << (2 * axis + input);
                        }
                    }
                }
                byte
            }
        }
    }

    fn ports(&self) -> [u8; 4] {
        InputPort::ALL.map(|p| self.port(p))
    }

    /// The hood supervision of `@0IH` (manual 4.2.13) reports the hood open:
    /// the port under the mask differs from the set value. Mask 0: off.
    fn hood_watch_open(&self) -> bool {
        let w = self.init.hood_input;
        w.mask != 0 && self.port(w.port) & w.mask != w.value & w.mask
    }

    /// Motion with the hood open stops the machine (code 9): only where a
    /// hood circuit is wired, in automatic mode (port 2 bit 6).
    fn hood_circuit_allows_motion(&self) -> bool {
        !self.config.hood_circuit || self.inputs.motion_allowed()
    }

    /// The logical state of limit switch input `input` (0 = switch 1) of
    /// `axis`: the contact, inverted for a switch `@0IE` calls low-active
    /// (the simulated switches are wired high-active, manual 4.2.6).
    fn input_active(&self, axis: usize, input: usize) -> bool {
        let Some(a) = self.axes.get(axis) else {
            return false;
        };
        let Some(ax) = Axis::from_index(axis) else {
            return false;
        };
        let setting = self
            .init
            .limit_switches
            .get(ax, input as u8 + 1)
            .unwrap_or_default();
        a.contact(input, self.init.swap_limits.contains(ax)) != setting.low_active
    }

    /// Whether an input is enabled by `@0IE` and active: what the
    /// controller sees of its limit switches (`@0DRp`/`@0DRn`, seeks).
    fn input_seen(&self, axis: usize, input: usize) -> bool {
        let enabled = Axis::from_index(axis)
            .and_then(|a| self.init.limit_switches.get(a, input as u8 + 1))
            .is_some_and(|s| s.enabled);
        enabled && self.input_active(axis, input)
    }

    /// Whether the controller watches this input during moves and it is
    /// active: seen, on an initialised axis.
    fn input_monitored(&self, axis: usize, input: usize) -> bool {
        let initialised = Axis::from_index(axis)
            .is_some_and(|a| self.axis_config.is_some_and(|c| c.axes().contains(a)));
        initialised && self.input_seen(axis, input)
    }

    /// The monitored inputs that are active, as port 3 bits.
    fn monitored_byte(&self) -> u8 {
        let mut byte = 0u8;
        for axis in 0..4 {
            for input in 0..2 {
                if self.input_monitored(axis, input) {
                    byte |= 1 << (2 * axis + input);
                }
            }
        }
        byte
    }

    fn positions(&self) -> Positions {
        // The counters are 24 bits wide; the encoder keeps the low 24 bits
        // (manual 2.2.21, decision 2). A `work-positions` controller counts
        // from the virtual zero of `@0n` instead of the reference point.
        let mut counters = self.counters();
        if self.config.work_positions {
            for (c, z) in counters.iter_mut().zip(self.virtual_zero) {
                *c -= z;
            }
        }
        let [x, y, z, a] = counters.map(|c| c as i32);
        Positions {
            x,
            y,
            z,
            a: (self.axis_config == Some(AxisConfig::XYZA)).then_some(a),
        }
    }

    /// Handle one received byte at `t` (the model is up to date).
    fn receive(&mut self, byte: u8, t: Instant) {
        if ControlByte::from_byte(byte).is_some() {
            if let Some(Received::Control(control)) = self.framer.push(byte) {
                self.control_byte(control, t);
            }
            return;
        }
        if let Some(Activity {
            step: Step::Sync { sync, offset },
            ..
        }) = &self.activity
        {
            let (sync, offset) = (*sync, *offset);
            self.sync_received(byte, sync, offset, t);
            return;
        }
        if self.activity.is_some() {
            // Busy: the controller reads nothing but the control bytes
            // until the command has answered (decision "Facts"); the byte
            // is lost (`docs/protocols.md`, isel).
            return;
        }
        match self.framer.push(byte) {
            Some(Received::Line(line)) => self.received_line(&line, t),
            Some(Received::Overlong { .. }) => {
                if self.storing {
                    self.storing = false;
                }
                self.answer_code(ReplyCode::Syntax);
            }
            Some(Received::Control(control)) => self.control_byte(control, t),
            None => {}
        }
    }

    fn control_byte(&mut self, control: ControlByte, t: Instant) {
        match control {
            ControlByte::SoftStop => self.soft_stop(t, false),
            ControlByte::Break => self.break_off(t),
            ControlByte::Reset => self.reset(t),
        }
    }

    /// 0xFE: stop at once, then start over like a power-up, keeping the
    /// line rate (manual 2.2.31; `docs/protocols.md`, isel). No answer.
    fn reset(&mut self, t: Instant) {
        self.halt_motion(t);
        if let Some(p) = self.flash.program.as_mut()
            && self.storing
        {
            p.valid = false;
        }
        self.power_up_state();
    }

    /// Handle every event due by `now`.
    fn catch_up(&mut self, now: Instant) {
        for _ in 0..MAX_EVENTS {
            let Some((t, event)) = self.next else {
                break;
            };
            if t > now {
                break;
            }
            self.tick(t);
            self.handle_event(event, t);
            self.schedule();
        }
        self.tick(now);
    }

    fn tick(&mut self, t: Instant) {
        self.clock = Some(self.clock.map_or(t, |c| c.max(t)));
    }

    fn now_or(&self, t: Instant) -> Instant {
        self.clock.map_or(t, |c| c.max(t))
    }

    /// After a change at `t`: work out the next event and handle what the
    /// change made due at once (a leg halted at `t` ends at `t`), so the
    /// next deadline always lies ahead.
    fn settle_at(&mut self, t: Instant) {
        self.schedule();
        self.catch_up(t);
        self.schedule();
    }

    /// Work out the next event after a change.
    fn schedule(&mut self) {
        self.next = self.clock.and_then(|now| self.compute_next(now));
    }

    fn sync_char(&mut self, sync: SyncChar) {
        self.out.push_back(vec![sync.byte()]);
    }
}

impl SimDevice for IselSim {
    fn line(&self) -> LineSettings {
        LineSettings::new(self.baud)
    }

    fn on_byte(&mut self, byte: u8, now: Instant) {
        self.catch_up(now);
        let t = self.now_or(now);
        self.receive(byte, t);
        self.settle_at(t);
    }

    fn advance(&mut self, now: Instant) {
        self.catch_up(now);
        self.schedule();
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.next.map(|(t, _)| t)
    }

    fn poll_output(&mut self) -> Option<Vec<u8>> {
        self.out.pop_front()
    }

    fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
        self.catch_up(now);
        let t = self.now_or(now);
        let result = self.operator(control, t);
        self.settle_at(t);
        result
    }

    fn input_names(&self) -> Vec<&'static str> {
        // Without a hood circuit there is no hood and no key switch to set.
        // With a work piece the probe follows the carriage, not a hand.
        let mut names = io::input_names();
        if !self.config.hood_circuit {
            names.retain(|n| !matches!(*n, "hood" | "key-switch"));
        }
        if self.config.probe_surface.is_some() {
            names.retain(|n| *n != "probe");
        }
        names
    }

    fn input_level(&self, name: &str) -> Option<bool> {
        if !self.config.hood_circuit && matches!(name, "hood" | "key-switch") {
            return None;
        }
        if self.config.probe_surface.is_some() && name.eq_ignore_ascii_case("probe") {
            return None;
        }
        self.operator_level(name)
    }

    fn describe(&self, now: Instant) -> String {
        self.state_line(now)
    }

    /// The flash takes `commands` program commands before the end `9` from
    /// the next stored line on (manual 2.2.13: beyond them `6`, memory
    /// full); a stored program stays.
    fn set_program_memory(&mut self, commands: usize) -> Result<(), String> {
        if commands > PROGRAM_CAPACITY {
            return Err(format!(
                "the isel controller's program memory holds at most {PROGRAM_CAPACITY} commands"
            ));
        }
        self.config.program_capacity = commands;
        Ok(())
    }
}
