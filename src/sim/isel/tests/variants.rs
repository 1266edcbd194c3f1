//! The controller variants (`config::variant`, `docs/simulator.md`): a
//! machine without a hood circuit, a controller without port 2, one whose
//! `@0P` counts from the virtual zero; and the default hood circuit, which
//! the controller supervises as its `@0IH` watch says (manual 4.2.13).

use std::time::Duration;

use super::{Conv, default_config};
use crate::config::SimVariant;
use crate::sim::{InputControl, SimDevice};

fn with(variant: SimVariant) -> Conv {
    Conv::with(default_config().with_variant(variant))
}

fn referenced(mut c: Conv) -> Conv {
    c.expect("@07", "0");
    c.expect_after("@0R7", "0", Duration::from_secs(60));
    c
}

const MOVE: &str = "@0A1000,2000,0,2000,0,2000,0,2000";

#[test]
fn without_a_hood_circuit_its_bits_read_0_and_the_controller_moves() {
    let mut c = referenced(with(SimVariant::HoodUnwired));
    // Spindle feedback off, power ok; hood and key-switch bits 0.
    assert_eq!(c.ask("@0b2"), "002");
    c.expect_after(MOVE, "0", Duration::from_secs(5));
    c.expect("@0B2,1", "0");
    assert_eq!(c.ask("@0b2"), "003");
    let err = c
        .sim
        .control(
            &InputControl::Set {
                name: "hood".into(),
                level: false,
            },
            c.now,
        )
        .unwrap_err();
    assert!(err.contains("no hood circuit"), "{err}");
    assert!(!c.sim.input_names().contains(&"hood"));
    assert_eq!(c.sim.input_level("hood"), None);
    // A hood supervision switched on where nothing is wired: the
    // controller refuses, as a real one set up so would.
    c.expect("@0IH2,64,64", "0");
    c.expect(MOVE, "H");
}

#[test]
fn with_a_hood_circuit_the_watch_decides_and_can_be_switched_off() {
    let mut c = Conv::referenced();
    c.set("hood", false);
    assert_eq!(c.ask("@0b2"), "002");
    c.expect(MOVE, "H");
    // Setup mode: bit 6 reads 1, the watch is on target.
    c.set("key-switch", true);
    c.expect_after(MOVE, "0", Duration::from_secs(5));
    c.set("key-switch", false);
    // Mask 0: the supervision is off (manual 4.2.13).
    c.expect("@0IH0,0,0", "0");
    c.expect_after(MOVE, "0", Duration::from_secs(5));
    // `@0IX` brings the factory watch back: a reference run needs the
    // hood closed again.
    c.expect("@0IX", "0");
    c.expect("@07", "0");
    c.expect("@0R7", "H");
}

#[test]
fn without_port_2_its_read_answers_1() {
    let mut c = referenced(with(SimVariant::NoPort2));
    c.expect("@0b2", "1");
    assert_eq!(c.ask("@0b1"), "003");
    c.expect_after(MOVE, "0", Duration::from_secs(5));
}

#[test]
fn work_positions_count_from_the_virtual_zero() {
    let mut c = referenced(with(SimVariant::WorkPositions));
    c.expect_after(MOVE, "0", Duration::from_secs(5));
    assert_eq!(c.ask("@0P"), "00003E8000000000000");
    c.expect("@0n7", "0");
    assert_eq!(c.ask("@0P"), "0000000000000000000");
    // Absolute moves count from the virtual zero, as on every iMC.
    c.expect_after(
        "@0M500,2000,0,2000,0,2000,0,2000",
        "0",
        Duration::from_secs(5),
    );
    assert_eq!(c.ask("@0P"), "00001F4000000000000");
    let mut plain = Conv::referenced();
    plain.expect_after(MOVE, "0", Duration::from_secs(5));
    plain.expect("@0n7", "0");
    assert_eq!(plain.ask("@0P"), "00003E8000000000000");
}
