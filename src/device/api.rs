//! What goes into the device task and what comes out of it. These types are
//! the only contract between the port owner and its clients (TUI, CLI, tests),
//! and they are the same for all three controller families: positions in
//! steps, speeds in steps per second (Hz), axes by name.

use std::fmt;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::traffic::TrafficRecord;
use crate::wiring::{BitKind, BitWiring, LimitSwitch, Side};

pub use crate::axis::{Dir, PerAxis};

/// Identifies one continuous jog, so a late renewal or release for an older
/// jog can never keep a newer one alive or stop it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JogId(pub u64);

/// Identifies an output bit or byte of the controller, as listed in an
/// `IoSnapshot`; clients echo it back in `Request::SetOutput`. Its meaning is
/// the driver's own (isel: port number and bit; EMP: drive and output).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct OutputId {
    pub group: u16,
    /// The bit within the group, or `None` for a whole byte (isel port 0, analog port 4).
    pub bit: Option<u8>,
}

/// Which coordinates a target is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Frame {
    /// Steps from the reference point.
    Machine,
    /// Steps from the work zero set with `SetZero`.
    Work,
}

/// Requests into the device task. A stop is not among them: it travels on its
/// own channel and overtakes everything (`DeviceHandle::stop`).
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// Continuous jog on one or more axes (diagonal when several). Runs until
    /// released, stopped, or its lease runs out without renewal (dead-man).
    /// The driver never drives past the soft limits, and never faster than
    /// `speed_hz` or than the lease allows: one lease at speed, the stop's
    /// way to the wire and braking stay within `jog.max_overrun`
    /// (`crate::motion::overrun`). A long first lease (the terminal's delay
    /// before its first key repeat) therefore starts the jog slower than the
    /// short renewals that follow let it run (`docs/jogging.md`).
    Jog {
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        speed_hz: PerAxis<f64>,
        lease: Duration,
    },
    /// A key repeat arrived: keep jog `id` alive for `lease` from now (at
    /// most as long as its speed allows within `jog.max_overrun`). A lease
    /// shorter than the one the jog holds lets it speed up towards
    /// `speed_hz`.
    JogRenew {
        id: JogId,
        lease: Duration,
    },
    /// The key was released (or any key in toggle mode): stop jog `id`.
    JogRelease {
        id: JogId,
    },
    /// Jog `axis` off the limit switch it stands in (what LinuxCNC calls
    /// "override limits"; `docs/jogging.md`, "Jog off a limit switch"):
    /// slowly (`jog.limit_jog_speed`) in `dir`, until the switch releases
    /// or `jog.limit_jog_distance` has been travelled. The operator has
    /// confirmed it; it holds no lease and ends on its own, or on a stop.
    /// Refused like any motion, except that the active limit switch (and a
    /// controller's limit-switch fault) does not block `axis` in `dir`,
    /// and no reference is needed; refused unless a wired limit switch of
    /// `axis` reads active and `dir` leads away from it (the switch's
    /// `side` in the profile's `[io]`). Ends with `Event::JogEnded { id,
    /// OffLimit | StillOnLimit | Stopped | Fault | LinkLost | Refused }`;
    /// the axis counts as not referenced afterwards.
    LimitJog {
        id: JogId,
        axis: Axis,
        dir: Dir,
    },
    /// Probe for a surface along one axis (`docs/probing.md`): a fast pass
    /// toward it that ends when the profile's probe input trips, a back-off
    /// until it releases, a slow pass from which the controller stops
    /// within a step, the position read there, and back to where it
    /// started. Refused like any move and also unless every axis is
    /// referenced, the probe input is wired and reads free, and the whole
    /// travel lies within the soft limits. Ends with `Event::ProbeEnded {
    /// id, .. }`, also when refused.
    Probe {
        id: JogId,
        probe: ProbeMove,
    },
    /// A relative step. Steps requested while one runs are coalesced up to the
    /// configured bound; beyond it they are dropped with `Event::Refused`.
    Step {
        delta: PerAxis<i64>,
        speed_hz: PerAxis<f64>,
    },
    /// Go to a position; axes left out do not move.
    MoveTo {
        target: PerAxis<i64>,
        frame: Frame,
        speed_hz: PerAxis<f64>,
    },
    /// Reference run of these axes (isel in the order Z, Y, X, A).
    Home {
        axes: AxisSet,
    },
    /// Make the current position the work zero of these axes.
    SetZero {
        axes: AxisSet,
    },
    SetOutput {
        output: OutputId,
        value: u8,
    },
    /// A command line typed by the operator, validated by the family's parser
    /// before it is sent.
    Raw {
        line: String,
    },
    /// Store a program in the controller (isel `@0i`…`9`, EMCU `@F`…0x01).
    /// `lines` are the commands as the controller takes them (comments stripped).
    Upload {
        lines: Vec<String>,
        erase_first: bool,
    },
    /// Start the stored program (isel `@0S`, EMCU `@J`).
    RunProgram,
    /// One line of a program check-out from the editor (`docs/editor.md`,
    /// "Check-out"): a DNC `line` of the family's syntax, checked like a
    /// raw line. A line that moves is held like a continuous jog: by
    /// `lease`, renewed with `JogRenew { id }`, let go with `JogRelease {
    /// id }`; when the lease runs out or the key is let go the move is
    /// paused without step loss (isel 0xFD alone, manual 2.2.31), its rest
    /// kept by the controller. `resume`: the id of the line that paused,
    /// whose rest this line's `@0S` finishes (refused unless that rest is
    /// still held: nothing else ran since). Ends with `Event::Checkout {
    /// id, .. }`, also when refused.
    Checkout {
        id: JogId,
        line: String,
        lease: Duration,
        resume: Option<JogId>,
        /// isel: read the position (`@0P`) after a move that ended, as the
        /// editor's check-out does to show it at once. A stream leaves it
        /// out where the move's end is exactly known: the bytes between two
        /// moves are time the tool stands in the part.
        read_back: bool,
    },
    /// Bring the controller into a known, ready state (isel: axes and ramp
    /// parameters; EMP: unit on and mode; EMCU: read status).
    Initialise,
    /// Reset the controller (isel 0xFE, EMCU `@R`); it needs initialising and
    /// referencing afterwards.
    Reset,
    /// Change the polling rates at run time.
    Poll {
        rate_hz: Option<f64>,
        ports_every: u32,
    },
    /// Stop all motion, flush, close the port and end the task.
    Shutdown,
    /// The operator holds a key for the motion the client drives (the
    /// console's hold-to-run frame): unless another `Hold` arrives within
    /// `lease`, the task stops all motion as the stop key does and reports
    /// `Event::HoldLapsed`. The task keeps the hold itself, so a client that
    /// stalls (a frozen console, a stopped process) cannot keep the machine
    /// moving; the drivers never see it.
    Hold {
        lease: Duration,
    },
    /// The client's hold ended without a stop (its motion ended).
    HoldEnd,
}

impl Request {
    /// Whether the request can set an axis in motion (refused unless the
    /// machine is in a state that allows it).
    pub fn may_move(&self) -> bool {
        matches!(
            self,
            Request::Jog { .. }
                | Request::LimitJog { .. }
                | Request::Step { .. }
                | Request::MoveTo { .. }
                | Request::Home { .. }
                | Request::RunProgram
                | Request::Raw { .. }
                | Request::Checkout { .. }
                | Request::Probe { .. }
        )
    }

    /// The probe a request starts, which ends with `Event::ProbeEnded`.
    pub fn probe_id(&self) -> Option<JogId> {
        match self {
            Request::Probe { id, .. } => Some(*id),
            _ => None,
        }
    }

    /// The check-out line a request is, which ends with `Event::Checkout`.
    pub fn checkout_id(&self) -> Option<JogId> {
        match self {
            Request::Checkout { id, .. } => Some(*id),
            _ => None,
        }
    }

    /// The jog a request starts, which ends with `Event::JogEnded` (also
    /// when it is refused): a continuous jog or a jog off a limit switch.
    pub fn jog_id(&self) -> Option<JogId> {
        match self {
            Request::Jog { id, .. } | Request::LimitJog { id, .. } => Some(*id),
            _ => None,
        }
    }
}

/// Whether a position was read from the controller or computed while it
/// could not be asked (isel during a move).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PositionSource {
    Measured,
    Estimated,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionSample {
    pub at: Instant,
    /// Machine coordinates, steps.
    pub steps: PerAxis<i64>,
    pub source: PositionSource,
}

/// The link to the controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkState {
    Connecting,
    Connected,
    /// The port vanished or went silent; `reason` in words.
    Lost {
        reason: String,
    },
    /// Waiting to try again (attempt number, counting from 1).
    Reconnecting {
        attempt: u32,
        retry_in: Duration,
    },
    Closed,
}

/// What an operator must do before motion is possible again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Recovery {
    /// Nothing: the command was wrong, not the machine.
    None,
    /// Initialise the axes again, then reference (isel `2`/`9`, EMCU error flag).
    ReinitialiseAndReference,
    /// Reference run needed (isel `R`, EMCU position unknown).
    Reference,
    /// Close the hood.
    CloseHood,
    /// Clear the emergency stop / safety circuit, then re-initialise and reference.
    ClearEmergencyStop,
    /// A move was interrupted: resume (start) or discard it (stop).
    ResumeOrDiscard,
    /// The stored program is invalid or in the way: erase it.
    EraseProgram,
    /// The drive must be switched on / its mode set again (EMP).
    SwitchOn,
    /// A reply was missing or unreadable: the line, not the machine, is in
    /// doubt (cable, baud rate, controller type).
    CheckLink,
}

impl Recovery {
    /// What to do, in words for the status bar.
    pub fn instruction(self) -> &'static str {
        match self {
            Recovery::None => "correct the command",
            Recovery::ReinitialiseAndReference => "initialise (i) and reference (h) the axes",
            Recovery::Reference => "reference the axes (h)",
            Recovery::CloseHood => "close the hood",
            Recovery::ClearEmergencyStop => {
                "release the emergency stop, then initialise (i) and reference (h)"
            }
            Recovery::ResumeOrDiscard => "start to resume the move, or stop to discard it",
            Recovery::EraseProgram => "erase the stored program",
            Recovery::SwitchOn => "switch the drive on (i)",
            Recovery::CheckLink => "check the cable, the baud rate and the controller type",
        }
    }
}

/// An error the controller answered (not a link failure).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ControllerFault {
    /// The command that was answered with the error, readable.
    pub command: String,
    /// The code as the controller sent it (isel `2`, EMP INFO `EE` …).
    pub code: String,
    pub meaning: String,
    pub recovery: Recovery,
}

/// What the machine is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Activity {
    #[default]
    Idle,
    Jogging,
    Stepping,
    Moving,
    Homing,
    Probing,
    RunningProgram,
    Uploading,
    Stopping,
}

/// Whether a program is stored in the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ProgramState {
    #[default]
    Unknown,
    None,
    Stored,
    /// A broken or partial program is stored (isel: after a failed upload).
    Invalid,
}

/// Everything the clients need to decide what is safe, tracked by the driver
/// from replies and polls.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MachineState {
    pub link_up: bool,
    /// Axes the controller has been told about (isel `@07`), or drives switched on (EMP).
    pub initialised: AxisSet,
    pub referenced: AxisSet,
    pub activity: Activity,
    /// An emergency-stop circuit is open (from ports or a `9` reply).
    pub estop: bool,
    /// A limit switch is active (from ports or a `2` reply).
    pub limit: bool,
    /// An error that blocks motion until its recovery is done.
    pub fault: Option<ControllerFault>,
    pub program: ProgramState,
    pub test_mode: bool,
    /// Work zero in machine steps, per axis.
    pub work_zero: PerAxis<i64>,
}

/// How a notice begins that says the controller does not answer because a
/// stored program or a move runs, and the session waits (a session that was
/// not asked to move, `docs/device.md`, "Sessions that do not move").
pub const BUSY_NOTICE: &str = "the controller is busy: a program runs; waiting";

/// How the notice begins that ends such a wait.
pub const ANSWERS_AGAIN_NOTICE: &str = "the controller answers again";

/// Why a request was not carried out, and what to do about it.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    NotConnected,
    NotInitialised,
    NotReferenced {
        axes: AxisSet,
    },
    EmergencyStop,
    LimitSwitch,
    Fault {
        recovery: Recovery,
    },
    Busy {
        activity: Activity,
    },
    /// The target lies outside the soft limits.
    SoftLimit {
        axis: Axis,
        target: i64,
        min: i64,
        max: i64,
    },
    /// Step presses beyond the coalescing bound.
    StepQueueFull,
    /// The request is invalid as such (bad raw command, wrong axis …).
    Invalid {
        reason: String,
    },
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::NotConnected => {
                write!(f, "not connected to the controller: wait for the link")
            }
            Refusal::NotInitialised => {
                write!(f, "controller not initialised: initialise (i) first")
            }
            Refusal::NotReferenced { axes } => {
                write!(f, "axes {axes} not referenced: reference them (h) first")
            }
            Refusal::EmergencyStop => write!(
                f,
                "emergency stop active: release it, then initialise (i) and reference (h)"
            ),
            Refusal::LimitSwitch => write!(
                f,
                "limit switch hit: initialise (i) and reference (h) the axes"
            ),
            Refusal::Fault { recovery } => {
                write!(f, "controller error: {}", recovery.instruction())
            }
            Refusal::Busy { activity } => write!(f, "busy ({activity:?}): stop it first"),
            Refusal::SoftLimit {
                axis,
                target,
                min,
                max,
            } => {
                write!(
                    f,
                    "{axis} target {target} is outside the soft limits {min}..{max} (steps)"
                )
            }
            Refusal::StepQueueFull => write!(f, "step dropped: steps are still running"),
            Refusal::Invalid { reason } => write!(f, "{reason}"),
        }
    }
}

/// One named bit of a port or status word.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IoBit {
    /// The profile's name for the bit (`crate::wiring`), else the driver's.
    pub name: String,
    /// The level as read, or as last written (outputs).
    pub value: bool,
    /// Set for outputs the operator may switch.
    pub output: Option<OutputId>,
    /// Switching it moves or powers something (spindle, motor currents,
    /// brake): the UI asks for confirmation.
    pub hazardous: bool,
    /// What the machine profile says the bit is wired to; `None` for a
    /// controller's status flag (EMCU `@X`), which is no wire.
    pub wiring: Option<BitWiring>,
}

impl IoBit {
    /// Whether the condition the bit's role names holds (a limit switch hit,
    /// an E-stop tripped …; `crate::wiring::Role`); for a status flag, that
    /// it is set.
    pub fn active(&self) -> bool {
        self.wiring
            .as_ref()
            .map_or(self.value, |w| w.is_active(self.value))
    }

    /// Whether the profile says something is connected (status flags are).
    pub fn wired(&self) -> bool {
        self.wiring.as_ref().is_none_or(|w| w.wired)
    }

    /// The limit switch this bit is, when it is a wired one.
    pub fn limit(&self) -> Option<LimitSwitch> {
        self.wiring.as_ref().and_then(BitWiring::limit)
    }
}

/// A wired limit switch that reads active: which axis, which end of its
/// travel, and what the profile calls it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ActiveLimit {
    pub axis: Axis,
    pub side: Side,
    pub name: String,
    /// The bit's address (`in3.1`, `11.limit-`).
    pub address: String,
}

impl ActiveLimit {
    /// The direction that moves the axis out of the switch: plus off the
    /// `min` switch, minus off the `max` switch.
    pub fn away(&self) -> Dir {
        match self.side {
            Side::Min => Dir::Plus,
            Side::Max => Dir::Minus,
        }
    }
}

/// A port, status word or drive I/O block as read from the controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IoGroup {
    pub name: String,
    /// The raw byte as read, shown in hex beside the bits.
    pub raw: Option<u8>,
    pub bits: Vec<IoBit>,
    /// Where and when its input bits were read from the controller; `None`
    /// for what jogterm cannot read back (outputs, settings). A snapshot
    /// repeats a group until it is read again, so the input recorder takes
    /// a group as a new sample only when `read.at` is newer.
    pub read: Option<InputRead>,
}

impl IoGroup {
    /// The group as read with `source` at `at` (`None`: not read yet).
    pub fn read_from(mut self, source: InputSource, at: Option<Instant>) -> IoGroup {
        self.read = at.map(|at| InputRead { source, at });
        self
    }
}

/// What an input group is read with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum InputSource {
    /// isel input port 0-3 (`@0b<n>`, manual 2.2.3).
    IselPort(u8),
    /// The EMCU's `@X` flags (manual 1.5.3).
    EmcuStatus,
    /// An EMP drive's switches and inputs I1-I4 (`40 01`), by its DS byte.
    EmpDrive(u8),
}

/// One reading of an input group: the reply that carried it arrived `at`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputRead {
    pub source: InputSource,
    pub at: Instant,
}

/// One input bit: its group and its place among the group's input bits
/// (isel: the port's bit number; EMCU: the `@X` flag, 0 moving … 5 job
/// running; EMP: 0 limit +, 1 limit -, 2 reference, 3-6 I1-I4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InputKey {
    pub source: InputSource,
    pub bit: u8,
}

/// What an input is for, as far as diagnostics care.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputRole {
    /// One channel of an emergency-stop circuit; active = open (tripped).
    Estop,
    /// A limit switch; active = hit.
    Limit,
    /// A start, stop or key switch the operator presses or turns.
    Key,
    /// A tool-length probe or a reference switch.
    Probe,
    /// A hood or door contact; active = open.
    Hood,
    /// Power supply or power-stage supervision; active = not ok.
    Power,
    /// Feedback of something jogterm switches (the isel spindle bit).
    Feedback,
    /// A user input.
    User,
    /// A status flag of the controller (EMCU `@X`).
    Status,
    /// Nothing is connected.
    Unused,
}

/// One input as the profile names it (`device::inputs::channels`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct InputChannel {
    pub key: InputKey,
    /// `in3.0`, `@X.3`, `11.limit+`.
    pub address: String,
    pub name: String,
    pub role: InputRole,
    /// Something is connected to it.
    pub wired: bool,
    /// The level read while the role's condition holds (a limit switch hit,
    /// an E-stop circuit open, a key pressed): `true` = 1.
    pub active: bool,
}

/// An input that changed more than the profile allows in its window
/// (`[diagnostics] chatter_changes` within `chatter_ms`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chatter {
    /// Changes of the input within `within`, this one included.
    pub changes: u32,
    pub within: Duration,
}

/// The time between two E-stop channels opening, attached to the second.
#[derive(Debug, Clone, PartialEq)]
pub struct EstopSkew {
    /// The channel that opened first.
    pub first: Arc<InputChannel>,
    /// Between the first samples that saw each channel open.
    pub measured: Duration,
    /// The skew lies between these, given the two sampling windows.
    pub min: Duration,
    pub max: Duration,
}

/// One change of an input bit, as the input recorder saw it in the samples
/// (`device::inputs`).
#[derive(Debug, Clone, PartialEq)]
pub struct InputChange {
    /// Every change the recorder saw, numbered from 1.
    pub seq: u64,
    pub channel: Arc<InputChannel>,
    /// The level as read.
    pub level: bool,
    /// The first sample that read the new level.
    pub seen: Instant,
    /// The last sample that read the old level: the change happened after
    /// it and at or before `seen`.
    pub before: Instant,
    /// `seen` since the link first came up.
    pub t: Duration,
    /// Set while the input chatters.
    pub chatter: Option<Chatter>,
    /// Set when this change opened the second E-stop channel.
    pub skew: Option<EstopSkew>,
}

impl InputChange {
    /// The window the change happened in: `before` to `seen`.
    pub fn window(&self) -> Duration {
        self.seen.saturating_duration_since(self.before)
    }

    /// Whether the input went to its active level (hit, open, pressed).
    pub fn activated(&self) -> bool {
        self.level == self.channel.active
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct IoSnapshot {
    pub at: Instant,
    pub groups: Vec<IoGroup>,
}

impl IoSnapshot {
    /// The wired limit switches that read active in this snapshot, with
    /// their axis and side, in the order the controller numbers them. An
    /// input the profile declares unwired never counts; an axis may have
    /// both of its switches active (a switch wired to both ends). The jog
    /// off a limit switch (issue 13) takes its axis and direction from here
    /// ([`ActiveLimit::away`]).
    pub fn active_limits(&self) -> Vec<ActiveLimit> {
        self.groups
            .iter()
            .flat_map(|g| &g.bits)
            .filter(|b| b.output.is_none() && b.active())
            .filter_map(|b| {
                let w = b.wiring.as_ref().filter(|w| w.kind == BitKind::Input)?;
                let l = w.limit()?;
                Some(ActiveLimit {
                    axis: l.axis,
                    side: l.side,
                    name: w.name.clone(),
                    address: w.address.clone(),
                })
            })
            .collect()
    }

    /// Whether the machine's start key (the profile's wired input of role
    /// `start`) reads pressed; `None` where the profile wires none. A wait
    /// for the operator goes on at its press (`jogterm run`, the console).
    pub fn start_key(&self) -> Option<bool> {
        self.groups
            .iter()
            .flat_map(|g| &g.bits)
            .filter(|b| b.output.is_none())
            .find(|b| {
                b.wiring.as_ref().is_some_and(|w| {
                    w.role == crate::wiring::Role::Start && w.kind == BitKind::Input && w.wired
                })
            })
            .map(IoBit::active)
    }
}

/// How a continuous jog ended.
#[derive(Debug, Clone, PartialEq)]
pub enum JogEnd {
    Released,
    /// Renewals stopped arriving in time.
    DeadMan,
    Stopped,
    SoftLimit,
    Refused(Refusal),
    Fault(ControllerFault),
    LinkLost,
    /// A jog off a limit switch: the switch released; the axis stands off
    /// it and needs a reference run.
    OffLimit,
    /// A jog off a limit switch travelled `jog.limit_jog_distance` and the
    /// switch still reads active (stuck, or wired other than the profile
    /// says): it stopped there.
    StillOnLimit,
}

/// What a probe does (`Request::Probe`), in machine steps and step
/// frequencies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeMove {
    pub axis: Axis,
    /// Toward the surface.
    pub dir: Dir,
    /// The farthest the first pass goes, steps (> 0).
    pub travel: i64,
    /// The first pass, steps/s (at most the axis's top speed).
    pub fast_hz: f64,
    /// The back-off and the second pass, steps/s: slow enough that the
    /// controller stops within a step (isel: at most the start-stop
    /// frequency, which it stops from without a ramp).
    pub slow_hz: f64,
}

/// How a probe ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ProbeEnd {
    /// The input tripped. `at`: the position after the slow pass (machine
    /// steps, every axis), the touched point; `fast_stop`: where the axis
    /// stood after the fast pass (past `at` by the controller's ramp-down).
    /// The axis stands where it started again.
    Touched {
        at: PerAxis<i64>,
        fast_stop: i64,
    },
    /// The whole travel without a trip: the axis went back to where it
    /// started.
    NoTrip {
        travel: i64,
    },
    Stopped,
    Refused(Refusal),
    Fault(ControllerFault),
    LinkLost,
}

/// How one line of a program check-out ended (`Request::Checkout`).
#[derive(Debug, Clone, PartialEq)]
pub enum CheckoutEnd {
    /// The controller answered that the line is done; `byte`: the port
    /// byte a port read answered.
    Done {
        byte: Option<u8>,
    },
    /// The key was let go (`dead_man`: its repeats stopped coming) and the
    /// move paused. `rest`: the controller keeps the rest of the move for
    /// a resume (it answered `F` to the 0xFD); false when the line never
    /// started. The position was read after it.
    Paused {
        dead_man: bool,
        rest: bool,
    },
    /// Stopped (0xFD 0xFF, the stop key, a reset): nothing is kept.
    Stopped,
    /// The controller refused the line, or a fault ended it.
    Fault(ControllerFault),
    Refused(Refusal),
    LinkLost,
}

#[derive(Debug, Clone, PartialEq)]
pub enum UploadEvent {
    Started {
        total: usize,
    },
    Progress {
        done: usize,
        total: usize,
        lines_per_second: f64,
    },
    Finished {
        total: usize,
        elapsed: Duration,
    },
    /// The controller rejected `line` (0-based index into the uploaded lines).
    Failed {
        line: usize,
        fault: ControllerFault,
    },
    /// Stopped by the operator or the link; the controller holds a partial program.
    Aborted {
        done: usize,
        reason: String,
        /// The link was lost: a client says so as a link failure, not as
        /// a refusal (`jogterm upload` exits 3).
        link_lost: bool,
    },
}

/// Poll statistics over the last second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PollStats {
    pub position_rate_hz: f64,
    /// The rate the line would allow for the current poll cycle.
    pub wire_limit_hz: f64,
}

/// What an `Event::Reply` is to the command it answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplyKind {
    /// Its answer: nothing more comes for the command (for a control byte,
    /// which has none, that it was sent).
    Answer,
    /// A long action has begun (EMP `55`, decision 1): its completion
    /// follows as another reply to the same command.
    Started,
}

/// Events out of the device task.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Link(LinkState),
    Position(PositionSample),
    Io(IoSnapshot),
    /// An input bit changed (`device::inputs`). Never dropped: at most one
    /// per input bit and port sample.
    Input(InputChange),
    State(MachineState),
    Fault(ControllerFault),
    Refused {
        request: String,
        reason: Refusal,
    },
    JogEnded {
        id: JogId,
        end: JogEnd,
    },
    /// A probe ended (`Request::Probe`).
    ProbeEnded {
        id: JogId,
        end: ProbeEnd,
    },
    /// A `Request::Hold` was not renewed within its lease: every motion was
    /// stopped (the stop went out on the stop lane).
    HoldLapsed,
    /// A check-out line ended (`Request::Checkout`).
    Checkout {
        id: JogId,
        end: CheckoutEnd,
    },
    Upload(UploadEvent),
    Traffic(TrafficRecord),
    /// The decoded answer to a `Raw` request.
    Reply {
        command: String,
        text: String,
        kind: ReplyKind,
    },
    Stats(PollStats),
    /// Something worth telling the operator that is none of the above.
    Notice(String),
}
