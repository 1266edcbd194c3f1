//! Storing and running programs.

use crate::device::api::{Event, ProgramState, Recovery, Request, UploadEvent};

use super::harness::{Harness, ms, position_reply};

fn upload(lines: &[&str], erase_first: bool) -> Request {
    Request::Upload {
        lines: lines.iter().map(|l| l.to_string()).collect(),
        erase_first,
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
fn a_program_is_stored_line_by_line_with_progress() {
    let mut h = Harness::ready();
    h.request(upload(
        &["0100,900,0,900,0,900,0,900", "133", "3 2,-2"],
        false,
    ));
    h.expect_text("@0i");
    h.reply(b"0");
    h.expect_text("0100,900,0,900,0,900,0,900");
    h.advance(ms(20));
    h.reply(b"0");
    h.expect_text("133");
    h.advance(ms(200));
    h.reply(b"0");
    h.expect_text("32,-2");
    h.reply(b"0");
    // `9` is appended.
    h.expect_text("9");
    h.reply(b"0");
    h.expect_nothing();
    let events = uploads(&h);
    assert_eq!(events.first(), Some(&UploadEvent::Started { total: 3 }));
    assert!(matches!(
        events.last(),
        Some(UploadEvent::Finished { total: 3, elapsed }) if *elapsed == ms(220)
    ));
    assert!(events.iter().any(|e| matches!(
        e,
        UploadEvent::Progress { done: 3, total: 3, lines_per_second } if *lines_per_second > 13.0
    )));
    assert_eq!(h.state().program, ProgramState::Stored);
}

#[test]
fn a_bad_line_is_refused_before_anything_is_sent() {
    let mut h = Harness::ready();
    h.request(upload(&["0100,900", "9", "133"], false));
    h.expect_nothing();
    assert_eq!(h.refusals().len(), 1);
    assert!(h.refusals()[0].starts_with("upload (3 lines): line 1:"));
    h.take_events();
    h.request(upload(&["133", "9", "133"], false));
    h.expect_nothing();
    assert!(h.refusals()[0].contains("line 2: `9` ends the program"));
}

#[test]
fn an_error_at_line_n_fails_the_upload_and_marks_the_program_invalid() {
    let mut h = Harness::ready();
    h.request(upload(&["133", "134", "135"], false));
    h.expect_text("@0i");
    h.reply(b"0");
    h.expect_text("133");
    h.reply(b"0");
    h.expect_text("134");
    h.reply(b"6");
    h.expect_nothing();
    let last = uploads(&h).pop();
    assert!(matches!(
        last,
        Some(UploadEvent::Failed { line: 1, ref fault })
            if fault.code == "6" && fault.recovery == Recovery::EraseProgram
    ));
    assert_eq!(h.state().program, ProgramState::Invalid);
}

#[test]
fn a_stored_program_is_erased_first_when_asked() {
    let mut h = Harness::ready();
    h.request(upload(&["133"], true));
    h.expect_text("@0i");
    h.reply(b"G");
    h.expect_text("@0k");
    h.advance(ms(2_000));
    h.reply(b"0");
    h.expect_text("@0i");
    h.reply(b"0");
    h.expect_text("133");
    h.reply(b"0");
    h.expect_text("9");
    h.reply(b"0");
    assert!(matches!(
        uploads(&h).last(),
        Some(UploadEvent::Finished { .. })
    ));
}

#[test]
fn without_erase_a_stored_program_fails_the_upload() {
    let mut h = Harness::ready();
    h.request(upload(&["133"], false));
    h.expect_text("@0i");
    h.reply(b"G");
    h.expect_nothing();
    assert!(matches!(
        uploads(&h).last(),
        Some(UploadEvent::Aborted { done: 0, reason, link_lost: false }) if reason.contains("erase it first")
    ));
    assert!(h.events.iter().any(|e| matches!(
        e,
        Event::Fault(f) if f.recovery == Recovery::EraseProgram
    )));
}

#[test]
fn a_stop_aborts_the_upload_with_a_line_that_cannot_be_stored() {
    let mut h = Harness::ready();
    h.request(upload(&["133", "134", "135"], false));
    h.expect_text("@0i");
    h.reply(b"0");
    h.expect_text("133");
    h.reply(b"0");
    h.expect_text("134");
    assert_eq!(h.stop(), [0xFD, 0xFF]);
    // The line on the wire is answered first.
    h.expect_nothing();
    h.reply(b"0");
    h.expect_text("@0#");
    h.reply(b"8");
    h.expect_nothing();
    assert!(matches!(
        uploads(&h).last(),
        Some(UploadEvent::Aborted { done: 2, reason, link_lost: false }) if reason == "stopped by the operator"
    ));
    assert_eq!(h.state().program, ProgramState::Invalid);
}

#[test]
fn a_program_runs_with_sync_characters_and_is_measured_at_its_end() {
    let mut h = Harness::ready();
    h.request(Request::RunProgram);
    h.expect_text("@0S");
    assert_eq!(
        h.state().activity,
        crate::device::api::Activity::RunningProgram
    );
    // No deadline: a program may take as long as it likes.
    h.advance(ms(60_000));
    assert!(h.state().link_up);
    h.reply(b"#");
    h.reply(b"0");
    assert!(
        h.notices()
            .iter()
            .any(|n| n == "program sync character `#`")
    );
    h.expect_text("@0P");
    h.reply(&position_reply(1, 2, 3));
}
