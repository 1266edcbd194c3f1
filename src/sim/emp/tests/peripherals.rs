//! I/O, ADC, joystick, EEPROM, RTC, operator controls and `describe`.

use super::harness::*;
use crate::proto::emp::DriveAddress;
use crate::sim::SimDevice;
use crate::sim::emp::{
    DriveConfig, EmpSim, EmpSimConfig, PROCESSING_TIME, SLOW_ADC_PROCESSING_TIME,
};

fn on() -> Conversation {
    let mut c = Conversation::new(EmpSimConfig::single());
    c.switch_on();
    c
}

#[test]
fn inputs_and_switches_read_with_40() {
    let mut c = on();
    c.exchange("4011010000000000", "4111002200000000");
    c.set("i1", true).unwrap();
    c.set("I3", true).unwrap();
    c.exchange("4011010000000000", "4111002200000005");
    c.set("i1", false).unwrap();
    c.exchange("4011010000000000", "4111002200000004");
    // The reference switch: the bench axis' cam is 500000 counts long.
    let config = EmpSimConfig {
        drives: vec![DriveConfig::new(DriveAddress::SINGLE).starting_at(-10.0)],
    };
    let mut c = Conversation::new(config);
    c.switch_on();
    c.exchange("4011010000000000", "4111042200000000");
}

#[test]
fn outputs_are_written_with_42_and_echoed() {
    let mut c = on();
    c.exchange("4211010000001001", "4311002200001001");
    let s = c.snapshot();
    assert!(s.outputs.get(1) && s.outputs.get(4) && !s.outputs.get(2));
    assert!(c.sim.describe(c.now).contains("O1001"));
    // A nibble other than 0 or 1 is a bad parameter.
    c.exchange("4211010000000002", "4311 00EE 00000000");
    assert_eq!(c.last_error(), 0x03);
    assert!(c.snapshot().outputs.get(4), "unchanged");
}

#[test]
fn the_adc_reads_the_operator_voltage() {
    let mut c = on();
    c.value("adc1", 1234.0).unwrap();
    // Bipolar channel 1, 16 bit, factor 1: 1234 mV = 4D20h, LSB in D1.
    c.exchange("501104000C000000", "511100220000204D");
    // Factor 2: full scale is 1024 mV, so 1234 mV clips …
    c.exchange("501104000D000000", "511100220000FF7F");
    // … and 500 mV reads 16000 = 3E80h.
    c.value("adc1", 500.0).unwrap();
    c.exchange("501104000D000000", "511100220000803E");
    // Channel 2 reads its own voltage; -100 mV in two's complement.
    c.press("adc2-down").unwrap();
    c.exchange("501104002C000000", "511100220000C0F9");
    c.press("adc2-up").unwrap();
    c.press("adc2-up").unwrap();
    c.exchange("501104002C000000", "5111002200004006");
    c.press("adc2-zero").unwrap();
    c.exchange("501104002C000000", "5111002200000000");
    // ADC type other than 04: bad parameter.
    c.exchange("501105000C000000", "511100EE00000000");
    assert_eq!(c.last_error(), 0x03);
}

#[test]
fn the_unipolar_jumper_reads_channel_3_and_no_negative_voltages() {
    let mut d = DriveConfig::new(DriveAddress::SINGLE);
    d.adc_unipolar = true;
    let mut c = Conversation::new(EmpSimConfig { drives: vec![d] });
    c.switch_on();
    c.value("adc3", 512.0).unwrap();
    c.value("adc1", -300.0).unwrap();
    // 2x is unipolar channel 3 now; 4x channel 1, clipped at 0.
    c.exchange("501104002C000000", "5111002200000020");
    c.exchange("501104004C000000", "5111002200000000");
}

#[test]
fn the_adc_takes_longer_with_the_i2c_bus_at_15_khz() {
    let mut c = on();
    let eof = c.send("501104000C000000");
    assert_eq!(c.next().at, eof + PROCESSING_TIME);
    // Beispiel 5: "I2C-Systemfrequenz auf 15 kHz einstellen".
    c.exchange("4411110000002600", "4511002200000000");
    let eof = c.send("501104000C000000");
    assert_eq!(c.next().at, eof + SLOW_ADC_PROCESSING_TIME);
    // The round trip becomes the manual's "14 ms" (13.7 ms at exact byte times).
    let round_trip = (c.now - (eof - Conversation::byte_time() * 17)).as_secs_f64();
    assert!(
        (13.5..14.1).contains(&(round_trip * 1000.0)),
        "{round_trip}"
    );
    // Other commands keep 1.6 ms.
    let eof = c.send("2C11000000000000");
    assert_eq!(c.next().at, eof + PROCESSING_TIME);
}

#[test]
fn the_eeprom_holds_64_kib() {
    let mut c = on();
    c.exchange("44110912 34A0005A", "4511002200000000");
    c.exchange("4411081234A00000", "451100220000005A");
    // Unwritten bytes read FF (erased), up to the last address.
    c.exchange("441108FFFFA00000", "45110022000000FF");
    c.exchange("441109FFFFA00001", "4511002200000000");
    c.exchange("441108FFFFA00000", "4511002200000001");
    c.exchange("4411080000A00000", "45110022000000FF");
}

#[test]
fn the_rtc_runs_from_a_fixed_power_up_date_and_can_be_set() {
    let mut c = on();
    // Thursday 2026-01-01 00:00:00.
    c.exchange("5411000000000000", "5511002204000000");
    c.exchange("5411010000000000", "5511002220260101");
    c.wait(secs(61.0));
    c.exchange("5411000000000000", "5511002204000101");
    // Friday 23:59:50, then past midnight: Saturday, the next day.
    c.exchange("5411020005235950", "5511002200000000");
    c.wait(secs(15.0));
    c.exchange("5411000000000000", "5511002206000005");
    c.exchange("5411010000000000", "5511002220260102");
    // A leap day.
    c.exchange("5411030020240229", "5511002200000000");
    c.exchange("5411010000000000", "5511002220240229");
    // Not BCD, not a date: bad parameter.
    c.exchange("541103002026023 0", "551100EE00000000");
    c.exchange("541102000A000000", "551100EE00000000");
    assert_eq!(c.last_error(), 0x03);
}

#[test]
fn a_joystick_drives_the_axis_in_pv_at_its_loop_rate() {
    let mut c = on();
    // Beispiel 5's parameters with one loop per reading: 10 ms.
    c.exchange("2011020104000140", "2111002200000000");
    c.exchange("2211050102000000", "2311002200000000");
    c.value("adc1", 1056.0).unwrap();
    let pressed = c.now;
    c.wait(ms(5.0));
    assert_eq!(c.snapshot().speed, 0.0, "read at the next loop");
    c.wait(ms(6.0));
    // Half way past the 64 mV dead band: V = 64, PV droop 2 %.
    assert_eq!(c.snapshot().speed, 64_000.0 * 0.98);
    assert!(c.now - pressed >= ms(10.0));
    c.value("adc1", -3000.0).unwrap();
    c.wait(ms(10.0));
    // V = -127: 124460 counts/s, clipped at the bench drive's top speed.
    assert_eq!(c.snapshot().speed, -100_000.0);
    c.value("adc1", 30.0).unwrap();
    c.wait(ms(50.0));
    assert_eq!(c.snapshot().speed, 0.0, "inside the dead band");
    // Joystick off: stops and holds; motion commands need a mode again.
    c.value("adc1", 1056.0).unwrap();
    c.wait(ms(20.0));
    c.send("2211060000000000");
    assert!(c.next().text.starts_with("23110022"));
    c.wait(ms(100.0));
    assert_eq!(c.snapshot().speed, 0.0);
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
}

#[test]
fn a_joystick_in_iv_waits_for_the_hosts_first_move() {
    let mut c = on();
    c.exchange("2211050103000000", "2311002200000000");
    c.value("adc1", 1056.0).unwrap();
    c.wait(ms(100.0));
    assert_eq!(c.snapshot().speed, 0.0, "IV needs 2A 00 01 first");
    c.value("adc1", 0.0).unwrap();
    // Beispiel 5: "Der Motor fährt kurz an und bleibt dann stehen."
    c.exchange("2A11000100000000", "2B11002200000000");
    assert_eq!(c.snapshot().speed, 1_000.0);
    c.wait(ms(20.0));
    assert_eq!(c.snapshot().speed, 0.0);
    let p = c.position();
    assert!((5..=15).contains(&p), "{p}");
    // From now on it follows.
    c.value("adc1", 2048.0).unwrap();
    c.wait(ms(20.0));
    assert_eq!(
        c.snapshot().speed,
        100_000.0,
        "127000 clipped at the top speed"
    );
    // 08 stops it and lets go of the joystick.
    c.exchange("0811000000000000", "0911002200000000");
    c.value("adc1", -2048.0).unwrap();
    c.wait(ms(100.0));
    assert_eq!(c.snapshot().speed, 0.0);
}

#[test]
fn controls_address_drives_and_name_what_exists() {
    let d = |m| DriveConfig::new(DriveAddress::module(m).unwrap());
    let mut c = Conversation::new(EmpSimConfig {
        drives: vec![d(1), d(3)],
    });
    c.set("31.i2", true).unwrap();
    assert_eq!(c.snapshot_of(0x31).inputs.bits(), 0b0010);
    assert_eq!(c.sim.input_level("31.i2"), Some(true));
    assert_eq!(c.sim.input_level("i2"), Some(false), "the first drive's");
    assert_eq!(c.sim.input_level("21.i2"), None, "no such drive");
    assert_eq!(c.sim.input_level("adc1"), None, "analogue");
    assert_eq!(c.snapshot_of(0x11).inputs.bits(), 0);
    let e = c.set("21.i2", true).unwrap_err();
    assert!(e.contains("no drive 21") && e.contains("11, 31"), "{e}");
    let e = c.set("x", true).unwrap_err();
    assert!(e.contains("i1, i2, i3, i4"), "{e}");
    assert!(c.value("adc1", 1e9).is_err());
    assert!(c.sim.input_names().contains(&"adc1"));
}

#[test]
fn describe_is_one_line_with_positions_modes_and_ports() {
    let mut c = Conversation::emp_profile();
    let line = c.sim.describe(c.now);
    assert_eq!(line, "11 X off pos 0 (physical 448000) I0000 O0000");
    c.switch_on();
    c.exchange("2211030000000000", "2311002200000000");
    c.exchange("2A11000A00000000", "2B11002200000000");
    c.set("i2", true).unwrap();
    c.value("adc1", 5.0).unwrap();
    c.wait(secs(1.0));
    let line = c.sim.describe(c.now);
    assert!(!line.contains('\n'));
    assert!(line.starts_with("11 X IV pos 10"), "{line}");
    assert!(
        line.contains("+10000/s running I0010 O0000 adc 5/0/0 mV"),
        "{line}"
    );
    c.send_bytes(b"junk\x1a");
    c.send("2C21000000000000");
    let line = c.sim.describe(c.now);
    assert!(
        line.ends_with("dropped: 1 framing, 1 not for a drive"),
        "{line}"
    );
    let sim = EmpSim::new(EmpSimConfig::single()).unwrap();
    assert_eq!(sim.describe(c.now), "11 off pos 0 I0000 O0000");
}
