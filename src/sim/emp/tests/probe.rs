//! The probe surface on an EMP link (variant `probe-surface`,
//! `docs/simulator.md`): the drive input the profile's `[io]` gives role
//! `probe` reads touched while the probing axis stands at or below the
//! surface, as `40 01` reads it (decision 5: I1-I4 in D0).

use super::harness::*;
use crate::config::{ConfigDirs, ProbeSurface, SimVariant, load_profile};
use crate::proto::emp::Frame;
use crate::sim::SimDevice;
use crate::sim::emp::{EmpSim, EmpSimError};
use crate::wiring::{BitPatch, RoleName};

const MM: f64 = 11_200.0;

/// The `emp` machine (one drive on X) standing at 21 mm, a probe on I1,
/// and a work piece at 20 mm.
fn emp_over_surface_at_20_mm() -> Conversation {
    let mut profile = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
    profile.sim.start_position = 21.0;
    profile.io.insert(
        "11.I1".into(),
        BitPatch {
            role: Some(RoleName::Probe),
            ..BitPatch::default()
        },
    );
    let surface = ProbeSurface::new(20.0 * MM, 0.0, 0.0).unwrap();
    profile.sim.variants.push(SimVariant::ProbeSurface(surface));
    Conversation::with(EmpSim::from_profile(&profile).unwrap())
}

/// `40 01` to drive 11: input I1.
fn i1(c: &mut Conversation) -> bool {
    c.send("4011010000000000");
    let frame: Frame = c.next().text.parse().unwrap();
    assert_eq!((frame.cmd, frame.info), (0x41, 0x22));
    frame.d0() & 1 != 0
}

#[test]
fn the_probe_input_follows_the_surface_as_the_axis_passes_it() {
    let mut c = emp_over_surface_at_20_mm();
    c.switch_on();
    assert!(!i1(&mut c), "1 mm above the surface");
    assert!(c.set("i1", true).unwrap_err().contains("probe surface"));
    // PV velocity mode, down at a slow speed; read I1 until it touches.
    c.exchange("2211030000000000", "2311002200000000");
    c.send("2A1100F800000000");
    assert!(c.next().text.starts_with("2B110022"));
    let mut above = c.snapshot().physical;
    let touched_at = loop {
        let touched = i1(&mut c);
        let at = c.snapshot().physical;
        if touched {
            break at;
        }
        assert!(at > 20.0 * MM, "not touched at {at}");
        above = at;
    };
    // It changed between two reads on either side of the surface.
    assert!(above > 20.0 * MM && touched_at <= 20.0 * MM + 1.0);
    assert!(
        c.sim
            .describe(c.now)
            .contains("probe surface 224000 on 11.I1: touched")
    );
    // Back up: released again.
    c.send("2A11000800000000");
    assert!(c.next().text.starts_with("2B110022"));
    c.wait(secs(1.0));
    assert!(c.snapshot().physical > 20.0 * MM);
    assert!(!i1(&mut c));
}

#[test]
fn a_surface_needs_a_probe_input_i1_to_i4() {
    let mut profile = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
    profile.sim.variants.push(
        "probe-surface=1000"
            .parse::<SimVariant>()
            .expect("a surface"),
    );
    assert!(matches!(
        EmpSim::from_profile(&profile),
        Err(EmpSimError::NoProbeInput)
    ));
    profile.io.insert(
        "11.ref".into(),
        BitPatch {
            role: Some(RoleName::Probe),
            ..BitPatch::default()
        },
    );
    let err = EmpSim::from_profile(&profile).expect_err("refused");
    assert!(err.to_string().contains("11.ref"), "{err}");
}
