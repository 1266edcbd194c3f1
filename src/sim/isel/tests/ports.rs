//! Ports, outputs, diagnosis, brake (isel manual 2.2.3, 2.2.4, 2.2.6,
//! 2.2.10; decision 7).

use super::Conv;
use crate::sim::InputControl;
use crate::sim::SimDevice;

#[test]
fn input_ports_read_what_the_operator_set() {
    let mut c = Conv::new();
    assert_eq!(c.ask("@0b0"), "000");
    assert_eq!(c.ask("@0b1"), "003");
    assert_eq!(c.ask("@0b2"), "062");
    assert_eq!(c.ask("@0b3"), "000");
    c.set("in0.3", true);
    c.set("in0.7", true);
    assert_eq!(c.ask("@0b0"), "088");
    c.set("probe", true);
    c.set("overtemp", true);
    assert_eq!(c.ask("@0b1"), "027");
    c.set("power-ok", false);
    assert_eq!(c.ask("@0b2"), "060");
    c.set("limit-z2", true);
    c.set("limit-a1", true);
    assert_eq!(c.ask("@0b3"), "060");
    c.expect("@0b4", "1");
}

#[test]
fn outputs_are_written_and_the_spindle_shows_on_port_2() {
    let mut c = Conv::new();
    c.expect("@0B2,1", "0");
    assert_eq!(c.ask("@0b2"), "063");
    c.expect("@0B100,0", "0");
    assert_eq!(c.ask("@0b2"), "062", "port 100 bit 4 is the same spindle");
    c.expect("@0B100,16", "0");
    assert_eq!(c.ask("@0b2"), "063");
    c.expect("@0B2,2", "1");
    c.expect("@0B7,1", "1");
    c.expect("@0B0,255", "0");
    c.expect("@0B4,128", "0");
    c.expect("@0B101,32", "0");
    c.expect("@0g1", "0");
    let line = c.sim.describe(c.now);
    assert!(line.contains("out user FF control 50"), "{line}");
    // The user outputs are not wired back to the user inputs.
    assert_eq!(c.ask("@0b0"), "000");
}

#[test]
fn diagnosis_reads_the_monitored_limit_switches() {
    let mut c = Conv::new();
    c.set("limit-x2", true);
    assert_eq!(c.ask("@0DRp"), "001");
    c.expect("@07", "0");
    assert_eq!(c.ask("@0DRp"), "001");
    assert_eq!(c.ask("@0DRn"), "000");
    c.set("limit-z1", true);
    assert_eq!(c.ask("@0DRn"), "004");
    // An undocumented code reads 0.
    assert_eq!(c.ask("@0DS0"), "000");
    // `@0IE`: a disabled switch is not monitored, a low-active one reads
    // active while released.
    c.expect("@0IE13105", "0");
    assert_eq!(c.ask("@0DRp"), "000");
    c.expect("@0IE13111", "0");
    assert_eq!(c.ask("@0b3"), "013");
}

#[test]
fn swapped_switch_inputs_follow_the_carriage() {
    let mut c = Conv::referenced();
    c.expect("@0T1", "0");
    c.expect_after(
        "@0A-1000,2000,0,100,0,100,0,100",
        "0",
        std::time::Duration::from_secs(10),
    );
    assert_eq!(c.ask("@0b3"), "001");
    c.expect("@0Ie1", "0");
    assert_eq!(c.ask("@0b3"), "002");
}

#[test]
fn unknown_inputs_and_buttons_are_refused_with_the_names() {
    let mut c = Conv::new();
    let err = c
        .sim
        .control(
            &InputControl::Set {
                name: "door".into(),
                level: true,
            },
            c.now,
        )
        .expect_err("unknown");
    assert!(err.contains("limit-x1") && err.contains("in0.7"), "{err}");
    let err = c
        .sim
        .control(
            &InputControl::Press {
                name: "hood".into(),
            },
            c.now,
        )
        .expect_err("not a button");
    assert!(err.contains("set hood"), "{err}");
    assert_eq!(c.sim.input_names().len(), 25);
}

#[test]
fn input_levels_are_what_the_operator_set() {
    let mut c = Conv::new();
    let level = |c: &Conv, name: &str| c.sim.input_level(name);
    assert_eq!(level(&c, "estop1"), Some(true), "circuits rest closed");
    assert_eq!(level(&c, "hood"), Some(true));
    assert_eq!(level(&c, "power-ok"), Some(true));
    assert_eq!(level(&c, "limit-x1"), Some(false));
    assert_eq!(level(&c, "in0.7"), Some(false));
    c.set("estop1", false);
    c.set("LIMIT-Z2", true);
    c.set("in0.7", true);
    c.set("key-switch", true);
    assert_eq!(level(&c, "estop1"), Some(false));
    assert_eq!(level(&c, "limit-z2"), Some(true));
    assert_eq!(level(&c, "in0.7"), Some(true));
    assert_eq!(level(&c, "key-switch"), Some(true));
    assert_eq!(level(&c, "door"), None);
    for name in c.sim.input_names() {
        assert!(level(&c, name).is_some(), "{name} has a level");
    }
}
