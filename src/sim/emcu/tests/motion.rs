//! Vector moves (manual 1.5.5-1.5.7, 1.5.10): absolute and relative, up to
//! three axes interpolated, the ramp from `#S` to `#E<n>` in `#R` ms, and end
//! stops that cost steps.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::motion::{Profile, Ramp};
use crate::proto::emcu::EmcuAxis;
use crate::sim::SimDevice;
use crate::sim::emcu::{AxisTravel, EmcuSimConfig, EndStops};

const READY: &[u8] = b"\x02\r";

/// Sends a batch and returns how long after its last byte the 0x02 CR came.
fn run(c: &mut Conversation, batch: &str) -> Duration {
    let said = c.send(batch);
    assert!(said.starts_with("<CR>"), "{batch:?} answered {said}");
    let sent = c.elapsed();
    let ready = c.wait_for(READY, Duration::from_secs(600)).unwrap();
    ready - sent
}

fn close(a: Duration, b: Duration) -> bool {
    a.abs_diff(b) <= Duration::from_micros(10)
}

#[test]
fn the_default_profile_ramps_500_ms_from_200_to_600_hz() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x1000\x01"), "<CR>");
    // 200 steps in the ramp up, 600 at 600 Hz, 200 in the ramp down: 2 s.
    c.wait(ms(500));
    assert_eq!(c.sim.counter(EmcuAxis::X, c.now), 200);
    c.wait(ms(500));
    assert_eq!(c.sim.counter(EmcuAxis::X, c.now), 500);
    let ready = c.wait_for(READY, Duration::from_secs(5)).unwrap();
    let sent = c.sim.line().transfer_time("L1,x1000\x01".len());
    assert!(close(ready - sent, Duration::from_secs(2)), "{ready:?}");
}

#[test]
fn absolute_and_relative_moves() {
    let mut c = Conversation::new();
    run(&mut c, "L1,X300,Y-200\x01");
    assert_eq!(
        (c.position(EmcuAxis::X), c.position(EmcuAxis::Y)),
        (300, -200)
    );
    run(&mut c, "L1,x-100,y50\x01");
    assert_eq!(
        (c.position(EmcuAxis::X), c.position(EmcuAxis::Y)),
        (200, -150)
    );
    run(&mut c, "L1,z35\x01");
    run(&mut c, "L1,X0,Y0,Z0\x01");
    for axis in EmcuAxis::ALL {
        assert_eq!(c.position(axis), 0);
    }
}

#[test]
fn three_axes_move_in_proportion_and_arrive_together() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,x900,y300,z-600\x01"), "<CR>");
    let mut last = [0; 3];
    while c.status().moving {
        c.wait(ms(37));
        let x = c.sim.counter(EmcuAxis::X, c.now);
        let y = c.sim.counter(EmcuAxis::Y, c.now);
        let z = c.sim.counter(EmcuAxis::Z, c.now);
        assert!((x - 3 * y).abs() <= 3, "x {x} y {y}");
        assert!((2 * x + 3 * z).abs() <= 3, "x {x} z {z}");
        assert!(x >= last[0] && y >= last[1] && z <= last[2]);
        last = [x, y, z];
    }
    assert_eq!(last, [900, 300, -600]);
    // The longest way leads along the profile: 900 steps take its time.
    let lead = Profile::new(
        900,
        Ramp {
            start_hz: 200.0,
            max_hz: 600.0,
            accel_hz_per_s: 800.0,
        },
    );
    let ready = c.times_of(READY);
    let sent = c.sim.line().transfer_time("L1,x900,y300,z-600\x01".len());
    assert_eq!(ready.len(), 1);
    assert!(close(ready[0] - sent, lead.duration()));
}

#[test]
fn speeds_slots_and_ramp_length_shape_the_move() {
    let mut c = Conversation::new();
    // 100 Hz to 1100 Hz in 250 ms: 4000 Hz/s, 150 steps per ramp.
    let took = run(&mut c, "#S100\r#E2,1100\r#R250\rL2,x2000\x01");
    let expected = Profile::new(
        2000,
        Ramp {
            start_hz: 100.0,
            max_hz: 1100.0,
            accel_hz_per_s: 4000.0,
        },
    )
    .duration();
    assert!(close(took, expected), "{took:?} vs {expected:?}");
    assert!(close(
        expected,
        Duration::from_secs_f64(0.5 + 1700.0 / 1100.0)
    ));
    // Slot 1 still has the default 600 Hz; the ramp is 500 Hz in 250 ms now.
    let took = run(&mut c, "L1,x1000\x01");
    let expected = Profile::new(
        1000,
        Ramp {
            start_hz: 100.0,
            max_hz: 600.0,
            accel_hz_per_s: 2000.0,
        },
    )
    .duration();
    assert!(close(took, expected), "{took:?} vs {expected:?}");
}

#[test]
fn an_end_speed_below_the_start_speed_runs_without_ramp() {
    let mut c = Conversation::new();
    let took = run(&mut c, "#S500\r#E1,300\rL1,x300\x01");
    assert!(close(took, Duration::from_secs(1)), "{took:?}");
}

#[test]
fn a_move_of_no_steps_ends_at_once() {
    let mut c = Conversation::new();
    assert_eq!(c.send("L1,X0,Y0\x01"), "<CR><02><CR>");
    assert_eq!(c.flags(), "000100");
}

#[test]
fn configuration_runs_in_order_with_the_moves() {
    let mut c = Conversation::new();
    // The second move runs at the speed set between the two.
    let took = run(
        &mut c,
        "#S600\r#E1,600\rL1,x600\r#S300\r#E1,300\rL1,x300\x01",
    );
    assert!(close(took, Duration::from_secs(2)), "{took:?}");
}

#[test]
fn a_move_past_an_end_stop_loses_steps() {
    let travel = AxisTravel {
        end_stops: Some(EndStops::new(-400, 60_400)),
        start: 8_000,
    };
    let mut c = Conversation::with(EmcuSimConfig { axes: [travel; 3] });
    run(&mut c, "#E1,5000\rL1,x60000\x01");
    assert_eq!(c.position(EmcuAxis::X), 60_000);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 60_400);
    assert!(
        c.sim
            .describe(c.now)
            .starts_with("X 60000 [machine 60400] Y 0 [machine 8000] Z 0 [machine 8000] |"),
        "{}",
        c.sim.describe(c.now)
    );
    // Back by as many steps: the counter is at 0 again, the carriage is not.
    run(&mut c, "L1,x-60000\x01");
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 400);
    // The interface cannot tell.
    assert_eq!(c.flags(), "000100");
}

#[test]
fn the_shipped_emcu_profile_builds_the_machine() {
    use crate::axis::Axis;
    use crate::config::{ConfigDirs, load_profile};
    use crate::sim::emcu::{EmcuSim, SimConfigError};

    let mut profile = load_profile("emcu", &ConfigDirs::builtin_only()).unwrap();
    let config = EmcuSimConfig::from_profile(&profile).unwrap();
    // 200 steps/mm, soft limits 0..300 / 0..200 / 0..80 mm, 2 mm margin, at 40 mm.
    let stops = config.axes.map(|a| a.end_stops.unwrap());
    assert_eq!(stops[0], EndStops::new(-400, 60_400));
    assert_eq!(stops[1], EndStops::new(-400, 40_400));
    assert_eq!(stops[2], EndStops::new(-400, 16_400));
    assert!(config.axes.iter().all(|a| a.start_position() == 8_000));
    let sim = EmcuSim::from_profile(&profile).unwrap();
    assert_eq!(sim.config(), &config);

    // A channel the profile gives no axis counts without end stops.
    profile.axes.remove(&Axis::Z);
    let config = EmcuSimConfig::from_profile(&profile).unwrap();
    assert_eq!(config.axes[2].end_stops, None);

    let a = profile.axes.get(&Axis::X).cloned().unwrap();
    profile.axes.insert(Axis::A, a);
    assert_eq!(
        EmcuSimConfig::from_profile(&profile),
        Err(SimConfigError::NotEmcuAxis(Axis::A))
    );
}

#[test]
fn describe_is_one_line_with_positions_flags_and_ports() {
    let mut c = Conversation::new();
    assert_eq!(c.send("A2,1\rL1,x120\x01"), "<CR><CR>");
    // 200 Hz and 800 Hz/s for 100 ms: 24 steps.
    c.wait(ms(100));
    let line = c.sim.describe(c.now);
    assert!(!line.contains('\n'));
    assert_eq!(
        line,
        "X 24 [machine 8024] Y 0 [machine 8000] Z 0 [machine 8000] \
         | moving, position unknown, job running | A1 off A2 on | E1 low \
         | memory 1/256 | ROM empty | #S200 #R500 &V0"
    );
}
