//! Master commands (manual 1.4.2, 1.5.1-1.5.4): answered at once, also while
//! the axes move; positions readable during a move.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::proto::emcu::EmcuAxis;
use crate::sim::SimDevice;
use crate::sim::emcu::EmcuSim;

#[test]
fn at_power_up_the_counters_are_zero_and_the_position_unknown() {
    let mut c = Conversation::new();
    assert_eq!(c.send("@X\r"), "@X000100<CR>");
    assert_eq!(c.send("@LX\r"), "@LX0<CR>");
    assert_eq!(c.send("@LY\r"), "@LY0<CR>");
    assert_eq!(c.send("@LZ\r"), "@LZ0<CR>");
    // The carriages stand where the machine was left (40 mm at 200 steps/mm).
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 8_000);
}

#[test]
fn version_is_the_manuals() {
    let mut c = Conversation::new();
    assert_eq!(c.send("@V\r"), "@V SMC3000i 1.00<CR>");
}

#[test]
fn the_line_is_19200_8n1() {
    let sim = EmcuSim::new(Default::default());
    assert_eq!(sim.line().baud, 19200);
    assert_eq!(sim.line().byte_time().as_micros(), 520);
}

#[test]
fn every_master_command_is_answered_as_its_line_ends_also_during_a_move() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x5000\x01"), "<CR>");
    assert_eq!(c.wait(Duration::from_secs(1)), "");
    for (line, answer) in [
        ("@V\r", "@V SMC3000i 1.00<CR>"),
        ("@X\r", "@X100101<CR>"),
        ("@LY\r", "@LY0<CR>"),
        ("@A\r", "<CR>"),
        ("@C\r", "<CR>"),
        ("@F\r", "<CR>"),
    ] {
        let sent_at = c.elapsed();
        assert_eq!(c.send(line), answer, "{line:?}");
        let (answered_at, _) = c.log.last().cloned().unwrap();
        // The answer leaves as the CR has arrived: one byte time per byte.
        let line_time = c.sim.line().byte_time() * line.len() as u32;
        assert_eq!(answered_at - sent_at, line_time, "{line:?}");
    }
    // `@LX` follows the axis.
    let a = c.position(EmcuAxis::X);
    c.wait(ms(100));
    let b = c.position(EmcuAxis::X);
    assert!(b > a, "{a} then {b}");
    assert_eq!(c.send("@S\r"), "<CR><02><CR>");
}

#[test]
fn position_read_during_a_move_rises_monotonically_and_ends_at_the_target() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x1000\x01"), "<CR>");
    let trace = c.trace(EmcuAxis::X, ms(20), Duration::from_secs(5));
    assert!(
        trace.windows(2).all(|w| w[0] <= w[1]),
        "not monotonic: {trace:?}"
    );
    let mut distinct = trace.clone();
    distinct.dedup();
    assert!(distinct.len() > 50, "too few readings: {trace:?}");
    assert_eq!(trace.last(), Some(&1000));
    assert_eq!(c.times_of(b"\x02\r").len(), 1);
    assert_eq!(c.flags(), "000100");
}

#[test]
fn negative_positions_are_reported_with_a_minus() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,y-1234\x01"), "<CR>");
    assert!(c.wait_for(b"\x02\r", Duration::from_secs(5)).is_some());
    assert_eq!(c.send("@LY\r"), "@LY-1234<CR>");
}
