//! Halt `@B`, stop `@S`, reset `@R`, pause `@A` and resume `@C` (manual
//! 1.5.1, 1.5.11-1.5.14, decision 5), and the 0x02 CR that ends a job
//! however it ends.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::motion::Ramp;
use crate::proto::emcu::job::DATA_MEMORY_CAPACITY;
use crate::proto::emcu::{EmcuAxis, Output};
use crate::sim::SimDevice;

const READY: &[u8] = b"\x02\r";
const X: EmcuAxis = EmcuAxis::X;

fn default_ramp() -> Ramp {
    Ramp {
        start_hz: 200.0,
        max_hz: 600.0,
        accel_hz_per_s: 800.0,
    }
}

/// A long move with another command queued behind it, cruising at 600 Hz.
fn long_job(c: &mut Conversation) {
    assert_eq!(c.send("L1,x10000\r"), "<CR>");
    assert_eq!(c.send("L1,x5\x01"), "<CR>");
    c.wait(Duration::from_secs(2));
}

#[test]
fn halt_mid_move_ramps_down_over_the_braking_distance_and_keeps_the_position() {
    let mut c = Conversation::referenced();
    long_job(&mut c);
    assert_eq!(c.send("@B\r"), "<CR>");
    let halted = c.elapsed();
    let at_halt = c.sim.counter(X, c.now);
    // Still moving while it ramps down; the job ends at rest.
    assert_eq!(c.flags(), "100001");
    let ready = c.wait_for(READY, Duration::from_secs(2)).unwrap();
    let ramp = default_ramp();
    assert!(
        (ready - halted).abs_diff(ramp.braking_time(600.0)) < Duration::from_micros(10),
        "{:?}",
        ready - halted
    );
    let stopped = c.position(X);
    let braking = f64::from(stopped - at_halt);
    assert!(
        (braking - ramp.braking_distance(600.0)).abs() <= 1.0,
        "braked over {braking} steps"
    );
    // Positions kept; the rest of the job is gone.
    assert_eq!(c.flags(), "000000");
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.position(X), stopped);
    assert_eq!(c.times_of(READY).len(), 2, "homing and this job");
}

#[test]
fn stop_mid_move_stops_at_once_loses_the_position_and_clears_the_memory() {
    let mut c = Conversation::referenced();
    long_job(&mut c);
    assert_eq!(c.send("@S\r"), "<CR><02><CR>");
    let at = c.sim.counter(X, c.now);
    assert_eq!(c.flags(), "000100");
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.position(X), at);
    // The queued move is gone: a new batch runs only itself.
    assert_eq!(c.send("L1,x10\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    assert_eq!(c.position(X), at + 10);
    assert_eq!(c.flags(), "000100", "unknown until a reference run");
    assert_eq!(c.send("$HX\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(100)).is_some());
    assert_eq!(c.flags(), "000000");
}

#[test]
fn reset_stops_zeroes_the_counters_and_keeps_the_configuration() {
    let mut c = Conversation::referenced();
    assert_eq!(
        c.send("#S400\r#E1,400\rA1,1\rL1,x400\x01"),
        "<CR><CR><CR><CR>"
    );
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert!(c.sim.output(Output::new(1).unwrap()));
    assert_eq!(c.send("L1,y4000\r"), "<CR>");
    assert_eq!(c.send("L1,y1\x01"), "<CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("L1,X5,y5\r"), "<CR>", "refused: sets the error flag");
    assert_eq!(c.flags(), "101001");
    assert_eq!(c.send("@R\r"), "<CR><02><CR>");
    let machine_y = c.sim.machine_position(EmcuAxis::Y, c.now);
    // Error cleared, position unknown, counters 0, outputs off.
    assert_eq!(c.flags(), "000100");
    for axis in EmcuAxis::ALL {
        assert_eq!(c.position(axis), 0);
    }
    assert!(!c.sim.output(Output::new(1).unwrap()));
    // The carriage stays where it stopped; nothing else moves on.
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.sim.machine_position(EmcuAxis::Y, c.now), machine_y);
    // Start and end speed kept: 400 steps at 400 Hz take a second.
    assert_eq!(c.send("L1,x400\x01"), "<CR>");
    let sent = c.elapsed();
    let ready = c.wait_for(READY, Duration::from_secs(2)).unwrap();
    assert!((ready - sent).abs_diff(Duration::from_secs(1)) < Duration::from_micros(10));
}

#[test]
fn stops_without_a_job_send_no_ready() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@B\r"), "<CR>");
    assert_eq!(c.send("@S\r"), "<CR>");
    assert_eq!(c.send("@R\r"), "<CR>");
    assert_eq!(c.wait(ms(100)), "");
}

#[test]
fn a_stop_while_room_is_owed_sends_both_readies() {
    let mut c = Conversation::referenced();
    for _ in 1..DATA_MEMORY_CAPACITY {
        c.send("W100\r");
    }
    assert_eq!(c.send("W100\r"), "<03><CR>");
    // Room again, then the job's end.
    assert_eq!(c.send("@S\r"), "<CR><02><CR><02><CR>");
    assert_eq!(c.wait(Duration::from_secs(1)), "");
}

#[test]
fn halt_sends_room_at_once_and_the_jobs_end_at_rest() {
    let mut c = Conversation::referenced();
    for _ in 1..DATA_MEMORY_CAPACITY {
        c.send("L1,x1000\r");
    }
    assert_eq!(c.send("L1,x1000\r"), "<03><CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    assert_eq!(c.wait(ms(499)), "");
    assert_eq!(c.wait(ms(2)), "<02><CR>");
}

#[test]
fn pause_ramps_down_and_resume_finishes_the_move_and_the_buffer() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x10000\r"), "<CR>");
    assert_eq!(c.send("W100\r"), "<CR>");
    assert_eq!(c.send("L1,x-1000\x01"), "<CR>");
    c.wait(Duration::from_secs(2));
    assert_eq!(c.send("@A\r"), "<CR>");
    let at = c.sim.counter(X, c.now);
    assert_eq!(c.flags(), "100001", "ramping down");
    c.wait(ms(600));
    assert_eq!(c.flags(), "000001", "paused: at rest, job not ended");
    let rest = c.position(X);
    assert!((f64::from(rest - at) - default_ramp().braking_distance(600.0)).abs() <= 1.0);
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.position(X), rest);
    assert_eq!(c.send("@C\r"), "<CR>");
    assert_eq!(c.flags(), "100001");
    assert!(c.wait_for(READY, Duration::from_secs(30)).is_some());
    assert_eq!(c.position(X), 9000);
    assert_eq!(c.times_of(READY).len(), 2, "homing and this job");
}

#[test]
fn resume_during_the_pause_ramp_goes_on_at_rest() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x3000\x01"), "<CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("@A\r"), "<CR>");
    c.wait(ms(100));
    assert_eq!(c.send("@C\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(30)).is_some());
    assert_eq!(c.position(X), 3000);
}

#[test]
fn pause_freezes_a_wait() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("W1000\x01"), "<CR>");
    c.wait(ms(300));
    assert_eq!(c.send("@A\r"), "<CR>");
    assert_eq!(c.flags(), "000001");
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.send("@C\r"), "<CR>");
    let resumed = c.elapsed();
    assert_eq!(c.flags(), "010001");
    let ready = c.wait_for(READY, Duration::from_secs(2)).unwrap();
    // 700 ms were left when the pause came (the `@A` line took 1.56 ms).
    let left = ms(700) - c.sim.line().byte_time() * 3;
    assert_eq!(ready - resumed, left);
}

#[test]
fn resume_without_pause_and_pause_without_job_are_ignored() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@C\r"), "<CR>");
    assert_eq!(c.send("@A\r"), "<CR>");
    assert_eq!(c.flags(), "000000");
    assert_eq!(c.send("L1,x10\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    assert_eq!(c.position(X), 10);
}

#[test]
fn halt_during_a_pause_ends_the_job_at_once() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("L1,x3000\r"), "<CR>");
    assert_eq!(c.send("L1,x5\x01"), "<CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("@A\r"), "<CR>");
    c.wait(Duration::from_secs(1));
    let at = c.position(X);
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    assert_eq!(c.send("@C\r"), "<CR>");
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.position(X), at);
    assert_eq!(c.flags(), "000000");
}

#[test]
fn halt_ends_a_wait_at_once() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("W1000\rA1,1\x01"), "<CR><CR>");
    c.wait(ms(100));
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert!(!c.sim.output(Output::new(1).unwrap()));
    assert_eq!(c.flags(), "000000");
}
