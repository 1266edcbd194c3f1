//! Validation of typed commands against the axis configuration and the
//! ranges of the manual: parameter counts (`7`, `docs/decisions.md`
//! isel 5), axis masks (`3`, isel 3), speeds (`D`, isel 13), numbers (`1`).
//!
//! [`check`] is what the console runs before anything goes on the wire and
//! what a simulator runs after [`parse_frame`](super::parse_frame) to find
//! the code to answer. [`validate_frame`] and [`validate_cnc`] do both steps
//! on a line of text.

use std::ops::{Range, RangeInclusive};

use thiserror::Error;

use crate::axis::AxisSet;

use super::axes::{AxisConfig, AxisSetting};
use super::cnc::CncCommand;
use super::command::{CircleParams, Command, Frame, InitCommand, MovePair};
use super::parse::{ParseError, Parsed, parse_cnc, parse_frame};
use super::ports::{OutputPort, PortBits};
use super::reply::ReplyCode;

/// Step frequencies of moves, reference runs, circles (isel 13).
pub const SPEED_HZ: RangeInclusive<u32> = 1..=40_000;
/// Start-stop frequency, `j` and `@0Ij` (manual 2.2.15).
pub const START_STOP_HZ: RangeInclusive<u32> = 20..=4000;
/// Acceleration in Hz/ms, `J` and `@0IJ` (manual 2.2.16).
pub const ACCELERATION_HZ_PER_MS: RangeInclusive<u32> = 1..=4000;
/// Step counts and positions: the 24-bit counters of `@0P` (isel 2).
pub const STEPS: RangeInclusive<i32> = -8_388_608..=8_388_607;
/// Loop counts of CNC `3`; 0 makes it a jump (manual 3.2.5).
pub const LOOP_COUNT: RangeInclusive<u16> = 0..=32_767;
/// Steps to clear a reference switch, `@0IF` (manual 4.2.2).
pub const REFERENCE_CLEAR_STEPS: RangeInclusive<u32> = 0..=65_535;
/// Longest user info, `@0IU` (manual 4.2.16).
pub const USER_INFO_MAX_CHARS: usize = 32;

/// A typed command the controller would refuse.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{message} (a controller answers {code})")]
pub struct CheckError {
    /// The reply code a controller gives.
    pub code: ReplyCode,
    /// What was expected and what was found.
    pub message: String,
    /// The offending parameter, as an index into the encoded parameter list
    /// (and into [`Parsed::params`] for a parsed line); `None` when the count
    /// or the command as a whole is wrong.
    pub param: Option<usize>,
}

fn fail<T>(code: ReplyCode, param: Option<usize>, message: String) -> Result<T, CheckError> {
    Err(CheckError {
        code,
        message,
        param,
    })
}

/// Check a DNC command for a controller initialised with `config`.
pub fn check(command: &Command, config: AxisConfig) -> Result<(), CheckError> {
    check_with(command, Some(config))
}

/// Check a DNC command for a controller that may not be initialised yet:
/// with `None`, commands that need axes answer `4`
/// ([`Command::needs_axes`]) and `@08` answers `3`.
pub fn check_with(command: &Command, config: Option<AxisConfig>) -> Result<(), CheckError> {
    let axes = || {
        config.ok_or_else(|| CheckError {
            code: ReplyCode::NoAxes,
            message: "no axes are initialised: send the axis setting (@01, @03 or @07) first"
                .into(),
            param: None,
        })
    };
    match command {
        Command::SetAxes(setting) => {
            if AxisConfig::after_setting(config, *setting).is_err() {
                return fail(
                    ReplyCode::BadAxis,
                    Some(0),
                    format!(
                        "`@0{}` switches the A axis on only after X, Y and Z (`@07`)",
                        AxisSetting::A.value()
                    ),
                );
            }
            Ok(())
        }
        Command::MoveRelative(pairs) => check_pairs("A", pairs, axes()?, false),
        Command::MoveAbsolute(pairs) => check_pairs("M", pairs, axes()?, true),
        Command::WritePort { port, value } => check_port_value(*port, *value, 1),
        Command::SetReferenceSpeeds(speeds) => check_reference_speeds("d", speeds, axes()?),
        Command::ClearLimitSwitch(axis) => {
            let config = axes()?;
            if config.axes().contains(*axis) {
                Ok(())
            } else {
                fail(
                    ReplyCode::BadAxis,
                    Some(0),
                    format!("axis {axis} is not initialised ({config})"),
                )
            }
        }
        Command::SetStartStop(hz) => check_start_stop(*hz, 0),
        Command::SetAcceleration(a) => check_acceleration(*a, 0),
        Command::SetZero(mask) | Command::SimulateReference(mask) | Command::Reference(mask) => {
            check_mask(*mask, axes()?)
        }
        Command::Circle(c) => {
            check_plane_axes("y", axes()?, 2)?;
            check_circle(c)
        }
        Command::Helix(h) => {
            check_plane_axes("w", axes()?, 3)?;
            check_circle(&h.circle)?;
            check_steps(h.s3, 7)
        }
        Command::MoveUntilPort(m) => {
            let config = axes()?;
            if m.steps.len() != config.axis_count() {
                return fail(
                    ReplyCode::ParameterCount,
                    None,
                    format!(
                        "`Z` with {config} takes port, mask, value, speed and {} step count{}, got {}",
                        config.axis_count(),
                        plural(config.axis_count()),
                        m.steps.len()
                    ),
                );
            }
            check_speed(m.speed, 3)?;
            for (i, s) in m.steps.iter().enumerate() {
                check_steps(*s, 4 + i)?;
            }
            Ok(())
        }
        Command::Init(init) => check_init(init),
        Command::ReadPort(_)
        | Command::Diagnose(_)
        | Command::SetPlane(_)
        | Command::SetCircleDirection(_)
        | Command::SetBrake(_)
        | Command::SetDeviceNumber(_)
        | Command::LimitSwitchStatus
        | Command::Status
        | Command::EraseProgram
        | Command::ReadPosition
        | Command::Start
        | Command::SetTestMode(_)
        | Command::ReadUserInfo
        | Command::ReadVersion
        | Command::Set3dInterpolation(_) => Ok(()),
        Command::StoreProgram => axes().map(|_| ()),
    }
}

/// Check a stored CNC line for a controller initialised with `config`.
/// Program-wide rules (jump targets inside the program, loop nesting) are
/// for a program linter; this checks the line on its own.
pub fn check_cnc(command: &CncCommand, config: AxisConfig) -> Result<(), CheckError> {
    match command {
        CncCommand::MoveRelative(pairs) => check_pairs("0", pairs, config, false),
        CncCommand::MoveAbsolute(pairs) => check_pairs("m", pairs, config, true),
        CncCommand::Loop { count, offset } => {
            if !LOOP_COUNT.contains(count) {
                return fail(
                    ReplyCode::BadNumber,
                    Some(0),
                    format!("the loop count is 1-32767 (0 for a jump), got {count}"),
                );
            }
            if *count > 0 && *offset >= 0 {
                return fail(
                    ReplyCode::BadNumber,
                    Some(1),
                    format!(
                        "a loop repeats commands before it: its offset is -1 or less, got {offset} \
                         (forward loops are not allowed)"
                    ),
                );
            }
            Ok(())
        }
        CncCommand::PortCondition { bits, value, .. }
        | CncCommand::BranchOnPort { bits, value, .. } => check_bits_value(*bits, *value),
        CncCommand::SetPort { port, bits, value } => {
            if port.max_value() == 1 && !matches!(bits, PortBits::Byte | PortBits::Bit(0)) {
                return fail(
                    ReplyCode::BadNumber,
                    Some(1),
                    format!("port {port} is on/off: address it with bit 0 or 128"),
                );
            }
            if let PortBits::Bit(b) = bits {
                check_bit_index(*b)?;
            }
            check_bits_value(*bits, *value)?;
            check_port_value(*port, *value, 2)
        }
        CncCommand::Reference(mask)
        | CncCommand::SetZero(mask)
        | CncCommand::SimulateReference(mask) => check_mask(*mask, config),
        CncCommand::SetReferenceSpeeds(speeds) => check_reference_speeds("d", speeds, config),
        CncCommand::SetStartStop(hz) => check_start_stop(*hz, 0),
        CncCommand::SetAcceleration(a) => check_acceleration(*a, 0),
        CncCommand::Circle(c) => {
            check_plane_axes("y", config, 2)?;
            check_circle(c)
        }
        CncCommand::Helix(h) => {
            check_plane_axes("w", config, 3)?;
            check_circle(&h.circle)?;
            check_steps(h.s3, 7)
        }
        CncCommand::SendSync(_)
        | CncCommand::WaitSync { .. }
        | CncCommand::Delay(_)
        | CncCommand::End
        | CncCommand::SetPlane(_)
        | CncCommand::SetCircleDirection(_)
        | CncCommand::SetBrake(_)
        | CncCommand::SetTestMode(_)
        | CncCommand::Set3dInterpolation(_) => Ok(()),
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

fn pair_names(config: AxisConfig) -> &'static str {
    match config {
        AxisConfig::X => "x",
        AxisConfig::XY => "x, y",
        AxisConfig::XYZ => "x, y, z1, z2",
        AxisConfig::XYZA => "x, y, z, a",
    }
}

/// `A`/`M`/`0`/`m` (manual 2.2.2, 2.2.18; isel 5). Every speed is checked,
/// also those of axes that do not move.
fn check_pairs(
    name: &str,
    pairs: &[MovePair],
    config: AxisConfig,
    absolute: bool,
) -> Result<(), CheckError> {
    let want = config.move_pairs();
    if pairs.len() != want {
        return fail(
            ReplyCode::ParameterCount,
            None,
            format!(
                "`{name}` with {config} takes {want} steps,speed pair{} ({}), got {}",
                plural(want),
                pair_names(config),
                pairs.len()
            ),
        );
    }
    for (i, pair) in pairs.iter().enumerate() {
        check_steps(pair.steps, 2 * i)?;
        check_speed(pair.speed, 2 * i + 1)?;
    }
    if absolute && config == AxisConfig::XYZ && pairs.get(3).is_some_and(|p| p.steps != 0) {
        return fail(
            ReplyCode::BadNumber,
            Some(6),
            format!(
                "`{name}` with 3 axes: the position of the 4th pair (z2) must be 0, got {}",
                pairs.get(3).map_or(0, |p| p.steps)
            ),
        );
    }
    Ok(())
}

fn check_steps(steps: i32, param: usize) -> Result<(), CheckError> {
    if STEPS.contains(&steps) {
        Ok(())
    } else {
        fail(
            ReplyCode::BadNumber,
            Some(param),
            format!(
                "steps and positions are 24-bit, {}..{}, got {steps}",
                STEPS.start(),
                STEPS.end()
            ),
        )
    }
}

fn check_speed(speed: u32, param: usize) -> Result<(), CheckError> {
    check_range(speed, &SPEED_HZ, param, "a speed", "Hz")
}

fn check_start_stop(hz: u32, param: usize) -> Result<(), CheckError> {
    check_range(hz, &START_STOP_HZ, param, "the start-stop frequency", "Hz")
}

fn check_acceleration(a: u32, param: usize) -> Result<(), CheckError> {
    check_range(
        a,
        &ACCELERATION_HZ_PER_MS,
        param,
        "the acceleration",
        "Hz/ms",
    )
}

fn check_range(
    value: u32,
    range: &RangeInclusive<u32>,
    param: usize,
    what: &str,
    unit: &str,
) -> Result<(), CheckError> {
    if range.contains(&value) {
        Ok(())
    } else {
        fail(
            ReplyCode::BadSpeed,
            Some(param),
            format!(
                "{what} must be {}-{} {unit}, got {value}",
                range.start(),
                range.end()
            ),
        )
    }
}

fn check_reference_speeds(
    name: &str,
    speeds: &[u32],
    config: AxisConfig,
) -> Result<(), CheckError> {
    let want = config.axis_count();
    if speeds.len() != want {
        return fail(
            ReplyCode::ParameterCount,
            None,
            format!(
                "`{name}` with {config} takes {want} speed{} (one per axis), got {}",
                plural(want),
                speeds.len()
            ),
        );
    }
    for (i, s) in speeds.iter().enumerate() {
        check_speed(*s, i)?;
    }
    Ok(())
}

/// `R`, `n`, `N`, CNC `7` (isel 3).
fn check_mask(mask: AxisSet, config: AxisConfig) -> Result<(), CheckError> {
    if config.accepts_mask(mask) {
        return Ok(());
    }
    let message = if mask.is_empty() {
        "the axis mask names no axis".to_string()
    } else if let Some(missing) = mask.iter().find(|a| !config.axes().contains(*a)) {
        format!("axis {missing} is not initialised ({config})")
    } else {
        format!(
            "the A axis must be named on its own (mask 8), got {} ({mask})",
            mask.mask()
        )
    };
    fail(ReplyCode::BadAxis, Some(0), message)
}

fn check_plane_axes(name: &str, config: AxisConfig, need: usize) -> Result<(), CheckError> {
    if config.axis_count() >= need {
        Ok(())
    } else {
        fail(
            ReplyCode::BadAxis,
            None,
            format!("`{name}` needs at least {need} initialised axes, the controller has {config}"),
        )
    }
}

/// `y`/`w` (manual 2.3, isel 12).
fn check_circle(c: &CircleParams) -> Result<(), CheckError> {
    if c.arc_length == 0 {
        return fail(
            ReplyCode::BadNumber,
            Some(0),
            "the arc length B must be at least 1 step".into(),
        );
    }
    check_speed(c.speed, 1)?;
    check_steps(c.xs, 3)?;
    check_steps(c.ys, 4)
}

/// `@0B` and CNC `p` (manual 2.2.4).
fn check_port_value(port: OutputPort, value: u8, param: usize) -> Result<(), CheckError> {
    if value <= port.max_value() {
        Ok(())
    } else {
        fail(
            ReplyCode::BadNumber,
            Some(param),
            format!(
                "port {port} ({}) takes 0-{}, got {value}",
                port.info().name,
                port.max_value()
            ),
        )
    }
}

fn check_bit_index(bit: u8) -> Result<(), CheckError> {
    if bit <= 7 {
        Ok(())
    } else {
        fail(
            ReplyCode::BadNumber,
            Some(1),
            format!("a port has bits 0-7, got bit index {bit}"),
        )
    }
}

/// CNC `6`, `o`, `p`: a single bit compares with or is set to 0 or 1.
fn check_bits_value(bits: PortBits, value: u8) -> Result<(), CheckError> {
    if let PortBits::Bit(b) = bits {
        check_bit_index(b)?;
    }
    if value <= bits.max_value() {
        Ok(())
    } else {
        fail(
            ReplyCode::BadNumber,
            Some(2),
            format!("a single bit is 0 or 1, got {value}"),
        )
    }
}

fn check_init(init: &InitCommand) -> Result<(), CheckError> {
    match init {
        InitCommand::DefaultReferenceSpeeds(speeds) => {
            for (i, s) in speeds.iter().enumerate() {
                check_speed(*s, i)?;
            }
            Ok(())
        }
        InitCommand::ReferenceClearSteps(steps) => {
            for (i, s) in steps.iter().enumerate() {
                if !REFERENCE_CLEAR_STEPS.contains(s) {
                    return fail(
                        ReplyCode::BadNumber,
                        Some(i),
                        format!(
                            "the clearing steps are {}-{}, got {s}",
                            REFERENCE_CLEAR_STEPS.start(),
                            REFERENCE_CLEAR_STEPS.end()
                        ),
                    );
                }
            }
            Ok(())
        }
        InitCommand::DefaultAcceleration(a) => check_acceleration(*a, 0),
        InitCommand::DefaultStartStop(hz) => check_start_stop(*hz, 0),
        InitCommand::SetUserInfo(text) => {
            if let Some(bad) = text.chars().find(|c| !(' '..='~').contains(c)) {
                return fail(
                    ReplyCode::BadNumber,
                    Some(0),
                    format!("the user info is printable ASCII, got {bad:?}"),
                );
            }
            if text.len() > USER_INFO_MAX_CHARS {
                return fail(
                    ReplyCode::BadNumber,
                    Some(0),
                    format!(
                        "the user info holds at most {USER_INFO_MAX_CHARS} characters, got {}",
                        text.len()
                    ),
                );
            }
            Ok(())
        }
        InitCommand::IoOnly(_)
        | InitCommand::LimitSwitches(_)
        | InitCommand::SwapLimitSwitches(_)
        | InitCommand::InvertDirections(_)
        | InitCommand::InvertReferenceDirections(_)
        | InitCommand::RotaryAxes(_)
        | InitCommand::AbortInput(_)
        | InitCommand::ErrorOutput(_)
        | InitCommand::HoodInput(_)
        | InitCommand::EmergencyStopInput(_)
        | InitCommand::Baud9600(_)
        | InitCommand::LoadFromFlash
        | InitCommand::WriteToFlash
        | InitCommand::RestoreDefaults => Ok(()),
    }
}

/// A line refused by the parser or by the check: the reply code a
/// controller would give, a message, and where in the line.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{message} (a controller answers {code})")]
pub struct Rejection {
    pub code: ReplyCode,
    pub message: String,
    /// Byte span in the line, when the fault is in one place.
    pub span: Option<Range<usize>>,
}

impl From<ParseError> for Rejection {
    fn from(e: ParseError) -> Rejection {
        Rejection {
            code: e.code,
            message: e.message,
            span: Some(e.span),
        }
    }
}

impl Rejection {
    fn from_check<T>(e: CheckError, parsed: &Parsed<T>) -> Rejection {
        Rejection {
            code: e.code,
            message: e.message,
            span: e.param.and_then(|i| parsed.params.get(i).cloned()),
        }
    }
}

/// Parse a DNC frame and check it: what the `send` command runs before a
/// line goes on the wire. `config` is the controller's axis configuration,
/// `None` before the axes are set.
pub fn validate_frame(
    line: impl AsRef<[u8]>,
    config: Option<AxisConfig>,
) -> Result<Parsed<Frame>, Rejection> {
    let parsed = parse_frame(line)?;
    match check_with(&parsed.value.command, config) {
        Ok(()) => Ok(parsed),
        Err(e) => Err(Rejection::from_check(e, &parsed)),
    }
}

/// Parse a CNC line and check it for `config`.
pub fn validate_cnc(
    line: impl AsRef<[u8]>,
    config: AxisConfig,
) -> Result<Parsed<CncCommand>, Rejection> {
    let parsed = parse_cnc(line)?;
    match check_cnc(&parsed.value, config) {
        Ok(()) => Ok(parsed),
        Err(e) => Err(Rejection::from_check(e, &parsed)),
    }
}
