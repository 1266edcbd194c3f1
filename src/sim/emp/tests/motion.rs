//! Modes, positioning, homing, limit switches and stops, on the machine of
//! the `emp` profile (11200 counts/mm, soft limits 0-500 mm, limit switches
//! at -2 mm and 502 mm, reference cam from -1 mm to machine 0, top speed
//! 112000 counts/s, power-up sample rate 1 kHz).

use super::harness::*;
use crate::config::{ConfigDirs, load_profile};
use crate::proto::emp::Frame;
use crate::sim::SimDevice;
use crate::sim::emp::{EmpSim, EmpSimConfig};

const MM: f64 = 11_200.0;

/// The `emp` machine standing at `mm` (machine coordinates) at power-up.
fn emp_at(mm: f64) -> Conversation {
    let profile = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
    let mut config = EmpSimConfig::from_profile(&profile).unwrap();
    config.drives[0].start_position = mm * MM;
    Conversation::with(EmpSim::new(config).unwrap())
}

fn mode(c: &mut Conversation, code: u8) {
    c.send(&format!("2211{code:02X}0000000000"));
    let text = c.next().text;
    assert!(text.starts_with("23110022"), "{text}");
}

/// Send a `2A 00` velocity and expect `22`.
fn velocity(c: &mut Conversation, v: i8) {
    c.send(&format!("2A1100{:02X}00000000", v as u8));
    let text = c.next().text;
    assert!(text.starts_with("2B110022"), "{text}");
}

fn frame(text: &str) -> Frame {
    text.parse().unwrap()
}

#[test]
fn tp_answers_busy_at_once_then_ready_and_2c_rises_meanwhile() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    // 2A 01, Vmax 7F, to 200000: 127000 counts/s clipped to the top speed.
    let eof = c.send("2A1101 7F 00030D40");
    let busy = c.next();
    assert_eq!(busy.text, "2B11005500000000");
    assert_eq!(busy.at, eof + crate::sim::emp::PROCESSING_TIME);
    let mut positions = Vec::new();
    let done = loop {
        c.send("2C11000000000000");
        let m = c.next();
        if m.text.starts_with("2B") {
            break m;
        }
        let f = frame(&m.text);
        assert_eq!((f.cmd, f.info), (0x2D, 0x22));
        positions.push(f.data_word());
    };
    assert_eq!(done.text, "2B11002200030D40");
    // The poll sent before the completion is still answered.
    c.expect("2D11002200030D40");
    assert!(positions.len() > 100, "{}", positions.len());
    assert!(
        positions.windows(2).all(|w| w[0] < w[1]),
        "not strictly rising: {positions:?}"
    );
    assert!(positions.iter().all(|p| *p < 200_000));
    // 200000 counts at 112000 counts/s with 0.1 s ramps: 1.886 s.
    let took = (done.at - busy.at).as_secs_f64();
    assert!(
        (took - (200_000.0 / 112_000.0 + 0.1)).abs() < 1e-3,
        "{took}"
    );
    c.silence(secs(5.0));
}

#[test]
fn homing_reaches_the_reference_point_from_above() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    // Vfast 14h = 20 counts/sample = 20000 counts/s, Vslow 4.
    let start = c.exchange("2611000000140400", "2711005500000000");
    // The position is readable meanwhile and falls.
    let a = c.position();
    c.wait(secs(1.0));
    let b = c.position();
    assert!(b < a - 19_000, "{a} {b}");
    let done = c.expect("2711002200000000");
    // 448000 counts at 20000/s, brake into the switch, creep out at 4000/s.
    let took = (done - start).as_secs_f64();
    assert!((22.4..23.0).contains(&took), "{took}");
    assert_eq!(c.position(), 0);
    let s = c.snapshot();
    assert_eq!(s.physical, 0.0);
    assert!(
        !s.limits.reference,
        "the reference point is the switch's edge"
    );
    c.silence(secs(5.0));
}

#[test]
fn homing_reaches_the_reference_point_from_below_and_from_inside_the_switch() {
    // -1.5 mm: below the cam, above limit - (-2 mm). The search goes down,
    // reverses at limit -, overruns the switch going up, reverses again and
    // creeps out of the switch from above.
    for start_mm in [-1.5, -0.5, -2.5, 503.0] {
        let mut c = emp_at(start_mm);
        c.switch_on();
        mode(&mut c, 0x03);
        c.exchange("2611000000140400", "2711005500000000");
        let m = c.next();
        assert_eq!(m.text, "2711002200000000", "from {start_mm} mm");
        assert_eq!(c.snapshot().physical, 0.0, "from {start_mm} mm");
        assert_eq!(c.position(), 0);
        // The counter follows from there.
        velocity(&mut c, 1);
        c.wait(secs(1.0));
        assert!((1_000..1_020).contains(&c.position()));
    }
}

#[test]
fn homing_needs_a_mode_and_a_new_move_ends_it_without_completion() {
    let mut c = emp_at(40.0);
    c.switch_on();
    c.exchange("2611000000140400", "271100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    mode(&mut c, 0x03);
    c.exchange("2611000000140400", "2711005500000000");
    c.wait(secs(1.0));
    // A velocity command takes over: answered, and no 27 ever follows.
    velocity(&mut c, 0);
    let p = c.position();
    c.silence(secs(60.0));
    assert_eq!(c.position(), p);
}

#[test]
fn a_limit_switch_stops_a_velocity_move_which_only_leaves_the_other_way() {
    let mut c = emp_at(499.0);
    c.switch_on();
    mode(&mut c, 0x03);
    velocity(&mut c, 0x7F);
    c.wait(secs(1.0));
    let s = c.snapshot();
    assert_eq!(s.speed, 0.0);
    assert!(s.limits.plus);
    // Braked from 112000 counts/s at 1.12e6 counts/s²: 5600 counts beyond.
    assert!(
        (s.physical - (502.0 * MM + 5_600.0)).abs() < 1.0,
        "{}",
        s.physical
    );
    // 40 shows limit + in PROP.
    c.exchange("4011010000000000", "4111012200000000");
    assert_eq!(c.last_error(), 0x05);
    // Further in: refused.
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x05);
    c.switch_on();
    // Out: fine, and the switch releases.
    velocity(&mut c, -0x7F);
    c.wait(secs(1.0));
    assert!(!c.snapshot().limits.plus);
    c.exchange("4011010000000000", "4111002200000000");
    assert!(c.snapshot().physical < 500.0 * MM);
}

#[test]
fn limit_minus_brakes_torque_moves_too() {
    let mut c = emp_at(1.0);
    c.switch_on();
    mode(&mut c, 0x04);
    c.send("2A1100C000000000");
    c.next();
    c.wait(secs(2.0));
    let s = c.snapshot();
    assert!(s.limits.minus && s.speed == 0.0, "{s:?}");
    c.exchange("4011010000000000", "4111022200000000");
    c.exchange("2A1100C000000000", "2B1100EE00000000");
    c.send("2A11004000000000");
    assert!(c.next().text.starts_with("2B110022"));
}

#[test]
fn positioning_into_a_limit_switch_fails_with_ee() {
    let mut c = emp_at(490.0);
    c.switch_on();
    mode(&mut c, 0x07);
    // 20 mm up: beyond limit + at 12 mm.
    c.exchange("2A1101400003 6B00", "2B11005500000000");
    c.expect("2B1100EE00000000");
    assert_eq!(c.last_error(), 0x05);
    c.wait(ms(100.0));
    assert!(c.snapshot().limits.plus);
    assert_eq!(c.snapshot().speed, 0.0);
    // Up again is refused at once, down is fine.
    c.exchange("2A11014000036B00", "2B1100EE00000000");
    let here = c.position();
    c.exchange(
        "2A11014000000000",
        &format!("2B110055{}", pos_hex(here.into())),
    );
    c.expect("2B11002200000000");
    assert_eq!(c.snapshot().physical, 490.0 * MM);
}

#[test]
fn hold_ends_positioning_without_completion_and_keeps_the_mode() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    c.exchange("2A11011000100000", "2B11005500000000");
    c.wait(ms(200.0));
    c.exchange("0811000000000000", "0911002200000000");
    c.wait(ms(200.0));
    let p = c.position();
    assert!(p > 0);
    c.silence(secs(30.0));
    assert_eq!(c.position(), p);
    // TPWM is still set: a new move is taken and completes.
    c.exchange(
        "2A11011000000000",
        &format!("2B110055{}", pos_hex(p.into())),
    );
    c.expect("2B11002200000000");
}

#[test]
fn fast_stop_brakes_harder_than_hold_and_needs_the_mode_again() {
    let distance = |stop: &str| {
        let mut c = emp_at(40.0);
        c.switch_on();
        mode(&mut c, 0x03);
        velocity(&mut c, 0x7F);
        c.wait(secs(1.0));
        // Where the axis was when the stop took effect: it ran at the top
        // speed since the last poll.
        c.send("2C11000000000000");
        let polled = c.next();
        c.send(stop);
        let m = c.next();
        let at =
            frame(&polled.text).data_word() as f64 + 112_000.0 * (m.at - polled.at).as_secs_f64();
        c.wait(secs(1.0));
        let rest = f64::from(c.position());
        (rest - at, c)
    };
    let (hold, mut c) = distance("0811000000000000");
    // From 112000 counts/s: 5600 counts at 1.12e6/s² …
    assert!((hold - 5_600.0).abs() < 150.0, "{hold}");
    velocity(&mut c, 1);
    let (fast, mut c) = distance("2A11030000000000");
    // … and a quarter of that in a fast stop.
    assert!((fast - 1_400.0).abs() < 150.0, "{fast}");
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    mode(&mut c, 0x03);
    velocity(&mut c, 1);
}

#[test]
fn motor_disable_and_off_need_the_mode_again() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x02);
    velocity(&mut c, 10);
    c.exchange("2411000000000000", "2511002200000000");
    c.wait(secs(1.0));
    assert_eq!(c.snapshot().speed, 0.0);
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    mode(&mut c, 0x02);
    velocity(&mut c, 10);
    c.exchange("0411000000000000", "0511002200000000");
    c.wait(secs(1.0));
    assert_eq!(c.snapshot().speed, 0.0);
    c.switch_on();
    c.exchange("2A11000100000000", "2B1100EE00000000");
}

#[test]
fn set_position_sets_the_counter_and_switches_the_controller_off() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x03);
    c.exchange("20110501000004D2", "21110022000004D2");
    assert_eq!(c.position(), 1234);
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    // Clear to 0, negative values are 25-bit two's complement.
    c.exchange("2011050100000000", "2111002200000000");
    c.exchange("20110501 01FFFFFB", "2111002201FFFFFB");
    mode(&mut c, 0x03);
    velocity(&mut c, -1);
    c.wait(secs(1.0));
    c.send("2C11000000000000");
    let f = frame(&c.next().text);
    assert_eq!(f.d3(), 0x01, "negative: sign bit in D3");
    let p = c.position();
    // -5, then 1000 counts/s for 1 s and three round trips.
    assert!((-1_040..-1_010).contains(&p), "{p}");
    // Physically it went where the counter says (it was set to -5 at 448000).
    let p = c.position();
    let physical = c.snapshot().physical;
    assert!(
        (physical - (448_000.0 + f64::from(p) + 5.0)).abs() < 10.0,
        "{physical} {p}"
    );
}

#[test]
fn pv_runs_slower_than_iv_under_load_and_the_sample_rate_scales_both() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x03);
    velocity(&mut c, 10);
    assert_eq!(c.snapshot().speed, 10_000.0);
    // 2 kHz doubles the running speed.
    c.exchange("201119000000186A", "2111002200000000");
    assert_eq!(c.snapshot().speed, 20_000.0);
    c.exchange("2011190000 0030D4", "2111002200000000");
    mode(&mut c, 0x02);
    c.wait(secs(1.0));
    assert_eq!(c.snapshot().speed, 0.0, "a new mode starts from rest");
    velocity(&mut c, 10);
    assert_eq!(c.snapshot().speed, 9_800.0);
}

#[test]
fn torque_within_the_friction_does_not_move_and_tpwm_takes_torque_too() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x04);
    velocity(&mut c, 4);
    assert_eq!(c.snapshot().speed, 0.0);
    velocity(&mut c, -4);
    assert_eq!(c.snapshot().speed, 0.0);
    velocity(&mut c, 5);
    let one_unit = c.snapshot().speed;
    assert!((one_unit - 112_000.0 / 123.0).abs() < 1e-6);
    velocity(&mut c, 0x7F);
    assert_eq!(c.snapshot().speed, 112_000.0);
    // 2A 02 only in TPWM.
    c.exchange("2A11021000000000", "2B1100EE00000000");
    mode(&mut c, 0x07);
    c.send("2A11021000000000");
    assert!(c.next().text.starts_with("2B110022"));
    assert!((c.snapshot().speed - 12.0 * one_unit).abs() < 1e-6);
}

#[test]
fn a_rejected_move_still_ends_the_running_positioning() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    c.exchange("2A11011000100000", "2B11005500000000");
    c.wait(ms(100.0));
    // V = 0 cannot position: refused, and what ran is over (the host's
    // correlator has ended it).
    c.exchange("2A11000000000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x03);
    c.wait(secs(1.0));
    let p = c.position();
    c.silence(secs(30.0));
    assert_eq!(c.position(), p);
    assert_eq!(c.snapshot().speed, 0.0);
}

#[test]
fn a_stalled_tp_move_stays_busy_and_unmoving_until_a_stop_holds_it() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    let at = c.now;
    c.sim.stall_next(at).unwrap();
    assert!(c.sim.describe(at).contains("stall armed"));
    let before = c.position();
    c.exchange("2A1101 7F 00030D40", &format!("2B110055{before:08X}"));
    // Armed once: the next long action took it.
    assert!(!c.sim.describe(c.now).contains("stall armed"));
    c.wait(secs(10.0));
    assert_eq!(c.position(), before);
    assert_eq!(c.snapshot().activity, "stalled");
    // No `22` ever came; a stop ends the action and answers for itself.
    c.exchange("0811000000000000", &format!("09110022{before:08X}"));
    assert_eq!(c.snapshot().activity, "idle");
    c.silence(secs(5.0));
    // The next move runs normally.
    c.exchange("2A1101 7F 00030D40", &format!("2B110055{before:08X}"));
    c.expect("2B11002200030D40");
}

#[test]
fn a_stalled_homing_answers_busy_and_stands() {
    let mut c = emp_at(40.0);
    c.switch_on();
    mode(&mut c, 0x07);
    let at = c.now;
    c.sim.stall_next(at).unwrap();
    let before = c.position();
    c.exchange("2611000000140400", &format!("27110055{before:08X}"));
    c.wait(secs(30.0));
    assert_eq!(c.position(), before);
    c.exchange("2A1103 00 00000000", &format!("2B110022{before:08X}"));
    c.silence(secs(5.0));
}
