//! The manual's Beispiel 1-4, replayed byte for byte (DS = 11) against the
//! machine of the shipped `emp` profile (14:1 gear, 5 mm spindle, 1000-line
//! encoder: 11200 counts/mm, standing at 40 mm, counter 0 at power-up).

use super::harness::*;
use crate::proto::emp::{Mechanics, ReloadValue};

fn speed(c: &Conversation) -> f64 {
    c.snapshot().speed
}

/// The speed the drive runs at with `v` counts per sample and `reload`.
fn counts_per_second(v: f64, reload: u16) -> f64 {
    v * ReloadValue::new(reload).unwrap().frequency_hz()
}

#[test]
fn beispiel_1_constant_torque() {
    let mut c = Conversation::emp_profile();
    // 1. Anlage einschalten
    c.exchange("0211110000000000", "0311002200000000");
    // 2. Betriebsart mit konstanten Drehmoment festlegen
    c.exchange("2211040000000000", "2311002200000000");
    // 3. Drehmoment in Höhe von "10" (RL10)
    c.exchange("2A11001000000000", "2B11002200000000");
    let v10 = speed(&c);
    assert!(v10 > 0.0);
    let p0 = c.position();
    c.wait(secs(1.0));
    let p1 = c.position();
    assert!(p1 > p0 + 10_000, "{p0} -> {p1}");
    // 4. Drehmoment "15" (RL15): faster against the same load.
    c.send("2A11001500000000");
    assert!(c.next().text.starts_with("2B110022"));
    let v15 = speed(&c);
    assert!(v15 > v10);
    // The load model: speed proportional to torque above the friction (4).
    assert!(((v15 / v10) - (0x15 as f64 - 4.0) / (0x10 as f64 - 4.0)).abs() < 1e-9);
    // 5. Drehmoment "F0" (LL10): the other way round.
    c.send("2A1100F000000000");
    assert!(c.next().text.starts_with("2B110022"));
    assert_eq!(speed(&c), -v10);
    let p2 = c.position();
    c.wait(secs(1.0));
    assert!(c.position() < p2 - 10_000);
}

#[test]
fn beispiel_2_iv_velocities() {
    let mut c = Conversation::emp_profile();
    c.switch_on();
    // 1. Betriebsart IV auswählen
    c.exchange("2211030000000000", "2311002200000000");
    // 2.-5. V = 2, 5, -2, -5 at the power-up sample rate of 1 kHz.
    for (frame, v) in [
        ("2A11000200000000", 2.0),
        ("2A11000500000000", 5.0),
        ("2A1100FE00000000", -2.0),
        ("2A1100FB00000000", -5.0),
    ] {
        c.send(frame);
        assert!(c.next().text.starts_with("2B110022"));
        assert_eq!(speed(&c), counts_per_second(v, 0x30D4), "{frame}");
    }
    // Scaled: 2 / -2 / 5 Umdr/min of the spindle with 14:1 and 5 mm/Umdr.
    let m = Mechanics::new(14.0, 5.0, 1000).unwrap();
    // 6. Betriebsart IV auswählen (stops what ran)
    c.send("2211030000000000");
    assert!(c.next().text.starts_with("23110022"));
    c.wait(secs(1.0));
    assert_eq!(speed(&c), 0.0);
    // 7. Abtastrate berechnen und übergeben
    c.exchange("2011190000001A28", "2111002200000000");
    // 8. Geschwindigkeit von 2 Umdr/min
    c.send("2A11000100000000");
    c.next();
    let expected = m.counts_per_second(m.feed_for_spindle_rpm(2.0));
    assert!((speed(&c) / expected - 1.0).abs() < 1e-3, "{}", speed(&c));
    let p0 = c.position();
    c.wait(secs(10.0));
    let moved = f64::from(c.position() - p0);
    // 10 s at 1866.8 counts/s, plus the 10.5 ms of the second poll.
    assert!((moved / (10.0 * expected) - 1.0).abs() < 2e-3, "{moved}");
    // 9. Geschwindigkeit von -2 Umdr/min
    c.send("2A1100FF00000000");
    c.next();
    assert!((speed(&c) / -expected - 1.0).abs() < 1e-3);
    // 10. Abtastrate berechnen und übergeben: the running -1 speeds up.
    c.exchange("2011190000000A76", "2111002200000000");
    let five = m.counts_per_second(m.feed_for_spindle_rpm(5.0));
    assert!((speed(&c) / -five - 1.0).abs() < 1e-3, "{}", speed(&c));
    // 11. Geschwindigkeit von 5 Umdr/min
    c.send("2A11000100000000");
    c.next();
    assert!((speed(&c) / five - 1.0).abs() < 1e-3);
}

#[test]
fn beispiel_3_position_during_motion() {
    let mut c = Conversation::emp_profile();
    c.switch_on();
    c.exchange("2211030000000000", "2311002200000000");
    c.exchange("2A11001000000000", "2B11002200000000");
    // 1. Position lesen, 2. Position lesen: one round trip (10.5 ms) apart
    // at 16 counts per sample and 1 kHz.
    let a = c.position();
    let b = c.position();
    assert!(a > 0 && b > a, "{a} {b}");
    let per_round_trip = f64::from(b - a);
    assert!(
        (per_round_trip - 16_000.0 * 0.010_45).abs() < 2.0,
        "{b} - {a}"
    );
}

#[test]
fn beispiel_4_tpwm_positioning() {
    let mut c = Conversation::emp_profile();
    c.switch_on();
    // 1. Betriebsart TPWM festlegen
    c.exchange("2211070000000000", "2311002200000000");
    // 4. Abtastfrequenz an Anlage senden (10 mm/min with V = 01)
    c.exchange("2011190000001A28", "2111002200000000");
    // 5. Bewegungskommando: V and position 100000.
    let start = c.exchange("2A110001000186A0", "2B11005500000000");
    // 6. warten, bis Achse positioniert hat: "Anlage sendet Info-byte 22".
    let done = c.expect("2B110022000186A0");
    let expected = 100_000.0 / counts_per_second(1.0, 0x1A28);
    let took = (done - start).as_secs_f64();
    assert!(
        (took - expected).abs() < 0.01,
        "{took} s, expected {expected}"
    );
    // 7. Position lesen
    assert_eq!(c.position(), 100_000);
    // 10./11. 5 mm/min back to 40000.
    c.exchange("2011190000003450", "2111002200000000");
    let start = c.exchange("2A11000100009C40", "2B110055000186A0");
    let done = c.expect("2B11002200009C40");
    let expected = 60_000.0 / counts_per_second(1.0, 0x3450);
    assert!(((done - start).as_secs_f64() - expected).abs() < 0.01);
    // 13. Position lesen
    assert_eq!(c.position(), 40_000);
    // The axis stands where the counter says: 40 mm + 40000 counts.
    assert_eq!(c.snapshot().physical, 448_000.0 + 40_000.0);
}
