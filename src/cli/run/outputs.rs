//! The job's outputs after it ended early (issue 37): a stop, a controller
//! error or a signal switches the spindle and the outputs the job switched
//! on off once the axes stand, and says so; a lost line can send nothing
//! and says they may still be on (`program::outputs`).

use std::time::Duration;

use super::super::out;
use super::super::session::{EXIT_LINK, Session};
use super::super::upload::Remedy;
use crate::device::api::{Activity, Event, LinkState, Request};
use crate::program::outputs::{
    Ended, JobOutput, STAND_WITHIN, left_on_text, link_lost_text, not_standing_text, still_on_text,
    switched_off_text,
};

/// How a job's exit status says it ended, for its outputs: `None` when it
/// ran to its end or never started for bad usage.
pub(in crate::cli) fn ended_by(code: u8) -> Option<Ended> {
    match code {
        1 => Some(Ended::Early),
        EXIT_LINK => Some(Ended::LinkLost),
        _ => None,
    }
}

/// How long an output's answer may take.
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
            "jogterm {command}: {}",
            link_lost_text(outputs)
        ));
        return;
    }
    if !stands(session).await {
        out::say(format_args!(
            "jogterm {command}: {}",
            not_standing_text(outputs)
        ));
        return;
    }
    let mut off = Vec::new();
    for o in outputs {
        if let Some(why) = &o.left {
            let how = format!(
                "switch it off with `{} @0B{},<value>`",
                remedy.send, o.id.group
            );
            out::say(format_args!(
                "jogterm {command}: {}",
                left_on_text(o, why, &how)
            ));
            continue;
        }
        match switch_off(session, o).await {
            Ok(()) => off.push(o),
            Err(why) => out::say(format_args!(
                "jogterm {command}: {}",
                still_on_text(o, &why)
            )),
        }
    }
    if !off.is_empty() {
        out::say(format_args!(
            "jogterm {command}: {}",
            switched_off_text(off)
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
