//! The job's outputs after it ended early (issue 37): a stop, a controller
//! error or a signal switches the spindle and the outputs the job switched
//! on off once the axes stand, and says so; a lost line can send nothing
//! and says they may still be on (`program::outputs`).

use std::time::Duration;

use super::super::out;
use super::super::session::{EXIT_LINK, Session};
use super::super::upload::Remedy;
use crate::device::api::{Activity, Event, LinkState, Request};
use crate::program::outputs::{JobOutput, labels};

/// How the job ended, for its outputs.
pub(in crate::cli) enum Ended {
    /// Stopped, a controller error: the link still stands.
    Early,
    /// The link is gone: nothing can be sent.
    LinkLost,
}

/// How a job's exit status says it ended, for its outputs: `None` when it
/// ran to its end or never started for bad usage.
pub(in crate::cli) fn ended_by(code: u8) -> Option<Ended> {
    match code {
        1 => Some(Ended::Early),
        EXIT_LINK => Some(Ended::LinkLost),
        _ => None,
    }
}

/// How long the axes may take to stand after a stop, and an output's
/// answer.
const STAND_WITHIN: Duration = Duration::from_secs(10);
const ANSWER_WITHIN: Duration = Duration::from_secs(3);

/// The outputs of `outputs` switched off once the machine is idle, what
/// could not be said on stderr as `jogterm <command>: …`.
pub(in crate::cli) async fn after_end(
    session: &mut Session,
    outputs: &[JobOutput],
    ended: Ended,
    command: &str,
    remedy: &Remedy,
) {
    if outputs.is_empty() {
        return;
    }
    if let Ended::LinkLost = ended {
        out::say(format_args!(
            "jogterm {command}: the link is lost: the job's outputs may still be on: {}; \
             switch them off at the machine",
            labels(outputs)
        ));
        return;
    }
    if !stands(session).await {
        out::say(format_args!(
            "jogterm {command}: the axes did not report standing: the job's outputs were left \
             as they are: {}",
            labels(outputs)
        ));
        return;
    }
    let mut off = Vec::new();
    for o in outputs {
        if let Some(why) = &o.left {
            out::say(format_args!(
                "jogterm {command}: {} left on: {why}; switch it off with `{} @0B{},<value>`",
                o.label, remedy.send, o.id.group
            ));
            continue;
        }
        match switch_off(session, o).await {
            Ok(()) => off.push(o),
            Err(why) => out::say(format_args!(
                "jogterm {command}: {} may still be on: {why}",
                o.label
            )),
        }
    }
    if !off.is_empty() {
        out::say(format_args!(
            "jogterm {command}: switched off once the axes stood: {}",
            labels(off)
        ));
    }
}

/// Wait until the device task reports the machine idle (at once when it
/// is); `false` when it did not within [`STAND_WITHIN`] or the link went.
async fn stands(session: &mut Session) -> bool {
    let deadline = tokio::time::Instant::now() + STAND_WITHIN;
    while session.activity != Activity::Idle {
        match tokio::time::timeout_at(deadline, session.next_event()).await {
            Ok(Some(Event::Link(LinkState::Lost { .. })) | None) | Err(_) => return false,
            Ok(Some(_)) => {}
        }
    }
    true
}

/// `SetOutput` to 0, followed to the device's answer: the port snapshot it
/// emits once the controller confirmed, or a refusal.
async fn switch_off(session: &mut Session, o: &JobOutput) -> Result<(), String> {
    let request = Request::SetOutput {
        output: o.id,
        value: 0,
    };
    if session.handle.request(request).is_err() {
        return Err("the device task ended".into());
    }
    let deadline = tokio::time::Instant::now() + ANSWER_WITHIN;
    loop {
        match tokio::time::timeout_at(deadline, session.next_event()).await {
            Ok(Some(Event::Io(_))) => return Ok(()),
            Ok(Some(Event::Refused { reason, .. })) => return Err(format!("refused: {reason}")),
            Ok(Some(Event::Fault(f))) => return Err(format!("`{}`: {}", f.code, f.meaning)),
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => {
                return Err(format!("link failure: {reason}"));
            }
            Ok(Some(_)) => {}
            Ok(None) => return Err("the device task ended".into()),
            Err(_) => return Err("no answer from the controller".into()),
        }
    }
}
