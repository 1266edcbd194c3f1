//! Reading the controller's state back after every (re)connect: the console
//! knows nothing about a controller it was not talking to.
//!
//! 0. `@0T0`, unless the profile allows test mode (`isel.test_mode`): test
//!    mode cannot be read back, and a controller left in it (by another
//!    program, or a jogterm that died in a jog off a limit switch) passes the
//!    reference probe and takes a reference run for "reference here"
//!    (manual 2.2.24).
//! 1. `@0P`, read until 50 ms of silence: `4` means no axes are initialised;
//!    18 hex digits mean up to three axes, 24 mean X, Y, Z and A (manual
//!    2.2.21, `docs/decisions.md` isel 2). `8` means the controller was
//!    still storing a program (a previous session died during an upload):
//!    that line ended the upload, so the read-back starts again.
//! 2. Ports 1, 2, 3: E-stop circuits, hood and power, limit switches. A
//!    port answered `1` is one the controller does not have: it is left
//!    out of polling on this link (`Context::port_absent`).
//! 3. The reference probe: a relative move of zero steps for every axis.
//!    It moves nothing and is answered `0` when the axes are referenced, `R`
//!    when not, `7` when the number of pairs does not match the controller's
//!    axes (then the next axis count is tried, so jogterm learns how the
//!    controller is set up), `9` in E-stop. With an E-stop circuit open the
//!    probe is skipped: the controller must be initialised and referenced
//!    again anyway (manual chapter 5, code 9). Test mode (`@0T1`) cannot be
//!    read back; a controller in test mode answers `0` (`docs/protocols.md`).
//! 4. When the controller is set up as the profile says: `@0j`, `@0J`, `@0d`
//!    from the profile, so that estimates and reference runs use known ramps.
//!
//! A session that only reads (`Context::reads_only`: `watch`, `poll`,
//! `commission`, `send` of lines that move nothing) sends steps 1 and 2
//! alone: `@0T0`, the probe and the ramps set something in the controller
//! (test mode, a move command, the operator's or a program's ramps). The
//! axes are then the ones the length of `@0P` allows, as the profile has
//! them, and the reference state is not known (`docs/device.md`, "Sessions
//! that only read").

use std::time::Instant;

use crate::axis::AxisSet;
use crate::device::api::{Activity, ProgramState};
use crate::proto::isel::{
    AxisConfig, Command, Decode, Expect, InputPort, MovePair, Reply, ReplyCode, decode,
};

use super::context::{Cmd, Context};
use super::op::{Abandon, Next, Operation};

const PORTS: [InputPort; 3] = [
    InputPort::Status1,
    InputPort::Status2,
    InputPort::LimitSwitches,
];

/// The ports read back: 1, 2, 3, and those the poll plan adds (port 0 when
/// the profile wires a user input to a role, `PollPlan::ports_for`).
fn ports(cx: &Context) -> Vec<InputPort> {
    let mut out = PORTS.to_vec();
    out.extend(cx.settings.poll.ports.iter().filter(|p| !PORTS.contains(p)));
    out
}

/// Read-backs started over after garbled replies before giving up.
const MAX_RESTARTS: u32 = 3;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// `@0T0` before anything else on a new link (`Context::test_mode_unknown`:
    /// nobody can read test mode back) unless the profile allows test mode,
    /// and always when a jog off a limit switch switched it on and the link
    /// broke before it was off again (`Context::test_mode_left_on`, `limit_op`).
    TestOff,
    Position,
    Port(usize),
    Probe(usize),
    Ramp(usize),
    Done,
}

#[derive(Debug)]
pub struct Readback {
    stage: Stage,
    initialised: bool,
    has_a: bool,
    candidates: Vec<AxisConfig>,
    restarts: u32,
}

impl Default for Readback {
    fn default() -> Self {
        Readback::new()
    }
}

impl Readback {
    pub fn new() -> Readback {
        Readback {
            stage: Stage::Position,
            initialised: false,
            has_a: false,
            candidates: Vec::new(),
            restarts: 0,
        }
    }

    fn restart(&mut self, cx: &mut Context, why: &str) {
        self.restarts += 1;
        if self.restarts > MAX_RESTARTS {
            cx.notice(format!(
                "state read-back failed ({why}); the controller's state is unknown: initialise (i)"
            ));
            cx.set_config(None);
            self.stage = Stage::Done;
        } else {
            cx.notice(format!("state read-back starts again: {why}"));
            cx.quiet_request = Some(cx.settings.timing.resync_gap);
            self.stage = Stage::Position;
        }
    }

    /// The axis configurations to probe, the profile's first.
    fn candidates(&self, profile: AxisConfig) -> Vec<AxisConfig> {
        if self.has_a {
            return vec![AxisConfig::XYZA];
        }
        let mut out: Vec<AxisConfig> = [AxisConfig::XYZ, AxisConfig::XY, AxisConfig::X]
            .into_iter()
            .filter(|c| *c != profile)
            .collect();
        if profile != AxisConfig::XYZA {
            out.insert(0, profile);
        }
        out
    }

    fn after_ports(&mut self, cx: &mut Context) {
        if !self.initialised {
            cx.set_config(None);
            self.stage = Stage::Done;
        } else if cx.state.estop || cx.state.limit {
            // A probe would answer `9` (E-stop) or `2` (a move into an active
            // limit switch) and so make the controller forget its axes
            // (`docs/protocols.md`, isel). After an E-stop they are lost
            // anyway; in a limit switch the reference state stays unknown.
            let config = self.unprobed_config(cx);
            if !cx.state.estop {
                cx.set_config(Some(config));
                cx.notice("a limit switch is active: the reference state was not probed");
            }
            cx.state.referenced = AxisSet::EMPTY;
            self.stage = Stage::Done;
        } else if cx.reads_only {
            // No probe: it is a move command (`Context::reads_only`).
            cx.set_config(Some(self.unprobed_config(cx)));
            cx.state.referenced = AxisSet::EMPTY;
            self.stage = Stage::Done;
        } else {
            self.candidates = self.candidates(cx.settings.config);
            self.stage = Stage::Probe(0);
        }
    }

    /// The axes `@0P` allows without a probe: X, Y, Z and A from 24 digits,
    /// else the profile's (XYZ for a profile with A).
    fn unprobed_config(&self, cx: &Context) -> AxisConfig {
        if self.has_a {
            AxisConfig::XYZA
        } else if cx.settings.config != AxisConfig::XYZA {
            cx.settings.config
        } else {
            AxisConfig::XYZ
        }
    }

    fn probe_result(&mut self, cx: &mut Context, config: AxisConfig, reply: Reply, cmd: &str) {
        let code = match reply {
            Reply::Code(code) => code,
            _ => {
                self.restart(cx, "the reference probe got a data reply");
                return;
            }
        };
        match code {
            ReplyCode::ParameterCount => {
                if let Stage::Probe(i) = self.stage
                    && i + 1 < self.candidates.len()
                {
                    self.stage = Stage::Probe(i + 1);
                } else {
                    cx.notice(
                        "the controller's axis setting matches no axis count: initialise (i)",
                    );
                    cx.set_config(None);
                    self.stage = Stage::Done;
                }
                return;
            }
            ReplyCode::NoAxes => {
                cx.set_config(None);
                self.stage = Stage::Done;
                return;
            }
            _ => {}
        }
        cx.set_config(Some(config));
        cx.zero_known = AxisSet::from_mask(cx.zero_known.mask() & config.axes().mask());
        match code {
            ReplyCode::Ok => cx.referenced(config.axes()),
            ReplyCode::ReferenceRequired => cx.state.referenced = AxisSet::EMPTY,
            ReplyCode::HoodOpen => {
                cx.state.referenced = AxisSet::EMPTY;
                cx.notice("the hood is open: the reference state could not be read (close it and reference)");
            }
            other => {
                cx.state.referenced = AxisSet::EMPTY;
                cx.controller_error(cmd, other);
            }
        }
        if config != cx.settings.config {
            cx.notice(format!(
                "the controller is set up for {config}, the profile for {}: initialise (i) before moving",
                cx.settings.config
            ));
            self.stage = Stage::Done;
        } else {
            self.stage = Stage::Ramp(0);
        }
    }

    fn summary(&self, cx: &Context) -> String {
        match cx.config {
            None => "state read back: no axes initialised".to_owned(),
            Some(c) => format!(
                "state read back: axes {c} initialised, {}{}",
                if cx.reads_only {
                    "reference not probed (a session that only reads sends no move)".to_owned()
                } else if cx.state.referenced.is_empty() {
                    "none referenced".to_owned()
                } else {
                    format!("{} referenced", cx.state.referenced)
                },
                if cx.state.estop {
                    ", E-stop active"
                } else {
                    ""
                }
            ),
        }
    }
}

/// The `i`th of the profile's ramp settings: `@0j`, `@0J`, `@0d` (manual
/// 2.2.15, 2.2.16, 2.2.5).
pub fn ramp_command(cx: &Context, i: usize) -> Option<Command> {
    let s = &cx.settings;
    match i {
        0 => Some(Command::SetStartStop(s.start_stop_hz)),
        1 => Some(Command::SetAcceleration(s.accel_hz_per_ms)),
        2 => Some(Command::SetReferenceSpeeds(vec![
            s.reference_speed_hz;
            s.config.axis_count()
        ])),
        _ => None,
    }
}

/// Keep what a ramp setting did once the controller answered `0`.
pub fn ramp_applied(cx: &mut Context, command: &Command) {
    match command {
        Command::SetStartStop(hz) => cx.ramp.start_stop_hz = *hz,
        Command::SetAcceleration(a) => cx.ramp.accel_hz_per_ms = *a,
        // The slowest speed bounds how long a reference run may take.
        Command::SetReferenceSpeeds(v) => {
            cx.reference_hz = v.iter().copied().min().unwrap_or(cx.reference_hz)
        }
        _ => {}
    }
}

/// The zero-step move that tells whether the axes are referenced.
pub fn probe_command(cx: &Context, config: AxisConfig) -> Cmd {
    let speed = cx.settings.start_stop_hz;
    cx.cmd(Command::MoveRelative(vec![
        MovePair::new(0, speed);
        config.move_pairs()
    ]))
}

/// Interpret `@0P` read as text: 18 or 24 hex digits after `0`.
fn positions_from_text(bytes: &[u8]) -> Option<(crate::proto::isel::Positions, bool)> {
    for with_a in [true, false] {
        if let Decode::Reply {
            reply: Reply::Positions(p),
            consumed,
        } = decode(Expect::Positions { with_a }, bytes, true)
            && consumed == bytes.len()
        {
            return Some((p, with_a));
        }
    }
    None
}

impl Operation for Readback {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if self.stage == Stage::Position
            && !cx.reads_only
            && (cx.test_mode_left_on || cx.test_mode_unknown)
        {
            self.stage = Stage::TestOff;
        }
        match self.stage {
            Stage::TestOff => Next::Send(cx.cmd(Command::SetTestMode(false))),
            Stage::Position => {
                let mut cmd = cx.cmd(Command::ReadPosition);
                // Read until silence: the reply's length tells the axis count.
                cmd.expect = Expect::TextUntilSilence;
                Next::Send(cmd)
            }
            Stage::Port(i) => match ports(cx).get(i) {
                Some(port) => Next::Send(cx.cmd(Command::ReadPort(*port))),
                None => Next::Done,
            },
            Stage::Probe(i) => match self.candidates.get(i) {
                Some(config) => Next::Send(probe_command(cx, *config)),
                None => Next::Done,
            },
            Stage::Ramp(i) => match ramp_command(cx, i) {
                Some(c) => Next::Send(cx.cmd(c)),
                None => {
                    self.stage = Stage::Done;
                    cx.notice(self.summary(cx));
                    Next::Done
                }
            },
            Stage::Done => {
                cx.notice(self.summary(cx));
                Next::Done
            }
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match self.stage {
            Stage::TestOff => {
                let ours = cx.test_mode_left_on;
                cx.test_mode_left_on = false;
                cx.test_mode_unknown = false;
                if reply == Reply::Code(ReplyCode::Ok) {
                    if ours {
                        cx.notice(
                            "test mode switched off (@0T0): a jog off a limit switch had it on \
                             when the link was lost",
                        );
                    }
                } else {
                    cx.notice(format!(
                        "test mode may still be on (@0T0 answered {reply:?}): a controller in \
                         test mode takes a reference run for \"reference here\"; reset the \
                         controller (ctrl-r) before moving"
                    ));
                }
                self.stage = Stage::Position;
            }
            Stage::Position => match reply {
                Reply::Text { lines, .. } => {
                    let bytes: Vec<u8> = lines.concat().chars().map(|c| c as u32 as u8).collect();
                    match positions_from_text(&bytes) {
                        Some((p, with_a)) => {
                            self.initialised = true;
                            self.has_a = with_a;
                            cx.measured(&p, now);
                            self.stage = Stage::Port(0);
                        }
                        None => self.restart(cx, "the position reply could not be read"),
                    }
                }
                Reply::Code(ReplyCode::NoAxes) => {
                    self.initialised = false;
                    cx.position = None;
                    self.stage = Stage::Port(0);
                }
                Reply::Code(ReplyCode::NotStorable) => {
                    // `@0P` arrived while the controller was storing a
                    // program: it ended the upload with an error (manual 3.1).
                    cx.state.program = ProgramState::Invalid;
                    self.restart(
                        cx,
                        "the controller was still storing a program; it is marked invalid",
                    );
                }
                Reply::Code(code) => {
                    cx.controller_error("@0P", code);
                    self.initialised = false;
                    self.stage = Stage::Port(0);
                }
                _ => self.restart(cx, "unexpected reply to @0P"),
            },
            Stage::Port(i) => {
                let all = ports(cx);
                let port = all.get(i).copied();
                match (reply, port) {
                    (Reply::Byte(v), Some(port)) => cx.port_read(port, v, now),
                    // A port the controller does not have (manual 2.2.3
                    // lists ports 0-3; a smaller controller may lack one).
                    (Reply::Code(ReplyCode::BadNumber), Some(port)) => cx.port_absent(port),
                    (Reply::Code(code), Some(port)) => {
                        cx.controller_error(&format!("@{}b{}", cx.device, port.number()), code);
                    }
                    _ => {}
                }
                if i + 1 < all.len() {
                    self.stage = Stage::Port(i + 1);
                } else {
                    cx.emit_io(now);
                    self.after_ports(cx);
                }
            }
            Stage::Probe(i) => {
                if let Some(config) = self.candidates.get(i).copied() {
                    let text = probe_command(cx, config).text;
                    self.probe_result(cx, config, reply, &text);
                }
            }
            Stage::Ramp(i) => {
                match (reply, ramp_command(cx, i)) {
                    (Reply::Code(ReplyCode::Ok), Some(c)) => ramp_applied(cx, &c),
                    (Reply::Code(code), Some(c)) => {
                        let text = cx.cmd(c).text;
                        cx.controller_error(&text, code);
                    }
                    _ => {}
                }
                self.stage = Stage::Ramp(i + 1);
            }
            Stage::Done => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        self.restart(cx, "a reply was garbled");
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.stage = Stage::Done;
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
