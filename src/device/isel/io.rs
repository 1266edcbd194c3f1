//! Port bytes as [`IoSnapshot`]s, every bit under the profile's name
//! (`crate::wiring`, defaults from the core's port tables,
//! `proto::isel::ports`, manual 2.2.3 and 2.2.4).
//!
//! The controller cannot read its outputs back, so output groups show what
//! jogterm last wrote (`raw: None` until it wrote one). What jogterm knows
//! of them (`docs/protocols.md`, isel): the byte of its own last `@0B` to
//! the port, menu or typed, that the controller answered `0`; nothing after
//! a reset (0xFE), a new connection, a stored program run (CNC `p` and
//! `@0Ia` write ports, manual 3.2.20, 4.2.12) or a machine fault (the
//! controller switches the spindle off, 2.2.4). An axis setting (`@07`)
//! leaves the outputs alone.

use std::collections::BTreeMap;
use std::time::Instant;

use crate::device::api::{InputSource, IoGroup, IoSnapshot, OutputId};
use crate::device::common::io;
use crate::proto::isel::ports::{InputRole, OUTPUT_PORTS};
use crate::proto::isel::{InputPort, OutputPort};
use crate::wiring::{BitWiring, Role, Wiring, isel_input_address, isel_output_address};

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

    /// Every output's value is unknown from now on.
    pub fn forget_outputs(&mut self) {
        self.outputs.clear();
    }

    /// A machine fault switched the spindle off (manual 2.2.4): port 2 and
    /// port 100, whose bit 4 it is, are unknown from now on.
    pub fn forget_spindle(&mut self) {
        self.outputs.remove(&OutputPort::Spindle.number());
        self.outputs.remove(&OutputPort::ControlOut.number());
    }

    /// Inputs that have been read, then every output port.
    pub fn snapshot(&self, at: Instant, wiring: &Wiring) -> IoSnapshot {
        let mut groups: Vec<IoGroup> = InputPort::ALL
            .into_iter()
            .filter_map(|p| {
                self.input(p).map(|v| {
                    input_group(p, v, wiring)
                        .read_from(InputSource::IselPort(p.number()), self.read_at(p))
                })
            })
            .collect();
        groups.extend(
            OutputPort::ALL
                .into_iter()
                .map(|p| output_group(p, self.output(p), wiring)),
        );
        IoSnapshot { at, groups }
    }

    /// Every input bit of the ports read so far, with its wiring and its
    /// level as read.
    pub fn read_inputs<'w>(&self, wiring: &'w Wiring) -> Vec<(&'w BitWiring, bool)> {
        InputPort::ALL
            .into_iter()
            .filter_map(|p| self.input(p).map(|v| (p, v)))
            .flat_map(|(port, value)| {
                (0..8u8).filter_map(move |bit| {
                    let w = wiring.bit(&isel_input_address(port, bit))?;
                    Some((w, value & (1 << bit) != 0))
                })
            })
            .collect()
    }

    /// The wired input bits that read active: the bits of every port read
    /// so far.
    pub fn active_inputs<'w>(&self, wiring: &'w Wiring) -> Vec<&'w BitWiring> {
        self.read_inputs(wiring)
            .into_iter()
            .filter(|(w, level)| w.wired && w.is_active(*level))
            .map(|(w, _)| w)
            .collect()
    }

    /// The wired hood inputs of the ports read so far and whether each is
    /// active (hood open).
    pub fn hood_inputs<'w>(&self, wiring: &'w Wiring) -> Vec<(&'w BitWiring, bool)> {
        self.read_inputs(wiring)
            .into_iter()
            .filter(|(w, _)| w.wired && w.role == Role::Hood)
            .map(|(w, level)| (w, w.is_active(level)))
            .collect()
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

/// An input port's byte with every bit under the profile's name.
pub fn input_group(port: InputPort, raw: u8, wiring: &Wiring) -> IoGroup {
    let bits = port
        .bits()
        .iter()
        .map(|b| {
            io::input_at(
                wiring,
                &isel_input_address(port, b.bit),
                b.name,
                raw & (1 << b.bit) != 0,
            )
        })
        .collect();
    io::group(port_title(port), Some(raw), bits)
}

/// An output port: on/off ports and the analog port are one switchable
/// value (`OutputId { bit: None }`), ports 0, 100, 101 have named bits.
pub fn output_group(port: OutputPort, written: Option<u8>, wiring: &Wiring) -> IoGroup {
    let info = port.info();
    let group = u16::from(port.number());
    let value = written.unwrap_or(0);
    let bits = if info.bits.is_empty() {
        vec![io::output_at(
            wiring,
            &isel_output_address(port, None),
            info.name,
            value != 0,
            OutputId { group, bit: None },
            info.hazard.is_some(),
        )]
    } else {
        info.bits
            .iter()
            .map(|b| {
                io::output_at(
                    wiring,
                    &isel_output_address(port, Some(b.bit)),
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

/// The names of the set bits of an input byte, for `jogterm send` and the
/// traffic console: the profile's names, unwired bits marked.
pub fn describe_input(port: InputPort, raw: u8, wiring: &Wiring) -> String {
    let set: Vec<String> = port
        .bits()
        .iter()
        .filter(|b| raw & (1 << b.bit) != 0)
        .filter_map(|b| match wiring.bit(&isel_input_address(port, b.bit)) {
            Some(w) if w.role == Role::Unused => None,
            Some(w) if !w.wired => Some(format!("{} (not wired)", w.name)),
            Some(w) => Some(w.name.clone()),
            None if b.role == InputRole::NotUsed => None,
            None => Some(b.name.to_owned()),
        })
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
    use std::collections::BTreeMap;

    use super::*;
    use crate::axis::AxisSet;
    use crate::proto::Protocol;
    use crate::wiring::{BitPatch, Side};

    fn defaults() -> Wiring {
        Wiring::defaults(Protocol::Isel, AxisSet::XYZ, &[])
    }

    #[test]
    fn input_bits_are_named_from_the_table() {
        let w = defaults();
        let g = input_group(InputPort::Status1, 0b0000_0011, &w);
        assert_eq!(g.raw, Some(3));
        assert_eq!(g.bits.len(), 8);
        assert_eq!(g.bits[0].name, "E-stop circuit 1");
        assert!(g.bits[0].value && g.bits[1].value && !g.bits[2].value);
        assert!(g.bits.iter().all(|b| b.output.is_none()));
        assert_eq!(
            describe_input(InputPort::LimitSwitches, 0b0001_0001, &w),
            "limit X1, limit Z1"
        );
        assert_eq!(describe_input(InputPort::Status1, 0xC0, &w), "no input set");
        // The hood bits of a machine without a hood read 0; set ones are
        // named as not wired.
        assert_eq!(
            describe_input(InputPort::Status2, 0x62, &w),
            "power ok (not wired), hood closed + automatic (not wired), \
             hood closed or setup (not wired)"
        );
    }

    #[test]
    fn the_profiles_names_and_roles_reach_the_groups() {
        let patches: BTreeMap<String, BitPatch> = toml::from_str(
            r#"
            "in0.3" = { name = "tool setter", role = "probe" }
            "in3.0" = { name = "X home" }
            "out0.1" = { name = "coolant" }
            "#,
        )
        .expect("patches");
        let (w, problems) = defaults().patched(&patches, AxisSet::XYZ);
        assert!(problems.is_empty());
        let user = input_group(InputPort::User, 0b1000, &w);
        assert_eq!(user.bits[3].name, "tool setter");
        assert!(user.bits[3].active());
        let limits = input_group(InputPort::LimitSwitches, 0b01, &w);
        let image = IoSnapshot {
            at: Instant::now(),
            groups: vec![limits],
        };
        let active = image.active_limits();
        assert_eq!(active.len(), 1);
        assert_eq!(
            (active[0].axis, active[0].side, active[0].name.as_str()),
            (crate::axis::Axis::X, Side::Min, "X home")
        );
        assert_eq!(active[0].away(), crate::device::api::Dir::Plus);
        assert_eq!(describe_input(InputPort::LimitSwitches, 1, &w), "X home");
        let out = output_group(OutputPort::User, Some(2), &w);
        assert_eq!(out.bits[1].name, "coolant");
        assert!(out.bits[1].value);
    }

    #[test]
    fn outputs_carry_ids_and_hazards() {
        let w = defaults();
        let spindle = output_group(OutputPort::Spindle, Some(1), &w);
        assert_eq!(spindle.bits.len(), 1);
        assert_eq!(
            spindle.bits[0].output,
            Some(OutputId {
                group: 2,
                bit: None
            })
        );
        assert!(spindle.bits[0].hazardous && spindle.bits[0].value);
        let lamps = output_group(OutputPort::SignalOut, None, &w);
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
        let user = output_group(OutputPort::User, Some(0x80), &w);
        assert!(user.bits[7].value && user.bits[7].hazardous);
    }

    #[test]
    fn only_wired_inputs_are_active_inputs() {
        let w = defaults();
        let mut image = PortImage::default();
        // E-stop circuit 2 open; hood open (port 2 = 02): only the E-stop
        // counts, the hood is not declared wired.
        let t = Instant::now();
        image.set_input(InputPort::Status1, 0b01, t);
        image.set_input(InputPort::Status2, 0x02, t);
        let active: Vec<&str> = image
            .active_inputs(&w)
            .iter()
            .map(|b| b.address.as_str())
            .collect();
        assert_eq!(active, ["in1.1"]);
        assert!(image.hood_inputs(&w).is_empty());
        let snap = image.snapshot(t + std::time::Duration::from_millis(5), &w);
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
                    source: InputSource::IselPort(2),
                    at: t
                })
            ]
        );
        assert!(read[2..].iter().all(Option::is_none));
    }
}
