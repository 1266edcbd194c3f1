//! What a machine's controller bits are wired to: every input and output bit
//! jogterm can read or switch, with its name, its role, the level that means
//! "active", and whether the machine has something connected to it.
//!
//! The defaults are the manuals' tables (isel manual 2.2.3 and 2.2.4, EMCU
//! manual 1.5.15 and 1.5.19, EMP document "40" and "42"); a profile's `[io]`
//! section patches them bit by bit ([`BitPatch`], `docs/profiles.md`).
//!
//! What jogterm does with it:
//! - every bit is shown under its name, unwired ones marked as such;
//! - jogterm refuses motion on its own reading of a bit only when the bit is
//!   wired and safety-relevant ([`BitWiring::interlocks`]): an emergency-stop
//!   circuit, a power or temperature input, a hood. Everything else the
//!   controller decides, and jogterm explains its answer (binding rule "The
//!   controller decides what its wiring allows", `docs/decisions.md`);
//! - limit switches carry their axis and side, so a client can tell which
//!   end of travel an axis stands in ([`Wiring::limit_switches`],
//!   `device::api::IoSnapshot::active_limits`).
//!
//! Addresses name the bits the way the controllers number them:
//! - isel: inputs `in0.0` … `in3.7` (port.bit, `@0b`), outputs `out0.0` …
//!   `out0.7`, `out1` … `out6`, `out100.0` … `out100.7`, `out101.0` …
//!   `out101.7` (`@0B`);
//! - EMCU: input `E1` (`&V`), outputs `A1`, `A2`;
//! - EMP, per drive (its DS byte, `11`): `11.limit+`, `11.limit-`, `11.ref`
//!   (`40` PROP), `11.I1` … `11.I4`, outputs `11.O1` … `11.O4`.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::axis::{Axis, AxisSet};
use crate::proto::Protocol;
use crate::proto::isel::ports::{INPUT_BITS, InputRole, OUTPUT_PORTS};
use crate::proto::isel::{InputPort, OutputPort};

/// The level of a bit as read or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    High,
    Low,
}

impl Level {
    fn of(high: bool) -> Level {
        if high { Level::High } else { Level::Low }
    }
}

/// Which end of an axis' travel a limit switch guards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    /// The end towards the soft minimum (the `-` end).
    #[serde(rename = "min", alias = "-")]
    Min,
    /// The end towards the soft maximum (the `+` end).
    #[serde(rename = "max", alias = "+")]
    Max,
}

impl Side {
    /// The sign of a move that leaves a switch on this side: +1 off the
    /// `min` switch, -1 off the `max` switch.
    pub fn away_sign(self) -> i64 {
        match self {
            Side::Min => 1,
            Side::Max => -1,
        }
    }
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Side::Min => "min",
            Side::Max => "max",
        })
    }
}

/// A limit switch: the axis and the end of travel it guards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LimitSwitch {
    pub axis: Axis,
    pub side: Side,
}

/// The `role` a profile gives a bit, as written (`role = "limit"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RoleName {
    Limit,
    Estop,
    Hood,
    Probe,
    Start,
    Stop,
    Spindle,
    Power,
    Reference,
    User,
    Unused,
    Coolant,
    Clamp,
    Vacuum,
    Lamp,
}

impl RoleName {
    const ALL: [RoleName; 15] = [
        RoleName::Limit,
        RoleName::Estop,
        RoleName::Hood,
        RoleName::Probe,
        RoleName::Start,
        RoleName::Stop,
        RoleName::Spindle,
        RoleName::Power,
        RoleName::Reference,
        RoleName::User,
        RoleName::Unused,
        RoleName::Coolant,
        RoleName::Clamp,
        RoleName::Vacuum,
        RoleName::Lamp,
    ];

    fn word(self) -> &'static str {
        match self {
            RoleName::Limit => "limit",
            RoleName::Estop => "estop",
            RoleName::Hood => "hood",
            RoleName::Probe => "probe",
            RoleName::Start => "start",
            RoleName::Stop => "stop",
            RoleName::Spindle => "spindle",
            RoleName::Power => "power",
            RoleName::Reference => "reference",
            RoleName::User => "user",
            RoleName::Unused => "unused",
            RoleName::Coolant => "coolant",
            RoleName::Clamp => "clamp",
            RoleName::Vacuum => "vacuum",
            RoleName::Lamp => "lamp",
        }
    }

    /// Roles an output may have: what it switches.
    fn fits_output(self) -> bool {
        matches!(
            self,
            RoleName::Spindle
                | RoleName::Power
                | RoleName::Hood
                | RoleName::User
                | RoleName::Unused
                | RoleName::Coolant
                | RoleName::Clamp
                | RoleName::Vacuum
                | RoleName::Lamp
        )
    }
}

/// What a bit is for. "Active" means the condition the role names holds:
/// a limit switch is hit, an emergency stop is tripped (its circuit open),
/// a hood is open, a probe is touched, a key is pressed, the spindle runs,
/// the power (supply or power stages) is not ok, a reference switch is
/// actuated; for `user` bits, that the bit is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    Limit(LimitSwitch),
    Estop,
    Hood,
    Probe,
    Start,
    Stop,
    Spindle,
    Power,
    Reference,
    User,
    Unused,
    /// Outputs only: what an operator switches by name (`docs/ui.md`,
    /// "Named outputs").
    Coolant,
    Clamp,
    Vacuum,
    Lamp,
}

impl Role {
    pub fn name(self) -> RoleName {
        match self {
            Role::Limit(_) => RoleName::Limit,
            Role::Estop => RoleName::Estop,
            Role::Hood => RoleName::Hood,
            Role::Probe => RoleName::Probe,
            Role::Start => RoleName::Start,
            Role::Stop => RoleName::Stop,
            Role::Spindle => RoleName::Spindle,
            Role::Power => RoleName::Power,
            Role::Reference => RoleName::Reference,
            Role::User => RoleName::User,
            Role::Unused => RoleName::Unused,
            Role::Coolant => RoleName::Coolant,
            Role::Clamp => RoleName::Clamp,
            Role::Vacuum => RoleName::Vacuum,
            Role::Lamp => RoleName::Lamp,
        }
    }

    fn plain(name: RoleName) -> Option<Role> {
        Some(match name {
            RoleName::Limit => return None,
            RoleName::Estop => Role::Estop,
            RoleName::Hood => Role::Hood,
            RoleName::Probe => Role::Probe,
            RoleName::Start => Role::Start,
            RoleName::Stop => Role::Stop,
            RoleName::Spindle => Role::Spindle,
            RoleName::Power => Role::Power,
            RoleName::Reference => Role::Reference,
            RoleName::User => Role::User,
            RoleName::Unused => Role::Unused,
            RoleName::Coolant => Role::Coolant,
            RoleName::Clamp => Role::Clamp,
            RoleName::Vacuum => Role::Vacuum,
            RoleName::Lamp => Role::Lamp,
        })
    }

    /// Safety-relevant: a wired input with this role, when active, makes
    /// jogterm refuse motion itself.
    pub fn is_interlock(self) -> bool {
        matches!(self, Role::Estop | Role::Power | Role::Hood)
    }

    /// An output with this role is something an operator switches by its
    /// name (spindle, coolant, clamp, vacuum, lamp, hood unlock): it gets a
    /// place in the outputs popup. Power stages and plain user outputs
    /// stay in the I/O panel only.
    pub fn is_named_output(self) -> bool {
        matches!(
            self,
            Role::Spindle | Role::Hood | Role::Coolant | Role::Clamp | Role::Vacuum | Role::Lamp
        )
    }
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Role::Limit(l) => write!(f, "limit {} {}", l.axis, l.side),
            other => f.write_str(other.name().word()),
        }
    }
}

/// Whether jogterm reads the bit or switches it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BitKind {
    Input,
    Output,
}

/// One bit as the machine is wired.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct BitWiring {
    /// `in3.0`, `out2`, `11.limit+` (module docs).
    pub address: String,
    pub name: String,
    pub role: Role,
    /// The level at which the role's condition holds.
    pub active: Level,
    /// Something is connected: jogterm acts on the bit only then.
    pub wired: bool,
    pub kind: BitKind,
    /// Outputs: whether switching it asks first, as the profile says
    /// (`hazardous = true`); `None` leaves it to the manual's table.
    pub hazardous: Option<bool>,
}

impl BitWiring {
    /// Whether a bit at `level` (true = high) is active.
    pub fn is_active(&self, level: bool) -> bool {
        Level::of(level) == self.active
    }

    /// Whether jogterm refuses motion while this input is active.
    pub fn interlocks(&self) -> bool {
        self.wired && self.kind == BitKind::Input && self.role.is_interlock()
    }

    /// The limit switch this input is, when it is one and wired.
    pub fn limit(&self) -> Option<LimitSwitch> {
        match self.role {
            Role::Limit(l) if self.wired && self.kind == BitKind::Input => Some(l),
            _ => None,
        }
    }

    /// `hood closed or setup (in2.6)`, for messages.
    pub fn label(&self) -> String {
        format!("{} ({})", self.name, self.address)
    }
}

/// A profile's change to one bit (`[io."in2.5"]`): every field optional, the
/// rest stays as the defaults have it.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BitPatch {
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default)]
    pub role: Option<RoleName>,
    /// For `role = "limit"`: the axis the switch belongs to.
    #[serde(default)]
    pub axis: Option<Axis>,
    /// For `role = "limit"`: `min` (`-`) or `max` (`+`).
    #[serde(default)]
    pub side: Option<Side>,
    #[serde(default)]
    pub active: Option<Level>,
    #[serde(default)]
    pub wired: Option<bool>,
    /// Outputs: ask before switching it (`true`) or not (`false`);
    /// absent, the manual's table decides.
    #[serde(default)]
    pub hazardous: Option<bool>,
}

/// A problem with one `[io]` entry: the key path below the profile's root
/// and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WiringProblem {
    pub key: Vec<String>,
    pub message: String,
}

/// Longest bit name a profile may give (a panel shows names whole).
pub const MAX_NAME_CHARS: usize = 32;

/// Every bit of one controller (or EMP link), in the order the controller
/// numbers them.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Wiring {
    bits: Vec<BitWiring>,
}

impl Wiring {
    /// The manuals' tables for `protocol`. `axes` are the machine's axes
    /// (limit switches of other axes count as not wired); `drives` the EMP
    /// drives (DS as two hex digits, axis) in the profile's order.
    pub fn defaults(protocol: Protocol, axes: AxisSet, drives: &[(String, Axis)]) -> Wiring {
        let bits = match protocol {
            Protocol::Isel => isel_defaults(axes),
            Protocol::Emcu => emcu_defaults(),
            Protocol::Emp => drives
                .iter()
                .flat_map(|(ds, axis)| emp_defaults(ds, *axis))
                .collect(),
        };
        Wiring { bits }
    }

    /// The defaults with `patches` applied; every entry that is wrong is
    /// reported (key path `io.<address>[.<field>]`) and left out.
    pub fn patched(
        mut self,
        patches: &BTreeMap<String, BitPatch>,
        axes: AxisSet,
    ) -> (Wiring, Vec<WiringProblem>) {
        let mut problems = Vec::new();
        for (address, patch) in patches {
            let key = |field: Option<&str>| {
                let mut k = vec!["io".to_owned(), address.clone()];
                k.extend(field.map(str::to_owned));
                k
            };
            let Some(index) = self.bits.iter().position(|b| &b.address == address) else {
                problems.push(WiringProblem {
                    key: key(None),
                    message: format!(
                        "`{address}` is no bit of this controller: expected one of {}",
                        self.address_summary()
                    ),
                });
                continue;
            };
            match apply(&self.bits[index], patch, axes) {
                Ok(bit) => self.bits[index] = bit,
                Err((field, message)) => problems.push(WiringProblem {
                    key: key(field),
                    message,
                }),
            }
        }
        (self, problems)
    }

    pub fn bits(&self) -> &[BitWiring] {
        &self.bits
    }

    pub fn bit(&self, address: &str) -> Option<&BitWiring> {
        self.bits.iter().find(|b| b.address == address)
    }

    /// The wired limit switches, with their axis and side.
    pub fn limit_switches(&self) -> impl Iterator<Item = (&BitWiring, LimitSwitch)> {
        self.bits.iter().filter_map(|b| b.limit().map(|l| (b, l)))
    }

    /// `in0.0 … in3.7, out0.0 … out0.7, out1, …` for error messages: runs
    /// of numbered bits are shortened.
    fn address_summary(&self) -> String {
        let mut out: Vec<String> = Vec::new();
        let mut run: Option<(String, String, String)> = None; // prefix, first, last
        let flush = |run: &mut Option<(String, String, String)>, out: &mut Vec<String>| {
            if let Some((_, first, last)) = run.take() {
                if first == last {
                    out.push(first);
                } else {
                    out.push(format!("{first} … {last}"));
                }
            }
        };
        for bit in &self.bits {
            let prefix = bit.address.rsplit_once('.').map(|(p, _)| p.to_owned());
            let grouped = prefix.is_some();
            let prefix = prefix.unwrap_or_default();
            match &mut run {
                Some((p, _, last)) if grouped && *p == prefix => *last = bit.address.clone(),
                _ => {
                    flush(&mut run, &mut out);
                    if grouped {
                        run = Some((prefix, bit.address.clone(), bit.address.clone()));
                    } else {
                        out.push(bit.address.clone());
                    }
                }
            }
        }
        flush(&mut run, &mut out);
        out.join(", ")
    }
}

/// One patch on one bit; the field at fault and why on error.
fn apply(
    base: &BitWiring,
    patch: &BitPatch,
    axes: AxisSet,
) -> Result<BitWiring, (Option<&'static str>, String)> {
    let mut bit = base.clone();
    if let Some(name) = &patch.name {
        let trimmed = name.trim();
        if trimmed.is_empty() {
            return Err((Some("name"), "a bit's name must not be empty".into()));
        }
        if trimmed.chars().count() > MAX_NAME_CHARS || trimmed.chars().any(char::is_control) {
            return Err((
                Some("name"),
                format!("a bit's name is at most {MAX_NAME_CHARS} printable characters"),
            ));
        }
        bit.name = trimmed.to_owned();
    }
    let role = patch.role.unwrap_or(base.role.name());
    if bit.kind == BitKind::Output && !role.fits_output() {
        let fits: Vec<&str> = RoleName::ALL
            .iter()
            .filter(|r| r.fits_output())
            .map(|r| r.word())
            .collect();
        return Err((
            Some("role"),
            format!(
                "`{}` is an output: its role is one of {}",
                base.address,
                fits.join(", ")
            ),
        ));
    }
    bit.role = match Role::plain(role) {
        Some(plain) => {
            for (field, given) in [
                ("axis", patch.axis.is_some()),
                ("side", patch.side.is_some()),
            ] {
                if given {
                    return Err((
                        Some(field),
                        format!(
                            "`{field}` belongs to a limit switch, not to role `{}`",
                            role.word()
                        ),
                    ));
                }
            }
            plain
        }
        None => {
            let inherited = match base.role {
                Role::Limit(l) => Some(l),
                _ => None,
            };
            let axis = patch.axis.or(inherited.map(|l| l.axis));
            let side = patch.side.or(inherited.map(|l| l.side));
            match (axis, side) {
                (Some(axis), Some(side)) => {
                    if !axes.contains(axis) && patch.axis.is_some() {
                        return Err((
                            Some("axis"),
                            format!("the machine has no axis {axis} (machine.axes = {axes})"),
                        ));
                    }
                    Role::Limit(LimitSwitch { axis, side })
                }
                _ => {
                    return Err((
                        Some("role"),
                        "a limit switch needs its `axis` (X, Y, Z, A) and `side` (min or max)"
                            .into(),
                    ));
                }
            }
        }
    };
    if let Some(active) = patch.active {
        bit.active = active;
    }
    if let Some(wired) = patch.wired {
        bit.wired = wired;
    }
    if let Some(hazardous) = patch.hazardous {
        if bit.kind != BitKind::Output {
            return Err((
                Some("hazardous"),
                format!(
                    "`{}` is an input: only switching an output can be hazardous",
                    base.address
                ),
            ));
        }
        bit.hazardous = Some(hazardous);
    }
    Ok(bit)
}

/// `in<port>.<bit>`.
pub fn isel_input_address(port: InputPort, bit: u8) -> String {
    format!("in{}.{bit}", port.number())
}

/// `out<port>.<bit>` for the byte-wide ports, `out<port>` for the others.
pub fn isel_output_address(port: OutputPort, bit: Option<u8>) -> String {
    match bit {
        Some(b) => format!("out{}.{b}", port.number()),
        None => format!("out{}", port.number()),
    }
}

/// isel manual 2.2.3 (inputs, `docs/decisions.md` isel 7) and 2.2.4
/// (outputs). Wired by default is everything but the bits a machine may
/// leave unconnected while the controller supervises them itself (hood and
/// key switch: `@0IH`, manual 4.2.13; power ok and over-temperature: the
/// controller answers `9`, chapter 5), and the limit switches of axes the
/// machine does not have.
fn isel_defaults(axes: AxisSet) -> Vec<BitWiring> {
    let mut bits: Vec<BitWiring> = INPUT_BITS
        .iter()
        .map(|b| {
            let (role, active, wired) = match b.role {
                InputRole::User => (Role::User, Level::High, true),
                InputRole::EmergencyStopCircuit => (Role::Estop, Level::Low, true),
                InputRole::OverTemperature => (Role::Power, Level::High, false),
                InputRole::StartKey => (Role::Start, Level::High, true),
                InputRole::StopKey => (Role::Stop, Level::High, true),
                InputRole::ToolLengthProbe => (Role::Probe, Level::High, true),
                InputRole::Spindle => (Role::Spindle, Level::High, true),
                InputRole::PowerOk => (Role::Power, Level::Low, false),
                // Active = the hood is open: both bits read 0 then (bit 5
                // also in setup mode, which is why a hood interlock needs
                // every wired hood bit active, `device::isel`).
                InputRole::Hood => (Role::Hood, Level::Low, false),
                InputRole::KeySwitch => (Role::User, Level::High, false),
                InputRole::LimitSwitch { axis, switch } => (
                    // Switch 1 is the one a reference run seeks (manual
                    // 2.2.22): the minus end.
                    Role::Limit(LimitSwitch {
                        axis,
                        side: if switch == 1 { Side::Min } else { Side::Max },
                    }),
                    Level::High,
                    axes.contains(axis),
                ),
                InputRole::NotUsed => (Role::Unused, Level::High, false),
            };
            BitWiring {
                address: isel_input_address(b.port, b.bit),
                name: b.name.to_owned(),
                role,
                active,
                wired,
                kind: BitKind::Input,
                hazardous: None,
            }
        })
        .collect();
    for info in &OUTPUT_PORTS {
        let port_role = match info.port {
            OutputPort::HoodUnlock => Role::Hood,
            OutputPort::Spindle => Role::Spindle,
            OutputPort::MotorCurrents | OutputPort::CurrentReduction => Role::Power,
            _ => Role::User,
        };
        if info.bits.is_empty() {
            bits.push(output_bit(
                isel_output_address(info.port, None),
                info.name,
                port_role,
            ));
            continue;
        }
        for b in info.bits {
            let role = match (info.port, b.bit) {
                _ if b.name == "not used" => Role::Unused,
                (OutputPort::ControlOut, 0 | 2 | 3) => Role::Power,
                (OutputPort::ControlOut, 4) => Role::Spindle,
                (OutputPort::ControlOut, 5) => Role::Hood,
                _ => Role::User,
            };
            bits.push(output_bit(
                isel_output_address(info.port, Some(b.bit)),
                b.name,
                role,
            ));
        }
    }
    bits
}

fn output_bit(address: String, name: &str, role: Role) -> BitWiring {
    BitWiring {
        address,
        name: name.to_owned(),
        wired: role != Role::Unused,
        role,
        active: Level::High,
        kind: BitKind::Output,
        hazardous: None,
    }
}

/// EMCU manual 1.5.19 (E1, which `&V1` moves wait for: a start input) and
/// 1.5.15 (outputs A1, A2 on relays K1, K2).
fn emcu_defaults() -> Vec<BitWiring> {
    vec![
        BitWiring {
            address: "E1".into(),
            name: "E1".into(),
            role: Role::Start,
            active: Level::High,
            wired: true,
            kind: BitKind::Input,
            hazardous: None,
        },
        output_bit("A1".into(), "A1 (K1)", Role::User),
        output_bit("A2".into(), "A2 (K2)", Role::User),
    ]
}

/// EMP document "40" (limit +, limit -, reference switch, I1-I4; decision
/// 5) and "42" (O1-O4) for the drive `ds` on `axis`.
fn emp_defaults(ds: &str, axis: Axis) -> Vec<BitWiring> {
    let input = |suffix: &str, name: String, role: Role| BitWiring {
        address: format!("{ds}.{suffix}"),
        name,
        role,
        active: Level::High,
        wired: true,
        kind: BitKind::Input,
        hazardous: None,
    };
    let mut bits = vec![
        input(
            "limit+",
            "limit +".into(),
            Role::Limit(LimitSwitch {
                axis,
                side: Side::Max,
            }),
        ),
        input(
            "limit-",
            "limit -".into(),
            Role::Limit(LimitSwitch {
                axis,
                side: Side::Min,
            }),
        ),
        input("ref", "reference".into(), Role::Reference),
    ];
    for n in 1..=4 {
        bits.push(input(&format!("I{n}"), format!("I{n}"), Role::User));
    }
    for n in 1..=4 {
        bits.push(output_bit(
            format!("{ds}.O{n}"),
            &format!("O{n}"),
            Role::User,
        ));
    }
    bits
}

#[cfg(test)]
mod tests {
    use super::*;

    fn isel() -> Wiring {
        Wiring::defaults(Protocol::Isel, AxisSet::XYZ, &[])
    }

    fn patch(text: &str) -> BTreeMap<String, BitPatch> {
        toml::from_str(text).expect("patch")
    }

    #[test]
    fn isel_defaults_follow_the_manuals_tables() {
        let w = isel();
        assert_eq!(w.bits().len(), 32 + 8 + 6 + 8 + 8);
        let x1 = w.bit("in3.0").expect("X1");
        assert_eq!(x1.name, "limit X1");
        assert_eq!(
            x1.limit(),
            Some(LimitSwitch {
                axis: Axis::X,
                side: Side::Min
            })
        );
        assert_eq!(
            w.bit("in3.5").and_then(BitWiring::limit),
            Some(LimitSwitch {
                axis: Axis::Z,
                side: Side::Max
            })
        );
        // No A axis: its switches are not wired.
        assert_eq!(w.bit("in3.6").and_then(BitWiring::limit), None);
        let estop = w.bit("in1.0").expect("estop");
        assert!(estop.interlocks() && estop.is_active(false) && !estop.is_active(true));
        // The controller supervises hood, power and temperature itself.
        for address in ["in2.1", "in2.5", "in2.6", "in1.2"] {
            assert!(!w.bit(address).expect(address).interlocks(), "{address}");
        }
        assert_eq!(w.bit("out2").map(|b| b.role), Some(Role::Spindle));
        assert_eq!(w.bit("out100.6").map(|b| b.name.as_str()), Some("brake"));
        assert_eq!(w.bit("out101.0").map(|b| b.wired), Some(false));
        assert_eq!(w.limit_switches().count(), 6);
    }

    #[test]
    fn a_patch_changes_only_what_it_names() {
        let (w, problems) = isel().patched(
            &patch(
                r#"
                "in0.3" = { name = "tool setter", role = "probe" }
                "in2.6" = { wired = true }
                "in3.2" = { side = "+" }
                "in3.4" = { active = "low", name = "Z home" }
                "#,
            ),
            AxisSet::XYZ,
        );
        assert!(problems.is_empty(), "{problems:?}");
        let probe = w.bit("in0.3").expect("probe");
        assert_eq!(
            (probe.name.as_str(), probe.role),
            ("tool setter", Role::Probe)
        );
        assert!(probe.wired);
        assert!(w.bit("in2.6").expect("hood").interlocks());
        assert_eq!(
            w.bit("in3.2").and_then(BitWiring::limit),
            Some(LimitSwitch {
                axis: Axis::Y,
                side: Side::Max
            })
        );
        let z = w.bit("in3.4").expect("Z");
        assert!(z.is_active(false) && z.name == "Z home");
    }

    #[test]
    fn every_bad_entry_is_reported_with_its_key() {
        let (_, problems) = isel().patched(
            &patch(
                r#"
                "in4.0" = { wired = true }
                "in0.1" = { role = "limit" }
                "in0.2" = { role = "probe", side = "min" }
                "out2" = { role = "limit", axis = "X", side = "min" }
                "in0.4" = { role = "limit", axis = "A", side = "max" }
                "in0.5" = { name = "" }
                "#,
            ),
            AxisSet::XYZ,
        );
        let keys: Vec<String> = problems.iter().map(|p| p.key.join(".")).collect();
        assert_eq!(
            keys,
            [
                "io.in0.1.role",
                "io.in0.2.side",
                "io.in0.4.axis",
                "io.in0.5.name",
                "io.in4.0",
                "io.out2.role",
            ]
        );
        assert!(
            problems[4].message.contains("in0.0 … in0.7"),
            "{}",
            problems[4].message
        );
        assert!(
            problems[4].message.contains("out1"),
            "{}",
            problems[4].message
        );
        assert!(
            problems[0].message.contains("`axis`"),
            "{}",
            problems[0].message
        );
    }

    #[test]
    fn emp_bits_belong_to_their_drive_and_axis() {
        let w = Wiring::defaults(
            Protocol::Emp,
            AxisSet::EMPTY.with(Axis::X).with(Axis::Y),
            &[("11".into(), Axis::X), ("21".into(), Axis::Y)],
        );
        assert_eq!(w.bits().len(), 2 * 11);
        assert_eq!(
            w.bit("21.limit-").and_then(BitWiring::limit),
            Some(LimitSwitch {
                axis: Axis::Y,
                side: Side::Min
            })
        );
        assert_eq!(w.bit("11.O4").map(|b| b.kind), Some(BitKind::Output));
        let emcu = Wiring::defaults(Protocol::Emcu, AxisSet::XYZ, &[]);
        assert_eq!(emcu.bit("E1").map(|b| b.role), Some(Role::Start));
    }

    #[test]
    fn sides_read_as_ends_of_travel() {
        assert_eq!(Side::Min.away_sign(), 1);
        assert_eq!(Side::Max.away_sign(), -1);
        let r = Role::Limit(LimitSwitch {
            axis: Axis::Z,
            side: Side::Max,
        });
        assert_eq!(r.to_string(), "limit Z max");
    }
}
