//! EMCU (SMC3000 interface): the host's reply decoder and the interface's
//! side, the command framer and parser.

use jogterm::proto::emcu::command::MAX_COMMAND_LINE;
use jogterm::proto::emcu::exchange::{Disposition, Expect};
use jogterm::proto::emcu::reply::MAX_REPLY_LINE;
use jogterm::proto::emcu::{
    CommandFramer, EmcuAxis, ReplyDecoder, ReplyEvent, Terminator, parse_bytes, parse_line,
};

use super::{Choices, split_independent};

/// Reply decoder: the input is what the line delivered.
pub fn reply(data: &[u8]) {
    let mut choices = Choices::new(data);
    split_independent(data, &mut choices, decode);
}

fn decode(pieces: &[&[u8]]) -> Vec<ReplyEvent> {
    let mut decoder = ReplyDecoder::new();
    let mut events = Vec::new();
    let mut fed = 0;
    for piece in pieces {
        events.extend(decoder.feed(piece));
        fed += piece.len();
        assert!(
            decoder.pending().len() <= MAX_REPLY_LINE,
            "{} bytes held",
            decoder.pending().len()
        );
        // One byte never yields more than one event (the decoder's promise).
        assert!(events.len() <= fed, "more events than bytes");
    }
    for event in &events {
        check_event(event);
    }
    events
}

const EXPECTS: [Expect; 7] = [
    Expect::Ack,
    Expect::AckOrMemoryFull,
    Expect::Version,
    Expect::Status,
    Expect::Position(EmcuAxis::X),
    Expect::Position(EmcuAxis::Y),
    Expect::Position(EmcuAxis::Z),
];

fn check_event(event: &ReplyEvent) {
    match event {
        ReplyEvent::Reply(reply) => {
            // The reply as the interface sends it decodes to itself, alone.
            let bytes = reply.encode();
            let mut fresh = ReplyDecoder::new();
            assert_eq!(
                fresh.feed(&bytes),
                [ReplyEvent::Reply(reply.clone())],
                "{reply:?} encodes to {bytes:?}"
            );
            assert!(fresh.pending().is_empty());
            // Every reply sorts into exactly one disposition for every
            // command; a ready line is never an answer.
            for expect in EXPECTS {
                let d = expect.classify(reply);
                assert!(!(reply.is_unsolicited() && d == Disposition::Answer));
            }
        }
        ReplyEvent::Garbage(g) => {
            assert!(!g.bytes.is_empty(), "garbage of no bytes");
            assert!(
                g.bytes.len() <= MAX_REPLY_LINE + 1,
                "{} bytes",
                g.bytes.len()
            );
            let _ = g.to_string();
        }
    }
}

/// The interface's side: lines cut at CR or 0x01 and parsed.
pub fn command(data: &[u8]) {
    let mut framer = CommandFramer::new();
    let mut byte_wise = Vec::new();
    for &b in data {
        byte_wise.extend(framer.push(b));
        assert!(framer.pending().len() <= MAX_COMMAND_LINE + 1);
    }
    let mut again = CommandFramer::new();
    assert_eq!(again.feed(data), byte_wise, "framing depends on the split");
    for received in &byte_wise {
        assert!(received.raw.len() <= MAX_COMMAND_LINE + 1);
        match &received.command {
            Ok(command) => {
                // The canonical line is accepted by a fresh framer as the
                // same command with the same terminator.
                let bytes = command.encode(received.terminator);
                assert!(bytes.is_ok(), "{command:?} does not encode: {bytes:?}");
                let bytes = bytes.unwrap_or_default();
                let back = CommandFramer::new().feed(&bytes);
                assert_eq!(back.len(), 1, "{bytes:?}");
                assert_eq!(back.first().map(|r| &r.command), Some(&Ok(*command)));
                assert_eq!(
                    back.first().map(|r| r.terminator),
                    Some(received.terminator)
                );
                let _ = (command.class(), command.expect(), command.may_move());
                if received.terminator == Terminator::RunBuffer {
                    assert!(!command.is_master());
                }
            }
            Err(e) => {
                assert!(
                    e.offset <= received.raw.len().max(MAX_COMMAND_LINE),
                    "{e:?}"
                );
                let _ = e.to_string();
            }
        }
    }
    // Text typed in the console goes through `parse_line`, which must agree
    // with the bytes parser on the same line.
    let pending = framer.pending();
    if let Ok(text) = std::str::from_utf8(pending) {
        assert_eq!(parse_line(text), parse_bytes(pending));
    }
    if let Err(e) = parse_bytes(pending) {
        assert!(
            e.offset <= pending.len(),
            "{e:?} in {} bytes",
            pending.len()
        );
    }
}
