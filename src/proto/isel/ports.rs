//! Input and output ports of the iMC controllers as data: every input bit of
//! ports 0–3 (`@0b`, isel manual 2.2.3, `docs/decisions.md` isel 7), every
//! output port (`@0B`, manual 2.2.4) with a flag for outputs that move or
//! energise something, the bits of `@0DRp`/`@0DRn` (manual 2.2.6) and the
//! limit switch coding of `@0IE` (manual 4.2.6). The UI renders its panels
//! from these tables; the simulator names its inputs after them.

use std::fmt;

use crate::axis::{Axis, AxisSet};

/// The readable ports (`@0b<n>`, CNC `6` and `o`, `@0Z`, `@0IA/IH/IN`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum InputPort {
    /// Port 0: the user inputs.
    User,
    /// Port 1: E-stop circuits, over-temperature, start/stop keys, probe.
    Status1,
    /// Port 2: spindle, power ok, hood, key switch.
    Status2,
    /// Port 3: the limit switches X1 … A2.
    LimitSwitches,
}

impl InputPort {
    pub const ALL: [InputPort; 4] = [
        InputPort::User,
        InputPort::Status1,
        InputPort::Status2,
        InputPort::LimitSwitches,
    ];

    pub fn number(self) -> u8 {
        self as u8
    }

    pub fn from_number(number: u64) -> Option<InputPort> {
        usize::try_from(number)
            .ok()
            .and_then(|n| InputPort::ALL.get(n))
            .copied()
    }

    /// The eight bits of this port, bit 0 first.
    pub fn bits(self) -> &'static [InputBit] {
        let start = self as usize * 8;
        INPUT_BITS.get(start..start + 8).unwrap_or(&[])
    }
}

impl fmt::Display for InputPort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// The writable ports (`@0B<n>,<v>`, CNC `p`, `@0Ia`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum OutputPort {
    /// Port 0: the user outputs, 0–255.
    User,
    /// Port 1: 1 = the hood may be opened.
    HoodUnlock,
    /// Port 2: 1 = spindle on.
    Spindle,
    /// Port 3: 1 = motor currents on.
    MotorCurrents,
    /// Port 4: analog output 0–10 V as 0–255.
    Analog,
    /// Port 5: 1 = current reduction on.
    CurrentReduction,
    /// Port 6: 1 = brake energised (released).
    Brake,
    /// Port 100: control out, reserved for isel software.
    ControlOut,
    /// Port 101: signal out (lamps), reserved for isel software.
    SignalOut,
}

impl OutputPort {
    pub const ALL: [OutputPort; 9] = [
        OutputPort::User,
        OutputPort::HoodUnlock,
        OutputPort::Spindle,
        OutputPort::MotorCurrents,
        OutputPort::Analog,
        OutputPort::CurrentReduction,
        OutputPort::Brake,
        OutputPort::ControlOut,
        OutputPort::SignalOut,
    ];

    pub fn number(self) -> u8 {
        match self {
            OutputPort::User => 0,
            OutputPort::HoodUnlock => 1,
            OutputPort::Spindle => 2,
            OutputPort::MotorCurrents => 3,
            OutputPort::Analog => 4,
            OutputPort::CurrentReduction => 5,
            OutputPort::Brake => 6,
            OutputPort::ControlOut => 100,
            OutputPort::SignalOut => 101,
        }
    }

    pub fn from_number(number: u64) -> Option<OutputPort> {
        OutputPort::ALL
            .into_iter()
            .find(|p| u64::from(p.number()) == number)
    }

    /// Largest value `@0B` accepts: 1 for the on/off ports, 255 for the
    /// byte-wide ones (isel manual 2.2.4).
    pub fn max_value(self) -> u8 {
        match self.info().values {
            OutputValues::Switch { .. } => 1,
            OutputValues::Byte { .. } => 255,
        }
    }

    pub fn info(self) -> &'static OutputPortInfo {
        // The table holds every port exactly once, in declaration order, so
        // the discriminant (0..=8) is always a valid index.
        &OUTPUT_PORTS[self as usize]
    }
}

impl fmt::Display for OutputPort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// What a port-bit operand of CNC `6`, `o` and `p` selects: one bit or the
/// whole byte (`128`). `Bit` holds the bit index 0–7; CNC `6` writes it as
/// 1–8 on the wire, `o` and `p` as 0–7 (`docs/decisions.md` isel 11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PortBits {
    Bit(u8),
    Byte,
}

impl PortBits {
    /// The wire value for the byte-wide selection.
    pub const BYTE_VALUE: u8 = 128;

    /// Largest comparison or output value this selection allows.
    pub fn max_value(self) -> u8 {
        match self {
            PortBits::Bit(_) => 1,
            PortBits::Byte => 255,
        }
    }
}

/// What an input bit is for, so a UI can group, colour and explain it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputRole {
    User,
    EmergencyStopCircuit,
    OverTemperature,
    StartKey,
    StopKey,
    ToolLengthProbe,
    Spindle,
    PowerOk,
    Hood,
    KeySwitch,
    /// Limit switch `1` or `2` of an axis (X1 … A2).
    LimitSwitch {
        axis: Axis,
        switch: u8,
    },
    NotUsed,
}

/// One bit of an input port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputBit {
    pub port: InputPort,
    pub bit: u8,
    /// Short name for a panel.
    pub name: &'static str,
    pub role: InputRole,
    /// What a 1 means; inputs are active-high as read.
    pub when_set: &'static str,
    /// The level that means "all is well" for safety-relevant inputs
    /// (E-stop circuits, temperature, power, limit switches), so a UI can
    /// show a fault; `None` where neither level is a fault.
    pub ok_level: Option<bool>,
}

const fn user_in(bit: u8, name: &'static str) -> InputBit {
    InputBit {
        port: InputPort::User,
        bit,
        name,
        role: InputRole::User,
        when_set: "input high",
        ok_level: None,
    }
}

const fn unused_in(port: InputPort, bit: u8) -> InputBit {
    InputBit {
        port,
        bit,
        name: "not used",
        role: InputRole::NotUsed,
        when_set: "-",
        ok_level: None,
    }
}

const fn limit_in(bit: u8, name: &'static str, axis: Axis, switch: u8) -> InputBit {
    InputBit {
        port: InputPort::LimitSwitches,
        bit,
        name,
        role: InputRole::LimitSwitch { axis, switch },
        when_set: "limit switch active",
        ok_level: Some(false),
    }
}

/// Every bit of input ports 0–3, port by port, bit 0 first
/// (isel manual 2.2.3 and 3.2.19, `docs/decisions.md` isel 7).
pub const INPUT_BITS: [InputBit; 32] = [
    user_in(0, "user input 0"),
    user_in(1, "user input 1"),
    user_in(2, "user input 2"),
    user_in(3, "user input 3"),
    user_in(4, "user input 4"),
    user_in(5, "user input 5"),
    user_in(6, "user input 6"),
    user_in(7, "user input 7"),
    InputBit {
        port: InputPort::Status1,
        bit: 0,
        name: "E-stop circuit 1",
        role: InputRole::EmergencyStopCircuit,
        when_set: "circuit closed (ok)",
        ok_level: Some(true),
    },
    InputBit {
        port: InputPort::Status1,
        bit: 1,
        name: "E-stop circuit 2",
        role: InputRole::EmergencyStopCircuit,
        when_set: "circuit closed (ok)",
        ok_level: Some(true),
    },
    InputBit {
        port: InputPort::Status1,
        bit: 2,
        name: "over-temperature",
        role: InputRole::OverTemperature,
        when_set: "power stages over temperature",
        ok_level: Some(false),
    },
    InputBit {
        port: InputPort::Status1,
        bit: 3,
        name: "start key",
        role: InputRole::StartKey,
        when_set: "pressed",
        ok_level: None,
    },
    InputBit {
        port: InputPort::Status1,
        bit: 4,
        name: "stop key",
        role: InputRole::StopKey,
        when_set: "pressed",
        ok_level: None,
    },
    InputBit {
        port: InputPort::Status1,
        bit: 5,
        name: "tool-length probe",
        role: InputRole::ToolLengthProbe,
        when_set: "probe touched",
        ok_level: None,
    },
    unused_in(InputPort::Status1, 6),
    unused_in(InputPort::Status1, 7),
    InputBit {
        port: InputPort::Status2,
        bit: 0,
        name: "spindle",
        role: InputRole::Spindle,
        when_set: "spindle on",
        ok_level: None,
    },
    InputBit {
        port: InputPort::Status2,
        bit: 1,
        name: "power ok",
        role: InputRole::PowerOk,
        when_set: "power supply ok",
        ok_level: Some(true),
    },
    unused_in(InputPort::Status2, 2),
    unused_in(InputPort::Status2, 3),
    unused_in(InputPort::Status2, 4),
    InputBit {
        port: InputPort::Status2,
        bit: 5,
        name: "hood closed + automatic",
        role: InputRole::Hood,
        when_set: "hood closed and automatic mode",
        ok_level: None,
    },
    InputBit {
        port: InputPort::Status2,
        bit: 6,
        name: "hood closed or setup",
        role: InputRole::Hood,
        when_set: "hood closed or setup mode",
        ok_level: None,
    },
    InputBit {
        port: InputPort::Status2,
        bit: 7,
        name: "key switch",
        role: InputRole::KeySwitch,
        when_set: "key switch on",
        ok_level: None,
    },
    limit_in(0, "limit X1", Axis::X, 1),
    limit_in(1, "limit X2", Axis::X, 2),
    limit_in(2, "limit Y1", Axis::Y, 1),
    limit_in(3, "limit Y2", Axis::Y, 2),
    limit_in(4, "limit Z1", Axis::Z, 1),
    limit_in(5, "limit Z2", Axis::Z, 2),
    limit_in(6, "limit A1", Axis::A, 1),
    limit_in(7, "limit A2", Axis::A, 2),
];

/// The input bit `bit` (0–7) of `port`.
pub fn input_bit(port: InputPort, bit: u8) -> Option<&'static InputBit> {
    port.bits().get(usize::from(bit))
}

/// The value range of an output port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputValues {
    /// 0 or 1, with what each does.
    Switch { off: &'static str, on: &'static str },
    /// 0–255, with what the byte means.
    Byte { meaning: &'static str },
}

/// One bit of a byte-wide output port (ports 0, 100, 101).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputBit {
    pub bit: u8,
    pub name: &'static str,
    /// Why setting this bit needs the operator's confirmation, if it does.
    pub hazard: Option<&'static str>,
}

/// One output port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputPortInfo {
    pub port: OutputPort,
    pub name: &'static str,
    pub values: OutputValues,
    /// Why writing this port needs the operator's confirmation: it moves or
    /// energises something. `None` for outputs that only signal.
    pub hazard: Option<&'static str>,
    /// Only usable with the matching hardware (manual 2.2.4, note 1).
    pub hardware_dependent: bool,
    /// Reserved for isel software products (manual 2.2.4, note 2).
    pub reserved: bool,
    /// The bits of a byte-wide port; empty for on/off ports and port 4.
    pub bits: &'static [OutputBit],
}

const fn user_out(bit: u8, name: &'static str) -> OutputBit {
    OutputBit {
        bit,
        name,
        hazard: Some("user outputs may switch any connected load"),
    }
}

const fn plain_out(bit: u8, name: &'static str) -> OutputBit {
    OutputBit {
        bit,
        name,
        hazard: None,
    }
}

const USER_OUT_BITS: [OutputBit; 8] = [
    user_out(0, "user output 0"),
    user_out(1, "user output 1"),
    user_out(2, "user output 2"),
    user_out(3, "user output 3"),
    user_out(4, "user output 4"),
    user_out(5, "user output 5"),
    user_out(6, "user output 6"),
    user_out(7, "user output 7"),
];

const CONTROL_OUT_BITS: [OutputBit; 8] = [
    OutputBit {
        bit: 0,
        name: "current reduction",
        hazard: Some("changes the holding torque of the motors"),
    },
    plain_out(1, "not used"),
    OutputBit {
        bit: 2,
        name: "reset power stages",
        hazard: Some("resets the motor power stages"),
    },
    OutputBit {
        bit: 3,
        name: "enable power stages",
        hazard: Some("energises the motors"),
    },
    OutputBit {
        bit: 4,
        name: "spindle",
        hazard: Some("starts the spindle"),
    },
    OutputBit {
        bit: 5,
        name: "hood enable",
        hazard: Some("lets the hood be opened"),
    },
    OutputBit {
        bit: 6,
        name: "brake",
        hazard: Some("releasing the brake can let a vertical axis drop"),
    },
    OutputBit {
        bit: 7,
        name: "software ok",
        hazard: Some("tells the safety circuit the software is healthy"),
    },
];

const SIGNAL_OUT_BITS: [OutputBit; 8] = [
    plain_out(0, "not used"),
    plain_out(1, "not used"),
    plain_out(2, "not used"),
    plain_out(3, "not used"),
    plain_out(4, "not used"),
    plain_out(5, "stop lamp"),
    plain_out(6, "start lamp"),
    plain_out(7, "error lamp"),
];

/// Every output port, in [`OutputPort::ALL`] order (isel manual 2.2.4, 3.2.20).
pub const OUTPUT_PORTS: [OutputPortInfo; 9] = [
    OutputPortInfo {
        port: OutputPort::User,
        name: "user outputs",
        values: OutputValues::Byte {
            meaning: "one bit per user output",
        },
        hazard: Some("user outputs may switch any connected load"),
        hardware_dependent: false,
        reserved: false,
        bits: &USER_OUT_BITS,
    },
    OutputPortInfo {
        port: OutputPort::HoodUnlock,
        name: "hood unlock",
        values: OutputValues::Switch {
            off: "hood must stay closed",
            on: "hood may be opened",
        },
        hazard: Some("unlocks the hood of the working area"),
        hardware_dependent: false,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::Spindle,
        name: "spindle",
        values: OutputValues::Switch {
            off: "spindle off",
            on: "spindle on",
        },
        hazard: Some("starts the spindle"),
        hardware_dependent: false,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::MotorCurrents,
        name: "motor currents",
        values: OutputValues::Switch {
            off: "motor currents off",
            on: "motor currents on",
        },
        hazard: Some("energises or de-energises the motors"),
        hardware_dependent: true,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::Analog,
        name: "analog output",
        values: OutputValues::Byte {
            meaning: "0-10 V as 0-255",
        },
        hazard: Some("the analog output often sets a spindle or pump speed"),
        hardware_dependent: false,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::CurrentReduction,
        name: "current reduction",
        values: OutputValues::Switch {
            off: "current reduction off",
            on: "current reduction on",
        },
        hazard: Some("changes the holding torque of the motors"),
        hardware_dependent: true,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::Brake,
        name: "brake",
        values: OutputValues::Switch {
            off: "brake not energised (holding)",
            on: "brake energised (released)",
        },
        hazard: Some("releasing the brake can let a vertical axis drop"),
        hardware_dependent: false,
        reserved: false,
        bits: &[],
    },
    OutputPortInfo {
        port: OutputPort::ControlOut,
        name: "control out",
        values: OutputValues::Byte {
            meaning: "power stage, spindle, hood, brake and watchdog bits",
        },
        hazard: Some("drives power stages, spindle, hood and brake directly"),
        hardware_dependent: false,
        reserved: true,
        bits: &CONTROL_OUT_BITS,
    },
    OutputPortInfo {
        port: OutputPort::SignalOut,
        name: "signal out",
        values: OutputValues::Byte {
            meaning: "stop, start and error lamps",
        },
        hazard: None,
        hardware_dependent: false,
        reserved: true,
        bits: &SIGNAL_OUT_BITS,
    },
];

/// The axis of each bit 0..3 of a `@0DRp`/`@0DRn` reply byte (isel manual
/// 2.2.6); bits 4..7 are unused.
pub const LIMIT_DIAGNOSIS_BITS: [Axis; 4] = [Axis::X, Axis::Y, Axis::Z, Axis::A];

/// The axes whose limit switch is active in a `@0DRp` (positive) or
/// `@0DRn` (negative) reply byte: bit0 X, bit1 Y, bit2 Z, bit3 A
/// (isel manual 2.2.6).
pub fn limit_diagnosis_axes(byte: u8) -> AxisSet {
    AxisSet::from_mask(byte & 0x0F)
}

/// One limit switch's setting in the `@0IE` word (isel manual 4.2.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LimitSwitchSetting {
    pub enabled: bool,
    pub low_active: bool,
}

/// The `@0IE` word per axis (X, Y, Z, A) and switch (1, 2): each axis owns
/// four bits, enable 1, enable 2, low-active 1, low-active 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LimitSwitchSettings(pub [[LimitSwitchSetting; 2]; 4]);

impl LimitSwitchSettings {
    pub fn from_word(word: u16) -> LimitSwitchSettings {
        let mut out = [[LimitSwitchSetting::default(); 2]; 4];
        for (axis, switches) in out.iter_mut().enumerate() {
            let nibble = (word >> (axis * 4)) & 0xF;
            for (n, s) in switches.iter_mut().enumerate() {
                s.enabled = nibble & (1 << n) != 0;
                s.low_active = nibble & (1 << (n + 2)) != 0;
            }
        }
        LimitSwitchSettings(out)
    }

    pub fn to_word(self) -> u16 {
        let mut word = 0u16;
        for (axis, switches) in self.0.iter().enumerate() {
            for (n, s) in switches.iter().enumerate() {
                word |= u16::from(s.enabled) << (axis * 4 + n);
                word |= u16::from(s.low_active) << (axis * 4 + n + 2);
            }
        }
        word
    }

    pub fn get(&self, axis: Axis, switch: u8) -> Option<LimitSwitchSetting> {
        self.0
            .get(axis.index())
            .and_then(|s| s.get(usize::from(switch.checked_sub(1)?)))
            .copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_input_bit_is_in_its_place() {
        for port in InputPort::ALL {
            let bits = port.bits();
            assert_eq!(bits.len(), 8);
            for (i, b) in bits.iter().enumerate() {
                assert_eq!((b.port, usize::from(b.bit)), (port, i));
            }
        }
        let names: Vec<_> = InputPort::Status1
            .bits()
            .iter()
            .take(6)
            .map(|b| b.name)
            .collect();
        assert_eq!(
            names,
            [
                "E-stop circuit 1",
                "E-stop circuit 2",
                "over-temperature",
                "start key",
                "stop key",
                "tool-length probe"
            ]
        );
        let limits: Vec<_> = InputPort::LimitSwitches
            .bits()
            .iter()
            .map(|b| b.name)
            .collect();
        assert_eq!(
            limits,
            [
                "limit X1", "limit X2", "limit Y1", "limit Y2", "limit Z1", "limit Z2", "limit A1",
                "limit A2"
            ]
        );
        assert_eq!(
            input_bit(InputPort::Status2, 7).map(|b| b.role),
            Some(InputRole::KeySwitch)
        );
        assert_eq!(
            input_bit(InputPort::Status2, 1).map(|b| b.role),
            Some(InputRole::PowerOk)
        );
        assert_eq!(input_bit(InputPort::Status2, 8), None);
    }

    #[test]
    fn output_table_matches_the_port_enum() {
        for (info, port) in OUTPUT_PORTS.iter().zip(OutputPort::ALL) {
            assert_eq!(info.port, port);
            assert_eq!(port.info().port, port);
            assert_eq!(OutputPort::from_number(port.number().into()), Some(port));
        }
        assert_eq!(OutputPort::from_number(7), None);
        assert_eq!(OutputPort::Spindle.max_value(), 1);
        assert_eq!(OutputPort::Analog.max_value(), 255);
        // Only the lamps can be switched without asking.
        let quiet: Vec<_> = OUTPUT_PORTS
            .iter()
            .filter(|p| p.hazard.is_none())
            .map(|p| p.port)
            .collect();
        assert_eq!(quiet, [OutputPort::SignalOut]);
        assert_eq!(OutputPort::ControlOut.info().bits[6].name, "brake");
        assert_eq!(OutputPort::SignalOut.info().bits[7].name, "error lamp");
    }

    #[test]
    fn limit_word_of_the_manual_example() {
        // @0IE57343 = 0xDFFF: everything enabled and low-active except A2.
        let s = LimitSwitchSettings::from_word(57343);
        assert_eq!(
            s.get(Axis::A, 2),
            Some(LimitSwitchSetting {
                enabled: false,
                low_active: true
            })
        );
        assert_eq!(
            s.get(Axis::X, 1),
            Some(LimitSwitchSetting {
                enabled: true,
                low_active: true
            })
        );
        assert_eq!(s.get(Axis::X, 3), None);
        assert_eq!(s.to_word(), 57343);
        for word in [0u16, 1, 0x8000, 0x1234, 0xFFFF] {
            assert_eq!(LimitSwitchSettings::from_word(word).to_word(), word);
        }
    }

    #[test]
    fn diagnosis_bits_name_axes() {
        for (bit, axis) in LIMIT_DIAGNOSIS_BITS.iter().enumerate() {
            assert_eq!(limit_diagnosis_axes(1 << bit).iter().next(), Some(*axis));
        }
        assert_eq!(limit_diagnosis_axes(0x05).to_string(), "XZ");
        assert_eq!(limit_diagnosis_axes(0xF8).to_string(), "A");
    }
}
