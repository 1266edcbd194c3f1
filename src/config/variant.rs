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

/// A simulated work piece under the probe, in machine steps (counts): x,
/// y, z are the axes' positions in machine coordinates, Z+ up, away from
/// the work, as the profiles' Z limits and G-code's safe height have it.
/// The probe touches while its tip stands inside material
/// (`probe-surface=Z0[,GX,GY]`, `block:X0,X1,Y0,Y1,TOP`, `bore:CX,CY,R,TOP`).
///
/// Every number is finite and none is -0 (the constructors see to it), so
/// that equal surfaces print, compare and hash alike.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProbeSurface {
    /// Material at and below the plane `z = z0 + gx·x + gy·y`: a surface
    /// to touch off Z on, or, steep, a wall to find an edge on.
    Plane { z0: f64, gx: f64, gy: f64 },
    /// A rectangular block of stock, `x0 ≤ x ≤ x1`, `y0 ≤ y ≤ y1`,
    /// `z ≤ top`: faces and corners to probe from outside.
    Block {
        x0: f64,
        x1: f64,
        y0: f64,
        y1: f64,
        top: f64,
    },
    /// Stock up to `top` with a round bore of radius `r` around `cx`,
    /// `cy` (through, however deep the probe goes): walls to probe from
    /// inside.
    Bore { cx: f64, cy: f64, r: f64, top: f64 },
}

/// The forms a surface is written in, for the errors that list them.
const SURFACE_FORMS: &str = "Z0 (steps, a flat plane), Z0,GX,GY (steps and the slopes in X and \
     Y, steps per step), block:X0,X1,Y0,Y1,TOP or bore:CX,CY,R,TOP (steps)";

/// Finite, and +0 for -0, or `None`.
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v + 0.0)
}

impl ProbeSurface {
    /// A plane from finite numbers.
    pub fn new(z0: f64, gx: f64, gy: f64) -> Option<ProbeSurface> {
        Some(ProbeSurface::Plane {
            z0: finite(z0)?,
            gx: finite(gx)?,
            gy: finite(gy)?,
        })
    }

    /// A block from finite numbers, each range in order.
    pub fn block(x0: f64, x1: f64, y0: f64, y1: f64, top: f64) -> Option<ProbeSurface> {
        let (x0, x1, y0, y1) = (finite(x0)?, finite(x1)?, finite(y0)?, finite(y1)?);
        (x0 <= x1 && y0 <= y1).then_some(ProbeSurface::Block {
            x0,
            x1,
            y0,
            y1,
            top: finite(top)?,
        })
    }

    /// A bore from finite numbers and a radius more than 0.
    pub fn bore(cx: f64, cy: f64, r: f64, top: f64) -> Option<ProbeSurface> {
        let r = finite(r).filter(|r| *r > 0.0)?;
        Some(ProbeSurface::Bore {
            cx: finite(cx)?,
            cy: finite(cy)?,
            r,
            top: finite(top)?,
        })
    }

    /// The top of the material over `x`, `y`; `None` where there is none
    /// (beside a block, inside a bore).
    pub fn height_at(&self, x: f64, y: f64) -> Option<f64> {
        match *self {
            ProbeSurface::Plane { z0, gx, gy } => Some(z0 + gx * x + gy * y),
            ProbeSurface::Block {
                x0,
                x1,
                y0,
                y1,
                top,
            } => ((x0..=x1).contains(&x) && (y0..=y1).contains(&y)).then_some(top),
            ProbeSurface::Bore { cx, cy, r, top } => {
                ((x - cx).powi(2) + (y - cy).powi(2) >= r * r).then_some(top)
            }
        }
    }

    /// Whether the probe touches with the axes at `x`, `y`, `z`.
    pub fn touches(&self, x: f64, y: f64, z: f64) -> bool {
        self.height_at(x, y).is_some_and(|top| z <= top)
    }

    /// Whether the material's top is level wherever there is material
    /// (a block's and a bore's always are).
    pub fn is_flat(&self) -> bool {
        match *self {
            ProbeSurface::Plane { gx, gy, .. } => gx == 0.0 && gy == 0.0,
            ProbeSurface::Block { .. } | ProbeSurface::Bore { .. } => true,
        }
    }

    /// Whether it is a plane, which a straight line crosses at most once
    /// (its material and its air are both convex); a block's air and a
    /// bore's material are not, so a line can pass in and out again.
    pub fn is_plane(&self) -> bool {
        matches!(self, ProbeSurface::Plane { .. })
    }

    /// The same work piece `dz` steps higher (a longer tool meets it with
    /// the carriage that much higher).
    pub fn raised(self, dz: f64) -> ProbeSurface {
        match self {
            ProbeSurface::Plane { z0, gx, gy } => ProbeSurface::Plane {
                z0: z0 + dz,
                gx,
                gy,
            },
            ProbeSurface::Block {
                x0,
                x1,
                y0,
                y1,
                top,
            } => ProbeSurface::Block {
                x0,
                x1,
                y0,
                y1,
                top: top + dz,
            },
            ProbeSurface::Bore { cx, cy, r, top } => ProbeSurface::Bore {
                cx,
                cy,
                r,
                top: top + dz,
            },
        }
    }

    /// Its numbers, in the order they are written.
    fn numbers(&self) -> Vec<f64> {
        match *self {
            ProbeSurface::Plane { z0, gx, gy } => vec![z0, gx, gy],
            ProbeSurface::Block {
                x0,
                x1,
                y0,
                y1,
                top,
            } => vec![x0, x1, y0, y1, top],
            ProbeSurface::Bore { cx, cy, r, top } => vec![cx, cy, r, top],
        }
    }

    fn parse(value: &str) -> Result<ProbeSurface, String> {
        let lower = value.trim().to_ascii_lowercase();
        if let Some(rest) = lower.strip_prefix("block:") {
            let block = match numbers(rest).as_deref() {
                Some(&[x0, x1, y0, y1, top]) => ProbeSurface::block(x0, x1, y0, y1, top),
                _ => None,
            };
            return block.ok_or_else(|| {
                "a block is block:X0,X1,Y0,Y1,TOP, finite numbers of steps with X0 <= X1 and \
                 Y0 <= Y1, such as block:12000,24000,8000,20000,8000"
                    .into()
            });
        }
        if let Some(rest) = lower.strip_prefix("bore:") {
            let bore = match numbers(rest).as_deref() {
                Some(&[cx, cy, r, top]) => ProbeSurface::bore(cx, cy, r, top),
                _ => None,
            };
            return bore.ok_or_else(|| {
                "a bore is bore:CX,CY,R,TOP, finite numbers of steps and a radius R more than \
                 0, such as bore:16000,12000,3200,8000"
                    .into()
            });
        }
        let plane = match numbers(&lower).as_deref() {
            Some(&[z0]) => ProbeSurface::new(z0, 0.0, 0.0),
            Some(&[z0, gx, gy]) => ProbeSurface::new(z0, gx, gy),
            _ => None,
        };
        plane.ok_or_else(|| format!("the surface is {SURFACE_FORMS}; such as 8000,0.01,-0.005"))
    }
}

/// The comma-separated numbers of `text`, or `None` if one is not a number.
fn numbers(text: &str) -> Option<Vec<f64>> {
    text.split(',').map(|n| n.trim().parse().ok()).collect()
}

/// Finite and without -0: equality is a true equivalence and agrees with
/// the hash of the bits.
impl Eq for ProbeSurface {}

impl std::hash::Hash for ProbeSurface {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        std::mem::discriminant(self).hash(state);
        for v in self.numbers() {
            v.to_bits().hash(state);
        }
    }
}

/// What [`ProbeSurface::parse`] reads back: `f64`'s `Display` is the
/// shortest text that parses to the same number.
impl fmt::Display for ProbeSurface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |v: Vec<f64>| v.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        match *self {
            ProbeSurface::Plane { z0, .. } if self.is_flat() => write!(f, "{z0}"),
            ProbeSurface::Plane { .. } => f.write_str(&list(self.numbers())),
            ProbeSurface::Block { .. } => write!(f, "block:{}", list(self.numbers())),
            ProbeSurface::Bore { .. } => write!(f, "bore:{}", list(self.numbers())),
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
        value: Some("<z0>[,<gx>,<gy>]|block:<x0>,<x1>,<y0>,<y1>,<top>|bore:<cx>,<cy>,<r>,<top>"),
        help: "a work piece that the probe input follows (machine steps): the plane \
               z = z0 + gx*x + gy*y, a block x0..x1, y0..y1 up to top, or stock up to top with \
               a bore of radius r around cx, cy (isel in1.5; EMP the drive input the profile's \
               [io] gives role probe)",
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
        assert_eq!(s, ProbeSurface::new(8000.0, 0.01, -0.005).expect("a plane"));
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
        // A plane's top over every point; the tool one millimetre longer
        // meets it one millimetre (400 steps) higher.
        assert_eq!(s.height_at(10_000.0, 4000.0), Some(8080.0));
        assert_eq!(s.raised(400.0).height_at(10_000.0, 4000.0), Some(8480.0));
        assert!(!s.is_flat() && s.is_plane());
        let why = tilted.refusal(Protocol::Emcu).expect("not for the EMCU");
        assert!(why.contains("cannot read its input E1"), "{why}");
        assert_eq!(tilted.refusal(Protocol::Emp), None);
        assert!(
            SimVariant::HoodUnwired
                .refusal(Protocol::Emp)
                .is_some_and(|w| w.ends_with("no variant `hood-unwired`"))
        );
    }

    fn surface(text: &str) -> ProbeSurface {
        match format!("probe-surface={text}").parse::<SimVariant>() {
            Ok(SimVariant::ProbeSurface(s)) => s,
            other => panic!("{text}: {other:?}"),
        }
    }

    #[test]
    fn a_block_is_material_inside_its_footprint_up_to_its_top() {
        let block = surface("block:12000,24000,8000,20000,8000");
        assert_eq!(
            block,
            ProbeSurface::block(12000.0, 24000.0, 8000.0, 20000.0, 8000.0).expect("a block")
        );
        // Its faces and top belong to it, the step beside them does not.
        assert!(block.touches(12000.0, 8000.0, 8000.0));
        assert!(block.touches(24000.0, 20000.0, -1e6));
        assert!(!block.touches(11999.0, 10000.0, 6000.0));
        assert!(!block.touches(15000.0, 7999.0, 6000.0));
        assert!(!block.touches(24001.0, 10000.0, 6000.0));
        assert!(!block.touches(15000.0, 10000.0, 8001.0));
        assert_eq!(block.height_at(15000.0, 10000.0), Some(8000.0));
        assert_eq!(block.height_at(0.0, 0.0), None);
        assert!(block.raised(400.0).touches(15000.0, 10000.0, 8400.0));
        assert!(block.is_flat() && !block.is_plane());
    }

    #[test]
    fn a_bore_is_material_outside_its_circle_up_to_the_top() {
        let bore = surface("bore:16000,12000,3200,8000");
        assert_eq!(
            bore,
            ProbeSurface::bore(16000.0, 12000.0, 3200.0, 8000.0).expect("a bore")
        );
        // Inside the circle there is air however deep; its wall is material.
        assert!(!bore.touches(16000.0, 12000.0, -1e6));
        assert!(!bore.touches(19199.0, 12000.0, 6000.0));
        assert!(bore.touches(19200.0, 12000.0, 6000.0));
        assert!(bore.touches(16000.0, 8800.0, 6000.0));
        // 3-4-5: on the circle off both axes.
        assert!(bore.touches(16000.0 + 1920.0, 12000.0 - 2560.0, 8000.0));
        assert!(!bore.touches(16000.0 + 1919.0, 12000.0 - 2559.0, 8000.0));
        assert!(!bore.touches(30000.0, 12000.0, 8001.0));
        assert_eq!(bore.height_at(0.0, 0.0), Some(8000.0));
        assert_eq!(bore.raised(-100.0).height_at(0.0, 0.0), Some(7900.0));
    }

    #[test]
    fn every_surface_prints_what_parses_back_to_it() {
        for text in [
            "8000",
            "-200.5",
            "8000,0.01,-0.005",
            "block:12000,24000,8000,20000,8000",
            "block:-1.5,0,0,0,0.25",
            "bore:16000,12000,3200,8000",
            "bore:0,-0.5,0.1,-300",
        ] {
            let s = surface(text);
            assert_eq!(s.to_string(), text);
            assert_eq!(surface(&s.to_string()), s);
        }
        // -0 is 0, and spaces and case do not matter: the same surface,
        // the same hash.
        use std::collections::HashSet;
        let same = [surface("block:-0,1,2,3,4"), surface(" Block: 0 , 1,2,3,4")];
        assert_eq!(same[0], same[1]);
        assert_eq!(same.iter().collect::<HashSet<_>>().len(), 1);
        assert_eq!(same[0].to_string(), "block:0,1,2,3,4");
        assert_eq!(surface("bore:-0,0,1,-0").to_string(), "bore:0,0,1,0");
    }

    #[test]
    fn bad_blocks_and_bores_say_their_form() {
        for bad in [
            "block:1,2,3,4",
            "block:2,1,0,1,0",
            "block:0,1,1,0,0",
            "block:0,1,0,1,inf",
            "block:",
        ] {
            let err = format!("probe-surface={bad}")
                .parse::<SimVariant>()
                .unwrap_err();
            assert!(err.contains("block:X0,X1,Y0,Y1,TOP"), "{bad}: {err}");
        }
        for bad in [
            "bore:0,0,0,0",
            "bore:0,0,-1,0",
            "bore:0,0,1",
            "bore:a,0,1,0",
        ] {
            let err = format!("probe-surface={bad}")
                .parse::<SimVariant>()
                .unwrap_err();
            assert!(err.contains("bore:CX,CY,R,TOP"), "{bad}: {err}");
        }
        // An unknown shape is read as a plane, whose error lists them all.
        let err = "probe-surface=cube:1,2".parse::<SimVariant>().unwrap_err();
        assert!(
            err.contains("Z0,GX,GY") && err.contains("block:") && err.contains("bore:"),
            "{err}"
        );
    }
}
