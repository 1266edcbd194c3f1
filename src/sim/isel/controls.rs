//! The operator's side of the simulated machine: inputs set and buttons
//! pressed from the simulator's stdin (`docs/simulator.md`, isel), and the
//! one-line state `show` prints.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::sim::InputControl;

use super::io::{INPUT_NAMES, InputName, SPINDLE_BIT};
use super::run::{JobKind, Step};
use super::{Activity, IselSim, ReplyTo};

/// How long `press` holds a key down: a quick tap of a finger. A stored
/// program that waits for the start key polls port 1 in a loop (CNC `o`,
/// manual 3.2.19) and sees the key only while it is down.
pub(super) const KEY_HOLD: Duration = Duration::from_millis(150);

/// Indices into `IselSim::key_release`.
pub(super) const START_KEY: usize = 0;
pub(super) const STOP_KEY: usize = 1;

impl IselSim {
    /// A pressed key is let go.
    pub(super) fn release_key(&mut self, key: usize, t: Instant) {
        let before = self.snapshot();
        if let Some(release) = self.key_release.get_mut(key) {
            *release = None;
        }
        match key {
            START_KEY => self.inputs.start_key = false,
            _ => self.inputs.stop_key = false,
        }
        self.inputs_changed(before, t);
    }

    /// The level an input was set to. A limit switch is the operator's
    /// forcing of it: a switch the axis runs onto shows on port 3, not here.
    pub(super) fn operator_level(&self, name: &str) -> Option<bool> {
        let i = &self.inputs;
        Some(match InputName::parse(name)? {
            InputName::Limit { axis, input } => *self.axes.get(axis)?.forced.get(input)?,
            InputName::Estop(n) => *i.estop.get(n)?,
            InputName::Overtemp => i.overtemp,
            InputName::Start => i.start_key,
            InputName::Stop => i.stop_key,
            InputName::Probe => i.probe,
            InputName::PowerOk => i.power_ok,
            InputName::Hood => i.hood_closed,
            InputName::KeySwitch => i.key_switch,
            InputName::User(bit) => i.user & 1u8.checked_shl(u32::from(bit))? != 0,
        })
    }

    /// `value tool <steps>`: the tool in the spindle is `steps` Z steps
    /// longer than the reference tool (a tool changed at the machine), so
    /// the probe surface and the tool sensor on it are met that much higher
    /// (`docs/simulator.md`, "Probe surface").
    fn set_tool_length(&mut self, steps: f64) -> Result<(), String> {
        if self.config.probe_surface.is_none() {
            return Err(
                "`tool`: the tool's length shows only on a probe surface (variant probe-surface)"
                    .to_owned(),
            );
        }
        if steps.fract() != 0.0 || steps.abs() > 1e9 {
            return Err(format!("`tool {steps}`: a whole number of Z steps"));
        }
        self.tool_length = steps as i64;
        self.surface_touch = self.surface_touched_at_rest();
        Ok(())
    }

    /// Apply an operator control at `t`.
    pub(super) fn operator(&mut self, control: &InputControl, t: Instant) -> Result<(), String> {
        let (name, level, press) = match control {
            InputControl::Set { name, level } => (name, *level, false),
            InputControl::Press { name } => (name, true, true),
            InputControl::Value { name, value } if name.eq_ignore_ascii_case("tool") => {
                return self.set_tool_length(*value);
            }
            InputControl::Value { name, .. } => {
                return Err(format!(
                    "`{name}`: the isel controller has no analogue inputs: use set {name} on|off"
                ));
            }
        };
        let input = InputName::parse(name).ok_or_else(|| {
            format!(
                "unknown input `{name}`: expected {}",
                INPUT_NAMES.join(", ")
            )
        })?;
        if !self.config.hood_circuit && matches!(input, InputName::Hood | InputName::KeySwitch) {
            return Err(format!(
                "`{name}`: this controller has no hood circuit (simulator variant {})",
                if self.config.port2 {
                    "hood-unwired"
                } else {
                    "no-port2"
                }
            ));
        }
        if let (InputName::Probe, Some(s)) = (input, self.config.probe_surface) {
            return Err(format!(
                "`{name}` follows the probe surface {s} (variant probe-surface) while one is set"
            ));
        }
        if press && !matches!(input, InputName::Start | InputName::Stop) {
            return Err(format!(
                "`{name}` is not a button (press works on start and stop): set {name} on|off"
            ));
        }
        let before = self.snapshot();
        match input {
            InputName::Limit { axis, input } => {
                if let Some(f) = self
                    .axes
                    .get_mut(axis)
                    .and_then(|a| a.forced.get_mut(input))
                {
                    *f = level;
                }
            }
            InputName::Estop(i) => {
                if let Some(e) = self.inputs.estop.get_mut(i) {
                    *e = level;
                }
            }
            InputName::Overtemp => self.inputs.overtemp = level,
            InputName::PowerOk => self.inputs.power_ok = level,
            InputName::Probe => self.inputs.probe = level,
            InputName::Hood => {
                self.inputs.hood_closed = level;
                if !level {
                    // The spindle may not run with the hood open.
                    self.outputs.control &= !SPINDLE_BIT;
                }
            }
            InputName::KeySwitch => self.inputs.key_switch = level,
            InputName::User(bit) => {
                let mask = 1u8 << (bit & 7);
                if level {
                    self.inputs.user |= mask;
                } else {
                    self.inputs.user &= !mask;
                }
            }
            InputName::Start => {
                let rising = level && !self.inputs.start_key;
                self.inputs.start_key = level;
                self.key_release[START_KEY] = press.then(|| t + KEY_HOLD);
                if rising {
                    // Like `@0S`, but nothing answers: there was no command.
                    let _ = self.start(ReplyTo::Silent, t);
                }
            }
            InputName::Stop => {
                let rising = level && !self.inputs.stop_key;
                self.inputs.stop_key = level;
                self.key_release[STOP_KEY] = press.then(|| t + KEY_HOLD);
                if rising {
                    self.soft_stop(t, true);
                }
            }
        }
        self.inputs_changed(before, t);
        Ok(())
    }

    /// One line for `show`: counters (and physical positions where they
    /// differ), modes, ports, outputs, what runs.
    pub(super) fn state_line(&self, now: Instant) -> String {
        let counters = self.counters_at(now);
        let phys = self.physical_positions(now);
        let mut s = String::new();
        let shown: Vec<Axis> = match self.axis_config {
            Some(c) if c.axis_count() == 4 => Axis::ALL.to_vec(),
            _ => vec![Axis::X, Axis::Y, Axis::Z],
        };
        for axis in &shown {
            let _ = write!(s, "{axis} {} ", counters[axis.index()].round());
        }
        if shown
            .iter()
            .any(|a| (phys[a.index()] - counters[a.index()]).abs() >= 0.5)
        {
            s.push_str("(physical");
            for axis in &shown {
                let _ = write!(s, " {axis} {}", phys[axis.index()].round());
            }
            s.push_str(") ");
        }
        let _ = write!(
            s,
            "| axes {} referenced {}",
            self.axis_config.map_or("-".to_owned(), |c| c.to_string()),
            if self.referenced.is_empty() {
                "-".to_owned()
            } else {
                self.referenced.to_string()
            }
        );
        for (on, flag) in [
            (self.test_mode, "test mode"),
            (self.three_d, "3D"),
            (self.storing, "storing program"),
            (self.paused.is_some(), "stopped (resumable)"),
        ] {
            if on {
                let _ = write!(s, ", {flag}");
            }
        }
        if let Some(surface) = self.config.probe_surface {
            let _ = write!(
                s,
                " | probe surface {surface} ({})",
                if self.surface_touch {
                    "touched"
                } else {
                    "clear"
                }
            );
            if self.tool_length != 0 {
                let _ = write!(s, ", tool {:+}", self.tool_length);
            }
        }
        let [p0, p1, p2, p3] = self.ports();
        let _ = write!(
            s,
            " | in {p0:02X} {p1:02X} {p2:02X} {p3:02X} | out user {:02X} control {:02X} | ",
            self.outputs.user, self.outputs.control
        );
        s.push_str(match &self.activity {
            None => "idle",
            Some(Activity { step, program, .. }) => match (step, program.is_some()) {
                (Step::Motion(job), _) => match job.kind {
                    JobKind::Move if program.is_some() => "program: moving",
                    JobKind::Move => "moving",
                    JobKind::Reference => "reference run",
                    JobKind::Clear => "clearing a limit switch",
                },
                (Step::Erase { .. }, _) => "erasing the program",
                (Step::Sync { .. }, _) => "program: waiting for a sync character",
                (
                    Step::Wait {
                        stoppable: false, ..
                    },
                    _,
                ) => "program: delay",
                (Step::Wait { .. }, _) => "program running",
            },
        });
        s
    }
}
