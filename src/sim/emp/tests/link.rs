//! The link: switching on and off, addressing, timing, rejections.

use super::harness::*;
use crate::proto::emp::{DriveAddress, FRAME_WIRE_LEN, LINE};
use crate::sim::SimDevice;
use crate::sim::emp::{DriveConfig, EmpSimConfig, PROCESSING_TIME};

fn two_drives() -> Conversation {
    let d = |m| DriveConfig::new(DriveAddress::module(m).unwrap());
    Conversation::new(EmpSimConfig {
        drives: vec![d(2), d(1)],
    })
}

#[test]
fn nothing_is_accepted_before_unit_on_and_after_off() {
    let mut c = Conversation::new(EmpSimConfig::single());
    c.exchange("2C11000000000000", "2D1100EE00000000");
    c.exchange("0A11000000000000", "0B11002200000002");
    c.exchange("2211030000000000", "231100EE00000000");
    c.exchange("0011000000000000", "011100EE00000000");
    c.exchange("0811000000000000", "091100EE00000000");
    // A malformed request before "on" is also "not switched on".
    c.exchange("2C11000000000001", "2D1100EE00000000");
    assert_eq!(c.last_error(), 0x02);

    c.switch_on();
    assert_eq!(c.last_error(), 0x00, "switching on clears the error");
    c.exchange("2C11000000000000", "2D11002200000000");
    c.exchange("0411000000000000", "0511002200000000");
    c.exchange("2C11000000000000", "2D1100EE00000000");
    assert_eq!(c.last_error(), 0x02);
    // The link form of "on" works for a single drive too.
    c.exchange("0211000000000000", "0311002200000000");
    c.exchange("2C11000000000000", "2D11002200000000");
}

#[test]
fn the_strict_variant_rejects_0a_too_until_unit_on() {
    let mut d = DriveConfig::new(DriveAddress::SINGLE);
    d.rejects_0a_before_on = true;
    let mut c = Conversation::new(EmpSimConfig { drives: vec![d] });
    c.exchange("2C11000000000000", "2D1100EE00000000");
    // The reason cannot be read before `02` (docs/decisions.md "EMP
    // before 02").
    c.exchange("0A11000000000000", "0B1100EE00000000");
    c.exchange("0811000000000000", "091100EE00000000");
    c.switch_on();
    c.exchange("0A11000000000000", "0B11002200000000");
    c.exchange("2C11000000000000", "2D11002200000000");
    // Off again: as before `02`.
    c.exchange("0411000000000000", "0511002200000000");
    c.exchange("0A11000000000000", "0B1100EE00000000");
}

#[test]
fn a_reply_is_produced_1_6_ms_after_the_eof() {
    let mut c = Conversation::new(EmpSimConfig::single());
    assert_eq!(c.sim.line(), crate::wire::LineSettings::new(38400));
    let start = c.now;
    let eof = c.send("0211110000000000");
    assert_eq!(c.sim.next_deadline(), Some(eof + PROCESSING_TIME));
    // Nothing before the processing time is over …
    c.sim.advance(eof + PROCESSING_TIME - ms(0.001));
    assert_eq!(c.sim.poll_output(), None);
    // … then the reply, produced exactly then.
    let at = c.expect("0311002200000000");
    assert_eq!(at, eof + PROCESSING_TIME);
    assert_eq!(c.sim.next_deadline(), None);
    // The round trip: 17 bytes each way at 38400 baud and 1.6 ms, 10.45 ms;
    // the manual rounds its parts to "ca. 10,8 ms".
    let round_trip = c.now - start;
    assert_eq!(
        round_trip,
        LINE.byte_time() * 17 + PROCESSING_TIME + LINE.transfer_time(FRAME_WIRE_LEN)
    );
    assert!((10.4..10.9).contains(&(round_trip.as_secs_f64() * 1000.0)));
}

#[test]
fn a_frame_for_an_address_nobody_has_is_not_answered() {
    let mut c = Conversation::new(EmpSimConfig::single());
    c.send("0221110000000000");
    c.send("0212110000000000");
    c.send("2CF1000000000000");
    c.silence(ms(100.0));
    assert_eq!(c.sim.stats().ignored_frames, 3);
    assert_eq!(c.sim.next_deadline(), None);
    // Replies travelling the chain (odd CMD) are not answered either.
    c.send("2D11002200000000");
    c.silence(ms(100.0));
    assert_eq!(c.sim.stats().ignored_frames, 4);
    c.switch_on();
}

#[test]
fn two_drives_on_one_link_answer_independently() {
    let mut c = two_drives();
    assert_eq!(
        c.sim
            .addresses()
            .iter()
            .map(|a| a.to_string())
            .collect::<Vec<_>>(),
        ["11", "21"]
    );
    c.switch_on();
    // Drive 21 is still off.
    c.exchange("2C21000000000000", "2D2100EE00000000");
    c.exchange("0A21000000000000", "0B21002200000002");
    c.exchange("0221000000000000", "0321002200000000");
    // Only 21 turns.
    c.exchange("2221030000000000", "2321002200000000");
    c.exchange("2A21000A00000000", "2B21002200000000");
    c.wait(secs(1.0));
    let p21 = c.position_of(0x21);
    let p11 = c.position_of(0x11);
    assert_eq!(p11, 0);
    // 10 counts per sample at 1 kHz.
    assert!((10_000..10_200).contains(&p21), "{p21}");
    // Each has its own error register.
    c.exchange("2A11000100000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    c.exchange("0A21000000000000", "0B21002200000000");
}

#[test]
fn version_and_device_number_are_text() {
    let mut c = two_drives();
    c.switch_on();
    c.send("0011000000000000");
    assert_eq!(c.next().text, "DRS-500-EC_V08.2");
    c.send("0011010000000000");
    assert_eq!(c.next().text, "DRS-500-EC_N0650");
    c.exchange("0221000000000000", "0321002200000000");
    c.send("0021010000000000");
    assert_eq!(c.next().text, "DRS-500-EC_N0651");
}

#[test]
fn garbage_and_broken_frames_are_dropped_and_the_line_recovers() {
    let mut c = Conversation::new(EmpSimConfig::single());
    c.send_bytes(b"hello\x1a");
    // A frame without its EOF is lost with the one glued to it.
    c.send_bytes(b"0211110000000000");
    c.send_bytes(b"0211110000000000\x1a");
    c.send_bytes(b"0a11000000000000\x1a");
    c.silence(ms(50.0));
    assert_eq!(c.sim.stats().framing_errors, 3);
    c.switch_on();
}

#[test]
fn invalid_requests_are_rejected_with_their_error_code() {
    let mut c = Conversation::new(EmpSimConfig::single());
    c.switch_on();
    // Unknown CMD: 01.
    c.exchange("6011000000000000", "611100EE00000000");
    assert_eq!(c.last_error(), 0x01);
    // Unknown sub-code: 01.
    c.exchange("2A11090000000000", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x01);
    // A blank byte that is not 00: 03.
    c.exchange("2C11000000000001", "2D1100EE00000000");
    assert_eq!(c.last_error(), 0x03);
    // Homing at speed 0: 03.
    c.exchange("2611000000000400", "271100EE00000000");
    assert_eq!(c.last_error(), 0x03);
    // TP outside TPWM: 04.
    c.exchange("2211030000000000", "2311002200000000");
    c.exchange("2A11010100000100", "2B1100EE00000000");
    assert_eq!(c.last_error(), 0x04);
    // Reading the error does not clear it.
    assert_eq!(c.last_error(), 0x04);
    // Frames to a drive that does not exist get nothing, valid or not.
    c.send("6031000000000000");
    c.silence(ms(50.0));
}
