//! The job's outputs (issue 37, item 6): a stored program run from the text
//! uploaded here, stopped, has the spindle it switched on switched off once
//! the machine stands, and says so; a controller error does the same; a
//! program that runs to its end and a lost link send nothing.

use super::job::activity;
use super::*;
use crate::device::api::{LinkState, OutputId};

/// The spindle on, a move, the spindle off.
const SPINDLE: &str =
    "7 7\np2,128,1 ; job.nc:2 spindle on\nm8000,8000,8000,8000,0,8000,0,8000\np2,128,0\n9\n";

/// [`SPINDLE`] uploaded from the editor and running.
fn running(host: &mut Host) -> Editor {
    let mut e = editing(host, SPINDLE);
    let out = host.send(&mut e, Input::Main(Action::Upload));
    assert!(
        matches!(requests(&out)[..], [Request::Upload { .. }]),
        "{out:?}"
    );
    let done = Event::Upload(UploadEvent::Finished {
        total: 4,
        elapsed: Duration::from_millis(10),
    });
    host.send(&mut e, Input::Device(&done));
    host.machine.program = ProgramState::Stored;
    activity(host, &mut e, Activity::RunningProgram);
    e
}

fn spindle_off() -> Request {
    Request::SetOutput {
        output: OutputId {
            group: 2,
            bit: None,
        },
        value: 0,
    }
}

#[test]
fn a_stop_switches_the_spindle_off_once_the_machine_stands() {
    let mut host = Host::isel();
    let mut e = running(&mut host);
    let out = host.send(&mut e, Input::Stopped);
    assert!(requests(&out).is_empty(), "not while it moves: {out:?}");
    activity(&mut host, &mut e, Activity::Stopping);
    host.now += Duration::from_millis(100);
    let out = host.send(&mut e, Input::Tick);
    assert!(requests(&out).is_empty(), "still ramping down: {out:?}");
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert_eq!(requests(&out), [&spindle_off()]);
    assert!(
        said(&out)
            .iter()
            .any(|s| s.contains("switched off once the axes stood: spindle (out2)")),
        "{out:?}"
    );
    // Once.
    let out = host.send(&mut e, Input::Tick);
    assert!(requests(&out).is_empty(), "{out:?}");
}

#[test]
fn a_controller_error_switches_the_spindle_off_and_a_refusal_is_said() {
    let mut host = Host::isel();
    let mut e = running(&mut host);
    let fault = ControllerFault {
        command: "@0S".into(),
        code: "2".into(),
        meaning: "limit switch".into(),
        recovery: DeviceRecovery::None,
    };
    host.send(&mut e, Input::Device(&Event::Fault(fault)));
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert_eq!(requests(&out), [&spindle_off()]);
    let refused = Event::Refused {
        request: crate::device::describe::describe(&spindle_off()),
        reason: crate::device::api::Refusal::NotInitialised,
    };
    let out = host.send(&mut e, Input::Device(&refused));
    assert_eq!(
        said(&out),
        [format!(
            "spindle (out2) may still be on: refused: {}",
            crate::device::api::Refusal::NotInitialised
        )]
    );
}

#[test]
fn a_program_that_ends_and_a_lost_link_send_nothing() {
    let mut host = Host::isel();
    let mut e = running(&mut host);
    let out = activity(&mut host, &mut e, Activity::Idle);
    assert!(requests(&out).is_empty(), "{out:?}");
    let out = host.send(&mut e, Input::Stopped);
    assert!(requests(&out).is_empty(), "{out:?}");
    host.now += Duration::from_millis(100);
    let out = host.send(&mut e, Input::Tick);
    assert!(requests(&out).is_empty(), "the job had ended: {out:?}");

    let mut host = Host::isel();
    let mut e = running(&mut host);
    let lost = Event::Link(LinkState::Lost {
        reason: "gone".into(),
    });
    let out = host.send(&mut e, Input::Device(&lost));
    assert!(requests(&out).is_empty(), "{out:?}");
    assert_eq!(
        said(&out)[0],
        "the link is lost: the job's outputs may still be on: spindle (out2); switch them off \
         at the machine"
    );
}

/// A check-out of a program with the spindle on: the key let go keeps it
/// and says so; a stop switches it off once the machine stands.
#[test]
fn a_check_out_keeps_the_spindle_in_a_pause_and_switches_it_off_after_a_stop() {
    use crate::device::api::CheckoutEnd;
    use crate::jog::KeyPhase;
    let mut host = Host::isel();
    let mut e = editing(
        &mut host,
        "p2,128,1 ; spindle on\n0 4000,2000,0,2000,0,2000,0,2000\np2,128,0\n9\n",
    );
    host.key(&mut e, Action::Checkout);
    host.key(&mut e, Action::Confirm);
    assert!(e.checkout.is_some(), "the check-out started");
    host.send(
        &mut e,
        Input::Checkout(Action::CheckoutHold, KeyPhase::Press),
    );
    host.now += Duration::from_millis(500);
    let out = host.send(
        &mut e,
        Input::Checkout(Action::CheckoutHold, KeyPhase::Press),
    );
    let id = requests(&out)
        .into_iter()
        .find_map(|r| match r {
            Request::Checkout { id, .. } => Some(*id),
            _ => None,
        })
        .expect("line 1 runs");
    let paused = Event::Checkout {
        id,
        end: CheckoutEnd::Paused {
            rest: false,
            dead_man: false,
        },
    };
    let out = host.send(&mut e, Input::Device(&paused));
    assert!(
        said(&out)
            .iter()
            .any(|s| s.contains("the job's outputs stay on while it pauses: spindle (out2)")),
        "{out:?}"
    );
    host.send(&mut e, Input::Stopped);
    host.now += Duration::from_millis(100);
    let out = host.send(&mut e, Input::Tick);
    assert_eq!(requests(&out), [&spindle_off()]);
}
