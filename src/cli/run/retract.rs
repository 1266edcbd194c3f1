//! The first step of a restart (`jogterm run FILE --from-line N`, issue 37):
//! the tool goes up, Z alone, from wherever it stands, before anything
//! else moves or is stored. After a broken tool it may stand in the
//! material, and an absolute move names every axis (isel `m`, EMCU `L`):
//! the program's own first move would go from there to the line's start
//! in a straight line through the part.
//!
//! So jogterm reads where the tool stands and sends a relative move of Z
//! alone, X and Y 0 (isel `@0A`, manual 2.2.2; EMCU `L` with `z` alone,
//! 1.5.10). Relative rather than absolute: an isel absolute move counts
//! from the controller's virtual zero (manual 2.2.19), which `@0P` does not
//! report, and it would have to name X and Y where they were read; a
//! relative move with X and Y 0 cannot move them whatever the zero is. Its
//! length comes from Z as the controller reports it (machine steps), the
//! height from the job's safe height, which the program counts from the
//! reference point too (`gcode.reference_first`, `docs/gcode.md`).

use std::time::Duration;

use crate::axis::Axis;
use crate::cli::out;
use crate::cli::session::{EXIT_LINK, Session};
use crate::cli::upload::{self, Remedy, Status};
use crate::config::profile::Profile;
use crate::device::api::{Activity, Event, LinkState, PerAxis, PositionSource, Request};
use crate::gcode::Restart;

use super::keys::{Key, Keys};

/// How long the position measured at the end of the set-up may come after
/// the state that says the controller has its axes (it follows at once).
const SETTLE: Duration = Duration::from_millis(500);

/// Where the retract goes and how fast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retract {
    /// The job's safe height, machine steps of Z.
    pub z: i64,
    /// Z's speed, steps/s: the rapid speed, at most Z's `max_speed`.
    pub hz: f64,
    /// The program begins with a reference run, Z first: with Z not
    /// referenced, that run takes the tool out of the part, Z alone.
    pub reference_first: bool,
    /// isel: the device number, for `@0z0` before the retract.
    pub isel_device: Option<u8>,
}

impl Retract {
    /// `None` for a machine without Z: nothing to retract.
    pub fn of(restart: &Restart, profile: &Profile) -> Option<Retract> {
        let z = profile.axis(Axis::Z)?;
        let speed = profile
            .gcode
            .rapid_speed
            .map_or(z.max_speed, |r| r.min(z.max_speed));
        Some(Retract {
            z: z.to_steps(restart.safe_z),
            hz: z.speed_hz(speed),
            reference_first: restart.reference_first,
            isel_device: (profile.connection.protocol == crate::proto::Protocol::Isel)
                .then_some(profile.isel.device),
        })
    }
}

/// The controller set up (the one `Initialise` of the run: a second one
/// would change nothing and send no state to wait on), then Z alone up to
/// the safe height. Nothing moves when the tool stands at or above it.
/// With Z not referenced where the tool stands is unknown: the program's
/// reference run, Z first, is then the retract; without one the run is
/// refused before anything moves. Space stops the retract as it stops the
/// job.
pub(in crate::cli) async fn retract(
    session: &mut Session,
    to: Retract,
    remedy: &Remedy,
    keys: &mut Keys,
) -> Status {
    let stopper = session.handle.clone();
    let up = async {
        let z = match where_z_stands(session, remedy).await? {
            Ok(z) => z,
            Err(why) if to.reference_first => {
                out::say(format_args!(
                    "retract: {why}: where the tool stands is unknown: the program's reference run takes Z up first, alone"
                ));
                return Ok(());
            }
            Err(why) => {
                out::say(format_args!(
                    "jogterm run: {why}: where the tool stands is unknown, and the job's moves count from the reference point; nothing was moved or stored. Reference the axes first (Z goes first, alone): {}",
                    remedy.reference(remedy.axes)
                ));
                return Err(1);
            }
        };
        if z >= to.z {
            out::say("retract: the tool stands at or above the safe height already");
            return Ok(());
        }
        out::say(format_args!(
            "retract: Z alone up {} steps to the safe height",
            to.z - z
        ));
        step_z(session, to, z, remedy).await
    };
    tokio::pin!(up);
    loop {
        tokio::select! {
            result = &mut up => return result,
            key = keys.next() => if matches!(key, Key::Stop | Key::Gone) {
                let _ = stopper.stop().written().await;
                out::say("jogterm run: stopped during the retract; nothing resumes");
                return Err(1);
            },
        }
    }
}

/// The controller set up (`Initialise`: isel's axes, ramps and reference
/// probe, EMCU's speeds, then the position), and where Z stands (machine
/// steps); else why it is unknown.
async fn where_z_stands(
    session: &mut Session,
    remedy: &Remedy,
) -> Result<Result<i64, &'static str>, u8> {
    let set_up = upload::initialise_settled(session, remedy).await?;
    let (state, measured) = (set_up.state, set_up.measured);
    if !state.referenced.contains(Axis::Z) {
        return Ok(Err("Z is not referenced"));
    }
    Ok(measured
        .and_then(|p| p.get(Axis::Z))
        .ok_or("the controller reported no position of Z"))
}

/// A relative move of Z alone from `from` up to `to.z`, followed to its
/// end; refused (exit 1) when the controller ends it anywhere else.
async fn step_z(session: &mut Session, to: Retract, from: i64, remedy: &Remedy) -> Status {
    if let Some(device) = to.isel_device {
        two_and_a_half_d(session, device, remedy).await?;
    }
    let request = Request::Step {
        delta: PerAxis::new().with(Axis::Z, to.z - from),
        speed_hz: PerAxis::new().with(Axis::Z, to.hz),
    };
    if session.handle.request(request).is_err() {
        return Err(lost("the device task ended"));
    }
    let mut moving = false;
    loop {
        match next(session).await? {
            Event::State(s) if s.activity != Activity::Idle => moving = true,
            Event::State(s) if moving => {
                // A limit switch or an E-stop ends the move with a reply
                // the state carries (isel `2`, `9`).
                if let Some(f) = s.fault {
                    return Err(ended_with(&f.code, &f.meaning));
                }
                break;
            }
            Event::Refused { reason, .. } => {
                return Err(upload::refused("the retract", &reason, remedy));
            }
            Event::Fault(f) => return Err(ended_with(&f.code, &f.meaning)),
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
    // The position read after the move (isel `@0P`, EMCU `@LZ`): the job
    // starts only from the safe height.
    let settle = tokio::time::Instant::now() + SETTLE;
    loop {
        match tokio::time::timeout_at(settle, session.next_event()).await {
            Ok(Some(Event::Position(p))) if p.source == PositionSource::Measured => {
                return match p.steps.get(Axis::Z) {
                    Some(z) if z != to.z => {
                        out::say(format_args!(
                            "jogterm run: the retract ended at Z {z} steps, not at the safe height ({} steps); nothing more was sent",
                            to.z
                        ));
                        Err(1)
                    }
                    _ => Ok(()),
                };
            }
            Ok(Some(Event::Fault(f))) => return Err(ended_with(&f.code, &f.meaning)),
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => return Err(lost(&reason)),
            Ok(Some(_)) => {}
            Ok(None) => return Err(lost("the device task ended")),
            Err(_) => return Ok(()),
        }
    }
}

/// isel: 3D interpolation off (`@0z0`, manual 2.2.29) before the retract.
/// A run that broke off without a power cycle (jogterm killed, a lost
/// line) leaves the controller in 3D, where the x speed of a relative move
/// is its path speed: Z alone would crawl up at the X pair's filler speed
/// (the start-stop frequency, 300 Hz: 8 s for 6 mm) and the driver, which
/// starts each session believing 2.5D, would take the late answer for a
/// lost line. The program that follows sets 3D again itself.
async fn two_and_a_half_d(session: &mut Session, device: u8, remedy: &Remedy) -> Status {
    one_line(session, &format!("@{device}z0"), "the retract", remedy).await
}

/// One controller command of jogterm's own (never text from a file or an
/// operator), sent and its answer awaited; an error answer is a fault.
pub(super) async fn one_line(
    session: &mut Session,
    line: &str,
    what: &str,
    remedy: &Remedy,
) -> Status {
    if session
        .handle
        .request(Request::Raw {
            line: line.to_owned(),
        })
        .is_err()
    {
        return Err(lost("the device task ended"));
    }
    loop {
        match next(session).await? {
            // The one raw line in flight is this one; an error answer
            // comes as a fault.
            Event::Reply {
                kind: crate::device::api::ReplyKind::Answer,
                ..
            } => return Ok(()),
            Event::Refused { reason, .. } => {
                return Err(upload::refused(what, &reason, remedy));
            }
            Event::Fault(f) => return Err(ended_with(&f.code, &f.meaning)),
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
}

fn ended_with(code: &impl std::fmt::Display, meaning: &str) -> u8 {
    out::say(format_args!(
        "jogterm run: the retract ended with `{code}`: {meaning}; nothing more was sent"
    ));
    1
}

async fn next(session: &mut Session) -> Result<Event, u8> {
    session
        .next_event()
        .await
        .ok_or_else(|| lost("the device task ended"))
}

fn lost(reason: &str) -> u8 {
    out::say(format_args!("jogterm run: link failure: {reason}"));
    EXIT_LINK
}
