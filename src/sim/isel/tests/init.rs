//! Axis initialisation, device numbers, positions (isel manual 2.2.1,
//! 2.2.11, 2.2.21; decisions 1-4).

use std::time::Duration;

use super::Conv;
use crate::sim::SimDevice;

#[test]
fn power_up_needs_axes_then_a_reference() {
    let mut c = Conv::new();
    c.expect("@0A100,900,0,900,0,900,0,900", "4");
    c.expect("@0R7", "4");
    c.expect("@07", "0");
    c.expect("@0A100,900,0,900,0,900,0,900", "R");
    c.expect("@0M100,900,0,900,0,900,0,900", "R");
    c.expect("@0y400,1500,119,-141,141,-1,-1", "R");
    c.expect("@0Z0,4,4,600,0,0,3000", "R");
    // Nothing moved.
    assert_eq!(c.position(), [0, 0, 0]);
}

#[test]
fn bad_axis_settings_and_masks_answer_3() {
    let mut c = Conv::new();
    for bad in ["@00", "@02", "@04", "@06", "@09", "@08"] {
        c.expect(bad, "3");
    }
    c.expect("@03", "0");
    c.expect("@08", "3");
    c.expect("@0R4", "3");
    c.expect("@0N4", "3");
    c.expect("@07", "0");
    c.expect("@0R8", "3");
    c.expect("@08", "0");
    c.expect("@0R9", "3");
    c.expect("@0n15", "3");
    // Parameter counts follow the axes (decision 5).
    c.expect("@0A100,900,0,900,0,900", "7");
    c.expect("@0A100,900,0,900,0,900,0,0", "D");
}

#[test]
fn the_position_reply_of_decision_2() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    // Test mode: `R` takes the current point as reference, no motion,
    // and switches may be overrun (manual 2.2.24).
    c.expect("@0T1", "0");
    c.expect("@0R7", "0");
    c.expect_after(
        "@0A256,40000,131087,40000,-2,1000,0,1000",
        "0",
        Duration::from_secs(10),
    );
    c.expect("@0P", "000010002000FFFFFFE");
    c.expect("@08", "0");
    c.expect("@0R8", "0");
    c.expect_after(
        "@0A2560,40000,147441,40000,4096,40000,12352,40000",
        "0",
        Duration::from_secs(10),
    );
    c.expect("@0P", "0000B00044000000FFE003040");
}

#[test]
fn frames_for_other_devices_are_ignored() {
    let mut c = Conv::new();
    c.expect("@0G2", "0");
    c.send("@0P");
    c.silent_for(Duration::from_millis(50));
    // A broken frame for another device gets no answer either.
    c.send("@0Q");
    c.silent_for(Duration::from_millis(50));
    c.expect("@2P", "0000000000000000000");
    c.expect("@2Q", "5");
    // A line that names no device is answered: it cannot be anyone else's.
    c.expect("P", "5");
    c.expect("@2G0", "0");
    c.expect("@0P", "0000000000000000000");
}

#[test]
fn optional_spaces_and_lf_are_accepted() {
    let mut c = Conv::new();
    c.send_bytes(b"@07\r\n");
    assert_eq!(c.take(), "0");
    c.expect("@0N 7", "0");
    c.send_bytes(b"@0P\r\n@0P\r");
    assert_eq!(c.take(), "0".repeat(38));
}

#[test]
fn the_line_rate_changes_only_at_the_next_power_up() {
    let mut c = Conv::new();
    assert_eq!(c.sim.line().baud, 19200);
    c.expect("@0IC1", "0");
    let now = c.now;
    c.sim.power_cycle(now);
    assert_eq!(c.sim.line().baud, 19200, "not stored in flash");
    c.expect("@0IC1", "0");
    c.expect("@0IW", "0");
    // A reset (0xFE) is no power-up for the serial interface.
    c.send_bytes(&[0xFE]);
    assert_eq!(c.sim.line().baud, 19200);
    let now = c.now;
    c.sim.power_cycle(now);
    assert_eq!(c.sim.line().baud, 9600);
    assert!(c.sim.flash().init.baud_9600);
}

#[test]
fn init_values_live_in_flash() {
    let mut c = Conv::new();
    c.expect("@0IUjogterm test bench", "0");
    c.expect("@0Id1000,900,500,900", "0");
    let now = c.now;
    c.sim.power_cycle(now);
    c.send("@0U");
    c.wait(Duration::from_millis(1));
    assert_eq!(c.take(), "\r\n", "not stored: the user info is empty again");
    c.expect("@0IUjogterm test bench", "0");
    c.expect("@0IW", "0");
    c.expect("@0IUsomething else", "0");
    c.expect("@0IL", "0");
    c.send("@0U");
    c.wait(Duration::from_millis(1));
    assert_eq!(c.take(), "jogterm test bench\r\n");
    // `IX` restores the built-in values and loses the reference.
    c.expect("@07", "0");
    c.expect("@0N7", "0");
    c.expect("@0IX", "0");
    c.expect("@0A1,100,0,100,0,100,0,100", "R");
    c.send("@0U");
    c.wait(Duration::from_millis(1));
    assert_eq!(c.take(), "\r\n");
    let now = c.now;
    c.sim.power_cycle(now);
    c.send("@0U");
    c.wait(Duration::from_millis(1));
    assert_eq!(
        c.take(),
        "jogterm test bench\r\n",
        "the flash kept its copy"
    );
}

#[test]
fn io_only_mode_drives_no_axes() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.expect("@0IO1", "0");
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
    c.expect("@07", "3");
    c.expect("@0b1", "003");
    c.expect("@0IO0", "0");
    c.expect("@07", "0");
}

#[test]
fn describe_is_one_line() {
    let mut c = Conv::referenced();
    c.send("@0A4000,4000,0,100,0,100,0,100");
    c.wait(Duration::from_millis(100));
    let line = c.sim.describe(c.now);
    assert!(!line.contains('\n'), "{line}");
    assert!(line.contains("moving"), "{line}");
    assert!(line.contains("referenced XYZ"), "{line}");
    let before = Conv::new().sim.describe(c.t0);
    assert!(before.contains("physical X 16000"), "{before}");
}
