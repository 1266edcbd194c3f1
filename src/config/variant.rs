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
    /// isel, EMP: a work piece under the probe, so that the probe input
    /// follows the carriage (`docs/simulator.md`, "Probe surface").
    ProbeSurface(ProbeSurface),
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

/// The plane `z = z0 + gx·x + gy·y` of a simulated work piece, in machine
/// steps (counts): x, y, z are the axes' positions in machine coordinates,
/// Z+ up, away from the work, as the profiles' Z limits and G-code's safe
/// height have it. The probe touches while the probing axis stands at or
/// below the plane (`probe-surface=Z0[,GX,GY]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeSurface {
    pub z0: f64,
    pub gx: f64,
    pub gy: f64,
}

impl ProbeSurface {
    /// A plane from finite numbers; -0 is kept as 0, so that equal planes
    /// print, compare and hash alike.
    pub fn new(z0: f64, gx: f64, gy: f64) -> Option<ProbeSurface> {
        [z0, gx, gy]
            .iter()
            .all(|v| v.is_finite())
            .then_some(ProbeSurface {
                z0: z0 + 0.0,
                gx: gx + 0.0,
                gy: gy + 0.0,
            })
    }

    /// The height of the plane over `x`, `y`.
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        self.z0 + self.gx * x + self.gy * y
    }

    /// Whether the probe touches with the axes at `x`, `y`, `z`.
    pub fn touches(&self, x: f64, y: f64, z: f64) -> bool {
        z <= self.height_at(x, y)
    }

    /// Whether the plane is tilted.
    pub fn is_flat(&self) -> bool {
        self.gx == 0.0 && self.gy == 0.0
    }

    fn parse(value: &str) -> Result<ProbeSurface, String> {
        let numbers: Vec<&str> = value.split(',').map(str::trim).collect();
        let parsed: Option<Vec<f64>> = numbers.iter().map(|n| n.parse::<f64>().ok()).collect();
        let surface = match parsed.as_deref() {
            Some([z0]) => ProbeSurface::new(*z0, 0.0, 0.0),
            Some([z0, gx, gy]) => ProbeSurface::new(*z0, *gx, *gy),
            _ => None,
        };
        surface.ok_or_else(|| {
            "the surface is Z0 (steps, a flat plane) or Z0,GX,GY (steps and the slopes in X \
             and Y, steps per step), finite numbers, such as 8000,0.01,-0.005"
                .into()
        })
    }
}

/// Finite and without -0 ([`ProbeSurface::new`]): equality is a true
/// equivalence and agrees with the hash of the bits.
impl Eq for ProbeSurface {}

impl std::hash::Hash for ProbeSurface {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        for v in [self.z0, self.gx, self.gy] {
            v.to_bits().hash(state);
        }
    }
}

impl fmt::Display for ProbeSurface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_flat() {
            write!(f, "{}", self.z0)
        } else {
            write!(f, "{},{},{}", self.z0, self.gx, self.gy)
        }
    }
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
    /// Why the other families' simulators do not have it, when there is
    /// more to say than that they do not.
    pub elsewhere: Option<&'static str>,
    /// The variant from its value (`None` without one); `Err` says what is
    /// wrong with the value.
    make: fn(Option<&str>) -> Result<SimVariant, String>,
}

/// Every variant; the first line of each help is what `--help` shows.
pub const VARIANTS: &[VariantInfo] = &[
    VariantInfo {
        name: "hood-unwired",
        families: &[Protocol::Isel],
        value: None,
        help: "isel without a hood circuit: port 2 bits 5-7 read 0, no hood supervision (@0IH off)",
        example: "hood-unwired",
        elsewhere: None,
        make: |_| Ok(SimVariant::HoodUnwired),
    },
    VariantInfo {
        name: "no-port2",
        families: &[Protocol::Isel],
        value: None,
        help: "isel without input port 2: @0b2 answers 1",
        example: "no-port2",
        elsewhere: None,
        make: |_| Ok(SimVariant::NoPort2),
    },
    VariantInfo {
        name: "work-positions",
        families: &[Protocol::Isel],
        value: None,
        help: "isel whose @0P reports positions from the virtual zero of @0n",
        example: "work-positions",
        elsewhere: None,
        make: |_| Ok(SimVariant::WorkPositions),
    },
    VariantInfo {
        name: "memory",
        families: &[Protocol::Isel, Protocol::Emcu],
        value: Some("<commands>"),
        help: "the program store holds this many commands (isel flash, EMCU ROM job store)",
        example: "memory=64",
        elsewhere: None,
        make: |v| {
            v.and_then(|v| v.parse().ok())
                .map(SimVariant::Memory)
                .ok_or_else(|| "<commands> is a whole number, such as memory=64".into())
        },
    },
    VariantInfo {
        name: "emp-rejects-0a-before-on",
        families: &[Protocol::Emp],
        value: None,
        help: "EMP drives that, not switched on, reject 0A too (EE), not only every other request",
        example: "emp-rejects-0a-before-on",
        elsewhere: None,
        make: |_| Ok(SimVariant::EmpRejects0aBeforeOn),
    },
    VariantInfo {
        name: "probe-surface",
        families: &[Protocol::Isel, Protocol::Emp],
        value: Some("<z0>[,<gx>,<gy>]"),
        help: "a work piece z = z0 + gx*x + gy*y (machine steps) that the probe input follows \
               (isel in1.5; EMP the drive input the profile's [io] gives role probe)",
        example: "probe-surface=8000,0.01,-0.005",
        elsewhere: Some(
            "the EMCU cannot read its input E1 (manual 1.5.19: `&V1` only makes a move wait for \
             it before it starts; no command reports its level and no move ends on it), so no \
             probe input could follow a surface",
        ),
        make: |v| ProbeSurface::parse(v.unwrap_or_default()).map(SimVariant::ProbeSurface),
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
            SimVariant::ProbeSurface(_) => "probe-surface",
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

    /// Why the simulator of `family` refuses this variant, or `None` when
    /// it has it: `the emcu simulator has no variant `…``, and the reason
    /// where the variant gives one.
    pub fn refusal(self, family: Protocol) -> Option<String> {
        if self.applies_to(family) {
            return None;
        }
        let mut text = format!("the {family} simulator has no variant `{self}`");
        if let Some(why) = self.info().elsewhere {
            text.push_str(": ");
            text.push_str(why);
        }
        Some(text)
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
        match (info.value, value) {
            (None, Some(_)) => return Err(format!("`{}` takes no value", info.name)),
            (Some(what), None) => {
                return Err(format!(
                    "`{}` needs a value: {}={what}",
                    info.name, info.name
                ));
            }
            _ => {}
        }
        (info.make)(value).map_err(|e| format!("`{text}`: {e}"))
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
            SimVariant::ProbeSurface(s) => write!(f, "probe-surface={s}"),
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
        assert_eq!(SimVariant::of(Protocol::Emp).count(), 2);
    }

    #[test]
    fn a_probe_surface_is_a_plane_or_a_height() {
        let tilted: SimVariant = "probe-surface=8000,0.01,-0.005".parse().expect("tilted");
        let SimVariant::ProbeSurface(s) = tilted else {
            panic!("{tilted:?}")
        };
        assert_eq!((s.z0, s.gx, s.gy), (8000.0, 0.01, -0.005));
        // 8000 + 0.01 * 10000 - 0.005 * 4000 = 8080.
        assert!(s.touches(10_000.0, 4000.0, 8080.0));
        assert!(!s.touches(10_000.0, 4000.0, 8081.0));
        let flat: SimVariant = "probe-surface = -200.5".parse().expect("flat");
        assert_eq!(flat.to_string(), "probe-surface=-200.5");
        assert_eq!(
            "probe-surface=8000,-0,0".parse::<SimVariant>(),
            "probe-surface=8000".parse()
        );
        for bad in [
            "probe-surface=8000,1",
            "probe-surface=inf",
            "probe-surface=a,b,c",
            "probe-surface=1,2,3,4",
        ] {
            let err = bad.parse::<SimVariant>().unwrap_err();
            assert!(err.contains("Z0,GX,GY"), "{bad}: {err}");
        }
        assert!(
            "probe-surface"
                .parse::<SimVariant>()
                .unwrap_err()
                .contains("probe-surface=<z0>[,<gx>,<gy>]")
        );
        let why = tilted.refusal(Protocol::Emcu).expect("not for the EMCU");
        assert!(why.contains("cannot read its input E1"), "{why}");
        assert_eq!(tilted.refusal(Protocol::Emp), None);
        assert!(
            SimVariant::HoodUnwired
                .refusal(Protocol::Emp)
                .is_some_and(|w| w.ends_with("no variant `hood-unwired`"))
        );
    }
}
