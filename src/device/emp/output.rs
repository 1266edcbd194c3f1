//! Outputs O1-O4 of a drive (`42 DS 01`, manual "42", decision 5). No
//! command reads them back, so the driver keeps what it wrote; a single
//! output switched before anything was written sends the other three off
//! (docs/protocols.md, EMP).

use std::time::Instant;

use crate::device::api::{Activity, OutputId, Refusal};
use crate::device::common::limits::invalid;
use crate::proto::emp::{Command, DriveAddress, Outputs, Reply, Request};

use super::context::Context;
use super::op::Operation;
use super::script::{Next, Outcome, Script};

pub use super::drive::output_id;

/// The frame that sets `output` to `value`: one output (bit 0-3) to on or
/// off, or with `bit: None` all four from the low nibble of `value`.
pub fn output_request(cx: &Context, output: OutputId, value: u8) -> Result<Request, Refusal> {
    let d = cx
        .drives
        .get(usize::from(output.group))
        .ok_or_else(|| invalid(format!("no drive number {} on this link", output.group)))?;
    let now = d.outputs.unwrap_or(Outputs::NONE);
    let outputs = match output.bit {
        None if value <= 0x0F => Outputs::from_bits(value),
        None => return Err(invalid(format!("outputs O1-O4 take 0-15, not {value}"))),
        Some(n) if n < 4 => now.with(n + 1, value != 0),
        Some(n) => {
            return Err(invalid(format!(
                "a drive has outputs O1-O4, not O{}",
                n + 1
            )));
        }
    };
    Ok(Request::new(d.ds, Command::WriteOutputs(outputs)))
}

/// An output's frame is a script and nothing more: it runs as one.
impl Operation for Script {
    fn next(&mut self, _cx: &mut Context, _now: Instant) -> Next {
        Script::next(self)
    }

    fn outcome(
        &mut self,
        _cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        _reply: Option<&Reply>,
        _now: Instant,
    ) {
        Script::outcome(self, request, outcome);
    }

    fn owns(&self, request: &Request) -> bool {
        Script::owns(self, request)
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[DriveAddress]) {
        self.cancel();
    }
}
