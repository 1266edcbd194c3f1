//! `jogterm frame FILE`: trace the rectangle of a G-code job's X/Y extents
//! at its safe height (`docs/gcode.md`, "Frame the job"), so that the
//! operator sees where the job lies on the stock before anything cuts. The
//! job is imported as `jogterm run` imports it (the same work offset, the
//! same `--work-zero`); the plan is `jogterm_gcode::frame`; each leg is the
//! device's relative step, followed, and stopped by Space, Ctrl-C, SIGTERM
//! or a hang-up like `jogterm probe`'s moves ([`super::probe::operator`]).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;

use super::probe::operator::{Operator, lost};
use super::session::{self, EXIT_USAGE, Linked, Session};
use super::upload::{self, Remedy};
use super::{GlobalArgs, out};
use crate::axis::Axis;
use crate::config::Profile;
use crate::device::api::PerAxis;
use crate::gcode::frame::{Frame, Leg, LegKind};
use crate::gcode::toolpath::Point;
use crate::probing;

pub const LONG_ABOUT: &str = "\
Frame a G-code job: trace the rectangle of its X/Y extents (machine coordinates through the
work offset `jogterm run` uses, or --work-zero) at its safe height (the highest Z the job
reaches, or --z), at the profile's jog speed: Z alone up to the safe height first when the tool
stands lower (never down), then the four corners and back to the first.

Refused before anything moves: a job outside the soft limits, axes not referenced, an E-stop or
controller error. jogterm asks for a confirmation on the terminal (--yes skips it; without a
terminal --yes is needed). Space, s or q, Ctrl-C, SIGTERM and a hang-up stop the machine;
nothing resumes.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 the frame was traced; 1 stopped, refused, a controller error, or not confirmed;
2 bad usage (an unreadable file, a job with errors, no terminal to confirm on without --yes);
3 link failure.

Examples:
  jogterm frame part.nc --port /dev/ttyUSB0 --protocol isel
  jogterm frame part.nc --z 10 --yes
  jogterm --sim isel frame examples/gcode/fusion-grbl.nc --work-zero \"X50 Y50 Z60\" --yes";

#[derive(Debug, Args)]
pub struct FrameArgs {
    /// The G-code job (.nc .ngc .gcode .tap .gc; any name is read as G-code)
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// The active work offset's zero in machine units (`X50 Y50 Z60`), instead of the
    /// console's stored one
    #[arg(long, value_name = "POS")]
    pub work_zero: Option<String>,
    /// The height to trace at, work Z (default: the highest Z the job reaches)
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    pub z: Option<f64>,
    /// Start without asking
    #[arg(long, short = 'y')]
    pub yes: bool,
}

pub fn run(global: &GlobalArgs, args: &FrameArgs) -> anyhow::Result<ExitCode> {
    let usage = |m: &dyn std::fmt::Display| {
        out::say(format_args!("jogterm frame: {m}"));
        Ok(ExitCode::from(EXIT_USAGE))
    };
    // Any family the import takes (isel, EMCU): the import says why not
    // for the others.
    let profile = match session::resolve(global, None) {
        Ok(p) => p,
        Err(session::StartError::Usage(m)) => return usage(&m),
        Err(session::StartError::Failed(e)) => return Err(e),
    };
    if args.z.is_some_and(|z| !z.is_finite()) {
        return usage(&"--z: expected a height in units");
    }
    let imported = match upload::import_gcode(
        global,
        &args.file,
        args.work_zero.as_deref(),
        None,
        None,
        &profile,
        "frame",
    ) {
        Ok(i) => i,
        Err((code, m)) => {
            if !m.is_empty() {
                out::say(m);
            }
            return Ok(ExitCode::from(code));
        }
    };
    let frame = match crate::gcode::frame::of(&imported.import.toolpath, args.z) {
        Ok(f) => f,
        Err(why) => return usage(&format_args!("{}: {why}", imported.name)),
    };
    if let Some(why) = frame.outside(limits(&profile)) {
        out::say(format_args!("jogterm frame: {why}; nothing moved"));
        return Ok(ExitCode::from(1));
    }
    let speed = jog_speed(&profile);
    out::say(describe(&imported.name, &frame, args.z.is_some(), speed));
    if !args.yes {
        match confirmed() {
            Ok(true) => {}
            Ok(false) => {
                out::say("jogterm frame: not started; nothing was sent");
                return Ok(ExitCode::from(1));
            }
            Err(m) => return usage(&m),
        }
    }
    let remedy = Remedy::of_command(&profile, "frame");
    let for_session = profile.clone();
    session::moving(global, for_session, "frame", async |mut session| {
        let code = match trace(&mut session, &profile, &frame, speed, &remedy).await {
            Ok(()) => 0,
            Err(code) => code,
        };
        session.close().await;
        ExitCode::from(code)
    })
}

/// The machine's soft limits of X, Y and Z (units); an axis it lacks has
/// none to leave.
fn limits(profile: &Profile) -> [(f64, f64); 3] {
    [Axis::X, Axis::Y, Axis::Z].map(|axis| {
        profile
            .axis(axis)
            .map_or((f64::NEG_INFINITY, f64::INFINITY), |a| (a.min, a.max))
    })
}

/// The continuous-jog speed selected at start (`jog.speeds[jog.speed]`),
/// units/s: the speed an operator is used to watching the tool at.
fn jog_speed(profile: &Profile) -> f64 {
    let jog = &profile.jog;
    jog.speeds
        .get(jog.speed)
        .or(jog.speeds.first())
        .copied()
        .unwrap_or(1.0)
}

fn describe(name: &str, f: &Frame, asked_z: bool, speed: f64) -> String {
    format!(
        "{name}: frame X {:.3} to {:.3}, Y {:.3} to {:.3} (machine) at Z {:.3} ({}), {speed} units/s",
        f.min_x,
        f.max_x,
        f.min_y,
        f.max_y,
        f.z,
        if asked_z {
            "--z"
        } else {
            "the job's highest Z"
        }
    )
}

/// Asks on the terminal; `Err` when there is none to ask on.
fn confirmed() -> Result<bool, String> {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return Err(
            "no terminal to confirm the start on: give --yes to start without asking".into(),
        );
    }
    out::say("keys: Space, s or q stop the machine");
    out::say_raw("trace the frame? [y/N] ");
    let mut answer = String::new();
    if stdin.read_line(&mut answer).is_err() {
        return Ok(false);
    }
    Ok(matches!(answer.trim(), "y" | "Y" | "yes" | "YES" | "Yes"))
}

/// The controller set up, the axes checked, every leg moved in turn.
async fn trace(
    session: &mut Session,
    profile: &Profile,
    frame: &Frame,
    speed: f64,
    remedy: &Remedy,
) -> Result<(), u8> {
    if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
        return Err(lost("frame", &reason));
    }
    let (referenced, here) = set_up(session, remedy).await?;
    let missing: Vec<Axis> = [Axis::X, Axis::Y, Axis::Z]
        .into_iter()
        .filter(|a| profile.axis(*a).is_some() && !referenced.contains(*a))
        .collect();
    if !missing.is_empty() {
        let axes: crate::axis::AxisSet = missing.iter().copied().collect();
        out::say(format_args!(
            "jogterm frame: refused: axes {axes} not referenced: reference them first ({}); nothing moved",
            remedy.reference(axes)
        ));
        return Err(1);
    }
    let Some(steps) = here else {
        out::say("jogterm frame: the controller reported no position: nothing moved");
        return Err(1);
    };
    let at = |axis| probing::units(profile, axis, steps.get(axis).unwrap_or(0));
    let start = Point {
        x: at(Axis::X),
        y: at(Axis::Y),
        z: at(Axis::Z),
    };
    let hz = PerAxis::new()
        .with(Axis::X, hz(profile, Axis::X, speed))
        .with(Axis::Y, hz(profile, Axis::Y, speed))
        .with(Axis::Z, hz(profile, Axis::Z, speed));
    let mut operator = Operator::of_command(Some(steps), "frame");
    for leg in frame.legs(start) {
        out::say(leg_text(&leg));
        let target = PerAxis::new()
            .with(Axis::X, probing::steps(profile, Axis::X, leg.to.x))
            .with(Axis::Y, probing::steps(profile, Axis::Y, leg.to.y))
            .with(Axis::Z, probing::steps(profile, Axis::Z, leg.to.z));
        operator.move_to(session, target, hz, remedy).await?;
    }
    out::say("jogterm frame: traced; the tool stands above the first corner");
    Ok(())
}

/// `speed` (units/s) as the axis' step frequency, at most its `max_speed`.
fn hz(profile: &Profile, axis: Axis, speed: f64) -> f64 {
    profile
        .axis(axis)
        .map_or(0.0, |a| a.speed_hz(speed.min(a.max_speed)).abs())
}

fn leg_text(leg: &Leg) -> String {
    let Point { x, y, z } = leg.to;
    match leg.kind {
        LegKind::Up => format!("Z up to the safe height, Z {z:.3}"),
        LegKind::Corner(n) => format!("corner {n}: X {x:.3} Y {y:.3} Z {z:.3}"),
    }
}

/// The controller initialised, and what is referenced and where the axes
/// stand (`upload::initialise_settled`).
async fn set_up(
    session: &mut Session,
    remedy: &Remedy,
) -> Result<(crate::axis::AxisSet, Option<PerAxis<i64>>), u8> {
    let set = upload::initialise_settled(session, remedy).await?;
    Ok((set.state.referenced, set.measured))
}
