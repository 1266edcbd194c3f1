//! Storing a job in ROM (`@F` … 0x01) and running it (`@J`).

use crate::device::api::{Activity, Event, ProgramState, Request, UploadEvent};

use super::harness::{Harness, ms};

fn upload(lines: &[&str]) -> Request {
    Request::Upload {
        lines: lines.iter().map(|l| l.to_string()).collect(),
        erase_first: false,
    }
}

fn uploads(h: &Harness) -> Vec<UploadEvent> {
    h.events
        .iter()
        .filter_map(|e| match e {
            Event::Upload(u) => Some(u.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn a_job_is_stored_line_by_line_the_last_ended_by_0x01() {
    let mut h = Harness::ready();
    h.request(upload(&["#E1,800", "L1,x500", "A1,1"]));
    h.expect_text("@F");
    assert_eq!(h.state().activity, Activity::Uploading);
    h.reply(b"\r");
    h.expect_text("#E1,800");
    h.advance(ms(10));
    h.reply(b"\r");
    h.expect_text("L1,x500");
    h.reply(b"\r");
    h.expect(b"A1,1\x01");
    h.reply(b"\r");
    // `@X` tells whether the interface took it.
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    h.expect_nothing();
    let events = uploads(&h);
    assert_eq!(events.first(), Some(&UploadEvent::Started { total: 3 }));
    assert!(matches!(
        events.last(),
        Some(UploadEvent::Finished { total: 3, .. })
    ));
    assert_eq!(h.state().program, ProgramState::Stored);
    assert_eq!(h.state().activity, Activity::Idle);
    // Run it: `@J`, watched until its 0x02 CR.
    h.request(Request::RunProgram);
    h.expect_text("@J");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::RunningProgram);
    h.run_ends();
    h.positions_read(20_500, 20_000, 8_000);
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn bad_and_master_lines_are_refused_before_anything_is_sent() {
    let mut h = Harness::ready();
    h.request(upload(&["#E1,800", "L1,X5,y5"]));
    h.request(upload(&["@B"]));
    h.expect_nothing();
    let refusals = h.refusals();
    assert_eq!(refusals.len(), 2, "{refusals:?}");
    assert!(refusals[0].contains("line 2"), "{refusals:?}");
}

#[test]
fn memory_full_fails_the_upload_at_that_line_and_ends_the_transfer() {
    let mut h = Harness::ready();
    h.request(upload(&["W10", "W20", "W30"]));
    h.expect_text("@F");
    h.reply(b"\r");
    h.expect_text("W10");
    h.reply(b"\r");
    h.expect_text("W20");
    h.reply(b"\x03\r");
    // The transfer is ended with a bare 0x01: nothing is left open.
    h.expect(b"\x01");
    h.reply(b"\r");
    h.expect_text("@X");
    h.reply(b"@X001000\r");
    assert!(
        uploads(&h)
            .iter()
            .any(|e| matches!(e, UploadEvent::Failed { line: 1, fault } if fault.code == "0x03")),
        "{:?}",
        uploads(&h)
    );
    assert_eq!(h.state().program, ProgramState::Invalid);
    h.request(Request::RunProgram);
    h.expect_nothing();
    assert_eq!(h.refusals().len(), 1, "{:?}", h.refusals());
}

#[test]
fn a_stop_ends_the_transfer_after_the_line_on_its_way() {
    let mut h = Harness::ready();
    h.request(upload(&["W10", "W20", "W30"]));
    h.expect_text("@F");
    h.reply(b"\r");
    h.expect_text("W10");
    let stop = h.stop();
    assert_eq!(stop, b"@B\r");
    h.reply(b"\r\r");
    h.expect(b"\x01");
    h.reply(b"\r");
    h.expect_text("@X");
    h.reply(b"@X001000\r");
    h.expect_nothing();
    assert!(
        uploads(&h)
            .iter()
            .any(|e| matches!(e, UploadEvent::Aborted { done: 1, .. })),
        "{:?}",
        uploads(&h)
    );
    assert_eq!(h.state().program, ProgramState::Invalid);
}
