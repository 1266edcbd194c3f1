//! The new tool measured at a tool change (`update::measure`) on a machine
//! with a tool sensor: after F6 the tool goes over and down to the sensor,
//! one go-to after the other, Z probes, the tool table takes the touch,
//! the tool comes back, and the pieces after the change cut higher by the
//! tool's offset; a probe that trips nothing ends the job.

use super::job::{activity, read_back, run_part};
use super::pieces::{at_wait, started, to_the_wait};
use super::*;
use crate::device::api::{Dir, Frame, JogId, ProbeEnd};
use crate::ui::editor::job::Phase as JobPhase;

/// The shipped isel profile (400 steps/mm) with a tool sensor under X25
/// Y0, the point above it at Z27.5 mm.
fn with_sensor() -> Host {
    let mut host = Host::isel();
    let mut profile = host.setup.profile.as_ref().clone();
    profile.probe.tool_sensor = Some("X25 Y0 Z27.5".into());
    host.setup.profile = std::sync::Arc::new(profile);
    host
}

/// The go-to `out` sends, machine steps.
fn go_to(out: &Outcome) -> PerAxis<i64> {
    match requests(out).as_slice() {
        [Request::MoveTo { target, frame, .. }] => {
            assert_eq!(*frame, Frame::Machine);
            *target
        }
        other => panic!("one go-to: {other:?}"),
    }
}

/// The go-to runs and ends where it was sent: the outcome of its end.
fn moved(host: &mut Host, e: &mut Editor, target: &PerAxis<i64>) -> Outcome {
    activity(host, e, Activity::Moving);
    let mut at = host_at(host);
    for (axis, steps) in target.iter() {
        at.set(axis, steps);
    }
    read_back(host, e, at);
    activity(host, e, Activity::Idle)
}

fn host_at(host: &Host) -> PerAxis<i64> {
    host.positions.xyz_steps()
}

/// From F6 at a tool change to the probe: the two legs to the sensor
/// (X and Y over, Z down: the tool stands above it already) and the
/// probe's id.
fn to_the_sensor(host: &mut Host, e: &mut Editor) -> JogId {
    let out = host.send(e, Input::Main(Action::RunProgram));
    let over = go_to(&out);
    assert_eq!(over, PerAxis::new().with(Axis::X, 10_000).with(Axis::Y, 0));
    assert_eq!(
        e.chunked.as_ref().map(|c| c.phase),
        Some(JobPhase::Measuring)
    );
    let status = e.job_status(host.now, false).expect("a status");
    assert_eq!(status.word, "MEASURE");
    let out = moved(host, e, &over);
    let down = go_to(&out);
    assert_eq!(down, PerAxis::new().with(Axis::Z, 11_000));
    let out = moved(host, e, &down);
    match requests(&out).as_slice() {
        [Request::Probe { id, probe }] => {
            assert_eq!((probe.axis, probe.dir), (Axis::Z, Dir::Minus));
            *id
        }
        other => panic!("the probe: {other:?}"),
    }
}

/// The probe touched at machine Z `z` steps: the outcome.
fn touched(host: &mut Host, e: &mut Editor, id: JogId, z: i64) -> Outcome {
    let end = ProbeEnd::Touched {
        at: PerAxis::new()
            .with(Axis::X, 10_000)
            .with(Axis::Y, 0)
            .with(Axis::Z, z),
        fast_stop: z - 20,
    };
    host.send(e, Input::Device(&Event::ProbeEnded { id, end }))
}

fn measured(out: &Outcome) -> Vec<(&str, f64)> {
    out.effects
        .iter()
        .filter_map(|e| match e {
            Effect::ToolMeasured { tool, z } => Some((tool.as_str(), *z)),
            _ => None,
        })
        .collect()
}

/// Back from the sensor to where the job waits (the plan's point: the
/// profile has no change position): Z up alone first, then X and Y, then
/// Z down if need be; then the next piece's upload.
fn back(host: &mut Host, e: &mut Editor, out: &Outcome) -> Vec<String> {
    let up = go_to(out);
    assert_eq!(up.axes().iter().collect::<Vec<_>>(), [Axis::Z], "{up:?}");
    assert!(up.get(Axis::Z) > Some(11_000), "up first: {up:?}");
    let mut out = moved(host, e, &up);
    let mut legs = 1;
    while super::job::upload(&out).is_none() {
        let leg = go_to(&out);
        out = moved(host, e, &leg);
        legs += 1;
        assert!(legs <= 3, "up, over, down: {out:?}");
    }
    let (lines, _) = super::job::upload(&out).unwrap_or_else(|| panic!("the next piece: {out:?}"));
    lines.to_vec()
}

#[test]
fn each_new_tool_is_measured_and_the_longer_one_cuts_higher() {
    let mut host = with_sensor();
    let (mut e, out) = started(&mut host);
    let q_total = super::job::upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, q_total);

    // T1: the reference (the table is empty), touched at 20 mm.
    let id = to_the_sensor(&mut host, &mut e);
    let out = touched(&mut host, &mut e, id, 8_000);
    assert_eq!(measured(&out), [("T1", 20.0)]);
    assert!(
        said(&out)[0].starts_with(
            "the measure of T1: touched at machine Z 20.0000: offset +0.0000 mm against the \
             reference tool T1"
        ),
        "{out:?}"
    );
    // The console's table takes it (as `ui::update` applies the effect).
    host.tools.table.measured("T1", 20.0);
    let piece2 = back(&mut host, &mut e, &out);
    // T1 cuts at the program's Z59 (23 600 steps).
    assert!(piece2.iter().any(|l| l.contains("23600")), "{piece2:?}");

    // T2, one millimetre longer: it touches 400 steps higher.
    to_the_wait(&mut host, &mut e, piece2.len());
    let id = to_the_sensor(&mut host, &mut e);
    let out = touched(&mut host, &mut e, id, 8_400);
    assert_eq!(measured(&out), [("T2", 21.0)]);
    assert!(said(&out)[0].contains("offset +1.0000 mm"), "{out:?}");
    assert!(said(&out)[0].contains("every Z from line 11 on"), "{out:?}");
    host.tools.table.measured("T2", 21.0);
    let piece3 = back(&mut host, &mut e, &out);
    // T2's cut, 1 mm higher: Z60 (24 000 steps), nothing at Z59.
    assert!(!piece3.iter().any(|l| l.contains("23600")), "{piece3:?}");
    assert!(piece3.iter().any(|l| l.contains(",24000,")), "{piece3:?}");
}

#[test]
fn a_probe_end_of_another_id_is_not_the_jobs() {
    let mut host = with_sensor();
    let (mut e, out) = started(&mut host);
    let total = super::job::upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let id = to_the_sensor(&mut host, &mut e);
    let other = JogId(id.0 + 1);
    let out = touched(&mut host, &mut e, other, 8_000);
    assert!(out.effects.is_empty(), "{out:?}");
    assert_eq!(
        e.chunked.as_ref().map(|c| c.phase),
        Some(JobPhase::Measuring)
    );
    // F6 meanwhile says what goes on and sends nothing.
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(said(&out)[0].contains("being measured"), "{out:?}");
    let _ = (run_part, at_wait);
}

#[test]
fn a_probe_that_trips_nothing_ends_the_job_and_nothing_more_goes() {
    let mut host = with_sensor();
    let (mut e, out) = started(&mut host);
    let total = super::job::upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let id = to_the_sensor(&mut host, &mut e);
    let out = host.send(
        &mut e,
        Input::Device(&Event::ProbeEnded {
            id,
            end: ProbeEnd::NoTrip { travel: 4_000 },
        }),
    );
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(measured(&out).is_empty());
    assert!(
        said(&out)
            .iter()
            .any(|s| s.starts_with("T1 was not measured: the measure of T1")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
}

#[test]
fn a_stop_on_the_way_to_the_sensor_ends_the_job() {
    let mut host = with_sensor();
    let (mut e, out) = started(&mut host);
    let total = super::job::upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    go_to(&out);
    activity(&mut host, &mut e, Activity::Moving);
    let out = host.send(&mut e, Input::Stopped);
    assert!(requests(&out).is_empty(), "{out:?}");
    assert_eq!(e.chunked, None);
    // The idle after the stop sends no next leg.
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
}

#[test]
fn a_broken_tool_table_refuses_the_job_before_anything_moves() {
    let mut host = with_sensor();
    host.tools = crate::ui::tools::ToolsState::start(None, Some(Err("bad json".into())));
    let mut e = super::job::opened(
        &mut host,
        crate::ui::editor::job::tests::converted(super::pieces::TWO_TOOLS, 2000),
    );
    host.send(&mut e, Input::Main(Action::RunProgram));
    let out = host.key(&mut e, Action::Confirm);
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)[0].starts_with("run refused: the tool table cannot be read (bad json)"),
        "{out:?}"
    );
}

#[test]
fn a_refused_leg_to_the_sensor_ends_the_job_and_nothing_more_goes() {
    let mut host = with_sensor();
    let (mut e, out) = started(&mut host);
    let total = super::job::upload(&out).expect("piece 1").0.len();
    to_the_wait(&mut host, &mut e, total);
    let out = host.send(&mut e, Input::Main(Action::RunProgram));
    let leg = requests(&out)
        .first()
        .map(|r| (*r).clone())
        .expect("the first leg");
    // A refusal of another request (a key meanwhile) is not the leg's.
    let other = host.send(
        &mut e,
        Input::Device(&Event::Refused {
            request: "Home".into(),
            reason: crate::device::api::Refusal::NotInitialised,
        }),
    );
    assert!(requests(&other).is_empty(), "{other:?}");
    assert_eq!(
        e.chunked.as_ref().map(|c| c.phase),
        Some(JobPhase::Measuring)
    );
    let out = host.send(
        &mut e,
        Input::Device(&Event::Refused {
            request: crate::device::describe::describe(&leg),
            reason: crate::device::api::Refusal::SoftLimit {
                axis: Axis::X,
                target: 10_000,
                min: 0,
                max: 5_000,
            },
        }),
    );
    assert!(requests(&out).is_empty(), "{out:?}");
    assert!(
        said(&out)
            .iter()
            .any(|s| s.contains("its move was refused: ")),
        "{out:?}"
    );
    assert_eq!(e.chunked, None);
    // The idle after it sends no next leg and no piece.
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
}
