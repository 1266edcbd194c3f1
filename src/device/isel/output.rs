//! `SetOutput`: `@0B<port>,<value>` (manual 2.2.4). Outputs cannot be read
//! back, so a single bit of a byte-wide port (0, 100, 101) can only be
//! changed once jogterm knows the whole byte (it wrote it).

use std::time::Instant;

use crate::device::api::{Activity, OutputId, Refusal};
use crate::device::common::limits::invalid;
use crate::proto::isel::{Command, OutputPort, Reply, ReplyCode};

use super::context::{Cmd, Context};
use super::io::output_ports_list;
use super::op::{Abandon, Next, Operation};

#[derive(Debug)]
pub struct OutputOp {
    port: OutputPort,
    value: u8,
    sent: bool,
    done: bool,
}

impl OutputOp {
    pub fn new(cx: &Context, output: OutputId, value: u8) -> Result<OutputOp, Refusal> {
        let port = u8::try_from(output.group)
            .ok()
            .and_then(|n| OutputPort::from_number(n.into()))
            .ok_or_else(|| {
                invalid(format!(
                    "there is no output port {}: expected one of {}",
                    output.group,
                    output_ports_list()
                ))
            })?;
        let byte = match output.bit {
            None => value,
            // An on/off port is its own bit 0.
            Some(0) if port.max_value() == 1 => value,
            Some(bit) if port.info().bits.is_empty() || bit > 7 => {
                return Err(invalid(format!(
                    "port {} ({}) has no bit {bit}",
                    port.number(),
                    port.info().name
                )));
            }
            Some(bit) => {
                if value > 1 {
                    return Err(invalid(format!("a single bit is 0 or 1, got {value}")));
                }
                let current = cx.ports.output(port).ok_or_else(|| {
                    invalid(format!(
                        "the other bits of port {} are unknown (outputs cannot be read back): \
                         set the whole byte first",
                        port.number()
                    ))
                })?;
                if value == 1 {
                    current | (1 << bit)
                } else {
                    current & !(1 << bit)
                }
            }
        };
        if byte > port.max_value() {
            return Err(invalid(format!(
                "port {} ({}) takes 0-{}, got {byte}",
                port.number(),
                port.info().name,
                port.max_value()
            )));
        }
        Ok(OutputOp {
            port,
            value: byte,
            sent: false,
            done: false,
        })
    }

    fn cmd(&self, cx: &Context) -> Cmd {
        cx.cmd(Command::WritePort {
            port: self.port,
            value: self.value,
        })
    }
}

impl Operation for OutputOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if self.done || self.sent {
            return Next::Done;
        }
        self.sent = true;
        Next::Send(self.cmd(cx))
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        let text = self.cmd(cx).text;
        match reply {
            Reply::Code(ReplyCode::Ok) => {
                cx.ports.set_output(self.port, self.value);
                cx.emit_io(now);
            }
            Reply::Code(code) => {
                cx.controller_error(&text, code);
            }
            other => {
                cx.link_suspect(&text, &format!("{other:?}"));
            }
        }
        self.done = true;
    }

    fn lost_reply(&mut self, _cx: &mut Context, _now: Instant) {
        self.done = true;
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.done = true;
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
