//! Inputs and outputs of the simulated iMC-S8 (isel manual 2.2.3, 2.2.4,
//! `docs/decisions.md` isel 7) and the names the operator uses for the
//! inputs (`docs/simulator.md`, isel).
//!
//! What an output does to the inputs: the spindle output (port 2, or bit 4
//! of port 100) shows on input port 2 bit 0, the spindle's feedback. Every
//! other output drives something the inputs do not see.

use crate::proto::isel::{InputPort, OutputPort, PortBits};

/// Bits of control out (port 100) that the on/off ports 1, 2, 3, 5, 6 and
/// `@0g` are views of (manual 2.2.4).
pub const CURRENT_REDUCTION_BIT: u8 = 1 << 0;
pub const POWER_STAGES_BIT: u8 = 1 << 3;
pub const SPINDLE_BIT: u8 = 1 << 4;
pub const HOOD_ENABLE_BIT: u8 = 1 << 5;
pub const BRAKE_BIT: u8 = 1 << 6;

/// The tool-length probe on input port 1 (manual 2.2.3, "Längenmesstaster").
pub const PROBE_BIT: u8 = 1 << 5;

/// The input side, as the operator set it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Inputs {
    /// Port 0.
    pub user: u8,
    /// E-stop circuits 1 and 2: `true` = closed (healthy).
    pub estop: [bool; 2],
    pub overtemp: bool,
    pub start_key: bool,
    pub stop_key: bool,
    pub probe: bool,
    pub power_ok: bool,
    pub hood_closed: bool,
    /// On = setup mode (Einrichten), off = automatic.
    pub key_switch: bool,
}

impl Inputs {
    /// A healthy machine: circuits closed, power ok, hood closed, automatic.
    pub fn power_up() -> Inputs {
        Inputs {
            user: 0,
            estop: [true, true],
            overtemp: false,
            start_key: false,
            stop_key: false,
            probe: false,
            power_ok: true,
            hood_closed: true,
            key_switch: false,
        }
    }

    /// Port 1: E-stop circuits, over-temperature, start, stop, probe.
    pub fn port1(&self) -> u8 {
        u8::from(self.estop[0])
            | u8::from(self.estop[1]) << 1
            | u8::from(self.overtemp) << 2
            | u8::from(self.start_key) << 3
            | u8::from(self.stop_key) << 4
            | if self.probe { PROBE_BIT } else { 0 }
    }

    /// Port 2: spindle feedback, power ok, the two hood bits, key switch.
    /// Bit 5 is "hood closed and automatic", bit 6 "hood closed or setup".
    pub fn port2(&self, spindle: bool) -> u8 {
        u8::from(spindle)
            | u8::from(self.power_ok) << 1
            | u8::from(self.hood_closed && !self.key_switch) << 5
            | u8::from(self.hood_closed || self.key_switch) << 6
            | u8::from(self.key_switch) << 7
    }

    /// A circuit open, over-temperature or no power: motion answers `9`
    /// (isel manual chapter 5).
    pub fn machine_fault(&self) -> bool {
        !self.estop[0] || !self.estop[1] || self.overtemp || !self.power_ok
    }

    /// Motion is allowed with the hood closed, or open in setup mode
    /// (port 2 bit 6).
    pub fn motion_allowed(&self) -> bool {
        self.hood_closed || self.key_switch
    }
}

/// The output side.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outputs {
    /// Port 0.
    pub user: u8,
    /// Port 100; ports 1, 2, 3, 5, 6 are its bits.
    pub control: u8,
    /// Port 4.
    pub analog: u8,
    /// Port 101.
    pub signal: u8,
}

impl Outputs {
    /// Power stages enabled, everything else off.
    pub fn power_up() -> Outputs {
        Outputs {
            user: 0,
            control: POWER_STAGES_BIT,
            analog: 0,
            signal: 0,
        }
    }

    pub fn spindle(&self) -> bool {
        self.control & SPINDLE_BIT != 0
    }

    /// The bit of port 100 an on/off port is.
    fn switch_bit(port: OutputPort) -> Option<u8> {
        match port {
            OutputPort::HoodUnlock => Some(HOOD_ENABLE_BIT),
            OutputPort::Spindle => Some(SPINDLE_BIT),
            OutputPort::MotorCurrents => Some(POWER_STAGES_BIT),
            OutputPort::CurrentReduction => Some(CURRENT_REDUCTION_BIT),
            OutputPort::Brake => Some(BRAKE_BIT),
            OutputPort::User
            | OutputPort::Analog
            | OutputPort::ControlOut
            | OutputPort::SignalOut => None,
        }
    }

    /// The value a port holds, as `@0B` would write it.
    pub fn read(&self, port: OutputPort) -> u8 {
        match port {
            OutputPort::User => self.user,
            OutputPort::Analog => self.analog,
            OutputPort::ControlOut => self.control,
            OutputPort::SignalOut => self.signal,
            _ => Outputs::switch_bit(port).map_or(0, |bit| u8::from(self.control & bit != 0)),
        }
    }

    /// `@0B<port>,<value>`; the value was checked against the port.
    pub fn write(&mut self, port: OutputPort, value: u8) {
        match port {
            OutputPort::User => self.user = value,
            OutputPort::Analog => self.analog = value,
            OutputPort::ControlOut => self.control = value,
            OutputPort::SignalOut => self.signal = value,
            _ => {
                if let Some(bit) = Outputs::switch_bit(port) {
                    if value != 0 {
                        self.control |= bit;
                    } else {
                        self.control &= !bit;
                    }
                }
            }
        }
    }

    /// The value `port` takes when CNC `p` sets `bits` to `value`
    /// (manual 3.2.20); the line was checked.
    pub fn with_bits(&self, port: OutputPort, bits: PortBits, value: u8) -> u8 {
        match bits {
            PortBits::Byte => value,
            PortBits::Bit(_) if port.max_value() == 1 => value & 1,
            PortBits::Bit(b) => {
                let mask = 1u8.checked_shl(u32::from(b)).unwrap_or(0);
                if value != 0 {
                    self.read(port) | mask
                } else {
                    self.read(port) & !mask
                }
            }
        }
    }

    /// Whether writing `value` to `port` switches the spindle on.
    pub fn starts_spindle(&self, port: OutputPort, value: u8) -> bool {
        match port {
            OutputPort::Spindle => value != 0,
            OutputPort::ControlOut => value & SPINDLE_BIT != 0,
            _ => false,
        }
    }
}

/// A condition on an input port: `@0Z` (manual 2.2.30), CNC `6` and `o`
/// (3.2.7, 3.2.19). It holds when `port & mask == value`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PortCondition {
    pub port: InputPort,
    pub mask: u8,
    pub value: u8,
}

impl PortCondition {
    /// A single bit (`Bit(0..=7)`) compared with 0/1, or the whole byte.
    pub fn from_bits(port: InputPort, bits: PortBits, value: u8) -> PortCondition {
        match bits {
            PortBits::Byte => PortCondition {
                port,
                mask: 0xFF,
                value,
            },
            PortBits::Bit(b) => {
                let mask = 1u8.checked_shl(u32::from(b)).unwrap_or(0);
                PortCondition {
                    port,
                    mask,
                    value: if value != 0 { mask } else { 0 },
                }
            }
        }
    }

    pub fn met(&self, byte: u8) -> bool {
        byte & self.mask == self.value
    }
}

/// An input as the operator names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputName {
    /// `limit-x1` … `limit-a2`: axis 0-3, input 0 (switch 1) or 1 (switch 2).
    Limit {
        axis: usize,
        input: usize,
    },
    /// `estop1`, `estop2`.
    Estop(usize),
    Overtemp,
    Start,
    Stop,
    Probe,
    PowerOk,
    Hood,
    KeySwitch,
    /// `in0.0` … `in0.7`.
    User(u8),
}

/// Every input name, in the order `help` lists them.
pub const INPUT_NAMES: [&str; 25] = [
    "limit-x1",
    "limit-x2",
    "limit-y1",
    "limit-y2",
    "limit-z1",
    "limit-z2",
    "limit-a1",
    "limit-a2",
    "estop1",
    "estop2",
    "overtemp",
    "start",
    "stop",
    "probe",
    "power-ok",
    "hood",
    "key-switch",
    "in0.0",
    "in0.1",
    "in0.2",
    "in0.3",
    "in0.4",
    "in0.5",
    "in0.6",
    "in0.7",
];

/// The names `help` shows.
pub fn input_names() -> Vec<&'static str> {
    INPUT_NAMES.to_vec()
}

impl InputName {
    /// The input a name stands for, case-insensitively.
    pub fn parse(name: &str) -> Option<InputName> {
        let lower = name.to_ascii_lowercase();
        let index = INPUT_NAMES.iter().position(|n| *n == lower)?;
        Some(match index {
            0..=7 => InputName::Limit {
                axis: index / 2,
                input: index % 2,
            },
            8 | 9 => InputName::Estop(index - 8),
            10 => InputName::Overtemp,
            11 => InputName::Start,
            12 => InputName::Stop,
            13 => InputName::Probe,
            14 => InputName::PowerOk,
            15 => InputName::Hood,
            16 => InputName::KeySwitch,
            n => InputName::User(u8::try_from(n - 17).ok()?),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_parses_to_its_input() {
        for name in input_names() {
            assert!(InputName::parse(name).is_some(), "{name}");
        }
        assert_eq!(
            InputName::parse("LIMIT-Z2"),
            Some(InputName::Limit { axis: 2, input: 1 })
        );
        assert_eq!(InputName::parse("in0.7"), Some(InputName::User(7)));
        assert_eq!(InputName::parse("estop2"), Some(InputName::Estop(1)));
        assert_eq!(InputName::parse("door"), None);
    }

    #[test]
    fn port_bytes_follow_the_manuals_tables() {
        let mut i = Inputs::power_up();
        assert_eq!(i.port1(), 0b0000_0011);
        assert_eq!(i.port2(false), 0b0110_0010);
        assert_eq!(i.port2(true), 0b0110_0011);
        i.hood_closed = false;
        assert_eq!(i.port2(false), 0b0000_0010);
        assert!(!i.motion_allowed());
        i.key_switch = true;
        assert_eq!(i.port2(false), 0b1100_0010);
        assert!(i.motion_allowed());
        i.estop[1] = false;
        assert!(i.machine_fault());
    }

    #[test]
    fn on_off_ports_are_bits_of_control_out() {
        let mut o = Outputs::power_up();
        o.write(OutputPort::Spindle, 1);
        assert!(o.spindle());
        assert_eq!(
            o.read(OutputPort::ControlOut),
            SPINDLE_BIT | POWER_STAGES_BIT
        );
        o.write(OutputPort::ControlOut, BRAKE_BIT);
        assert_eq!(o.read(OutputPort::Brake), 1);
        assert_eq!(o.read(OutputPort::Spindle), 0);
        assert_eq!(o.with_bits(OutputPort::User, PortBits::Bit(3), 1), 0b1000);
        assert_eq!(o.with_bits(OutputPort::Brake, PortBits::Bit(0), 0), 0);
        assert!(o.starts_spindle(OutputPort::ControlOut, 0xFF));
        assert!(!o.starts_spindle(OutputPort::User, 0xFF));
    }

    #[test]
    fn port_conditions_compare_a_bit_or_the_byte() {
        let bit = PortCondition::from_bits(InputPort::User, PortBits::Bit(2), 1);
        assert!(bit.met(0b0100) && !bit.met(0b1011));
        let zero = PortCondition::from_bits(InputPort::User, PortBits::Bit(0), 0);
        assert!(zero.met(0b1110) && !zero.met(1));
        let byte = PortCondition::from_bits(InputPort::User, PortBits::Byte, 1);
        assert!(byte.met(1) && !byte.met(3));
    }
}
