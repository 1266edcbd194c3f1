//! `jogterm ports`: the serial ports of this machine, with their stable
//! `/dev/serial/by-id` names, what sysfs says about the adapter, and who has
//! each one now (`transport::list_ports`).

use std::process::ExitCode;

use clap::Args;

use super::out::{self, StdoutError};
use crate::transport::{PortInfo, PortUse, list_ports};

pub const LONG_ABOUT: &str = "\
List the serial ports of this machine: each device, its /dev/serial/by-id names, the USB
vendor and product where sysfs has them, and whether a process has it now (a UUCP lock
file in /run/lock, an flock, or an open file descriptor this user can see).

Give --port (and a profile's connection.port) the by-id name: it stays the same when the
adapter is plugged into another socket or a second adapter comes, where /dev/ttyUSB0 does
not. A controller on a serial port server is reached with --port tcp://HOST:PORT (raw) or
rfc2217://HOST:PORT (docs/network.md); such ports are not listed here.";

pub const AFTER_LONG_HELP: &str = "\
Examples:
  jogterm ports                 one block per port
  jogterm ports --json          one JSON object per port and line

Exit status: 0 (also when there are no ports), 1 when sysfs cannot be read.";

/// Options of `jogterm ports`.
#[derive(Debug, Args)]
pub struct PortsArgs {
    /// One JSON object per port and line: {\"path\", \"by_id\": [...], \"description\",
    /// \"in_use\": null or who}
    #[arg(long)]
    pub json: bool,
}

/// Run `jogterm ports`.
pub fn run(args: &PortsArgs) -> anyhow::Result<ExitCode> {
    let ports = list_ports()?;
    if ports.is_empty() {
        out::say("jogterm ports: no serial ports on this machine (sysfs lists none)");
        return Ok(ExitCode::SUCCESS);
    }
    for port in &ports {
        let text = if args.json { json(port) } else { block(port) };
        match out::line(text) {
            Ok(()) => {}
            Err(StdoutError::Closed) => return Ok(ExitCode::SUCCESS),
            Err(e) => return Err(e.into()),
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// `/dev/ttyUSB0  USB 0403:6001 FTDI …  free`, then one line per by-id name.
fn block(port: &PortInfo) -> String {
    let mut text = format!("{}  {}  {}", port.path, port.description, port.in_use);
    if port.by_id.is_empty() {
        text.push_str("\n  (no /dev/serial/by-id name)");
    }
    for name in &port.by_id {
        text.push_str("\n  ");
        text.push_str(name);
    }
    text
}

fn json(port: &PortInfo) -> String {
    let in_use = match &port.in_use {
        PortUse::Free => serde_json::Value::Null,
        PortUse::Held(who) => serde_json::Value::String(who.clone()),
    };
    serde_json::json!({
        "path": port.path,
        "by_id": port.by_id,
        "description": port.description,
        "in_use": in_use,
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ftdi(in_use: PortUse) -> PortInfo {
        PortInfo {
            path: "/dev/ttyUSB0".into(),
            description: "USB 0403:6001 FTDI FT232R USB UART (serial A12345)".into(),
            by_id: vec!["/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0".into()],
            in_use,
        }
    }

    #[test]
    fn a_port_is_one_block_with_its_by_id_names() {
        assert_eq!(
            block(&ftdi(PortUse::Free)),
            "/dev/ttyUSB0  USB 0403:6001 FTDI FT232R USB UART (serial A12345)  free\n  \
             /dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0"
        );
        let mut bare = ftdi(PortUse::Held(
            "held by ser2net (pid 812, lock file /run/lock/LCK..ttyS0)".into(),
        ));
        bare.path = "/dev/ttyS0".into();
        bare.description = "PCI".into();
        bare.by_id.clear();
        assert_eq!(
            block(&bare),
            "/dev/ttyS0  PCI  held by ser2net (pid 812, lock file /run/lock/LCK..ttyS0)\n  \
             (no /dev/serial/by-id name)"
        );
    }

    #[test]
    fn json_has_a_null_or_the_holder() {
        let v: serde_json::Value = serde_json::from_str(&json(&ftdi(PortUse::Free))).expect("json");
        assert_eq!(v["in_use"], serde_json::Value::Null);
        assert_eq!(
            v["by_id"][0],
            "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A12345-if00-port0"
        );
        let v: serde_json::Value =
            serde_json::from_str(&json(&ftdi(PortUse::Held("held by x (pid 1)".into()))))
                .expect("json");
        assert_eq!(v["in_use"], "held by x (pid 1)");
    }
}
