//! One behaviour suite for every controller family: what the driver core
//! promises whatever the family is (`docs/device.md`): a connection opens
//! with the stop sequence and reads back before anything else, nothing runs
//! while the link is down, a jog ends on its own when its lease runs out,
//! a stop ends it and nothing starts after it, a lost link ends it. Each test is
//! written once, over [`Subject`], and `for_every_family!` runs it for isel,
//! EMCU and EMP against their simulators in memory. What only one family
//! does stays in its own tests (`device::{isel,emcu,emp}::tests`).

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::config::{ConfigDirs, Profile, load_profile};
use crate::device::api::{Activity, Dir, JogEnd, JogId, PerAxis, Refusal, Request};
use crate::device::driver::Driver;
use crate::device::emcu::{EmcuDriver, EmcuLine, EmcuSettings};
use crate::device::emp::{EmpDriver, EmpLine, EmpSettings};
use crate::device::isel::{IselDriver, IselLine, IselSettings};
use crate::sim::SimDevice;
use crate::sim::emcu::EmcuSim;
use crate::sim::emp::EmpSim;
use crate::sim::isel::IselSim;
use crate::traffic::Owner;

use super::core::{Core, Family};
use super::testing::{Bench, Harness, jog_ends, ms, refusal_reasons};

/// A family under test: its driver and simulator from its shipped profile.
trait Subject {
    type Line: Family;
    type S: SimDevice;

    fn profile() -> Profile;
    fn driver(profile: &Profile) -> Core<Self::Line>;
    fn bench() -> Bench<Core<Self::Line>, Self::S>;
    /// The axes a reference run needs, and how long it may take at most.
    fn homing() -> (AxisSet, Duration);
    /// A jog speed the family runs X at.
    fn jog_hz() -> f64;
}

struct Isel;
struct Emcu;
struct Emp;

impl Subject for Isel {
    type Line = IselLine;
    type S = IselSim;

    fn profile() -> Profile {
        load_profile("default", &ConfigDirs::builtin_only()).expect("isel profile")
    }

    fn driver(profile: &Profile) -> IselDriver {
        IselDriver::new(IselSettings::from_profile(profile).expect("settings"))
    }

    fn bench() -> Bench<IselDriver, IselSim> {
        let profile = Self::profile();
        let sim = IselSim::from_profile(&profile).expect("simulator");
        Bench::new(Self::driver(&profile), sim, profile.connection.line())
    }

    fn homing() -> (AxisSet, Duration) {
        (AxisSet::XYZ, Duration::from_secs(120))
    }

    fn jog_hz() -> f64 {
        4_000.0
    }
}

impl Subject for Emcu {
    type Line = EmcuLine;
    type S = EmcuSim;

    fn profile() -> Profile {
        load_profile("emcu", &ConfigDirs::builtin_only()).expect("emcu profile")
    }

    fn driver(profile: &Profile) -> EmcuDriver {
        EmcuDriver::new(EmcuSettings::from_profile(profile).expect("settings"))
    }

    fn bench() -> Bench<EmcuDriver, EmcuSim> {
        let profile = Self::profile();
        let sim = EmcuSim::from_profile(&profile).expect("simulator");
        Bench::new(Self::driver(&profile), sim, profile.connection.line())
    }

    fn homing() -> (AxisSet, Duration) {
        // At the start speed from 40 mm: 40 s an axis, one after the other.
        (AxisSet::XYZ, Duration::from_secs(200))
    }

    fn jog_hz() -> f64 {
        1_000.0
    }
}

impl Subject for Emp {
    type Line = EmpLine;
    type S = EmpSim;

    fn profile() -> Profile {
        load_profile("emp", &ConfigDirs::builtin_only()).expect("emp profile")
    }

    fn driver(profile: &Profile) -> EmpDriver {
        EmpDriver::new(EmpSettings::from_profile(profile).expect("settings"))
    }

    fn bench() -> Bench<EmpDriver, EmpSim> {
        let profile = Self::profile();
        let sim = EmpSim::from_profile(&profile).expect("simulator");
        Bench::new(Self::driver(&profile), sim, profile.connection.line())
    }

    fn homing() -> (AxisSet, Duration) {
        (AxisSet::EMPTY.with(Axis::X), Duration::from_secs(120))
    }

    fn jog_hz() -> f64 {
        11_200.0
    }
}

/// Initialised and referenced, the events of it cleared.
fn homed<F: Subject>() -> Bench<Core<F::Line>, F::S> {
    let (axes, within) = F::homing();
    let mut b = F::bench();
    b.run(ms(500));
    b.request(Request::Initialise);
    b.run(ms(500));
    b.request(Request::Home { axes });
    b.run(within);
    assert!(
        axes.iter().all(|a| b.driver.state().referenced.contains(a)),
        "{:?}",
        b.events
    );
    b.events.clear();
    b
}

fn jog(id: u64, hz: f64, lease: Duration) -> Request {
    Request::Jog {
        id: JogId(id),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: PerAxis::new().with(Axis::X, hz),
        lease,
    }
}

/// The last position the driver measured, X.
fn measured_x<F: Subject>(b: &Bench<Core<F::Line>, F::S>) -> Option<i64> {
    b.last_measured().and_then(|p| p.get(Axis::X))
}

/// Every message of the connect until the line is quiet, and whose.
fn connect_traffic<F: Subject>(halt: bool) -> Vec<Owner> {
    let mut h = Harness::on(F::driver(&F::profile()));
    h.driver.set_connect_halt(halt);
    h.driver.connected(h.now);
    let mut owners = Vec::new();
    while let Some(out) = h.driver.poll_transmit(h.now) {
        owners.extend(out.messages.iter().map(|m| m.owner));
        h.driver.transmitted(h.now);
    }
    owners
}

fn a_connection_opens_with_the_stop_sequence<F: Subject>() {
    let owners = connect_traffic::<F>(true);
    assert!(!owners.is_empty());
    assert_eq!(owners[0], Owner::Stop, "{owners:?}");
}

fn a_session_not_asked_to_move_connects_without_a_stop<F: Subject>() {
    let owners = connect_traffic::<F>(false);
    assert!(!owners.contains(&Owner::Stop), "{owners:?}");
}

fn nothing_runs_while_the_link_is_down<F: Subject>() {
    let mut h = Harness::on(F::driver(&F::profile()));
    h.request(jog(1, F::jog_hz(), ms(500)));
    h.request(Request::Home { axes: AxisSet::XYZ });
    assert_eq!(h.take(), None);
    assert_eq!(
        refusal_reasons(&h.events),
        [Refusal::NotConnected, Refusal::NotConnected]
    );
    assert_eq!(
        jog_ends(&h.events),
        [(1, JogEnd::Refused(Refusal::NotConnected))]
    );
}

fn a_jog_without_renewal_ends_by_the_dead_man_and_the_axis_stands<F: Subject>() {
    let mut b = homed::<F>();
    b.request(jog(1, F::jog_hz(), ms(400)));
    b.run(Duration::from_secs(4));
    assert_eq!(jog_ends(&b.events), [(1, JogEnd::DeadMan)]);
    assert_eq!(b.driver.state().activity, Activity::Idle);
    let stood = measured_x::<F>(&b);
    b.run(Duration::from_secs(1));
    assert_eq!(measured_x::<F>(&b), stood);
    assert!(stood.is_some_and(|x| x > 0), "{stood:?}");
}

fn a_stop_ends_a_jog_and_nothing_runs_after_it<F: Subject>() {
    let mut b = homed::<F>();
    b.request(jog(1, F::jog_hz(), Duration::from_secs(30)));
    b.run(ms(300));
    // Never queued behind a move: refused at once, so the stop leaves
    // nothing that could start after it.
    b.request(Request::Home {
        axes: F::homing().0,
    });
    assert!(
        matches!(refusal_reasons(&b.events)[..], [Refusal::Busy { .. }]),
        "{:?}",
        b.events
    );
    b.stop();
    b.run(Duration::from_secs(3));
    assert_eq!(jog_ends(&b.events), [(1, JogEnd::Stopped)]);
    assert_eq!(b.driver.state().activity, Activity::Idle);
    let stood = measured_x::<F>(&b);
    b.run(Duration::from_secs(1));
    assert_eq!(measured_x::<F>(&b), stood);
}

fn a_lost_link_ends_a_jog_and_nothing_resumes<F: Subject>() {
    let mut b = homed::<F>();
    b.request(jog(1, F::jog_hz(), Duration::from_secs(30)));
    b.run(ms(300));
    let now = b.now;
    b.driver.disconnected("the port vanished", now);
    b.run(ms(1));
    assert_eq!(jog_ends(&b.events), [(1, JogEnd::LinkLost)]);
    assert!(!b.driver.state().link_up);
    b.request(jog(2, F::jog_hz(), ms(500)));
    assert_eq!(
        jog_ends(&b.events)[1..],
        [(2, JogEnd::Refused(Refusal::NotConnected))]
    );
}

/// Each behaviour, for each family.
macro_rules! for_every_family {
    ($($behaviour:ident),* $(,)?) => {
        mod isel {
            $(#[test] fn $behaviour() { super::$behaviour::<super::Isel>() })*
        }
        mod emcu {
            $(#[test] fn $behaviour() { super::$behaviour::<super::Emcu>() })*
        }
        mod emp {
            $(#[test] fn $behaviour() { super::$behaviour::<super::Emp>() })*
        }
    };
}

for_every_family!(
    a_connection_opens_with_the_stop_sequence,
    a_session_not_asked_to_move_connects_without_a_stop,
    nothing_runs_while_the_link_is_down,
    a_jog_without_renewal_ends_by_the_dead_man_and_the_axis_stands,
    a_stop_ends_a_jog_and_nothing_runs_after_it,
    a_lost_link_ends_a_jog_and_nothing_resumes,
);
