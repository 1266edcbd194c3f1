//! The jog off a limit switch on an EMP drive (`limit_op`), against the
//! simulated drive: one TP positioning away from the switch, its switches
//! read meanwhile, stopped once the switch releases; the bound; refusals.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Event, JogEnd, JogId, Request};
use crate::device::common::testing::ms;
use crate::proto::emp::DriveAddress;
use crate::sim::InputControl;

use super::harness::{profile, settings, x_speed};
use super::with_sim::{Bench, bench_for, counter, hold, run_until_homed};

const ID: JogId = JogId(9);

fn jog_ended(b: &mut Bench, within: Duration) -> Vec<JogEnd> {
    b.run_until(within, |e| {
        e.iter()
            .any(|e| matches!(e, Event::JogEnded { id: ID, .. }))
    });
    b.events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { id: ID, end } => Some(end.clone()),
            _ => None,
        })
        .collect()
}

fn refusal(b: &Bench) -> String {
    b.events
        .iter()
        .find_map(|e| match e {
            Event::Refused { reason, .. } => Some(reason.to_string()),
            _ => None,
        })
        .unwrap_or_default()
}

/// Switched on, unreferenced jogs allowed, X run into its minus switch
/// (2 mm below machine 0): the drive braked there (`40` shows it).
fn in_the_minus_switch() -> Bench {
    let mut b = bench_for(&profile(), |s| s.jog.allow_unreferenced = true);
    b.run(ms(300));
    b.request(Request::Initialise);
    b.run(ms(300));
    b.request(Request::Jog {
        id: JogId(3),
        axes: vec![(Axis::X, Dir::Minus)],
        speed_hz: x_speed(56_000.0),
        lease: settings().jog.repeat_timeout,
    });
    hold(&mut b, JogId(3), Duration::from_secs(20));
    assert!(b.driver.state().limit, "{:?}", b.events);
    b.run(ms(300));
    b.events.clear();
    b
}

#[test]
fn the_drive_positions_off_its_switch_and_stops_once_it_has_released() {
    let mut b = in_the_minus_switch();
    // Into the switch: the drive would answer `05`; jogterm does not ask.
    let sent_before = b.sent.len();
    b.request(Request::LimitJog {
        id: ID,
        axis: Axis::X,
        dir: Dir::Minus,
    });
    b.run(ms(100));
    assert!(
        refusal(&b).contains("X- leads into the switch"),
        "{:?}",
        b.events
    );
    assert!(
        !b.sent_text()[sent_before..]
            .iter()
            .any(|t| t.starts_with("2A"))
    );
    b.events.clear();
    let from = counter(&b, DriveAddress::SINGLE);
    let sent_before = b.sent.len();
    b.request(Request::LimitJog {
        id: ID,
        axis: Axis::X,
        dir: Dir::Plus,
    });
    assert_eq!(
        jog_ended(&mut b, Duration::from_secs(10)),
        [JogEnd::OffLimit]
    );
    b.run(ms(300));
    let moved = counter(&b, DriveAddress::SINGLE) - from;
    // 0.5 mm/s = 5600 counts/s; reads every 20 ms: off the switch by
    // little more than its hysteresis.
    assert!(moved > 0 && moved < 11_200, "{moved}");
    assert!(!b.driver.state().limit);
    let sent: Vec<String> = b.sent_text()[sent_before..].to_vec();
    assert!(sent.iter().any(|t| t.starts_with("2211")), "TPWM: {sent:?}");
    assert_eq!(
        sent.iter().filter(|t| t.starts_with("2A1101")).count(),
        1,
        "one positioning: {sent:?}"
    );
    assert!(sent.iter().filter(|t| t.starts_with("4011")).count() >= 2);
    assert!(
        sent.iter().any(|t| t.starts_with("0811")),
        "stopped: {sent:?}"
    );
    // The reference run is what is left to do, and it runs.
    b.request(Request::Home {
        axes: AxisSet::EMPTY.with(Axis::X),
    });
    run_until_homed(&mut b, Duration::from_secs(120));
    assert!(b.driver.state().fault.is_none(), "{:?}", b.driver.state());
    assert!(b.driver.state().referenced.contains(Axis::X));
}

#[test]
fn a_switch_that_never_releases_is_left_at_the_bound() {
    // Limit X min wired to I1 (held on by the simulator's input): the drive
    // itself knows nothing of it, so it reads active all the way.
    let mut p = profile();
    p.io.insert(
        "11.I1".into(),
        crate::wiring::BitPatch {
            role: Some(crate::wiring::RoleName::Limit),
            axis: Some(Axis::X),
            side: Some(crate::wiring::Side::Min),
            ..Default::default()
        },
    );
    let mut b = bench_for(&p, |_| {});
    b.run(ms(300));
    b.request(Request::Initialise);
    b.run(ms(300));
    b.control(InputControl::Set {
        name: "i1".into(),
        level: true,
    });
    b.run(ms(300));
    b.events.clear();
    let from = counter(&b, DriveAddress::SINGLE);
    b.request(Request::LimitJog {
        id: ID,
        axis: Axis::X,
        dir: Dir::Plus,
    });
    assert_eq!(
        jog_ended(&mut b, Duration::from_secs(10)),
        [JogEnd::StillOnLimit]
    );
    b.run(ms(300));
    // jog.limit_jog_distance: 2 mm at 11 200 counts/mm.
    assert_eq!(counter(&b, DriveAddress::SINGLE) - from, 22_400);
    let notices: Vec<String> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Notice(n) => Some(n.clone()),
            _ => None,
        })
        .collect();
    assert!(
        notices.iter().any(|n| n.contains("still reads active")),
        "{notices:?}"
    );
}

#[test]
fn a_stop_ends_it_and_nothing_resumes() {
    let mut b = in_the_minus_switch();
    b.request(Request::LimitJog {
        id: ID,
        axis: Axis::X,
        dir: Dir::Plus,
    });
    b.run(ms(60));
    b.stop();
    assert_eq!(jog_ended(&mut b, Duration::from_secs(2)), [JogEnd::Stopped]);
    let here = counter(&b, DriveAddress::SINGLE);
    b.run(Duration::from_secs(1));
    assert_eq!(counter(&b, DriveAddress::SINGLE), here);
}
