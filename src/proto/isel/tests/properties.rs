//! Property tests: encode/parse and encode/decode round trips, byte-split
//! invariance of the decoder, and garbage that never panics and always
//! makes progress.

use proptest::collection::vec;
use proptest::prelude::*;

use super::strategies::{cnc_command, command, config, device, expect, reply};
use crate::proto::isel::*;

fn run(expect: Expect, chunks: &[&[u8]]) -> Vec<Event> {
    let mut d = ReplyDecoder::new();
    let mut events = Vec::new();
    if d.expect(expect).is_err() {
        unreachable!("a fresh decoder has nothing outstanding");
    }
    for chunk in chunks {
        events.extend(d.feed(chunk));
    }
    events.extend(d.silence());
    events
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn frames_round_trip(device in device(), command in command()) {
        let frame = Frame::new(device, command);
        let text = frame.to_string();
        let parsed = parse_frame(&text);
        prop_assert_eq!(parsed.as_ref().map(|p| &p.value), Ok(&frame), "{}", text);
        prop_assert!(parsed.is_ok_and(|p| p.notes.is_empty()));
        let mut bytes = text.into_bytes();
        bytes.push(CR);
        prop_assert_eq!(frame.encode(), bytes);
    }

    #[test]
    fn cnc_lines_round_trip(command in cnc_command()) {
        let text = command.to_string();
        let parsed = parse_cnc(&text);
        prop_assert_eq!(parsed.as_ref().map(|p| &p.value), Ok(&command), "{}", text);
        prop_assert!(parsed.is_ok_and(|p| p.notes.is_empty()));
        let encoded = command.encode();
        prop_assert_eq!(encoded.last(), Some(&CR));
    }

    #[test]
    fn checking_never_panics_and_agrees_with_validation(
        command in command(),
        cnc in cnc_command(),
        config in config(),
    ) {
        let frame = Frame::default_device(command.clone());
        let checked = check_with(&command, config).map_err(|e| e.code);
        let validated = validate_frame(frame.to_string(), config).map(|_| ()).map_err(|e| e.code);
        prop_assert_eq!(checked, validated);
        if let Some(config) = config {
            let checked = check_cnc(&cnc, config).map_err(|e| e.code);
            let validated = validate_cnc(cnc.to_string(), config).map(|_| ()).map_err(|e| e.code);
            prop_assert_eq!(checked, validated);
        }
    }

    #[test]
    fn replies_round_trip((expect, reply) in reply()) {
        let bytes = reply.encode();
        prop_assert!(bytes.is_ok(), "{:?}: {:?}", reply, bytes);
        let bytes = bytes.unwrap_or_default();
        prop_assert_eq!(run(expect, &[&bytes]), vec![Event::Reply(reply)]);
    }

    #[test]
    fn any_split_gives_the_same_events(
        (expect, reply) in reply(),
        trailer in vec(any::<u8>(), 0..8),
    ) {
        let mut bytes = reply.encode().unwrap_or_default();
        bytes.extend(trailer);
        let whole = run(expect, &[&bytes]);
        for at in 0..=bytes.len() {
            let (a, b) = bytes.split_at(at);
            prop_assert_eq!(&run(expect, &[a, b]), &whole, "split at {}", at);
        }
        let singles: Vec<&[u8]> = bytes.chunks(1).collect();
        prop_assert_eq!(&run(expect, &singles), &whole);
    }

    #[test]
    fn garbage_splits_give_the_same_events(
        expect in expect(),
        bytes in vec(any::<u8>(), 0..64),
        at in any::<prop::sample::Index>(),
    ) {
        let whole = run(expect, &[&bytes]);
        let (a, b) = bytes.split_at(at.index(bytes.len() + 1));
        prop_assert_eq!(run(expect, &[a, b]), whole);
    }

    #[test]
    fn garbage_never_panics_and_always_makes_progress(
        expect in expect(),
        bytes in vec(any::<u8>(), 0..80),
        silence in any::<bool>(),
    ) {
        let outcome = decode(expect, &bytes, silence);
        if bytes.len() >= expect.max_len() || (silence && !bytes.is_empty()) {
            prop_assert_ne!(&outcome, &Decode::NeedMore);
        }
        let consumed = match &outcome {
            Decode::NeedMore => 0,
            Decode::Reply { consumed, .. } | Decode::Sync { consumed, .. } => *consumed,
            Decode::Error(e) => {
                prop_assert!(e.consumed >= 1);
                e.consumed
            }
        };
        prop_assert!(consumed <= bytes.len());
    }

    #[test]
    fn the_decoder_buffers_less_than_one_reply(
        expect in expect(),
        chunks in vec(vec(any::<u8>(), 0..300), 0..20),
    ) {
        let mut d = ReplyDecoder::new();
        prop_assert!(d.expect(expect).is_ok());
        for chunk in &chunks {
            let _ = d.feed(chunk);
            prop_assert!(d.pending().len() < expect.max_len().max(1));
        }
        let _ = d.silence();
        prop_assert!(d.pending().is_empty());
    }

    #[test]
    fn the_parsers_never_panic_on_bytes(bytes in vec(any::<u8>(), 0..64)) {
        let _ = parse_frame(&bytes);
        let _ = parse_cnc(&bytes);
        let mut framer = RequestFramer::new();
        for received in framer.push_all(&bytes) {
            if let Received::Line(line) = received {
                prop_assert!(line.len() <= MAX_LINE);
            }
        }
        prop_assert!(framer.partial().len() <= MAX_LINE);
    }

    #[test]
    fn the_parsers_never_panic_on_near_misses(
        tail in "[ -~]{0,40}",
        config in config(),
    ) {
        for line in [format!("@0{tail}"), format!("@0I{tail}"), format!("@0D{tail}"), tail.clone()] {
            // Whatever parses re-encodes to a line that parses to the same.
            if let Ok(parsed) = parse_frame(&line) {
                prop_assert_eq!(parse_frame(parsed.value.to_string()).map(|p| p.value), Ok(parsed.value.clone()));
                let _ = check_with(&parsed.value.command, config);
            }
            if let Ok(parsed) = parse_cnc(&line) {
                prop_assert_eq!(parse_cnc(parsed.value.to_string()).map(|p| p.value), Ok(parsed.value.clone()));
            }
        }
    }

    #[test]
    fn parse_errors_point_into_the_line(line in "[ -~]{0,30}") {
        for e in [parse_frame(&line).err(), parse_cnc(&line).err()].into_iter().flatten() {
            prop_assert!(e.span.start <= e.span.end && e.span.end <= line.len(), "{:?} in {}", e.span, line);
            prop_assert!(!e.message.is_empty());
        }
    }

    /// Decision 12: `B` is the count of the controller's walk, so the walk
    /// of `B` steps ends within one step of the arc's end, for any angles,
    /// in all quadrants, both directions and across quadrant boundaries
    /// (the manual's formula `4 R (E - A) / pi` misses by up to 10 % of the
    /// arc).
    #[test]
    fn circles_are_valid_and_the_walk_of_b_steps_ends_within_a_step_of_the_end(
        radius in 1u32..=200_000,
        start in -720.0f64..720.0,
        end in -720.0f64..720.0,
        ccw in any::<bool>(),
        speed in 1u32..=40_000,
    ) {
        let direction = if ccw { CircleDirection::Ccw } else { CircleDirection::Cw };
        match circle(radius, start, end, direction, speed) {
            Err(CircleError::ArcTooShort) => {}
            Err(CircleError::ParameterTooLarge(d)) => {
                prop_assert!(radius > 46_000 && i32::try_from(d).is_err());
            }
            Err(e) => prop_assert!(false, "{}", e),
            Ok(arc) => {
                prop_assert_eq!(check(&Command::Circle(arc.params), AxisConfig::XY), Ok(()));
                let r = radius_from_parameters(&arc.params);
                prop_assert!(r.is_some_and(|r| (r - f64::from(radius)).abs() < 1.0), "{:?}", r);
                let mut walk = ArcWalk::new(
                    i64::from(radius),
                    (i64::from(arc.params.xs), i64::from(arc.params.ys)),
                    direction,
                );
                walk.advance(u64::from(arc.params.arc_length));
                let (x, y) = walk.point();
                let want = arc_end(radius, start, end).from_centre;
                let (dx, dy) = (x - i64::from(want.0), y - i64::from(want.1));
                prop_assert!(dx.abs() <= 1 && dy.abs() <= 1, "walk ends at ({}, {}), the arc at {:?}", x, y, want);
                // What the simulator and previews use agrees with the walk.
                let from_params = arc.params.end_point(direction);
                prop_assert_eq!(from_params.from_centre, (x as i32, y as i32));
            }
        }
    }
}
