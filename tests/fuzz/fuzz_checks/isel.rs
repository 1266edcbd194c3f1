//! isel @-format: the host's reply decoder (every [`Expect`] kind) and the
//! controller's side, the request framer and the line parsers.

use std::fmt::{Debug, Display};

use jogterm::proto::isel::{
    AxisConfig, Event, Expect, MAX_LINE, MAX_TEXT_REPLY, ParseError, Parsed, Received, Reply,
    ReplyDecoder, RequestFramer, parse_cnc, parse_frame, validate_cnc, validate_frame,
};

use super::{Choices, chunks, split_head};

/// Every kind of reply a command can get.
pub const EXPECTS: [Expect; 7] = [
    Expect::Handshake,
    Expect::Positions { with_a: false },
    Expect::Positions { with_a: true },
    Expect::Byte,
    Expect::TextThenCode,
    Expect::TextUntilSilence,
    Expect::ProgramRun,
];

/// Reply decoder. The first byte picks the expectation; the rest is what
/// the line delivered.
pub fn reply(data: &[u8]) {
    let (head, stream) = split_head(data);
    let expect = EXPECTS[usize::from(head) % EXPECTS.len()];
    let mut choices = Choices::new(data);

    // However the bytes are split, the events are the same.
    let whole = decode_once(expect, &[stream]);
    let single: Vec<&[u8]> = stream.chunks(1).collect();
    assert_eq!(
        decode_once(expect, &single),
        whole,
        "{expect:?}: byte by byte differs from all at once"
    );
    let pieces = chunks(stream, &mut choices);
    assert_eq!(
        decode_once(expect, &pieces),
        whole,
        "{expect:?}: split {:?} differs from all at once",
        pieces.iter().map(|p| p.len()).collect::<Vec<_>>()
    );

    conversation(stream, &mut choices);
}

/// One expectation, the chunks fed in order, then silence.
fn decode_once(expect: Expect, pieces: &[&[u8]]) -> Vec<Event> {
    let mut decoder = ReplyDecoder::new();
    assert!(decoder.expect(expect).is_ok(), "a fresh decoder is idle");
    let mut events = Vec::new();
    let mut fed = 0;
    for piece in pieces {
        events.extend(decoder.feed(piece));
        fed += piece.len();
        check_buffer(&decoder);
        assert!(events.len() <= fed, "more events than bytes");
    }
    events.extend(decoder.silence());
    check_after_silence(&decoder);
    assert!(events.len() <= fed + 1, "more events than bytes");
    for event in &events {
        check_event(expect, event);
    }
    events
}

/// A console's life on one line: after each reply the next command is sent
/// (its expectation armed), silence and timeouts come at times the input
/// chooses, one byte at a time.
fn conversation(stream: &[u8], choices: &mut Choices) {
    let mut decoder = ReplyDecoder::new();
    let mut events = 0usize;
    let mut budget = 0usize;
    for &byte in stream {
        let next = EXPECTS[choices.below(EXPECTS.len() as u64) as usize];
        match decoder.outstanding() {
            None => assert!(decoder.expect(next).is_ok()),
            Some(current) => {
                // One command at a time: a second expectation is refused and
                // changes nothing.
                let pending = decoder.pending().to_vec();
                assert!(decoder.expect(next).is_err());
                assert_eq!(decoder.outstanding(), Some(current));
                assert_eq!(decoder.pending(), pending.as_slice());
            }
        }
        let expect = decoder.outstanding();
        let got = decoder.feed(&[byte]);
        budget += 1;
        if let Some(expect) = expect {
            for e in &got {
                check_event(expect, e);
            }
        }
        events += got.len();
        check_buffer(&decoder);
        if choices.one_in(16) {
            events += decoder.silence().len();
            budget += 1;
            check_after_silence(&decoder);
        }
        if choices.one_in(64) {
            decoder.abandon();
            assert!(decoder.outstanding().is_none() && decoder.pending().is_empty());
        }
        assert!(events <= budget, "more events than bytes and silences");
    }
}

/// What the decoder holds is bounded by the longest reply of its kind.
fn check_buffer(decoder: &ReplyDecoder) {
    let held = decoder.pending().len();
    match decoder.outstanding() {
        None => assert_eq!(held, 0, "bytes held with nothing outstanding"),
        Some(Expect::TextThenCode | Expect::TextUntilSilence) => {
            assert!(held < MAX_TEXT_REPLY, "{held} bytes of text held")
        }
        Some(expect) => assert!(
            held < expect.max_len(),
            "{held} bytes held for {expect:?} (at most {})",
            expect.max_len()
        ),
    }
}

/// Silence ends every reply that has begun.
fn check_after_silence(decoder: &ReplyDecoder) {
    assert!(
        decoder.outstanding().is_none() || decoder.pending().is_empty(),
        "{:?} still outstanding after silence with {} bytes held",
        decoder.outstanding(),
        decoder.pending().len()
    );
}

fn check_event(expect: Expect, event: &Event) {
    match event {
        Event::Reply(reply) => check_reply_round_trip(expect, reply),
        Event::Error(e) => {
            assert!(e.consumed >= 1, "an error that drops nothing: {e:?}");
            let _ = e.to_string();
        }
        Event::Sync(_) | Event::Unsolicited(_) => {}
    }
}

/// A decoded reply, encoded as a controller would send it, decodes to the
/// same reply.
fn check_reply_round_trip(expect: Expect, reply: &Reply) {
    let _ = (reply.code().meaning(), reply.code().name());
    // Text lines may hold what no controller could send unambiguously (a
    // line that starts with a digit after silence ended it); those have no
    // encoding, which `encode` says.
    let Ok(bytes) = reply.encode() else { return };
    let mut decoder = ReplyDecoder::new();
    assert!(decoder.expect(expect).is_ok());
    let mut events = decoder.feed(&bytes);
    events.extend(decoder.silence());
    assert_eq!(
        events,
        [Event::Reply(reply.clone())],
        "{expect:?}: {reply:?} encodes to {bytes:?}, which decodes differently"
    );
}

/// The controller's side: the framer cuts lines and control bytes, each line
/// is parsed as a DNC frame and as a stored CNC line and checked against every
/// axis configuration.
pub fn request(data: &[u8]) {
    let mut framer = RequestFramer::new();
    let mut byte_wise = Vec::new();
    for &b in data {
        byte_wise.extend(framer.push(b));
        assert!(
            framer.partial().len() <= MAX_LINE,
            "the framer holds too much"
        );
    }
    let mut again = RequestFramer::new();
    assert_eq!(
        again.push_all(data),
        byte_wise,
        "framing depends on the split"
    );
    for received in &byte_wise {
        match received {
            Received::Line(line) => {
                assert!(line.len() <= MAX_LINE);
                line_checks(line);
            }
            Received::Overlong { len } => assert!(*len > MAX_LINE),
            Received::Control(_) => {}
        }
    }
    // A line the framer never ended (no CR yet) is parsed too: a console
    // validates what is typed before it is sent.
    line_checks(framer.partial());
}

fn line_checks(line: &[u8]) {
    let len = line.len();
    if let Ok(frame) = parsed_checks(line, |l| parse_frame(l)) {
        assert_eq!(frame.encode().last(), Some(&b'\r'));
    }
    if let Ok(cnc) = parsed_checks(line, |l| parse_cnc(l)) {
        let _ = (cnc.code(), cnc.jump_offset(), cnc.as_dnc());
    }
    for config in AxisConfig::ALL {
        for rejection in [
            validate_frame(line, Some(config)).err(),
            validate_cnc(line, config).err(),
        ]
        .into_iter()
        .flatten()
        {
            if let Some(span) = &rejection.span {
                assert!(
                    span.start <= span.end && span.end <= len.max(1),
                    "{rejection:?}"
                );
            }
        }
    }
    let _ = validate_frame(line, None);
}

/// What both line parsers (DNC frames and CNC commands) promise for any
/// line: spans inside the line; the canonical text parses to the same value,
/// without notes; an error's span inside the line (or at its first byte when
/// it is empty). The value, or the error.
fn parsed_checks<T>(
    line: &[u8],
    parse: impl Fn(&[u8]) -> Result<Parsed<T>, ParseError>,
) -> Result<T, ParseError>
where
    T: Display + PartialEq + Debug,
{
    let len = line.len();
    match parse(line) {
        Ok(parsed) => {
            for r in parsed
                .params
                .iter()
                .chain(parsed.notes.iter().map(|n| &n.span))
            {
                assert!(
                    r.start <= r.end && r.end <= len,
                    "span {r:?} outside {len} bytes"
                );
            }
            let text = parsed.value.to_string();
            let back = parse(text.as_bytes());
            assert_eq!(
                back.as_ref().map(|p| &p.value),
                Ok(&parsed.value),
                "{text:?} (from {line:?})"
            );
            assert!(back.is_ok_and(|p| p.notes.is_empty()), "{text:?} has notes");
            Ok(parsed.value)
        }
        Err(e) => {
            assert!(
                e.span.start <= e.span.end && e.span.end <= len.max(1),
                "{e:?} in {len}"
            );
            let _ = e.to_string();
            Err(e)
        }
    }
}
