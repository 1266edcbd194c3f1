//! The data memory (manual 1.4.2, decision 1): buffered commands wait until a
//! command ends with 0x01 or the memory is full; 0x02 CR when the buffer has
//! run, 0x03 CR for the command that fills it, 0x02 CR when room frees.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::proto::emcu::EmcuAxis;
use crate::proto::emcu::job::DATA_MEMORY_CAPACITY;
use crate::sim::SimDevice;

const READY: &[u8] = b"\x02\r";

#[test]
fn buffered_commands_wait_for_the_run_byte() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x100\r"), "<CR>");
    assert_eq!(c.send("A1,1\r"), "<CR>");
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.flags(), "000100");
    // The command ended by 0x01 is stored too, acknowledged, then all run.
    assert_eq!(c.send("L1,x100\x01"), "<CR>");
    assert_eq!(c.flags(), "100101");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 200);
    assert!(c.sim.describe(c.now).contains("A1 on"));
    assert_eq!(c.flags(), "000100");
}

#[test]
fn commands_sent_while_the_buffer_runs_are_appended() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x1000\x01"), "<CR>");
    c.wait(ms(500));
    assert_eq!(c.send("L1,x500\r"), "<CR>");
    assert_eq!(c.send("L1,x-200\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(10)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 1300);
    assert_eq!(c.times_of(READY).len(), 1, "one run, one 0x02 CR");
}

#[test]
fn a_300_command_stream_fills_the_memory_at_256_and_goes_on_when_room_frees() {
    let mut c = Conversation::new();
    let n = 300;
    let mut first_room: Option<Duration> = None;
    for i in 1..=n {
        let last = i == n;
        let line = format!("L1,x10{}", if last { '\x01' } else { '\r' });
        let said = c.send(&line);
        if i < DATA_MEMORY_CAPACITY {
            assert_eq!(said, "<CR>", "command {i}");
            assert!(!c.status().moving, "nothing runs before the memory is full");
            continue;
        }
        // From 256 on every command fills the memory again.
        assert_eq!(said, "<03><CR>", "command {i}");
        if i == DATA_MEMORY_CAPACITY {
            let status = c.status();
            assert!(status.moving && status.job_running, "the full memory runs");
            assert_eq!(c.position(EmcuAxis::X), 0);
        }
        if last {
            break;
        }
        let room = c.wait_for(READY, Duration::from_secs(1)).unwrap();
        first_room.get_or_insert(room);
    }
    // Room freed when the first move had ended: 10 steps, not before.
    let first_room = first_room.unwrap();
    let full_at = c.log.iter().find(|(_, m)| m == b"\x03\r").unwrap().0;
    assert!(first_room > full_at + ms(40), "{first_room:?} {full_at:?}");
    // No room notice for the last command; the buffer's own 0x02 CR ends it.
    assert!(c.wait_for(READY, Duration::from_secs(60)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 3000);
    assert_eq!(c.flags(), "000100");
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.times_of(READY).len(), n - DATA_MEMORY_CAPACITY + 1);
}

#[test]
fn the_command_that_fills_the_memory_starts_it() {
    let mut c = Conversation::new();
    for _ in 1..DATA_MEMORY_CAPACITY {
        assert_eq!(c.send("W10\r"), "<CR>");
    }
    assert_eq!(c.send("W10\r"), "<03><CR>");
    assert_eq!(c.flags(), "010101");
    let room = c.wait_for(READY, Duration::from_secs(1)).unwrap();
    let filled = c.log.iter().find(|(_, m)| m == b"\x03\r").unwrap().0;
    assert_eq!(room - filled, ms(10));
    // The rest runs to its end without any more commands.
    let done = c.wait_for(READY, Duration::from_secs(5)).unwrap();
    assert_eq!(done - filled, ms(10) * DATA_MEMORY_CAPACITY as u32);
    assert_eq!(c.flags(), "000100");
}

#[test]
fn a_command_sent_into_a_full_memory_is_lost_and_flags_an_error() {
    let mut c = Conversation::new();
    for _ in 1..DATA_MEMORY_CAPACITY {
        c.send("L1,x100\r");
    }
    assert_eq!(c.send("L1,x100\r"), "<03><CR>");
    assert_eq!(c.send("L1,x1000\r"), "<03><CR>");
    assert!(c.status().error);
    // Room again when the first move is done, then the end of the buffer.
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    assert!(c.wait_for(READY, Duration::from_secs(600)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 100 * DATA_MEMORY_CAPACITY as i32);
}
