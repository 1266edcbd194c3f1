//! `SetOutput`: `A<n>,<0|1>` (manual 1.5.15) as a batch of one, ended by
//! 0x01 so that it switches at once (decision 1). The outputs cannot be read
//! back: jogterm keeps what it switched.

use std::time::Duration;

use crate::device::api::{Activity, OutputId, Refusal};
use crate::device::common::limits::invalid;
use crate::proto::emcu::{Command, Output, Status};

use super::context::Context;
use super::run::Run;
use super::run_op::{Purpose, RunOp};

#[derive(Debug)]
pub struct Switch {
    output: Output,
    on: bool,
}

impl Switch {
    fn set(&self, cx: &mut Context, value: Option<bool>) {
        if let Some(cell) = cx
            .outputs
            .get_mut(usize::from(self.output.get().saturating_sub(1)))
        {
            *cell = value;
        }
    }
}

pub fn output_op(cx: &Context, id: OutputId, value: u8) -> Result<RunOp<Switch>, Refusal> {
    let output = Output::new(id.group).map_err(|_| {
        invalid(format!(
            "there is no output {}: the EMCU has A1 and A2 (groups 1 and 2)",
            id.group
        ))
    })?;
    if let Some(bit) = id.bit.filter(|b| *b != 0) {
        return Err(invalid(format!(
            "output A{output} is one on/off value, it has no bit {bit}"
        )));
    }
    let on = match value {
        0 => false,
        1 => true,
        other => return Err(invalid(format!("A{output} is 0 or 1, got {other}"))),
    };
    cx.memory_free()?;
    let run = Run::batch(
        cx,
        &[Command::SetOutput { output, on }],
        Some(Duration::ZERO),
    );
    Ok(RunOp::new(Switch { output, on }, run))
}

impl Purpose for Switch {
    fn text(&self) -> String {
        Command::SetOutput {
            output: self.output,
            on: self.on,
        }
        .to_string()
    }

    fn ended(&mut self, cx: &mut Context, _status: Status, _stopped: bool) {
        self.set(cx, Some(self.on));
    }

    fn unknown(&mut self, cx: &mut Context) {
        self.set(cx, None);
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
