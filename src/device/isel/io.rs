//! Port bytes as [`IoSnapshot`]s, every bit named from the core's port
//! tables (`proto::isel::ports`, manual 2.2.3 and 2.2.4), and what the
//! safety bits mean for the machine state.
//!
//! The controller cannot read its outputs back, so output groups show what
//! jogterm last wrote (`raw: None` until it wrote one).

use std::collections::BTreeMap;
use std::time::Instant;

use crate::device::api::{InputSource, IoGroup, IoSnapshot, OutputId};
use crate::device::common::io;
use crate::proto::isel::ports::{InputRole, OUTPUT_PORTS};
use crate::proto::isel::{InputPort, OutputPort};

/// What jogterm knows about the ports: the last byte read from each input
/// port and the last value written to each output port.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PortImage {
    pub inputs: [Option<u8>; 4],
    /// When each input port's reply arrived, for the input recorder.
    pub read_at: [Option<Instant>; 4],
    pub outputs: BTreeMap<u8, u8>,
}

impl PortImage {
    pub fn input(&self, port: InputPort) -> Option<u8> {
        self.inputs
            .get(usize::from(port.number()))
            .copied()
            .flatten()
    }

    /// The port's byte as read at `at` (when its reply arrived).
    pub fn set_input(&mut self, port: InputPort, value: u8, at: Instant) {
        let i = usize::from(port.number());
        if let (Some(slot), Some(read)) = (self.inputs.get_mut(i), self.read_at.get_mut(i)) {
            *slot = Some(value);
            *read = Some(at);
        }
    }

    fn read_at(&self, port: InputPort) -> Option<Instant> {
        self.read_at
            .get(usize::from(port.number()))
            .copied()
            .flatten()
    }

    pub fn output(&self, port: OutputPort) -> Option<u8> {
        self.outputs.get(&port.number()).copied()
    }

    pub fn set_output(&mut self, port: OutputPort, value: u8) {
        self.outputs.insert(port.number(), value);
    }

    /// Inputs that have been read, then every output port.
    pub fn snapshot(&self, at: Instant) -> IoSnapshot {
        let mut groups: Vec<IoGroup> = InputPort::ALL
            .into_iter()
            .filter_map(|p| {
                self.input(p).map(|v| {
                    input_group(p, v).read_from(InputSource::IselPort(p.number()), self.read_at(p))
                })
            })
            .collect();
        groups.extend(
            OutputPort::ALL
                .into_iter()
                .map(|p| output_group(p, self.output(p))),
        );
        IoSnapshot { at, groups }
    }

    /// Port 1 bits 0 and 1 read 1 while the E-stop circuits are closed
    /// (manual 2.2.3, `../shared/protocols.md` isel 7); `None` until read.
    pub fn estop(&self) -> Option<bool> {
        self.input(InputPort::Status1).map(|v| v & 0b11 != 0b11)
    }

    /// Any limit switch of port 3 active.
    pub fn limit(&self) -> Option<bool> {
        self.input(InputPort::LimitSwitches).map(|v| v != 0)
    }
}

fn port_title(port: InputPort) -> &'static str {
    match port {
        InputPort::User => "in 0: user inputs",
        InputPort::Status1 => "in 1: safety and keys",
        InputPort::Status2 => "in 2: spindle, power, hood",
        InputPort::LimitSwitches => "in 3: limit switches",
    }
}

/// An input port's byte with every bit named.
pub fn input_group(port: InputPort, raw: u8) -> IoGroup {
    let bits = port
        .bits()
        .iter()
        .map(|b| io::input(b.name, raw & (1 << b.bit) != 0))
        .collect();
    io::group(port_title(port), Some(raw), bits)
}

/// An output port: on/off ports and the analog port are one switchable
/// value (`OutputId { bit: None }`), ports 0, 100, 101 have named bits.
pub fn output_group(port: OutputPort, written: Option<u8>) -> IoGroup {
    let info = port.info();
    let group = u16::from(port.number());
    let value = written.unwrap_or(0);
    let bits = if info.bits.is_empty() {
        vec![io::output(
            info.name,
            value != 0,
            OutputId { group, bit: None },
            info.hazard.is_some(),
        )]
    } else {
        info.bits
            .iter()
            .map(|b| {
                io::output(
                    b.name,
                    value & (1 << b.bit) != 0,
                    OutputId {
                        group,
                        bit: Some(b.bit),
                    },
                    b.hazard.is_some() || (info.hazard.is_some() && b.name != "not used"),
                )
            })
            .collect()
    };
    io::group(
        format!("out {}: {}", port.number(), info.name),
        written,
        bits,
    )
}

/// The names of the set bits of an input byte, for `jogterm send`.
pub fn describe_input(port: InputPort, raw: u8) -> String {
    let set: Vec<&str> = port
        .bits()
        .iter()
        .filter(|b| raw & (1 << b.bit) != 0 && b.role != InputRole::NotUsed)
        .map(|b| b.name)
        .collect();
    if set.is_empty() {
        "no input set".to_owned()
    } else {
        set.join(", ")
    }
}

/// Every output port, for error messages.
pub fn output_ports_list() -> String {
    OUTPUT_PORTS
        .iter()
        .map(|p| format!("{} ({})", p.port.number(), p.name))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_bits_are_named_from_the_table() {
        let g = input_group(InputPort::Status1, 0b0000_0011);
        assert_eq!(g.raw, Some(3));
        assert_eq!(g.bits.len(), 8);
        assert_eq!(g.bits[0].name, "E-stop circuit 1");
        assert!(g.bits[0].value && g.bits[1].value && !g.bits[2].value);
        assert!(g.bits.iter().all(|b| b.output.is_none()));
        assert_eq!(
            describe_input(InputPort::LimitSwitches, 0b0001_0001),
            "limit X1, limit Z1"
        );
        assert_eq!(describe_input(InputPort::Status1, 0xC0), "no input set");
    }

    #[test]
    fn outputs_carry_ids_and_hazards() {
        let spindle = output_group(OutputPort::Spindle, Some(1));
        assert_eq!(spindle.bits.len(), 1);
        assert_eq!(
            spindle.bits[0].output,
            Some(OutputId {
                group: 2,
                bit: None
            })
        );
        assert!(spindle.bits[0].hazardous && spindle.bits[0].value);
        let lamps = output_group(OutputPort::SignalOut, None);
        assert_eq!(lamps.raw, None);
        assert_eq!(lamps.bits[7].name, "error lamp");
        assert!(!lamps.bits[7].hazardous);
        assert_eq!(
            lamps.bits[7].output,
            Some(OutputId {
                group: 101,
                bit: Some(7)
            })
        );
        let user = output_group(OutputPort::User, Some(0x80));
        assert!(user.bits[7].value && user.bits[7].hazardous);
    }

    #[test]
    fn safety_bits_become_flags() {
        let mut image = PortImage::default();
        let t = Instant::now();
        assert_eq!(image.estop(), None);
        image.set_input(InputPort::Status1, 0b01, t);
        assert_eq!(image.estop(), Some(true));
        image.set_input(InputPort::Status1, 0b11, t);
        assert_eq!(image.estop(), Some(false));
        image.set_input(InputPort::LimitSwitches, 0, t);
        assert_eq!(image.limit(), Some(false));
        let snap = image.snapshot(t + std::time::Duration::from_millis(5));
        assert_eq!(snap.groups.len(), 2 + OutputPort::ALL.len());
        // Inputs say when they were read, outputs are never read.
        let read: Vec<_> = snap.groups.iter().map(|g| g.read).collect();
        assert_eq!(
            read[..2],
            [
                Some(crate::device::api::InputRead {
                    source: InputSource::IselPort(1),
                    at: t
                }),
                Some(crate::device::api::InputRead {
                    source: InputSource::IselPort(3),
                    at: t
                })
            ]
        );
        assert!(read[2..].iter().all(Option::is_none));
    }
}
