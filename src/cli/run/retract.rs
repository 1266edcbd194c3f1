//! The first step of a restart (`jogterm run FILE --from-line N`, issue 37):
//! the tool goes up, Z alone, from wherever it stands, before anything
//! else moves. After a broken tool it may stand in the material, and an
//! absolute move names every axis (isel `m`, EMCU `L`): the program's own
//! first move would go from there to the line's start in a straight line
//! through the part. So jogterm reads where the tool stands and moves Z up
//! relative to it (isel `@0A`, EMCU `L` with `z`), X and Y standing still.

use crate::axis::Axis;
use crate::cli::out;
use crate::cli::session::{EXIT_LINK, Session};
use crate::cli::upload::Status;
use crate::config::profile::Profile;
use crate::device::api::{Activity, Event, LinkState, PerAxis, Request};
use crate::gcode::Restart;

/// Where the retract goes and how fast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retract {
    /// The job's safe height, machine steps of Z.
    pub z: i64,
    /// Z's speed, steps/s: the rapid speed, at most Z's `max_speed`.
    pub hz: f64,
}

impl Retract {
    pub fn of(restart: &Restart, profile: &Profile) -> Option<Retract> {
        let z = profile.axis(Axis::Z)?;
        let speed = profile
            .gcode
            .rapid_speed
            .map_or(z.max_speed, |r| r.min(z.max_speed));
        Some(Retract {
            z: z.to_steps(restart.safe_z),
            hz: z.speed_hz(speed),
        })
    }
}

/// Up to the safe height, Z alone: the controller set up, where the tool
/// stands read, then a relative step of Z. Nothing to do when the tool
/// stands at or above the safe height; nothing it can do when Z is not
/// referenced (after a power cut): the program's reference run then moves
/// Z first, or the start refuses.
pub async fn retract(session: &mut Session, to: Retract) -> Status {
    let (referenced, z) = where_it_stands(session).await?;
    let Some(z) = z.filter(|_| referenced) else {
        out::say(
            "retract: Z is not referenced, where the tool stands is unknown: nothing moved (a reference run moves Z first)",
        );
        return Ok(());
    };
    if z >= to.z {
        out::say("retract: the tool stands at or above the safe height already");
        return Ok(());
    }
    out::say(format_args!(
        "retract: Z alone up {} steps to the safe height",
        to.z - z
    ));
    let request = Request::Step {
        delta: PerAxis::new().with(Axis::Z, to.z - z),
        speed_hz: PerAxis::new().with(Axis::Z, to.hz),
    };
    if session.handle.request(request).is_err() {
        return Err(lost("the device task ended"));
    }
    let mut moving = false;
    loop {
        match next(session).await? {
            Event::State(s) if s.activity != Activity::Idle => moving = true,
            Event::State(_) if moving => return Ok(()),
            Event::Refused { reason, .. } => {
                out::say(format_args!(
                    "jogterm run: the retract was refused: {reason}"
                ));
                return Err(1);
            }
            Event::Fault(f) => {
                out::say(format_args!(
                    "jogterm run: the retract ended with `{}`: {}",
                    f.code, f.meaning
                ));
                return Err(1);
            }
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
}

/// The controller set up (`Request::Initialise`: isel's axes and its
/// reference probe, then the position), and what it left: whether Z is
/// referenced, and where it stands (machine steps).
async fn where_it_stands(session: &mut Session) -> Result<(bool, Option<i64>), u8> {
    if session.handle.request(Request::Initialise).is_err() {
        return Err(lost("the device task ended"));
    }
    let mut z = None;
    let referenced = loop {
        match next(session).await? {
            Event::State(s) if !s.initialised.is_empty() && s.activity == Activity::Idle => {
                break s.referenced.contains(Axis::Z);
            }
            Event::Position(p) => z = p.steps.get(Axis::Z),
            Event::Refused { reason, .. } => {
                out::say(format_args!(
                    "jogterm run: initialising was refused: {reason}"
                ));
                return Err(1);
            }
            Event::Fault(f) => {
                out::say(format_args!(
                    "jogterm run: initialising failed: `{}` answered {}: {}",
                    f.command, f.code, f.meaning
                ));
                return Err(1);
            }
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    };
    // The position read at the end of the set-up comes with or just after
    // its idle state.
    let settle = tokio::time::Instant::now() + std::time::Duration::from_millis(500);
    while z.is_none() {
        match tokio::time::timeout_at(settle, session.events.recv()).await {
            Ok(Some(Event::Position(p))) => z = p.steps.get(Axis::Z),
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => return Err(lost(&reason)),
            Ok(Some(_)) => {}
            Ok(None) => return Err(lost("the device task ended")),
            Err(_) => break,
        }
    }
    Ok((referenced, z))
}

async fn next(session: &mut Session) -> Result<Event, u8> {
    session
        .events
        .recv()
        .await
        .ok_or_else(|| lost("the device task ended"))
}

fn lost(reason: &str) -> u8 {
    out::say(format_args!("jogterm run: link failure: {reason}"));
    EXIT_LINK
}
