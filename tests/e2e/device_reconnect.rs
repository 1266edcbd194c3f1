//! Link loss and reconnect over a pseudo-terminal: the simulator's line is
//! closed under the device task and brought back at the same path.

use crate::device_support;

use std::time::Duration;

use device_support::{pty_rig, settings};
use jogterm::axis::Axis;
use jogterm::device::api::{Event, LinkState, PerAxis, PositionSource, Request};
use jogterm::device::isel::PollRate;

fn secs(n: u64) -> Duration {
    Duration::from_secs(n)
}

/// A motion command with some travel (the reference probe moves nothing).
fn moves(sent: &str) -> bool {
    let Some(rest) = sent.strip_prefix("@0") else {
        return false;
    };
    match rest.as_bytes().first() {
        Some(b'M' | b'R' | b'S') => true,
        Some(b'A') => rest[1..]
            .trim_end_matches("<CR>")
            .split(',')
            .step_by(2)
            .any(|steps| steps != "0"),
        _ => false,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lost_line_is_reconnected_stopped_and_read_back_without_repeating_the_move() {
    let dir = tempfile::tempdir().expect("temp dir");
    let link = dir.path().join("isel");
    let mut rig = pty_rig(settings(PollRate::LineSpeed), &link);
    rig.ready().await;
    rig.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 60_000),
        speed_hz: PerAxis::new().with(Axis::X, 6_000.0),
    });
    rig.wait_for(
        "the move",
        secs(5),
        |e| matches!(e, Event::Position(p) if p.source == PositionSource::Estimated),
    )
    .await;
    let before = rig.close_and_reconnect().await;
    let end = rig
        .wait_for(
            "a measured position",
            secs(5),
            |e| matches!(e, Event::Position(p) if p.source == PositionSource::Measured),
        )
        .await;
    let Event::Position(p) = end else {
        unreachable!()
    };
    let x = p.steps.get(Axis::X).unwrap_or(0);
    assert!(
        x > 0 && x < 60_000,
        "the move was stopped on reconnect: X {x}"
    );
    let after: Vec<String> = rig.seen[before..]
        .iter()
        .filter_map(|e| match e {
            Event::Traffic(r) if r.direction == jogterm::traffic::Direction::Sent => {
                Some(jogterm::traffic::readable(&r.bytes))
            }
            _ => None,
        })
        .collect();
    assert_eq!(
        after.first().map(String::as_str),
        Some("<FD><FF>"),
        "{after:?}"
    );
    assert!(!after.iter().any(|s| moves(s)), "{after:?}");
    assert!(
        rig.link_states()
            .iter()
            .any(|l| matches!(l, LinkState::Reconnecting { .. }))
    );
    rig.handle.shutdown().await;
}
