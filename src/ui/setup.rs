//! What the session is connected to and what the profile fixes for its
//! lifetime ([`Setup`]), and the jog step and speed selected: read by the
//! model and by the components below it (the editor, the jog screen), so
//! it lives below them all.

use std::sync::Arc;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::config::macros::Macro;
use crate::config::profile::AxisProfile;
use crate::device::api::InputChannel;
use crate::jog::JogSettings;
use crate::proto::Protocol;
use crate::wire::LineSettings;

/// What the session is connected to; fixed for its lifetime.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    pub protocol: Protocol,
    /// `sim` for the built-in simulator, else the device path.
    pub port: String,
    pub line: LineSettings,
    /// The machine's axes in X, Y, Z, A order.
    pub axes: Vec<(Axis, AxisProfile)>,
    /// Jog step distances and speeds in units (and units per second).
    pub jog_steps: Vec<f64>,
    pub jog_speeds: Vec<f64>,
    /// The step and speed selected at start.
    pub jog_start: JogSelection,
    pub isel_device: u8,
    /// The built-in simulator's inputs with their levels at start (`None`
    /// where the simulator does not say), when the session runs on one.
    pub simulator_inputs: Option<Vec<(String, Option<bool>)>>,
    /// Everything jogging needs from the profile (`crate::jog`).
    pub jog: JogSettings,
    /// The profile's macros, their lines checked (`config::macros`).
    pub macros: Vec<Macro>,
    /// The controller's inputs as the profile names them
    /// (`device::inputs::channels`).
    pub inputs: Vec<Arc<InputChannel>>,
    /// The controller's program memory in commands (`Profile::program_memory`):
    /// what the editor's check and a converted job's fit count against.
    pub program_memory: Option<usize>,
    /// The profile's `[probe]` table (`docs/probing.md`).
    pub probe: crate::config::probe::ProbeProfile,
    /// The whole profile, for what needs all of it: a G-code job opened in
    /// the console is imported (and checked again) against it.
    pub profile: Arc<Profile>,
    /// The simulator's button wired as the machine's start key, or why
    /// there is none (`sim::start_key`).
    pub sim_start_key: Result<crate::sim::start_key::StartKey, String>,
}

impl Setup {
    pub fn from_profile(
        profile: &Profile,
        simulator_inputs: Option<Vec<(String, Option<bool>)>>,
    ) -> Self {
        Setup {
            protocol: profile.connection.protocol,
            port: profile.connection.port.clone(),
            line: profile.connection.line(),
            axes: profile.axes.iter().map(|(a, p)| (*a, p.clone())).collect(),
            jog_steps: profile.jog.steps.clone(),
            jog_speeds: profile.jog.speeds.clone(),
            jog_start: JogSelection {
                step: profile.jog.step,
                speed: profile.jog.speed,
            },
            isel_device: profile.isel.device,
            simulator_inputs,
            jog: JogSettings::from_profile(profile),
            // Refused at load when broken: a profile here has passed.
            macros: profile.macros().unwrap_or_default(),
            inputs: crate::device::inputs::channels::shared(profile),
            program_memory: profile.gcode.memory,
            probe: profile.probe.clone(),
            profile: Arc::new(profile.clone()),
            sim_start_key: crate::sim::start_key::StartKey::of(profile),
        }
    }

    pub fn axis_set(&self) -> AxisSet {
        self.axes.iter().map(|(a, _)| *a).collect()
    }

    pub fn axis(&self, axis: Axis) -> Option<&AxisProfile> {
        self.axes.iter().find(|(a, _)| *a == axis).map(|(_, p)| p)
    }

    pub fn is_simulator(&self) -> bool {
        self.port == crate::config::profile::Connection::SIMULATOR
    }
}

/// The jog step and speed selected (indices into the profile's lists).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JogSelection {
    pub step: usize,
    pub speed: usize,
}
