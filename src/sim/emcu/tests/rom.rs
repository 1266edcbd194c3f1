//! The ROM job store (manual 1.5.17, 1.5.18, decision 2): `@F` stores the
//! following buffered commands up to the first ended by 0x01, nothing runs;
//! `@J` runs the job, 0x02 CR when it ends; the job survives `@R`.

use std::time::Duration;

use super::harness::Conversation;
use crate::proto::emcu::job::JOB_CAPACITY;
use crate::proto::emcu::{Command, EmcuAxis, JobUpload, Output};
use crate::sim::SimDevice;

const READY: &[u8] = b"\x02\r";
const X: EmcuAxis = EmcuAxis::X;

fn store_job(c: &mut Conversation, commands: &[&str]) {
    let commands: Vec<Command> = commands.iter().map(|t| t.parse().unwrap()).collect();
    let upload = JobUpload::new(&commands).unwrap();
    for line in upload.lines() {
        assert_eq!(c.send_bytes(&line.bytes), b"\r", "{:?}", line.command);
    }
}

#[test]
fn a_stored_job_runs_on_j_and_not_before() {
    let mut c = Conversation::referenced();
    store_job(&mut c, &["L1,x100", "A1,1"]);
    assert_eq!(c.wait(Duration::from_secs(2)), "");
    assert_eq!(c.position(X), 0);
    assert!(!c.sim.output(Output::new(1).unwrap()));
    assert_eq!(c.flags(), "000000");
    assert!(c.sim.describe(c.now).contains("ROM job 2"));
    assert_eq!(c.send("@J\r"), "<CR>");
    assert_eq!(c.flags(), "100001");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(X), 100);
    assert!(c.sim.output(Output::new(1).unwrap()));
    assert_eq!(c.flags(), "000000");
    // It stays stored: once more.
    assert_eq!(c.send("@J\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(X), 200);
}

#[test]
fn the_job_survives_reset() {
    let mut c = Conversation::referenced();
    store_job(&mut c, &["#S400", "#E1,400", "L1,x400"]);
    assert_eq!(c.send("@R\r"), "<CR>");
    assert_eq!(c.send("@J\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(X), 400);
}

#[test]
fn a_new_transfer_replaces_the_job() {
    let mut c = Conversation::referenced();
    store_job(&mut c, &["L1,x100"]);
    store_job(&mut c, &["L1,y7", "L1,z9"]);
    assert_eq!(c.send("@J\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(X), 0);
    assert_eq!(c.position(EmcuAxis::Y), 7);
    assert_eq!(c.position(EmcuAxis::Z), 9);
}

#[test]
fn j_without_a_job_flags_an_error_and_ends_at_once() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@J\r"), "<CR><02><CR>");
    assert_eq!(c.flags(), "001000");
    assert!(
        c.sim
            .describe(c.now)
            .ends_with("| error: @J without a stored job")
    );
    assert_eq!(c.send("@R\r"), "<CR>");
    assert!(!c.sim.describe(c.now).contains("error"));
}

#[test]
fn a_transfer_cut_off_by_reset_leaves_no_job() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@F\r"), "<CR>");
    assert_eq!(c.send("L1,x100\r"), "<CR>");
    assert_eq!(c.send("@R\r"), "<CR>");
    // Not a transfer any more: this goes into the data memory and runs.
    assert_eq!(c.send("L1,x5\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    assert_eq!(c.position(X), 5);
    assert_eq!(c.send("@J\r"), "<CR><02><CR>");
    assert_eq!(c.position(X), 5);
}

#[test]
fn a_refused_line_spoils_the_transfer() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@F\r"), "<CR>");
    assert_eq!(c.send("L1,x100\r"), "<CR>");
    assert_eq!(c.send("L1,x5,X5\r"), "<CR>");
    assert_eq!(c.send("A1,1\x01"), "<CR>");
    assert!(c.sim.describe(c.now).contains("ROM empty"));
    assert_eq!(c.send("@J\r"), "<CR><02><CR>");
    assert_eq!(c.wait(Duration::from_secs(1)), "");
    assert_eq!(c.position(X), 0);
    assert_eq!(c.flags(), "001000");
}

#[test]
fn a_job_longer_than_the_store_is_discarded() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("@F\r"), "<CR>");
    for _ in 0..JOB_CAPACITY {
        assert_eq!(c.send("W1\r"), "<CR>");
    }
    // Memory full (decision 1's 0x03 CR), and the transfer is spoilt.
    assert_eq!(c.send("W1\x01"), "<03><CR>");
    assert_eq!(c.flags(), "001000");
    assert_eq!(c.send("@J\r"), "<CR><02><CR>");
}

#[test]
fn a_smaller_store_answers_memory_full_at_the_first_command_beyond_it() {
    let mut c = Conversation::referenced();
    c.sim.set_program_memory(2).unwrap();
    assert!(c.sim.describe(c.now).contains("(room for 2)"));
    assert_eq!(c.send("@F\r"), "<CR>");
    assert_eq!(c.send("W1\r"), "<CR>");
    assert_eq!(c.send("W1\r"), "<CR>");
    assert_eq!(c.send("L1,x100\r"), "<03><CR>");
    // The rest of the transfer is taken and thrown away with it.
    assert_eq!(c.send("\x01"), "<CR>");
    assert!(c.sim.describe(c.now).contains("ROM empty"));
    assert_eq!(c.flags(), "001000");
    assert_eq!(c.send("@J\r"), "<CR><02><CR>");
    assert_eq!(c.position(X), 0);
    // A job that fits is stored and runs.
    c.send("@R\r");
    assert!(c.sim.set_program_memory(JOB_CAPACITY + 1).is_err());
    store_job(&mut c, &["L1,x100", "A1,1"]);
    assert!(c.sim.describe(c.now).contains("ROM job 2"));
}

#[test]
fn a_running_job_cannot_be_started_again_or_replaced() {
    let mut c = Conversation::referenced();
    store_job(&mut c, &["L1,x1000"]);
    assert_eq!(c.send("@J\r"), "<CR>");
    assert_eq!(c.send("@J\r"), "<CR>", "its own 0x02 CR comes at its end");
    assert_eq!(c.send("@F\r"), "<CR>");
    assert_eq!(c.flags(), "101001");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.position(X), 1000);
    // The job is still the old one.
    assert_eq!(c.send("@J\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.position(X), 2000);
}

#[test]
fn halt_ends_a_rom_job() {
    let mut c = Conversation::referenced();
    store_job(&mut c, &["L1,x10000", "L1,x-5"]);
    assert_eq!(c.send("@J\r"), "<CR>");
    c.wait(Duration::from_secs(1));
    assert_eq!(c.send("@B\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    let at = c.position(X);
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.position(X), at);
    assert_eq!(c.flags(), "000000");
}
