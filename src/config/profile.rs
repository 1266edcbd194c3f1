//! Machine profiles: how to reach the controller, the machine's axes in real
//! units, how to jog it, how fast to poll it. Every field has a shipped default
//! (`config/default.toml`); a user's profile patches it field by field.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::axis::{Axis, AxisSet};
use crate::proto::Protocol;
use crate::wire::LineSettings;
use crate::wiring::{BitPatch, Wiring};

use super::macros::{self, Macro, MacroProfile};
use super::variant::SimVariant;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// Which shipped profile this one patches; `default` when absent.
    #[serde(default)]
    pub base: Option<String>,
    pub name: String,
    pub description: String,
    pub connection: Connection,
    pub machine: Machine,
    /// Axis definitions, keyed `X`, `Y`, `Z`, `A`. After loading, only the axes
    /// listed in `machine.axes` remain.
    pub axes: BTreeMap<Axis, AxisProfile>,
    pub jog: JogProfile,
    pub poll: PollProfile,
    pub diagnostics: DiagnosticsProfile,
    pub isel: IselProfile,
    pub emcu: EmcuProfile,
    pub emp: EmpProfile,
    pub sim: SimProfile,
    /// What the controller's bits are wired to, by address (`in2.5`,
    /// `out0.3`, `11.limit+`): patches of the manuals' tables
    /// (`crate::wiring`, `docs/profiles.md`).
    #[serde(default)]
    pub io: BTreeMap<String, BitPatch>,
    /// Keymap overrides: mode -> key -> action (validated by the UI's keymap).
    #[serde(default)]
    pub keys: BTreeMap<String, BTreeMap<String, String>>,
    /// Named command sequences in the family's syntax (`config::macros`).
    #[serde(default)]
    pub macros: BTreeMap<String, MacroProfile>,
    /// G-code import (`docs/gcode.md`, "The profile's [gcode] table").
    #[serde(default)]
    pub gcode: GcodeProfile,
    /// Probing (`docs/probing.md`).
    #[serde(default)]
    pub probe: super::probe::ProbeProfile,
    /// Tool changes (`docs/gcode.md`, "Tool changes").
    #[serde(default)]
    pub tools: super::probe::ToolsProfile,
}

/// `[gcode]`: how G-code from CAM becomes this machine's program. Settings
/// by name; every other key is a G or M code and what to do with it
/// (`m8 = "ignore"`, `m3 = "output:spindle"`), checked by `gcode::Setup`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GcodeProfile {
    /// The unit of a file with neither G20 nor G21 (`mm`, `inch`); absent,
    /// such a file is refused.
    #[serde(default)]
    pub unit: Option<String>,
    /// Arcs the controller cannot run as arcs become chords that stay
    /// this close to the arc, mm.
    #[serde(default = "default_chord_tolerance")]
    pub chord_tolerance: f64,
    /// Consecutive straight cuts that stay this close to one line are
    /// merged into one move, mm (0: never).
    #[serde(default = "default_merge_tolerance")]
    pub merge_tolerance: f64,
    /// G0's path speed, units/s; absent, each rapid runs as fast as its
    /// slowest moving axis' `max_speed` allows.
    #[serde(default)]
    pub rapid_speed: Option<f64>,
    /// Begin the program with a reference run of its axes (and 3D mode
    /// after it), so absolute moves count from the reference point.
    #[serde(default = "default_true")]
    pub reference_first: bool,
    /// The feed of a restart's descent to its line's start, units/min,
    /// when the file plunges nowhere before the line (a plunge: a feed
    /// move of Z alone, downwards); else the file's last plunge feed.
    #[serde(default = "default_plunge_feed")]
    pub plunge_feed: f64,
    /// Program memory in commands, when it differs from the manual's
    /// (isel 2000 before the closing `9`, EMCU 256): the one setting the
    /// import, `check`, `upload`, `run` and the console's editor count
    /// against.
    #[serde(default)]
    pub memory: Option<usize>,
    #[serde(flatten)]
    pub codes: BTreeMap<String, String>,
}

fn default_chord_tolerance() -> f64 {
    0.01
}

fn default_merge_tolerance() -> f64 {
    0.005
}

/// 300 mm/min: a plunge of 5 mm/s, slow enough for the small end mills
/// of the routers these controllers drive.
pub const DEFAULT_PLUNGE_FEED: f64 = 300.0;

fn default_plunge_feed() -> f64 {
    DEFAULT_PLUNGE_FEED
}

fn default_true() -> bool {
    true
}

impl Default for GcodeProfile {
    fn default() -> GcodeProfile {
        GcodeProfile {
            unit: None,
            chord_tolerance: default_chord_tolerance(),
            merge_tolerance: default_merge_tolerance(),
            rapid_speed: None,
            reference_first: true,
            plunge_feed: default_plunge_feed(),
            memory: None,
            codes: BTreeMap::new(),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Connection {
    pub protocol: Protocol,
    /// `sim` for the built-in simulator, otherwise a serial device path.
    pub port: String,
    /// Baud rate; the family's default when absent (isel, EMCU 19200; EMP 38400),
    /// within [`Connection::BAUD`].
    #[serde(default)]
    pub baud: Option<u32>,
    /// Added to a reply's wire time before the controller counts as silent,
    /// ms ([`Connection::DEFAULT_REPLY_MARGIN_MS`] when absent): the
    /// controller's processing and the host's scheduling, which no manual
    /// states (`docs/profiles.md`).
    #[serde(default)]
    pub reply_margin_ms: Option<u64>,
}

impl Connection {
    pub const SIMULATOR: &'static str = "sim";
    pub const DEFAULT_REPLY_MARGIN_MS: u64 = 100;
    /// The margins a profile may set: below 20 ms a busy host misses
    /// replies that came; above 5 s a dead line goes unnoticed too long.
    pub const REPLY_MARGIN_MS: std::ops::RangeInclusive<u64> = 20..=5000;
    /// The baud rates a profile or `--baud` may set. The controllers run at
    /// 9600 or 19200 (isel, `@0IC`, manual 4.2.15), 19200 (EMCU, manual
    /// 1.4.1) and 38400 (EMP); a serial port server or a test simulator may
    /// run the line faster. 300 is the slowest rate USB serial adapters
    /// take, 4 000 000 the fastest a Linux serial port has (termios
    /// `B4000000`). Below, a reply's wire time is seconds per byte, and 0
    /// has none at all: a session waited for ever (issue 37).
    pub const BAUD: std::ops::RangeInclusive<u32> = 300..=4_000_000;

    /// Whether `baud` is one a line can run at; else what is expected.
    pub fn check_baud(baud: u32) -> Result<(), String> {
        if Self::BAUD.contains(&baud) {
            Ok(())
        } else {
            Err(format!(
                "{baud}: expected {} to {} baud (isel 19200 or 9600, EMCU 19200, EMP 38400)",
                Self::BAUD.start(),
                Self::BAUD.end()
            ))
        }
    }

    pub fn reply_margin(&self) -> std::time::Duration {
        std::time::Duration::from_millis(
            self.reply_margin_ms
                .unwrap_or(Self::DEFAULT_REPLY_MARGIN_MS),
        )
    }

    pub fn is_simulator(&self) -> bool {
        self.port == Self::SIMULATOR
    }

    pub fn line(&self) -> LineSettings {
        self.baud
            .map(LineSettings::new)
            .unwrap_or_else(|| self.protocol.default_line())
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    /// The axes the machine has, e.g. `"XYZ"`; each needs an `[axes.<letter>]` table.
    pub axes: String,
}

impl Machine {
    pub fn axis_set(&self) -> Result<AxisSet, String> {
        let mut set = AxisSet::EMPTY;
        for c in self.axes.chars() {
            let axis = Axis::from_letter(c)
                .filter(|_| c.is_ascii_uppercase())
                .ok_or_else(|| format!("`{c}` is not an axis: expected letters from X, Y, Z, A"))?;
            if set.contains(axis) {
                return Err(format!("axis {axis} is listed twice"));
            }
            set = set.with(axis);
        }
        Ok(set)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    Mm,
    Deg,
    Steps,
}

impl Unit {
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::Deg => "°",
            Unit::Steps => "st",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisProfile {
    /// Motor steps (or encoder increments) per unit.
    pub steps_per_unit: f64,
    pub unit: Unit,
    /// Soft limits in units, machine coordinates (from the reference point).
    pub min: f64,
    pub max: f64,
    /// Highest speed any move of this axis may be given, units per second.
    pub max_speed: f64,
    /// EMP drive address (DS byte, e.g. `11`) driving this axis.
    #[serde(default)]
    pub drive: Option<String>,
}

impl AxisProfile {
    pub fn to_steps(&self, units: f64) -> i64 {
        (units * self.steps_per_unit).round() as i64
    }

    pub fn to_units(&self, steps: i64) -> f64 {
        steps as f64 / self.steps_per_unit
    }

    /// A speed in units per second as a step frequency.
    pub fn speed_hz(&self, units_per_second: f64) -> f64 {
        units_per_second * self.steps_per_unit
    }

    pub fn min_steps(&self) -> i64 {
        self.to_steps(self.min)
    }

    pub fn max_steps(&self) -> i64 {
        self.to_steps(self.max)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JogMode {
    /// Moves while the key is held (release or dead-man stops it).
    Hold,
    /// Opt-in: a press starts, any key stops.
    Toggle,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JogProfile {
    /// Step-jog distances in units, smallest first.
    pub steps: Vec<f64>,
    /// Continuous-jog speeds in units per second, slowest first.
    pub speeds: Vec<f64>,
    /// Index into `steps` selected at start.
    pub step: usize,
    /// Index into `speeds` selected at start.
    pub speed: usize,
    pub mode: JogMode,
    /// Dead-man grace before the first key repeat arrives (terminals wait
    /// 250-660 ms before repeating).
    pub first_repeat_grace_ms: u64,
    /// Dead-man timeout once repeats flow: the jog stops when the next repeat
    /// is later than this.
    pub repeat_timeout_ms: u64,
    /// Largest distance (units) an axis may travel after the operator lets go:
    /// one dead-man timeout at jog speed plus braking. Jog speeds are capped to it.
    pub max_overrun: f64,
    /// Step-jog presses remembered while a step runs; more are dropped.
    pub step_queue: usize,
    /// Allow jogging axes that have not been referenced.
    pub allow_unreferenced: bool,
    /// The jog off a limit switch (`L`, `docs/jogging.md`): the most it
    /// travels away from the switch, units. It stops there if the switch has
    /// not released by then (a switch stuck or wired the other way round).
    pub limit_jog_distance: f64,
    /// The jog off a limit switch: its speed, units per second (at most the
    /// axis's `max_speed`).
    pub limit_jog_speed: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PollProfile {
    /// Position polls per second; 0 = as fast as the line allows.
    pub rate_hz: f64,
    /// Read the port/status bits every Nth poll cycle.
    pub ports_every: u32,
}

/// The input recorder's judgement (`device::inputs`, `docs/ui.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnosticsProfile {
    /// An input that changes more often than this within `chatter_ms`
    /// chatters (a loose wire, a bouncing contact).
    pub chatter_changes: u32,
    pub chatter_ms: u64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IselProfile {
    /// Device number 0-9 (the digit after `@`).
    pub device: u8,
    /// Start-stop frequency (Hz) jogterm sets with `@0j` after initialising.
    pub start_stop_hz: u32,
    /// Acceleration (Hz/ms) jogterm sets with `@0J` after initialising.
    pub accel_hz_per_ms: u32,
    /// Reference-run speed (Hz) per axis for `@0d`.
    pub reference_speed_hz: u32,
    /// Allow switching on test mode (`@0T1`): moves without reference run and
    /// over limit switches, to free an axis standing in a switch.
    pub test_mode: bool,
    /// Whether a stored program jogterm did not store in this session may be
    /// started on axes that are not referenced (`docs/profiles.md`).
    #[serde(default)]
    pub start_unreferenced: StartUnreferenced,
    /// How long a session that only reads waits for a controller that
    /// answers nothing before it gives up, s
    /// ([`IselProfile::DEFAULT_BUSY_WAIT_S`] when absent, `docs/profiles.md`).
    #[serde(default)]
    pub busy_wait_s: Option<u64>,
}

impl IselProfile {
    /// Ten minutes: longer than most stored programs a console watches
    /// run, short enough that a dead line is not waited on for a shift.
    pub const DEFAULT_BUSY_WAIT_S: u64 = 600;
    /// From a second to a day.
    pub const BUSY_WAIT_S: std::ops::RangeInclusive<u64> = 1..=86_400;

    pub fn busy_wait(&self) -> std::time::Duration {
        std::time::Duration::from_secs(self.busy_wait_s.unwrap_or(Self::DEFAULT_BUSY_WAIT_S))
    }
}

/// Starting a stored program on axes not referenced (issue 24). A program
/// jogterm stored in this session is judged by its first lines either way
/// (`device::common::gate::program_start`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StartUnreferenced {
    /// A program jogterm does not know is refused until the axes are
    /// referenced.
    #[default]
    Refuse,
    /// The operator vouches that the programs stored in this controller
    /// reference their axes themselves: an unknown one may start.
    Allow,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmcuProfile {
    /// Start speed (Hz), `#S`; also the reference-run speed.
    pub start_speed_hz: u32,
    /// Ramp length (ms), `#R`.
    pub ramp_ms: u32,
    /// End-speed slot (`#E<n>`) jogterm uses for jog and go-to moves.
    pub move_slot: u8,
    /// As `isel.start_unreferenced`, for the ROM job (`@J`).
    #[serde(default)]
    pub start_unreferenced: StartUnreferenced,
    /// What the estimate assumes a move too short for both ramps does: the
    /// manual (1.5.7) does not say (`docs/profiles.md`).
    #[serde(default)]
    pub short_move_ramp: ShortMoveRamp,
}

/// An EMCU move shorter than its two ramps (`emcu.short_move_ramp`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShortMoveRamp {
    /// Up at the ramp's acceleration to half way and down again (what the
    /// simulator does).
    #[default]
    Triangle,
    /// No ramp at all: the whole move at the start speed.
    StartSpeed,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EmpStop {
    /// `08`: hold the position actively.
    Hold,
    /// `2A 03`: brake as fast as possible, motor currentless afterwards.
    Fast,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EmpJog {
    /// IV velocity mode with a signed velocity byte.
    Velocity,
    /// TPWM positioning towards the soft limit.
    Position,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmpProfile {
    pub stop: EmpStop,
    pub jog: EmpJog,
    /// Homing speeds (velocity bytes) for `26`.
    pub home_fast: u8,
    pub home_slow: u8,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimProfile {
    /// Where the simulated machine's hard limit switches sit beyond the soft
    /// limits, in units.
    pub limit_margin: f64,
    /// Position (units, machine coordinates) the simulated axes stand at when
    /// the simulator starts, before any reference run.
    pub start_position: f64,
    /// How the simulated controller differs from the default one
    /// (`hood-unwired`, `memory=64`, …: `config::variant`).
    #[serde(default)]
    pub variants: Vec<SimVariant>,
}

/// A profile problem found after parsing: the key path and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    pub key: Vec<String>,
    pub message: String,
    /// For a string value: the byte offset in the string where the problem
    /// is (a macro's bad line), so the error names its column.
    pub offset: Option<usize>,
}

impl Invalid {
    fn new(key: &[&str], message: impl Into<String>) -> Self {
        Self {
            key: key.iter().map(|s| s.to_string()).collect(),
            message: message.into(),
            offset: None,
        }
    }
}

impl Profile {
    pub fn axis_set(&self) -> AxisSet {
        self.axes.keys().copied().collect()
    }

    pub fn axis(&self, axis: Axis) -> Option<&AxisProfile> {
        self.axes.get(&axis)
    }

    /// The machine's axes as `machine.axes` lists them (all defined axes
    /// when that list is broken, which `validate` reports).
    fn listed_axes(&self) -> AxisSet {
        self.machine.axis_set().unwrap_or_else(|_| self.axis_set())
    }

    /// The EMP drives of the listed axes, DS as two upper-case hex digits
    /// (axes without a valid address are left out; `validate` reports them).
    fn drives(&self) -> Vec<(String, Axis)> {
        let listed = self.listed_axes();
        self.axes
            .iter()
            .filter(|(axis, _)| listed.contains(**axis))
            .filter_map(|(axis, p)| {
                let ds = parse_drive_address(p.drive.as_deref()?).ok()?;
                Some((format!("{ds:02X}"), *axis))
            })
            .collect()
    }

    /// The machine's wiring: the family's tables patched by `[io]`, or every
    /// problem with the `[io]` entries.
    pub fn wiring(&self) -> Result<Wiring, Vec<Invalid>> {
        let axes = self.listed_axes();
        let drives = if self.connection.protocol == Protocol::Emp {
            self.drives()
        } else {
            Vec::new()
        };
        let (wiring, problems) =
            Wiring::defaults(self.connection.protocol, axes, &drives).patched(&self.io, axes);
        if problems.is_empty() {
            Ok(wiring)
        } else {
            Err(problems
                .into_iter()
                .map(|p| Invalid {
                    key: p.key,
                    message: p.message,
                    offset: None,
                })
                .collect())
        }
    }

    /// The macros, every line checked with the family's parser for the
    /// machine's axes, or every problem with them.
    pub fn macros(&self) -> Result<Vec<Macro>, Vec<Invalid>> {
        macros::check(
            &self.macros,
            self.connection.protocol,
            self.isel.device,
            self.listed_axes(),
        )
        .map_err(|problems| {
            problems
                .into_iter()
                .map(|p| Invalid {
                    key: p.key,
                    message: p.message,
                    offset: p.offset,
                })
                .collect()
        })
    }

    /// Keep only the axes `machine.axes` lists (after a successful `validate`).
    pub fn retain_listed_axes(&mut self) {
        if let Ok(listed) = self.machine.axis_set() {
            self.axes.retain(|axis, _| listed.contains(*axis));
        }
    }

    /// Checks that serde cannot make: ranges, combinations, what a controller
    /// family supports. Looks only at the axes `machine.axes` lists.
    pub fn validate(&self) -> Vec<Invalid> {
        let mut out = Vec::new();
        // The name goes into every converted program's header and onto the
        // screen: a line break in it would be a line of the program
        // (issue 37), so it is one line of printable text.
        if let Some(bad) = self.name.chars().find(|c| c.is_control()) {
            out.push(Invalid::new(
                &["name"],
                format!(
                    "a profile name is one line of printable text, got {bad:?} in {:?}",
                    self.name
                ),
            ));
        }
        // A broken `machine.axes` is one problem among the others (issue
        // 37): the axes the profile defines are checked in its place, and
        // what only the list says (its shape, an axis without its table)
        // waits until the list reads.
        let (axes, listed) = match self.machine.axis_set() {
            Ok(set) => (set, true),
            Err(msg) => {
                out.push(Invalid::new(&["machine", "axes"], msg));
                (self.axis_set(), false)
            }
        };
        if listed && axes.is_empty() {
            out.push(Invalid::new(
                &["machine", "axes"],
                "at least one axis is needed",
            ));
        }
        for axis in axes.iter().filter(|_| listed) {
            if !self.axes.contains_key(&axis) {
                out.push(Invalid::new(
                    &["machine", "axes"],
                    format!("axis {axis} is listed but has no [axes.{axis}] table"),
                ));
            }
        }
        if let Some(ms) = self.connection.reply_margin_ms
            && !Connection::REPLY_MARGIN_MS.contains(&ms)
        {
            out.push(Invalid::new(
                &["connection", "reply_margin_ms"],
                format!(
                    "{ms} ms: expected {} to {} ms",
                    Connection::REPLY_MARGIN_MS.start(),
                    Connection::REPLY_MARGIN_MS.end()
                ),
            ));
        }
        if !(self.gcode.plunge_feed.is_finite() && self.gcode.plunge_feed > 0.0) {
            out.push(Invalid::new(
                &["gcode", "plunge_feed"],
                format!(
                    "{}: must be a positive feed (units/min)",
                    self.gcode.plunge_feed
                ),
            ));
        }
        if let Some(s) = self.isel.busy_wait_s
            && !IselProfile::BUSY_WAIT_S.contains(&s)
        {
            out.push(Invalid::new(
                &["isel", "busy_wait_s"],
                format!(
                    "{s} s: expected {} to {} s",
                    IselProfile::BUSY_WAIT_S.start(),
                    IselProfile::BUSY_WAIT_S.end()
                ),
            ));
        }
        for (key, message) in self.tools.problems() {
            out.push(Invalid::new(&["tools", key], message));
        }
        for (key, message) in self.probe.problems() {
            out.push(Invalid::new(&["probe", key], message));
        }
        if let Some(baud) = self.connection.baud
            && let Err(message) = Connection::check_baud(baud)
        {
            out.push(Invalid::new(&["connection", "baud"], message));
        }
        match self.connection.protocol {
            // isel manual 2.2.1: X, XY, XYZ, and A only on top of XYZ.
            Protocol::Isel => {
                let ok = [0b0001, 0b0011, 0b0111, 0b1111].contains(&axes.mask());
                if listed && !axes.is_empty() && !ok {
                    out.push(Invalid::new(
                        &["machine", "axes"],
                        format!("isel controllers drive X, XY, XYZ or XYZA, not {axes}"),
                    ));
                }
            }
            Protocol::Emcu => {
                if listed && axes.contains(Axis::A) {
                    out.push(Invalid::new(
                        &["machine", "axes"],
                        "EMCU drives only X, Y and Z",
                    ));
                }
            }
            Protocol::Emp => {
                let mut seen = BTreeMap::new();
                for (axis, p) in self.axes.iter().filter(|(a, _)| axes.contains(**a)) {
                    let key = ["axes", axis_key(*axis), "drive"];
                    match p.drive.as_deref().map(parse_drive_address) {
                        None => out.push(Invalid::new(
                            &key,
                            "EMP axes need a drive address such as \"11\"",
                        )),
                        Some(Err(msg)) => out.push(Invalid::new(&key, msg)),
                        Some(Ok(ds)) => {
                            if let Some(other) = seen.insert(ds, *axis) {
                                out.push(Invalid::new(
                                    &key,
                                    format!("drive {ds:02X} is already axis {other}"),
                                ));
                            }
                        }
                    }
                }
            }
        }
        for (axis, p) in self.axes.iter().filter(|(a, _)| axes.contains(**a)) {
            let k = axis_key(*axis);
            if !(p.steps_per_unit.is_finite() && p.steps_per_unit > 0.0) {
                out.push(Invalid::new(
                    &["axes", k, "steps_per_unit"],
                    "must be a positive number",
                ));
            }
            for (key, value) in [("min", p.min), ("max", p.max)] {
                if !value.is_finite() {
                    out.push(Invalid::new(
                        &["axes", k, key],
                        format!("must be a finite number of units, got {value}"),
                    ));
                }
            }
            if p.min.is_finite() && p.max.is_finite() && p.min >= p.max {
                out.push(Invalid::new(
                    &["axes", k, "max"],
                    format!("soft limits need min < max (min {}, max {})", p.min, p.max),
                ));
            }
            if !(p.max_speed.is_finite() && p.max_speed > 0.0) {
                out.push(Invalid::new(
                    &["axes", k, "max_speed"],
                    "must be a positive number",
                ));
            }
        }
        let jog = &self.jog;
        if jog.steps.is_empty() || jog.steps.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            out.push(Invalid::new(
                &["jog", "steps"],
                "needs at least one positive step size",
            ));
        }
        if jog.speeds.is_empty() || jog.speeds.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            out.push(Invalid::new(
                &["jog", "speeds"],
                "needs at least one positive speed",
            ));
        }
        if jog.step >= jog.steps.len().max(1) {
            out.push(Invalid::new(
                &["jog", "step"],
                format!(
                    "index {} is outside `steps` (0..{})",
                    jog.step,
                    jog.steps.len()
                ),
            ));
        }
        if jog.speed >= jog.speeds.len().max(1) {
            out.push(Invalid::new(
                &["jog", "speed"],
                format!(
                    "index {} is outside `speeds` (0..{})",
                    jog.speed,
                    jog.speeds.len()
                ),
            ));
        }
        if !(50..=1000).contains(&jog.repeat_timeout_ms) {
            out.push(Invalid::new(
                &["jog", "repeat_timeout_ms"],
                "must be between 50 and 1000 ms",
            ));
        }
        if jog.first_repeat_grace_ms < jog.repeat_timeout_ms || jog.first_repeat_grace_ms > 2000 {
            out.push(Invalid::new(
                &["jog", "first_repeat_grace_ms"],
                "must be at least repeat_timeout_ms and at most 2000 ms",
            ));
        }
        if !(jog.max_overrun.is_finite() && jog.max_overrun > 0.0) {
            out.push(Invalid::new(
                &["jog", "max_overrun"],
                "must be a positive distance",
            ));
        }
        if jog.step_queue == 0 || jog.step_queue > 10 {
            out.push(Invalid::new(
                &["jog", "step_queue"],
                "must be between 1 and 10",
            ));
        }
        if !(jog.limit_jog_distance.is_finite() && jog.limit_jog_distance > 0.0) {
            out.push(Invalid::new(
                &["jog", "limit_jog_distance"],
                "must be a positive distance",
            ));
        }
        if !(jog.limit_jog_speed.is_finite() && jog.limit_jog_speed > 0.0) {
            out.push(Invalid::new(
                &["jog", "limit_jog_speed"],
                "must be a positive speed",
            ));
        }
        if !(self.poll.rate_hz.is_finite() && self.poll.rate_hz >= 0.0) {
            out.push(Invalid::new(
                &["poll", "rate_hz"],
                "must be 0 (line speed) or a positive rate",
            ));
        }
        if self.poll.ports_every == 0 {
            out.push(Invalid::new(&["poll", "ports_every"], "must be at least 1"));
        }
        // Two changes are one press and release: chatter needs more.
        if !(2..=1000).contains(&self.diagnostics.chatter_changes) {
            out.push(Invalid::new(
                &["diagnostics", "chatter_changes"],
                "must be between 2 and 1000 changes",
            ));
        }
        if !(10..=60_000).contains(&self.diagnostics.chatter_ms) {
            out.push(Invalid::new(
                &["diagnostics", "chatter_ms"],
                "must be between 10 and 60000 ms",
            ));
        }
        let isel = &self.isel;
        if isel.device > 9 {
            out.push(Invalid::new(
                &["isel", "device"],
                "isel device numbers are 0-9",
            ));
        }
        // isel manual 2.2.15/2.2.16 and protocols.md isel 13.
        if !(20..=4000).contains(&isel.start_stop_hz) {
            out.push(Invalid::new(
                &["isel", "start_stop_hz"],
                "must be 20-4000 Hz",
            ));
        }
        if !(1..=4000).contains(&isel.accel_hz_per_ms) {
            out.push(Invalid::new(
                &["isel", "accel_hz_per_ms"],
                "must be 1-4000 Hz/ms",
            ));
        }
        if !(1..=40000).contains(&isel.reference_speed_hz) {
            out.push(Invalid::new(
                &["isel", "reference_speed_hz"],
                "must be 1-40000 Hz",
            ));
        }
        if !(1..=9).contains(&self.emcu.move_slot) {
            out.push(Invalid::new(
                &["emcu", "move_slot"],
                "EMCU end-speed slots are 1-9",
            ));
        }
        if !(self.sim.limit_margin.is_finite() && self.sim.limit_margin >= 0.0) {
            out.push(Invalid::new(
                &["sim", "limit_margin"],
                "must be zero or positive",
            ));
        }
        // The one memory setting (issue 37): what the controller holds, at
        // most what its manual says (the simulators hold no more either).
        if let Some(memory) = self.gcode.memory {
            let most = match self.connection.protocol {
                Protocol::Isel => Some(crate::proto::isel::PROGRAM_CAPACITY),
                Protocol::Emcu => Some(crate::proto::emcu::job::JOB_CAPACITY),
                Protocol::Emp => None,
            };
            if let Some(most) = most
                && !(1..=most).contains(&memory)
            {
                out.push(Invalid::new(
                    &["gcode", "memory"],
                    format!(
                        "{memory} commands: a {} controller stores 1 to {most} (its manual's memory; set it lower for one that holds less)",
                        self.connection.protocol
                    ),
                ));
            }
        }
        let family = self.connection.protocol;
        for (i, variant) in self.sim.variants.iter().enumerate() {
            if let Some(why) = variant.refusal(family) {
                let index = i.to_string();
                out.push(Invalid::new(&["sim", "variants", index.as_str()], why));
            }
        }
        if let Err(problems) = self.wiring() {
            out.extend(problems);
        }
        if let Err(problems) = self.macros() {
            out.extend(problems);
        }
        out
    }
}

fn axis_key(axis: Axis) -> &'static str {
    match axis {
        Axis::X => "X",
        Axis::Y => "Y",
        Axis::Z => "Z",
        Axis::A => "A",
    }
}

/// An EMP DS byte: module 1-F in the high nibble, drive 1-F in the low one
/// (EMP document, command 02).
pub fn parse_drive_address(text: &str) -> Result<u8, String> {
    let byte = (text.len() == 2)
        .then(|| u8::from_str_radix(text, 16).ok())
        .flatten()
        .ok_or_else(|| {
            format!("`{text}` is not a drive address: expected two hex digits such as \"11\"")
        })?;
    if byte >> 4 == 0 || byte & 0x0F == 0 {
        return Err(format!(
            "`{text}`: module and drive numbers start at 1 (\"11\" … \"F1\")"
        ));
    }
    Ok(byte)
}
