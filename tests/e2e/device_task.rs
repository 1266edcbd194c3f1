//! The device task over a socket pair against the isel simulator shell:
//! polling, the stop path, uploads, garbled and missing replies, shutdown.

use crate::device_support;

use std::time::Duration;

use device_support::{Rig, settings, socket_rig};
use jogterm::axis::Axis;
use jogterm::device::api::{
    Event, LinkState, PerAxis, PositionSource, ProgramState, Request, UploadEvent,
};
use jogterm::device::isel::PollRate;
use jogterm::sim::fault::{ByteIndex, Fault};

fn secs(n: u64) -> Duration {
    Duration::from_secs(n)
}

fn measured(e: &Event) -> bool {
    matches!(e, Event::Position(p) if p.source == PositionSource::Measured)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn positions_are_polled_and_ports_reported() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.connected().await;
    let mut count = 0;
    while count < 20 {
        rig.wait_for("a measured position", secs(5), measured).await;
        count += 1;
    }
    rig.wait_for("a port snapshot", secs(5), |e| matches!(e, Event::Io(_)))
        .await;
    let sent = rig.sent();
    assert!(
        sent.iter().filter(|s| *s == "@0P<CR>").count() >= 20,
        "{sent:?}"
    );
    assert!(sent.iter().any(|s| s == "@0b1<CR>"));
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_during_polling_overtakes_and_ends_a_move() {
    // A timing promise (the stop written within 50 ms): one at a time.
    let _serial = crate::timing::SERIAL.lock().await;
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.ready().await;
    rig.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100_000),
        speed_hz: PerAxis::new().with(Axis::X, 10_000.0),
    });
    rig.wait_for(
        "an estimated position",
        secs(5),
        |e| matches!(e, Event::Position(p) if p.source == PositionSource::Estimated),
    )
    .await;
    rig.run_for(Duration::from_millis(300)).await;
    let ticket = rig.handle.stop();
    let written = ticket.written().await.expect("stop written");
    // A loose bound for a loaded test machine; `benches/device.rs` measures.
    assert!(written.latency() < Duration::from_millis(50), "{written:?}");
    let end = rig.wait_for("the measured end", secs(5), measured).await;
    let Event::Position(p) = end else {
        unreachable!()
    };
    let x = p.steps.get(Axis::X).unwrap_or(0);
    assert!(x > 0 && x < 100_000, "stopped at {x}");
    assert!(rig.sent().iter().any(|s| s == "<FD><FF>"));
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_during_an_upload_aborts_it_without_a_valid_program() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.ready().await;
    let lines: Vec<String> = (0..300).map(|i| format!("1{}", 33 + i % 60)).collect();
    rig.request(Request::Upload {
        lines,
        erase_first: true,
    });
    rig.wait_for(
        "upload progress",
        secs(10),
        |e| matches!(e, Event::Upload(UploadEvent::Progress { done, .. }) if *done > 5),
    )
    .await;
    rig.handle.stop();
    let aborted = rig
        .wait_for("the abort", secs(5), |e| {
            matches!(e, Event::Upload(UploadEvent::Aborted { .. }))
        })
        .await;
    assert!(matches!(aborted, Event::Upload(UploadEvent::Aborted { done, .. }) if done < 300));
    rig.wait_for(
        "the program marked invalid",
        secs(5),
        |e| matches!(e, Event::State(s) if s.program == ProgramState::Invalid),
    )
    .await;
    // Back in DNC mode: polling goes on.
    rig.wait_for("a position after the abort", secs(5), measured)
        .await;
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropped_corrupted_and_stray_bytes_are_survived() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.connected().await;
    let control = rig.shell.control();
    for fault in [
        Fault::DropByte(ByteIndex::Middle),
        Fault::CorruptByte(ByteIndex::At(5)),
        Fault::Garbage(b"xyz".to_vec()),
        Fault::Delay(Duration::from_millis(30)),
    ] {
        control.fault(fault).expect("fault");
        rig.run_for(Duration::from_millis(200)).await;
    }
    // Still polling, still connected, and every measured position is one
    // the controller reported.
    rig.wait_for("a position after the faults", secs(5), measured)
        .await;
    assert!(
        !rig.link_states()
            .iter()
            .any(|l| matches!(l, LinkState::Lost { .. })),
        "{:?}",
        rig.link_states()
    );
    let positions: Vec<_> = rig
        .seen
        .iter()
        .filter_map(|e| match e {
            Event::Position(p) => Some(p.steps),
            _ => None,
        })
        .collect();
    let first = positions[0];
    assert!(positions.iter().all(|p| *p == first), "{positions:?}");
    rig.handle.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_withheld_reply_is_a_dead_link_that_gets_the_stop_bytes() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.connected().await;
    rig.shell.control().fault(Fault::Withhold).expect("fault");
    let lost = rig
        .wait_for("the link lost", secs(5), |e| {
            matches!(e, Event::Link(LinkState::Lost { .. }))
        })
        .await;
    assert!(
        matches!(&lost, Event::Link(LinkState::Lost { reason }) if reason.starts_with("no reply to @0")),
        "{lost:?}"
    );
    rig.wait_for("a reconnect attempt", secs(5), |e| {
        matches!(e, Event::Link(LinkState::Reconnecting { attempt: 1, .. }))
    })
    .await;
    assert_eq!(rig.sent().last().map(String::as_str), Some("<FD><FF>"));
    rig.handle.shutdown().await;
    assert!(rig.handle.is_closed());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_stops_first_and_then_closes() {
    let mut rig = socket_rig(settings(PollRate::Off));
    rig.connected().await;
    rig.handle.shutdown().await;
    rig.run_for(Duration::from_millis(100)).await;
    assert_eq!(rig.sent().last().map(String::as_str), Some("<FD><FF>"));
    assert_eq!(rig.link_states().last(), Some(&LinkState::Closed));
    assert!(rig.handle.request(Request::Initialise).is_err());
    assert!(rig.handle.stop().written().await.is_none());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dropping_every_handle_stops_and_closes() {
    let Rig {
        shell,
        handle,
        mut events,
        ..
    } = socket_rig(settings(PollRate::Off));
    drop(handle);
    let mut last = None;
    let mut stop_sent = false;
    while let Some(e) = tokio::time::timeout(secs(5), events.recv())
        .await
        .expect("the task ends")
    {
        if let Event::Traffic(r) = &e {
            stop_sent |= r.bytes == [0xFD, 0xFF];
        }
        last = Some(e);
    }
    assert!(stop_sent);
    assert_eq!(last, Some(Event::Link(LinkState::Closed)));
    drop(shell);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_emergency_handle_writes_through_the_open_port() {
    let mut rig = socket_rig(settings(PollRate::Off));
    rig.connected().await;
    let emergency = rig.handle.emergency();
    assert_eq!(emergency.bytes(), [0xFD, 0xFF]);
    assert_eq!(emergency.fire().ok(), Some(true));
    rig.handle.shutdown().await;
    assert_eq!(emergency.fire().ok(), Some(false), "no port open any more");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn requests_without_a_link_are_refused() {
    let mut rig = socket_rig(settings(PollRate::Off));
    rig.connected().await;
    rig.shell
        .control()
        .fault(Fault::Close { reopen_after: None })
        .expect("close");
    rig.wait_for("the link lost", secs(5), |e| {
        matches!(e, Event::Link(LinkState::Lost { .. }))
    })
    .await;
    rig.request(Request::Initialise);
    rig.wait_for(
        "the refusal",
        secs(5),
        |e| matches!(e, Event::Refused { request, .. } if request == "initialise"),
    )
    .await;
    rig.handle.shutdown().await;
}

/// A client's hold (`Request::Hold`) that is not renewed, as when the
/// console that drives a hold-to-run frame stalls: the task itself stops
/// the move about one lease after the last renewal, says so
/// (`Event::HoldLapsed`) before the idle state the stop brings, and the
/// move ends short of its target.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hold_not_renewed_stops_the_move_in_the_task_itself() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.ready().await;
    let from = rig.seen.len();
    rig.request(Request::Hold {
        lease: Duration::from_millis(300),
    });
    let asked = std::time::Instant::now();
    rig.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 100_000),
        frame: jogterm::device::api::Frame::Machine,
        speed_hz: PerAxis::new().with(Axis::X, 10_000.0),
    });
    rig.wait_for("the lapse", secs(5), |e| matches!(e, Event::HoldLapsed))
        .await;
    let lapsed = asked.elapsed();
    assert!(
        lapsed >= Duration::from_millis(290) && lapsed < Duration::from_millis(1_500),
        "lapsed after {lapsed:?}"
    );
    let end = rig.wait_for("the measured end", secs(5), measured).await;
    let Event::Position(p) = end else {
        unreachable!()
    };
    // The lapse is said before the idle state the stop brings: a client
    // that reads on after its stall sends no next move on that idle.
    let state_of = |e: &Event| match e {
        Event::State(s) => Some(s.activity),
        _ => None,
    };
    let seen = &rig.seen[from..];
    let moving = seen
        .iter()
        .position(|e| state_of(e).is_some_and(|a| a != jogterm::device::api::Activity::Idle))
        .expect("the move was reported");
    let idle_again = seen[moving..]
        .iter()
        .position(|e| state_of(e) == Some(jogterm::device::api::Activity::Idle))
        .map(|i| i + moving)
        .expect("idle after the stop");
    let lapse = seen
        .iter()
        .position(|e| matches!(e, Event::HoldLapsed))
        .expect("the lapse");
    assert!(lapse < idle_again, "{lapse} before {idle_again}");
    let x = p.steps.get(Axis::X).unwrap_or(0);
    assert!(x > 0 && x < 100_000, "stopped at {x}");
    assert!(rig.sent_since(from).iter().any(|s| s == "<FD><FF>"));
    rig.handle.shutdown().await;
}

/// Renewed, the hold lets the move run to its end; `HoldEnd` then ends it
/// without a stop.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_renewed_hold_lets_the_move_end_and_hold_end_stops_nothing() {
    let mut rig = socket_rig(settings(PollRate::LineSpeed));
    rig.ready().await;
    let from = rig.seen.len();
    let lease = Duration::from_millis(300);
    rig.request(Request::Hold { lease });
    rig.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 8_000),
        frame: jogterm::device::api::Frame::Machine,
        speed_hz: PerAxis::new().with(Axis::X, 8_000.0),
    });
    // A second at 8000 Hz, renewed every 100 ms for 1.5 s.
    for _ in 0..15 {
        rig.run_for(Duration::from_millis(100)).await;
        rig.request(Request::Hold { lease });
    }
    rig.request(Request::HoldEnd);
    rig.run_for(Duration::from_millis(800)).await;
    assert!(
        !rig.seen[from..]
            .iter()
            .any(|e| matches!(e, Event::HoldLapsed)),
        "renewed, the hold never lapsed"
    );
    assert!(
        !rig.sent_since(from).iter().any(|s| s.contains("<FD>")),
        "no stop: {:?}",
        rig.sent_since(from)
    );
    let x = rig.seen[from..].iter().rev().find_map(|e| match e {
        Event::Position(p) if p.source == PositionSource::Measured => p.steps.get(Axis::X),
        _ => None,
    });
    assert_eq!(x, Some(8_000), "the move ran to its end");
    rig.handle.shutdown().await;
}
