//! Simulator variants: the ways real controllers differ from the manual's
//! default that the built-in simulators can model (`[sim] variants` in a
//! profile, `jogterm sim --variant`, `docs/simulator.md`). jogterm's own
//! simulators share its drivers' assumptions; a variant is a controller
//! that does not, so the workflows can be tested against the range of real
//! machines (issue 20).
//!
//! Adding a variant: a [`SimVariant`] case and its line in [`VARIANTS`]
//! (name, families, help, how to build it from the value), then its effect
//! where the family's simulator is built from the profile (`sim::*::config`).
//! The end-to-end workflow matrix (`tests/e2e/workflow_variants.rs`) runs every
//! variant of [`VARIANTS`] by itself.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::proto::Protocol;

/// One way a simulated controller differs from the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum SimVariant {
    /// isel: no hood circuit. Port 2 bits 5-7 read 0 and the controller
    /// supervises no hood (`@0IH` mask 0, manual 4.2.13).
    HoodUnwired,
    /// isel: no port 2 (spindle, power ok, hood, key switch): `@0b2`
    /// answers `1`, as for any port the controller does not have.
    NoPort2,
    /// isel: `@0P` reports positions from the virtual zero of `@0n`, not
    /// from the reference point (manual 2.2.19 says it does not).
    WorkPositions,
    /// The program store holds this many commands (isel flash, manual
    /// 2.2.13; EMCU ROM job store, manual 1.5.17), as the `memory` control.
    Memory(usize),
    /// EMP: a drive that is not switched on rejects `0A` too, as every
    /// other request but `02` (manual "02": "Ohne diesen Einschalt-Befehl
    /// werden keine Kommandos angenommen"); by default it answers `0A` with
    /// error `02`.
    EmpRejects0aBeforeOn,
}

/// A variant's name, families and meaning, for parsing and help texts.
#[derive(Debug, Clone, Copy)]
pub struct VariantInfo {
    pub name: &'static str,
    pub families: &'static [Protocol],
    /// The value it takes after `=` (`memory=256`), if any.
    pub value: Option<&'static str>,
    pub help: &'static str,
    /// An example as the workflow matrix runs it.
    pub example: &'static str,
    make: fn(Option<usize>) -> Option<SimVariant>,
}

/// Every variant; the first line of each help is what `--help` shows.
pub const VARIANTS: &[VariantInfo] = &[
    VariantInfo {
        name: "hood-unwired",
        families: &[Protocol::Isel],
        value: None,
        help: "isel without a hood circuit: port 2 bits 5-7 read 0, no hood supervision (@0IH off)",
        example: "hood-unwired",
        make: |_| Some(SimVariant::HoodUnwired),
    },
    VariantInfo {
        name: "no-port2",
        families: &[Protocol::Isel],
        value: None,
        help: "isel without input port 2: @0b2 answers 1",
        example: "no-port2",
        make: |_| Some(SimVariant::NoPort2),
    },
    VariantInfo {
        name: "work-positions",
        families: &[Protocol::Isel],
        value: None,
        help: "isel whose @0P reports positions from the virtual zero of @0n",
        example: "work-positions",
        make: |_| Some(SimVariant::WorkPositions),
    },
    VariantInfo {
        name: "memory",
        families: &[Protocol::Isel, Protocol::Emcu],
        value: Some("<commands>"),
        help: "the program store holds this many commands (isel flash, EMCU ROM job store)",
        example: "memory=64",
        make: |n| n.map(SimVariant::Memory),
    },
    VariantInfo {
        name: "emp-rejects-0a-before-on",
        families: &[Protocol::Emp],
        value: None,
        help: "EMP drives that, not switched on, reject 0A too (EE), not only every other request",
        example: "emp-rejects-0a-before-on",
        make: |_| Some(SimVariant::EmpRejects0aBeforeOn),
    },
];

impl SimVariant {
    pub fn info(self) -> &'static VariantInfo {
        let name = match self {
            SimVariant::HoodUnwired => "hood-unwired",
            SimVariant::NoPort2 => "no-port2",
            SimVariant::WorkPositions => "work-positions",
            SimVariant::Memory(_) => "memory",
            SimVariant::EmpRejects0aBeforeOn => "emp-rejects-0a-before-on",
        };
        VARIANTS
            .iter()
            .find(|v| v.name == name)
            .unwrap_or(&VARIANTS[0])
    }

    /// Whether the simulator of `family` models this variant.
    pub fn applies_to(self, family: Protocol) -> bool {
        self.info().families.contains(&family)
    }

    /// The variants of `family`, for help texts and the test matrix.
    pub fn of(family: Protocol) -> impl Iterator<Item = &'static VariantInfo> {
        VARIANTS
            .iter()
            .filter(move |v| v.families.contains(&family))
    }
}

impl std::str::FromStr for SimVariant {
    type Err = String;

    fn from_str(text: &str) -> Result<SimVariant, String> {
        let (name, value) = match text.split_once('=') {
            Some((n, v)) => (n.trim(), Some(v.trim())),
            None => (text.trim(), None),
        };
        let known = || {
            VARIANTS
                .iter()
                .map(|v| match v.value {
                    Some(value) => format!("{}={value}", v.name),
                    None => v.name.to_owned(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        };
        let info = VARIANTS
            .iter()
            .find(|v| v.name.eq_ignore_ascii_case(name))
            .ok_or_else(|| format!("unknown simulator variant `{text}`: expected {}", known()))?;
        let number = match (info.value, value) {
            (None, None) => None,
            (None, Some(_)) => return Err(format!("`{}` takes no value", info.name)),
            (Some(what), None) => {
                return Err(format!(
                    "`{}` needs a value: {}={what}",
                    info.name, info.name
                ));
            }
            (Some(what), Some(v)) => Some(v.parse::<usize>().map_err(|_| {
                format!(
                    "`{text}`: {what} is a whole number, such as {}",
                    info.example
                )
            })?),
        };
        (info.make)(number).ok_or_else(|| format!("`{text}` is no simulator variant"))
    }
}

impl TryFrom<String> for SimVariant {
    type Error = String;

    fn try_from(text: String) -> Result<SimVariant, String> {
        text.parse()
    }
}

impl From<SimVariant> for String {
    fn from(v: SimVariant) -> String {
        v.to_string()
    }
}

impl fmt::Display for SimVariant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimVariant::Memory(n) => write!(f, "memory={n}"),
            other => f.write_str(other.info().name),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_variant_parses_from_its_example_and_prints_back() {
        for info in VARIANTS {
            let v: SimVariant = info.example.parse().expect(info.example);
            assert_eq!(v.to_string(), info.example);
            assert_eq!(v.info().name, info.name);
            assert!(info.families.iter().all(|f| v.applies_to(*f)));
        }
        assert_eq!("Memory = 12".parse(), Ok(SimVariant::Memory(12)));
    }

    #[test]
    fn bad_variants_say_what_was_expected() {
        let err = "hood".parse::<SimVariant>().unwrap_err();
        assert!(
            err.contains("hood-unwired") && err.contains("memory=<commands>"),
            "{err}"
        );
        assert!(
            "memory"
                .parse::<SimVariant>()
                .unwrap_err()
                .contains("memory=<commands>")
        );
        assert!(
            "memory=lots"
                .parse::<SimVariant>()
                .unwrap_err()
                .contains("whole number")
        );
        assert!(
            "no-port2=1"
                .parse::<SimVariant>()
                .unwrap_err()
                .contains("no value")
        );
        assert!(!SimVariant::HoodUnwired.applies_to(Protocol::Emp));
        assert_eq!(SimVariant::of(Protocol::Emcu).count(), 1);
        assert_eq!(SimVariant::of(Protocol::Emp).count(), 1);
    }
}
