//! Reply decoding tables: data replies, codes where data was expected, text
//! replies, program runs, unsolicited bytes and garbage.

use crate::axis::AxisSet;
use crate::isel::ports::{input_bit, limit_diagnosis_axes};
use crate::isel::*;

fn decoded(expect: Expect, bytes: &[u8]) -> Vec<Event> {
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(expect), Ok(()));
    d.feed(bytes)
}

fn sync(c: u8) -> SyncChar {
    SyncChar::new(c).unwrap_or_else(|| panic!("{c} is no sync char"))
}

#[test]
fn the_expected_reply_follows_from_the_command() {
    use Command as C;
    let table = [
        (C::ReadPosition, None, Expect::Positions { with_a: false }),
        (
            C::ReadPosition,
            Some(AxisConfig::XYZ),
            Expect::Positions { with_a: false },
        ),
        (
            C::ReadPosition,
            Some(AxisConfig::XYZA),
            Expect::Positions { with_a: true },
        ),
        (C::ReadPort(InputPort::Status1), None, Expect::Byte),
        (C::Diagnose(Diagnosis::POSITIVE_LIMITS), None, Expect::Byte),
        (C::Status, None, Expect::TextThenCode),
        (C::LimitSwitchStatus, None, Expect::TextThenCode),
        (C::ReadVersion, None, Expect::TextUntilSilence),
        (C::ReadUserInfo, None, Expect::TextUntilSilence),
        (C::Start, None, Expect::ProgramRun),
        (C::Reference(AxisSet::XYZ), None, Expect::Handshake),
        (C::EraseProgram, None, Expect::Handshake),
        (C::Init(InitCommand::WriteToFlash), None, Expect::Handshake),
    ];
    for (command, config, expect) in table {
        assert_eq!(Expect::for_command(&command, config), expect, "{command:?}");
    }
    assert_eq!(Expect::Positions { with_a: false }.max_len(), 19);
    assert_eq!(Expect::Positions { with_a: true }.max_len(), 25);
}

#[test]
fn every_reply_code_decodes_as_a_handshake() {
    for code in ReplyCode::ALL {
        assert_eq!(
            decoded(Expect::Handshake, &[code.byte()]),
            [Event::Reply(Reply::Code(code))]
        );
        assert_eq!(Reply::Code(code).encode(), Ok(vec![code.byte()]));
    }
}

#[test]
fn port_and_diagnosis_replies() {
    // @0b1 -> 0x1B: both E-stop circuits closed, start and stop key pressed.
    let events = decoded(Expect::Byte, b"01B");
    assert_eq!(events, [Event::Reply(Reply::Byte(0x1B))]);
    let set: Vec<_> = (0..8)
        .filter(|bit| 0x1B & (1 << bit) != 0)
        .filter_map(|bit| input_bit(InputPort::Status1, bit))
        .map(|b| b.name)
        .collect();
    assert_eq!(
        set,
        [
            "E-stop circuit 1",
            "E-stop circuit 2",
            "start key",
            "stop key"
        ]
    );
    assert_eq!(
        decoded(Expect::Byte, b"0ff"),
        [Event::Reply(Reply::Byte(0xFF))]
    );
    assert_eq!(Reply::Byte(0x0A).encode(), Ok(b"00A".to_vec()));
    // @0DRp -> 0x05: positive limit switches of X and Z.
    let events = decoded(Expect::Byte, b"005");
    assert_eq!(events, [Event::Reply(Reply::Byte(5))]);
    assert_eq!(limit_diagnosis_axes(5).to_string(), "XZ");
}

#[test]
fn a_code_where_data_was_expected_is_a_normal_reply() {
    assert_eq!(
        decoded(Expect::Positions { with_a: false }, b"R"),
        [Event::Reply(Reply::Code(ReplyCode::ReferenceRequired))]
    );
    assert_eq!(
        decoded(Expect::Byte, b"9"),
        [Event::Reply(Reply::Code(ReplyCode::MachineFault))]
    );
    assert_eq!(
        decoded(Expect::TextThenCode, b"5"),
        [Event::Reply(Reply::Code(ReplyCode::Syntax))]
    );
}

#[test]
fn text_replies() {
    let status = decoded(Expect::TextThenCode, b"X1: free\r\nHood: closed\r\n0");
    assert_eq!(
        status,
        [Event::Reply(Reply::Text {
            lines: vec!["X1: free".into(), "Hood: closed".into()],
            end: TextEnd::Code(ReplyCode::Ok),
        })]
    );
    // A letter at a line start is text, so a lone `H` needs the silence.
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::TextThenCode), Ok(()));
    assert!(d.feed(b"H").is_empty());
    assert_eq!(
        d.silence(),
        [Event::Reply(Reply::Code(ReplyCode::HoodOpen))]
    );

    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::TextUntilSilence), Ok(()));
    assert!(d.feed(b"iMC-S8 V1.20\r\n(c) isel\r\n").is_empty());
    assert_eq!(
        d.silence(),
        [Event::Reply(Reply::Text {
            lines: vec!["iMC-S8 V1.20".into(), "(c) isel".into()],
            end: TextEnd::Silence,
        })]
    );
    assert_eq!(d.outstanding(), None);

    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::TextUntilSilence), Ok(()));
    assert_eq!(
        d.silence(),
        [Event::Reply(Reply::Text {
            lines: vec![],
            end: TextEnd::Silence
        })]
    );
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::TextUntilSilence), Ok(()));
    d.feed(b"5");
    assert_eq!(d.silence(), [Event::Reply(Reply::Code(ReplyCode::Syntax))]);
}

#[test]
fn a_program_run_reports_sync_characters_until_its_code() {
    let events = decoded(Expect::ProgramRun, b"!A=0");
    assert_eq!(
        events,
        [
            Event::Sync(sync(b'!')),
            // Unused codes cannot be replies of this controller: sync chars.
            Event::Sync(sync(b'A')),
            Event::Sync(sync(b'=')),
            Event::Reply(Reply::Code(ReplyCode::Ok)),
        ]
    );
    assert_eq!(
        decoded(Expect::ProgramRun, b"F"),
        [Event::Reply(Reply::Code(ReplyCode::UserStop))]
    );
    let garbage = decoded(Expect::ProgramRun, b"! ");
    assert!(matches!(garbage.as_slice(), [Event::Sync(_), Event::Error(e)] if e.consumed == 1));
}

#[test]
fn unsolicited_bytes_and_one_command_at_a_time() {
    let mut d = ReplyDecoder::new();
    assert_eq!(
        d.feed(b"0!"),
        [Event::Unsolicited(b'0'), Event::Unsolicited(b'!')]
    );
    assert_eq!(d.expect(Expect::Handshake), Ok(()));
    assert_eq!(d.expect(Expect::Byte), Err(Outstanding(Expect::Handshake)));
    // The rest after a complete reply is unsolicited.
    assert_eq!(
        d.feed(b"0F"),
        [
            Event::Reply(Reply::Code(ReplyCode::Ok)),
            Event::Unsolicited(b'F')
        ]
    );
    assert_eq!(d.expect(Expect::Positions { with_a: false }), Ok(()));
    d.feed(b"0001");
    assert_eq!(d.pending(), b"0001");
    assert_eq!(d.abandon(), b"0001".to_vec());
    assert_eq!(d.outstanding(), None);
}

#[test]
fn garbage_is_a_clear_error_and_the_stream_resynchronises() {
    let events = decoded(Expect::Positions { with_a: false }, b"0001G0\r0");
    let [Event::Error(e), rest @ ..] = events.as_slice() else {
        panic!("{events:?}");
    };
    assert_eq!(e.consumed, 5);
    assert_eq!(e.bytes, "0001G");
    assert!(e.expected.contains("hex digit 4 of 18"), "{e}");
    assert_eq!(e.got, "`G`");
    assert_eq!(
        rest,
        [
            Event::Unsolicited(b'0'),
            Event::Unsolicited(b'\r'),
            Event::Unsolicited(b'0')
        ]
    );
    let events = decoded(Expect::Handshake, b"\r");
    assert!(
        matches!(events.as_slice(), [Event::Error(e)] if e.to_string().contains("<CR>")),
        "{events:?}"
    );
    // Silence in the middle of a data reply: truncated.
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::Byte), Ok(()));
    d.feed(b"0A");
    let events = d.silence();
    assert!(
        matches!(events.as_slice(), [Event::Error(e)] if e.consumed == 2 && e.got.contains("silence")),
        "{events:?}"
    );
    // A move may take minutes: silence with nothing received is not an error.
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::Handshake), Ok(()));
    assert!(d.silence().is_empty());
    assert_eq!(d.outstanding(), Some(Expect::Handshake));
}

#[test]
fn text_replies_are_bounded() {
    let mut d = ReplyDecoder::new();
    assert_eq!(d.expect(Expect::TextThenCode), Ok(()));
    let line = [b'x'; 100];
    let mut events = Vec::new();
    for _ in 0..50 {
        events.extend(d.feed(&line));
    }
    assert!(
        matches!(events.first(), Some(Event::Error(e)) if e.consumed == MAX_TEXT_REPLY),
        "{:?}",
        events.first()
    );
    assert_eq!(d.outstanding(), None);
    assert!(
        events
            .iter()
            .skip(1)
            .all(|e| matches!(e, Event::Unsolicited(b'x')))
    );
}
