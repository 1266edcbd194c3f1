//! Device model of the EMCU interface on an SMC3000 stepper card (manual
//! `emcu-smc3000-programming.de.txt`, chapter 1; `docs/decisions.md`,
//! EMCU; the simulator's own decisions in `docs/protocols.md`, EMCU).
//!
//! Sans-IO: bytes arrive through [`SimDevice::on_byte`], time through the
//! `Instant`s passed in. Lines are cut and parsed by the protocol core's
//! [`CommandFramer`], replies written by [`Reply::encode`].
//!
//! - [`config`]: the machine behind the interface (end stops, start position);
//! - `settings`: start speed, end-speed slots, ramp length, E1 linkage;
//! - `mechanics`: step counters, carriages, end stops, reference switches and
//!   the interpolated motion under way;
//! - `memory`: the data memory and the ROM job store;
//! - `lines`: what a received line does;
//! - `executor`: running the stored commands, pause, halt and stops.

pub mod config;
mod executor;
mod lines;
mod mechanics;
mod memory;
mod settings;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::time::Instant;

use crate::config::Profile;
use crate::proto::emcu::job::{DATA_MEMORY_CAPACITY, JOB_CAPACITY};
use crate::proto::emcu::{CommandFramer, EmcuAxis, Output, Reply, Status};
use crate::wire::LineSettings;

use super::{InputControl, SimDevice};

pub use config::{AxisTravel, EmcuSimConfig, EndStops, SimConfigError};

use executor::{Executor, Mode};
use mechanics::Mechanics;
use memory::{DataMemory, Rom};
use settings::Settings;

/// What `@V` reports (manual 1.5.2).
pub const VERSION: &str = "SMC3000i 1.00";

/// The one input of the interface (manual 1.5.19), as the operator control
/// names it.
pub const INPUT_E1: &str = "e1";

/// The EMCU device model.
#[derive(Debug, Clone)]
pub struct EmcuSim {
    config: EmcuSimConfig,
    framer: CommandFramer,
    /// The time the model has been brought up to.
    clock: Option<Instant>,
    outbox: VecDeque<Vec<u8>>,
    mech: Mechanics,
    settings: Settings,
    memory: DataMemory,
    rom: Rom,
    /// Commands the ROM store takes (`memory <n>` on the simulator's stdin
    /// lowers it, as a controller with less memory than assumed).
    job_capacity: usize,
    exec: Executor,
    error: bool,
    position_unknown: bool,
    /// A1 (K1) and A2 (K2), manual 1.5.15.
    outputs: [bool; 2],
    e1: bool,
    /// Why the error flag was last set, for `describe`.
    last_error: Option<String>,
}

impl EmcuSim {
    /// Power-up: counters 0, position unknown, the manual's defaults.
    pub fn new(config: EmcuSimConfig) -> EmcuSim {
        EmcuSim {
            config,
            framer: CommandFramer::new(),
            clock: None,
            outbox: VecDeque::new(),
            mech: Mechanics::new(&config),
            settings: Settings::default(),
            memory: DataMemory::default(),
            rom: Rom::default(),
            job_capacity: JOB_CAPACITY,
            exec: Executor::default(),
            error: false,
            position_unknown: true,
            outputs: [false; 2],
            e1: false,
            last_error: None,
        }
    }

    /// The machine a profile describes (see [`EmcuSimConfig::from_profile`]).
    pub fn from_profile(profile: &Profile) -> Result<EmcuSim, SimConfigError> {
        EmcuSimConfig::from_profile(profile).map(EmcuSim::new)
    }

    pub fn config(&self) -> &EmcuSimConfig {
        &self.config
    }

    /// What `@X` would answer at `now`.
    pub fn status(&mut self, now: Instant) -> Status {
        self.run_until(now);
        self.current_status()
    }

    /// The step counter of an axis at `now`, as `@L` reports it.
    pub fn counter(&mut self, axis: EmcuAxis, now: Instant) -> i32 {
        let now = self.run_until(now);
        self.mech.counter(axis, now)
    }

    /// The carriage's machine position at `now`, in steps from the reference
    /// switch (differs from the counter by the reference point and any lost
    /// steps).
    pub fn machine_position(&mut self, axis: EmcuAxis, now: Instant) -> i64 {
        let now = self.run_until(now);
        self.mech.physical(axis, now)
    }

    pub fn output(&self, output: Output) -> bool {
        self.outputs
            .get(usize::from(output.get().saturating_sub(1)))
            .copied()
            .unwrap_or(false)
    }

    fn send(&mut self, reply: Reply) {
        self.outbox.push_back(reply.encode());
    }

    /// The `@X` flags (manual 1.5.3). The job flag stays 0 during a reference
    /// run, as in the manual's example `@X100110` (`docs/protocols.md`, EMCU).
    fn current_status(&self) -> Status {
        let referencing = self.exec.is_referencing();
        Status {
            moving: self.mech.is_moving(),
            waiting: self.exec.is_waiting(),
            error: self.error,
            position_unknown: self.position_unknown,
            referencing,
            job_running: self.exec.is_active() && !referencing,
        }
    }

    fn set_e1(&mut self, level: bool, now: Instant) {
        self.e1 = level;
        if level {
            self.e1_rose(now);
        }
    }
}

impl SimDevice for EmcuSim {
    /// 19200 baud 8N1 (manual 1.4.1).
    fn line(&self) -> LineSettings {
        LineSettings::new(19200)
    }

    fn on_byte(&mut self, byte: u8, now: Instant) {
        let now = self.run_until(now);
        if let Some(line) = self.framer.push(byte) {
            // The interface answers at once (manual 1.4.2 allows up to 500 ms;
            // nothing says when it takes longer).
            self.on_line(line, now);
            self.run_until(now);
        }
    }

    fn advance(&mut self, now: Instant) {
        self.run_until(now);
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.due()
    }

    fn poll_output(&mut self) -> Option<Vec<u8>> {
        self.outbox.pop_front()
    }

    fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
        let now = self.run_until(now);
        let name = control.name();
        if !name.eq_ignore_ascii_case(INPUT_E1) {
            return Err(format!(
                "the EMCU simulator has no input `{name}`: its only input is {INPUT_E1}"
            ));
        }
        match control {
            InputControl::Set { level, .. } => self.set_e1(*level, now),
            // A push button on E1: high for an instant, long enough for a
            // move that waits for it to start.
            InputControl::Press { .. } => {
                self.set_e1(true, now);
                self.e1 = false;
            }
            InputControl::Value { .. } => {
                return Err(format!(
                    "{INPUT_E1} is a digital input: use `set {INPUT_E1} on|off`"
                ));
            }
        }
        self.run_until(now);
        Ok(())
    }

    fn input_names(&self) -> Vec<&'static str> {
        vec![INPUT_E1]
    }

    /// The ROM job store (manual 1.5.17) takes `commands` from the next
    /// line on; a job stored already stays (it is in the ROM).
    fn set_program_memory(&mut self, commands: usize) -> Result<(), String> {
        if commands > JOB_CAPACITY {
            return Err(format!(
                "the EMCU's ROM job store holds at most {JOB_CAPACITY} commands"
            ));
        }
        self.job_capacity = commands;
        Ok(())
    }

    fn input_level(&self, name: &str) -> Option<bool> {
        name.eq_ignore_ascii_case(INPUT_E1).then_some(self.e1)
    }

    /// `X 120 [machine 8120] Y 0 [machine 8000] Z 0 | moving, job running |
    /// A1 off A2 off | E1 low | memory 3/256 | ROM job 5 | #S200 #R500 &V0`.
    fn describe(&self, now: Instant) -> String {
        let now = self.clock.map_or(now, |c| c.max(now));
        let mut out = String::new();
        for axis in EmcuAxis::ALL {
            let counter = self.mech.counter(axis, now);
            let physical = self.mech.physical(axis, now);
            let _ = write!(out, "{axis} {counter}");
            if physical != i64::from(counter) {
                let _ = write!(out, " [machine {physical}]");
            }
            out.push(' ');
        }
        let _ = write!(out, "| {}", self.current_status());
        match self.exec.mode {
            Mode::Pausing { .. } => out.push_str(", pausing"),
            Mode::Paused => out.push_str(", paused"),
            Mode::Ending => out.push_str(", halting"),
            Mode::Running => {}
        }
        if self.exec.is_awaiting_e1() {
            out.push_str(", awaiting E1");
        }
        let on_off = |on: bool| if on { "on" } else { "off" };
        let [a1, a2] = self.outputs;
        let _ = write!(
            out,
            " | A1 {} A2 {} | E1 {} | memory {}/{DATA_MEMORY_CAPACITY}",
            on_off(a1),
            on_off(a2),
            if self.e1 { "high" } else { "low" },
            self.memory.len(),
        );
        let _ = match &self.rom {
            Rom::Empty => write!(out, " | ROM empty"),
            Rom::Receiving { .. } => write!(out, " | ROM receiving {}", self.rom.len()),
            Rom::Stored(_) => write!(out, " | ROM job {}", self.rom.len()),
        };
        if self.job_capacity != JOB_CAPACITY {
            let _ = write!(out, " (room for {})", self.job_capacity);
        }
        let _ = write!(
            out,
            " | #S{} #R{} &V{}",
            self.settings.start,
            self.settings.ramp,
            u8::from(self.settings.link_e1)
        );
        if let (true, Some(why)) = (self.error, &self.last_error) {
            let _ = write!(out, " | error: {why}");
        }
        out
    }
}
