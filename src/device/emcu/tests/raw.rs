//! Raw lines (`Request::Raw`, `jogterm send`): checked before a byte is
//! sent, queries between the lines of what runs, stops at once.

use crate::device::api::{Activity, Request};

use super::harness::Harness;

fn raw(line: &str) -> Request {
    Request::Raw { line: line.into() }
}

#[test]
fn a_bad_line_is_refused_and_nothing_is_sent() {
    let mut h = Harness::ready();
    for line in ["L1,q5", "@r", "#S0", "L1,X5,y5", "@X\u{1}", ""] {
        h.request(raw(line));
    }
    h.expect_nothing();
    assert_eq!(h.refusals().len(), 6, "{:?}", h.refusals());
}

#[test]
fn stored_lines_wait_and_the_0x01_line_runs_them() {
    let mut h = Harness::ready();
    h.request(raw("#E1,800"));
    h.expect_text("#E1,800");
    h.reply(b"\r");
    h.request(raw("L1,x100\u{1}"));
    h.expect(b"L1,x100\x01");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Moving);
    // A query goes at once, between the polls of the run.
    h.request(raw("@LX"));
    h.expect_text("@LX");
    h.reply(b"@LX42\r");
    // Any other line waits: busy.
    h.request(raw("A1,1"));
    h.expect_nothing();
    h.run_ends();
    let replies = h.replies();
    assert_eq!(
        replies,
        [
            (
                "#E1,800".to_owned(),
                "CR: stored in the data memory (1 waiting; a line ended by \\x01 runs them)"
                    .to_owned()
            ),
            ("L1,x100<01>".to_owned(), "CR: running".to_owned()),
            ("@LX".to_owned(), "@LX42: X = 42 steps".to_owned()),
        ]
    );
    assert_eq!(h.refusals().len(), 1, "{:?}", h.refusals());
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn a_move_is_refused_while_the_position_is_unknown() {
    let mut h = Harness::new();
    h.connect();
    h.readback("000100", 0, 0, 0);
    h.request(raw("L1,x100\u{1}"));
    h.expect_nothing();
    assert_eq!(h.refusals().len(), 1, "{:?}", h.refusals());
    // The reference run is what makes it known.
    h.request(raw("$HZYX\u{1}"));
    h.expect(b"$HZYX\x01");
}

#[test]
fn raw_stops_go_out_at_once() {
    let mut h = Harness::ready();
    h.request(raw("#E1,800"));
    h.expect_text("#E1,800");
    // `@B` does not wait for the outstanding answer.
    h.request(raw("@B"));
    h.expect(b"@B\r");
    h.reply(b"\r\r");
    h.expect_nothing();
    assert!(
        h.replies()
            .iter()
            .any(|(c, t)| c == "@B" && t.starts_with("@B sent")),
        "{:?}",
        h.replies()
    );
}

/// What makes a console a session that moves (issue 24): a typed query or
/// stop is no motion; a move, a reference run, a line ended by 0x01 (it
/// runs the data memory) or a line that does not parse is.
#[test]
fn a_typed_query_is_no_motion_a_typed_move_or_run_is() {
    use crate::device::driver::Driver;
    let h = Harness::new();
    let raw = |line: &str| Request::Raw { line: line.into() };
    for line in ["@X", "@LX", "@V", "@B", "#S200"] {
        assert!(!h.driver.may_move(&raw(line)), "{line:?}");
    }
    for line in ["L1,x500", "$HZYX", "#S200\u{1}", "@J", "@C", "nonsense"] {
        assert!(h.driver.may_move(&raw(line)), "{line:?}");
    }
}
