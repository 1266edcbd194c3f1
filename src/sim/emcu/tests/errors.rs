//! The error flag (manual 1.5.3, decision 4): a malformed command is
//! acknowledged with CR, not executed, and sets the flag; so does a master
//! command ended by 0x01; only `@R` clears it.

use std::time::Duration;

use super::harness::Conversation;
use crate::proto::emcu::EmcuAxis;
use crate::sim::SimDevice;

const READY: &[u8] = b"\x02\r";

#[test]
fn malformed_commands_set_the_error_flag_and_move_nothing() {
    let long = format!("L1,x1{}\r", "0".repeat(40));
    let bad: Vec<&str> = vec![
        "L1,X5,y5\r",
        "l1,x5\r",
        "L0,x5\r",
        "L1,x1234567\r",
        "L1,a5\r",
        "$Hx\r",
        "$HXX\r",
        "#S0\r",
        "#E10,500\r",
        "W0\r",
        "A3,1\r",
        "&V2\r",
        "@Q\r",
        "@LA\r",
        "@X1\r",
        "L1, x5\r",
        "\x00\r",
        "\n@X\r",
        &long,
    ];
    for line in bad {
        let mut c = Conversation::referenced();
        assert_eq!(c.send(line), "<CR>", "{line:?}");
        assert_eq!(c.flags(), "001000", "{line:?}");
        // Nothing was stored either: running the memory moves nothing.
        assert_eq!(c.send("W1\x01"), "<CR>");
        assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
        for axis in EmcuAxis::ALL {
            assert_eq!(c.position(axis), 0, "{line:?}");
        }
        assert!(
            c.sim.describe(c.now).contains("| error: refused `"),
            "{}",
            c.sim.describe(c.now)
        );
    }
}

#[test]
fn a_refused_last_line_starts_nothing_and_says_so() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x100\r"), "<CR>");
    assert_eq!(c.send("L1,x100,x5\x01"), "<CR><02><CR>");
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.flags(), "001000");
    // The stored command is still there and runs with the next batch.
    assert_eq!(c.send("L1,x1\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 101);
}

#[test]
fn a_master_command_ended_by_0x01_is_not_executed() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x1000\x01"), "<CR>");
    c.wait(Duration::from_secs(1));
    // Neither a halt nor a query: acknowledged with CR, flagged.
    assert_eq!(c.send("@B\x01"), "<CR>");
    assert_eq!(c.send("@X\x01"), "<CR>");
    assert_eq!(c.flags(), "101001");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 1000);
    // With no job running, the refused 0x01 line sends 0x02 CR at once.
    assert_eq!(c.send("@R\x01"), "<CR><02><CR>");
    assert_eq!(c.flags(), "001000");
}

#[test]
fn only_reset_clears_the_error_flag() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@Z\r"), "<CR>");
    for line in ["@B\r", "@S\r", "@C\r", "@A\r"] {
        assert_eq!(c.send(line), "<CR>");
        assert!(c.status().error, "{line:?}");
    }
    assert_eq!(c.send("$HXYZ\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(10)).is_some());
    assert!(c.status().error, "a reference run does not clear it");
    assert_eq!(c.send("@R\r"), "<CR>");
    assert_eq!(c.flags(), "000100");
}

#[test]
fn an_empty_line_is_acknowledged_and_no_error() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("\r"), "<CR>");
    assert_eq!(c.flags(), "000000");
    // A bare 0x01 is no command that could start the memory.
    assert_eq!(c.send("\x01"), "<CR><02><CR>");
    assert_eq!(c.flags(), "001000");
}

#[test]
fn errors_during_a_move_leave_it_running() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x2000\x01"), "<CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("garbage\r"), "<CR>");
    assert_eq!(c.flags(), "101001");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 2000);
}
