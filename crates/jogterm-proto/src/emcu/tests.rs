//! Tables from the manual's examples (chapter 1.5), one refusal test per
//! validation rule, and property tests of the encoders and decoders.

use proptest::prelude::*;

use super::*;

fn steps(v: i32) -> Steps {
    Steps::new(v).unwrap()
}

fn mv(mode: MoveMode, targets: &[(EmcuAxis, i32)]) -> Command {
    let targets: Vec<(EmcuAxis, Steps)> = targets.iter().map(|(a, s)| (*a, steps(*s))).collect();
    Command::Move(Move::new(Slot::FIRST, mode, &targets).unwrap())
}

fn reference(axes: &[EmcuAxis]) -> Command {
    Command::Reference(ReferenceOrder::new(axes).unwrap())
}

/// Every command example of manual 1.5 with its typed form and class.
fn manual_commands() -> Vec<(&'static str, Command, Class)> {
    use Class::{Buffered, Master};
    use EmcuAxis as A;
    use MoveMode::{Absolute, Relative};
    vec![
        ("@R", Command::Reset, Master),
        ("@V", Command::Version, Master),
        ("@X", Command::Status, Master),
        ("@LX", Command::Position(A::X), Master),
        ("@LY", Command::Position(A::Y), Master),
        (
            "#S150",
            Command::StartSpeed(Speed::new(150).unwrap()),
            Buffered,
        ),
        (
            "#E1,800",
            Command::EndSpeed {
                slot: Slot::FIRST,
                speed: Speed::new(800).unwrap(),
            },
            Buffered,
        ),
        (
            "#R400",
            Command::Ramp(RampMillis::new(400).unwrap()),
            Buffered,
        ),
        ("$HZXY", reference(&[A::Z, A::X, A::Y]), Buffered),
        ("$HY", reference(&[A::Y]), Buffered),
        (
            "L1,X200,Y500",
            mv(Absolute, &[(A::X, 200), (A::Y, 500)]),
            Buffered,
        ),
        (
            "L1,x500,y1000",
            mv(Relative, &[(A::X, 500), (A::Y, 1000)]),
            Buffered,
        ),
        (
            "L1,X0,Y0,Z0",
            mv(Absolute, &[(A::X, 0), (A::Y, 0), (A::Z, 0)]),
            Buffered,
        ),
        (
            "L1,x15,y25,z35",
            mv(Relative, &[(A::X, 15), (A::Y, 25), (A::Z, 35)]),
            Buffered,
        ),
        (
            "L1,x-50,y-100",
            mv(Relative, &[(A::X, -50), (A::Y, -100)]),
            Buffered,
        ),
        ("@B", Command::Halt, Master),
        ("@S", Command::Stop, Master),
        ("@A", Command::Pause, Master),
        ("@C", Command::Resume, Master),
        ("A1,1", output(1, true), Buffered),
        ("A1,0", output(1, false), Buffered),
        ("A2,1", output(2, true), Buffered),
        ("A2,0", output(2, false), Buffered),
        (
            "W250",
            Command::Wait(WaitMillis::new(250).unwrap()),
            Buffered,
        ),
        ("@F", Command::StoreJob, Master),
        ("@J", Command::RunJob, Master),
        ("&V0", Command::LinkE1(false), Buffered),
        ("&V1", Command::LinkE1(true), Buffered),
    ]
}

fn output(n: u16, on: bool) -> Command {
    Command::SetOutput {
        output: Output::new(n).unwrap(),
        on,
    }
}

#[test]
fn every_manual_command_example_parses_encodes_and_classifies() {
    for (text, command, class) in manual_commands() {
        assert_eq!(parse_line(text), Ok(command), "{text}");
        assert_eq!(command.to_string(), text);
        let mut line = text.as_bytes().to_vec();
        line.push(b'\r');
        assert_eq!(command.encode(Terminator::Cr), Ok(line), "{text}");
        assert_eq!(command.class(), class, "{text}");
        let run = command.encode(Terminator::RunBuffer);
        match class {
            Class::Buffered => {
                let mut line = text.as_bytes().to_vec();
                line.push(0x01);
                assert_eq!(run, Ok(line), "{text}");
            }
            Class::Master => assert!(run.is_err(), "{text}"),
        }
    }
}

#[test]
fn the_manual_reply_examples_decode() {
    let mut d = ReplyDecoder::new();
    let table: Vec<(&[u8], Reply)> = vec![
        (b"\r", Reply::Ack),
        (
            b"@V SMC3000i 1.00\r",
            Reply::Version(VersionText::new("SMC3000i 1.00").unwrap()),
        ),
        (
            b"@LX1234\r",
            Reply::Position {
                axis: EmcuAxis::X,
                steps: 1234,
            },
        ),
        (
            b"@LY-1234\r",
            Reply::Position {
                axis: EmcuAxis::Y,
                steps: -1234,
            },
        ),
        (b"\x02\r", Reply::Ready),
        (b"\x03\r", Reply::MemoryFull),
    ];
    for (bytes, reply) in table {
        assert_eq!(d.feed(bytes), vec![ReplyEvent::Reply(reply.clone())]);
        assert_eq!(reply.encode(), bytes);
    }
}

fn status_of(bytes: &[u8]) -> Status {
    match ReplyDecoder::new().feed(bytes).as_slice() {
        [ReplyEvent::Reply(Reply::Status(s))] => *s,
        other => panic!("not one status: {other:?}"),
    }
}

#[test]
fn status_100110_is_a_reference_run_with_unknown_position() {
    // Manual 1.5.3, first example.
    let s = status_of(b"@X100110\r");
    assert_eq!(
        s.flags().collect::<Vec<_>>(),
        vec![
            StatusFlag::Moving,
            StatusFlag::PositionUnknown,
            StatusFlag::Referencing
        ]
    );
    assert!(
        s.moving && !s.waiting && !s.error && s.position_unknown && s.referencing && !s.job_running
    );
    assert!(s.needs_reference() && !s.needs_reset() && !s.ready_for_motion());
    assert_eq!(
        StatusFlag::PositionUnknown.remedy(),
        "run a reference ($H): no defined move is possible until then"
    );
    assert_eq!(Reply::Status(s).encode(), b"@X100110\r");
}

#[test]
fn status_100001_is_a_running_job() {
    // Manual 1.5.3, second example.
    let s = status_of(b"@X100001\r");
    assert_eq!(
        s.flags().collect::<Vec<_>>(),
        vec![StatusFlag::Moving, StatusFlag::JobRunning]
    );
    assert!(s.is_busy() && !s.needs_reference());
    assert_eq!(s.to_string(), "moving, job running");
}

#[test]
fn every_status_flag_has_its_meaning_and_remedy() {
    let expected = [
        (StatusFlag::Moving, "moving", "@B halts"),
        (StatusFlag::Waiting, "wait time", "go on"),
        (
            StatusFlag::Error,
            "error",
            "reset (@R), then run a reference ($H)",
        ),
        (
            StatusFlag::PositionUnknown,
            "not known",
            "run a reference ($H)",
        ),
        (StatusFlag::Referencing, "reference run", "wait"),
        (StatusFlag::JobRunning, "job", "only master commands"),
    ];
    for (index, (flag, meaning, remedy)) in expected.into_iter().enumerate() {
        assert_eq!(flag.index(), index);
        assert!(flag.meaning().contains(meaning), "{flag}");
        assert!(flag.remedy().contains(remedy), "{flag}");
        // The flag is read from its own character and no other.
        let mut digits = *b"000000";
        if let Some(d) = digits.get_mut(index) {
            *d = b'1';
        }
        let mut line = b"@X".to_vec();
        line.extend_from_slice(&digits);
        line.push(b'\r');
        assert_eq!(status_of(&line).flags().collect::<Vec<_>>(), vec![flag]);
    }
}

// ---- refusals: one test per validation rule ----

fn refused(text: &str) -> ParseError {
    match parse_line(text) {
        Ok(c) => panic!("`{text}` was accepted as {c:?}"),
        Err(e) => e,
    }
}

fn assert_refused(cases: &[(&str, usize)], what: impl Fn(&ParseErrorKind) -> bool) {
    for (text, offset) in cases {
        let e = refused(text);
        assert!(what(&e.kind), "`{text}`: unexpected error {e}");
        assert_eq!(e.offset, *offset, "`{text}`: {e}");
    }
}

#[test]
fn refuses_unknown_commands() {
    assert_refused(
        &[
            ("@Q", 0),
            ("X100", 0),
            ("?", 0),
            ("#Q1", 0),
            ("$X", 0),
            ("&W1", 0),
            ("\x01", 0),
        ],
        |k| matches!(k, ParseErrorKind::UnknownCommand(_)),
    );
    assert_eq!(
        refused("@Q").to_string(),
        "column 1: unknown command `@Q`: EMCU commands are @R @V @X @LX @LY @LZ @B @S @A @C @F @J \
         #S #E #R $H L A W &V"
    );
}

#[test]
fn refuses_lower_case_commands_with_a_hint() {
    assert_refused(
        &[
            ("@r", 0),
            ("l1,x5", 0),
            ("#s150", 0),
            ("w250", 0),
            ("a1,1", 0),
            ("$hX", 0),
            ("&v1", 0),
        ],
        |k| matches!(k, ParseErrorKind::LowerCaseCommand { .. }),
    );
    assert_eq!(
        refused("#s150").to_string(),
        "column 1: `#s`: commands are upper case, did you mean `#S`?"
    );
}

#[test]
fn refuses_axes_the_emcu_does_not_have() {
    assert_refused(
        &[
            ("@LA", 2),
            ("$HA", 2),
            ("L1,A5", 3),
            ("L1,q5", 3),
            ("$HXB", 3),
        ],
        |k| matches!(k, ParseErrorKind::Expected { .. }),
    );
}

#[test]
fn refuses_lower_case_axes_where_upper_case_is_required() {
    assert_refused(&[("@Lx", 2), ("$Hx", 2), ("$HZx", 3)], |k| {
        matches!(
            k,
            ParseErrorKind::Expected {
                found: Found::Byte(b'x'),
                ..
            }
        )
    });
    assert_eq!(
        refused("@Lx").to_string(),
        "column 3: expected axis X, Y or Z (upper case) after `@L`, found `x`"
    );
}

#[test]
fn refuses_repeated_axes() {
    assert_refused(
        &[
            ("$HXX", 3),
            ("$HZXZ", 4),
            ("L1,X1,X2", 6),
            ("L1,x1,y2,x3", 9),
        ],
        |k| matches!(k, ParseErrorKind::Value(ValueError::RepeatedAxis(_))),
    );
}

#[test]
fn refuses_moves_that_mix_absolute_and_relative_axes() {
    assert_refused(&[("L1,X1,y2", 6), ("L1,z1,Y2", 6)], |k| {
        matches!(k, ParseErrorKind::MixedMoveModes { .. })
    });
}

#[test]
fn refuses_missing_parameters() {
    assert_refused(
        &[
            ("@", 1),
            ("#", 1),
            ("$", 1),
            ("&", 1),
            ("@L", 2),
            ("#S", 2),
            ("#E1", 3),
            ("#E1,", 4),
            ("#R", 2),
            ("$H", 2),
            ("L", 1),
            ("L1", 2),
            ("L1,", 3),
            ("L1,X", 4),
            ("L,X5", 1),
            ("A1", 2),
            ("A1,", 3),
            ("W", 1),
            ("&V", 2),
        ],
        |k| {
            matches!(
                k,
                ParseErrorKind::Expected {
                    found: Found::EndOfLine | Found::Byte(b','),
                    ..
                }
            )
        },
    );
    assert_eq!(
        refused("#E1").to_string(),
        "column 4: expected `,` after the speed slot, found the end of the line"
    );
}

#[test]
fn refuses_extra_parameters() {
    assert_refused(
        &[
            ("@R1", 2),
            ("@XX", 2),
            ("@LXY", 3),
            ("#S150,1", 5),
            ("#E1,800,2", 7),
            ("A1,1,1", 4),
            ("&V01", 3),
            ("L1,X5,", 6),
            ("L1,X5Y5", 5),
            ("$HXYZ1", 5),
        ],
        |k| matches!(k, ParseErrorKind::Expected { .. }),
    );
}

#[test]
fn refuses_whitespace_and_foreign_bytes() {
    assert_refused(
        &[
            (" @X", 0),
            ("@X ", 2),
            ("L1, X5", 3),
            ("#S 150", 2),
            ("W2ä0", 2),
            ("@X\r", 2),
        ],
        |k| {
            matches!(
                k,
                ParseErrorKind::Expected { .. } | ParseErrorKind::UnknownCommand(_)
            )
        },
    );
    assert_eq!(
        refused("W2ä0").to_string(),
        "column 3: expected the end of the command, found `<C3>`"
    );
}

#[test]
fn refuses_signs_where_none_are_allowed() {
    assert_refused(
        &[
            ("#S-150", 2),
            ("#S+150", 2),
            ("#E1,-800", 4),
            ("#E-1,800", 2),
            ("#R-4", 2),
            ("W-250", 1),
            ("A-1,1", 1),
            ("L-1,X5", 1),
            ("L1,X+5", 4),
        ],
        |k| matches!(k, ParseErrorKind::SignNotAllowed { .. }),
    );
    assert_eq!(
        refused("L1,X+5").to_string(),
        "column 5: steps takes no sign `+`: positive steps are written without a sign"
    );
    // A sign on a 0/1 switch is not a 0 or 1.
    assert_refused(&[("&V-1", 2), ("A1,-1", 3)], |k| {
        matches!(k, ParseErrorKind::Expected { .. })
    });
}

#[test]
fn refuses_numbers_out_of_range() {
    assert_refused(
        &[
            ("#S0", 2),
            ("#E1,0", 4),
            ("#R0", 2),
            ("W0", 1),
            ("#S0000", 2),
        ],
        |k| matches!(k, ParseErrorKind::Value(ValueError::OutOfRange { .. })),
    );
    assert_refused(
        &[
            ("#S10000", 2),
            ("#R12345", 2),
            ("W00250", 1),
            ("L1,x1000000", 4),
            ("L1,X-1000000", 4),
        ],
        |k| matches!(k, ParseErrorKind::TooManyDigits { .. }),
    );
    assert_eq!(
        refused("W0").to_string(),
        "column 2: wait time (ms) 0 is out of range 1..=9999"
    );
    // The edges themselves are fine, leading zeros within the width too.
    for ok in [
        "#S9999",
        "#S1",
        "W0250",
        "L1,X-999999,Y999999,Z-000001",
        "#R9999",
    ] {
        assert!(parse_line(ok).is_ok(), "{ok}");
    }
}

#[test]
fn refuses_slots_out_of_range() {
    assert_refused(&[("#E0,800", 2), ("L0,X5", 1)], |k| {
        matches!(
            k,
            ParseErrorKind::Value(ValueError::OutOfRange {
                what: "speed slot",
                ..
            })
        )
    });
    assert_refused(&[("#E10,800", 2), ("L10,X5", 1)], |k| {
        matches!(
            k,
            ParseErrorKind::TooManyDigits {
                what: "speed slot",
                ..
            }
        )
    });
    assert_eq!(
        parse_line("L9,z-7").map(|c| c.to_string()),
        Ok("L9,z-7".to_string())
    );
}

#[test]
fn refuses_output_numbers_and_states_out_of_range() {
    assert_refused(&[("A0,1", 1), ("A3,1", 1)], |k| {
        matches!(
            k,
            ParseErrorKind::Value(ValueError::OutOfRange { what: "output", .. })
        )
    });
    assert_refused(&[("A1,2", 3), ("&V2", 2)], |k| {
        matches!(k, ParseErrorKind::Expected { .. })
    });
}

#[test]
fn refuses_an_empty_line() {
    assert_refused(&[("", 0)], |k| *k == ParseErrorKind::Empty);
}

#[test]
fn accepts_move_axes_in_any_order_and_writes_them_xyz() {
    let c = parse_line("L1,z3,x1").unwrap();
    assert_eq!(c.to_string(), "L1,x1,z3");
    assert_eq!(c.expect(), Expect::AckOrMemoryFull);
}

// ---- properties ----

fn arb_axis() -> impl Strategy<Value = EmcuAxis> {
    prop::sample::select(EmcuAxis::ALL.to_vec())
}

fn arb_axes() -> impl Strategy<Value = Vec<EmcuAxis>> {
    prop::sample::subsequence(EmcuAxis::ALL.to_vec(), 1..=3).prop_shuffle()
}

fn arb_speed() -> impl Strategy<Value = Speed> {
    (Speed::MIN..=Speed::MAX).prop_map(|v| Speed::new(v).unwrap())
}

fn arb_slot() -> impl Strategy<Value = Slot> {
    (Slot::MIN..=Slot::MAX).prop_map(|v| Slot::new(v).unwrap())
}

fn arb_move() -> impl Strategy<Value = Move> {
    (
        arb_slot(),
        prop_oneof![Just(MoveMode::Absolute), Just(MoveMode::Relative)],
        arb_axes(),
        prop::collection::vec(Steps::MIN..=Steps::MAX, 3),
    )
        .prop_map(|(slot, mode, axes, values)| {
            let targets: Vec<(EmcuAxis, Steps)> = axes
                .into_iter()
                .zip(values)
                .map(|(a, v)| (a, steps(v)))
                .collect();
            Move::new(slot, mode, &targets).unwrap()
        })
}

fn arb_command() -> impl Strategy<Value = Command> {
    prop_oneof![
        prop::sample::select(vec![
            Command::Reset,
            Command::Version,
            Command::Status,
            Command::Halt,
            Command::Stop,
            Command::Pause,
            Command::Resume,
            Command::StoreJob,
            Command::RunJob,
        ]),
        arb_axis().prop_map(Command::Position),
        arb_speed().prop_map(Command::StartSpeed),
        (arb_slot(), arb_speed()).prop_map(|(slot, speed)| Command::EndSpeed { slot, speed }),
        (RampMillis::MIN..=RampMillis::MAX)
            .prop_map(|v| Command::Ramp(RampMillis::new(v).unwrap())),
        arb_axes().prop_map(|a| reference(&a)),
        arb_move().prop_map(Command::Move),
        (Output::MIN..=Output::MAX, any::<bool>()).prop_map(|(n, on)| output(n, on)),
        (WaitMillis::MIN..=WaitMillis::MAX)
            .prop_map(|v| Command::Wait(WaitMillis::new(v).unwrap())),
        any::<bool>().prop_map(Command::LinkE1),
    ]
}

fn arb_reply() -> impl Strategy<Value = Reply> {
    prop_oneof![
        Just(Reply::Ack),
        Just(Reply::Ready),
        Just(Reply::MemoryFull),
        "[ -~]{1,61}".prop_map(|t| Reply::Version(VersionText::new(&t).unwrap())),
        prop::array::uniform6(any::<bool>()).prop_map(|f| {
            let mut s = Status::default();
            for (flag, on) in StatusFlag::ALL.into_iter().zip(f) {
                s.set(flag, on);
            }
            Reply::Status(s)
        }),
        (arb_axis(), any::<i32>()).prop_map(|(axis, steps)| Reply::Position { axis, steps }),
    ]
}

fn encode_all(replies: &[Reply]) -> Vec<u8> {
    replies.iter().flat_map(Reply::encode).collect()
}

fn only_replies(events: Vec<ReplyEvent>) -> Vec<Reply> {
    events
        .into_iter()
        .filter_map(|e| match e {
            ReplyEvent::Reply(r) => Some(r),
            ReplyEvent::Garbage(_) => None,
        })
        .collect()
}

proptest! {
    #[test]
    fn commands_round_trip_through_text_and_bytes(command in arb_command(), run in any::<bool>()) {
        let end = if run && !command.is_master() { Terminator::RunBuffer } else { Terminator::Cr };
        let bytes = command.encode(end).unwrap();
        prop_assert!(bytes.len() <= command::MAX_COMMAND_LINE + 1);
        prop_assert_eq!(parse_line(&command.to_string()), Ok(command));
        let got = CommandFramer::new().feed(&bytes);
        prop_assert_eq!(got, vec![Received {
            raw: bytes[..bytes.len() - 1].to_vec(),
            terminator: end,
            command: Ok(command),
        }]);
    }

    #[test]
    fn the_parser_never_panics_and_what_it_accepts_is_canonical(line in prop::collection::vec(any::<u8>(), 0..40)) {
        if let Ok(command) = parse_bytes(&line) {
            prop_assert_eq!(parse_line(&command.to_string()), Ok(command));
        }
    }

    #[test]
    fn near_miss_lines_never_panic(line in "[@#$&LAWSERHXYZxyzVBCFJ0-9,+-]{0,30}") {
        match parse_line(&line) {
            Ok(command) => prop_assert_eq!(parse_line(&command.to_string()), Ok(command)),
            Err(e) => prop_assert!(e.offset <= line.len()),
        }
    }

    #[test]
    fn the_framer_never_panics_on_garbage(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let mut framer = CommandFramer::new();
        for line in framer.feed(&bytes) {
            prop_assert!(line.raw.len() <= command::MAX_COMMAND_LINE + 1);
        }
    }

    #[test]
    fn replies_round_trip(replies in prop::collection::vec(arb_reply(), 0..8)) {
        let events = ReplyDecoder::new().feed(&encode_all(&replies));
        let expected: Vec<ReplyEvent> = replies.into_iter().map(ReplyEvent::Reply).collect();
        prop_assert_eq!(events, expected);
    }

    #[test]
    fn any_split_gives_the_same_events(
        replies in prop::collection::vec(arb_reply(), 1..6),
        noise in prop::collection::vec(any::<u8>(), 0..20),
    ) {
        let mut bytes = noise;
        bytes.extend(encode_all(&replies));
        let whole = ReplyDecoder::new().feed(&bytes);
        for cut in 0..=bytes.len() {
            let (a, b) = bytes.split_at(cut);
            let mut d = ReplyDecoder::new();
            let mut events = d.feed(a);
            events.extend(d.feed(b));
            prop_assert_eq!(&events, &whole, "split at {}", cut);
        }
        let mut d = ReplyDecoder::new();
        let bytewise: Vec<ReplyEvent> = bytes.iter().filter_map(|b| d.push(*b)).collect();
        prop_assert_eq!(bytewise, whole);
    }

    #[test]
    fn garbage_never_panics_and_the_decoder_recovers(
        garbage in prop::collection::vec(any::<u8>(), 0..400),
        replies in prop::collection::vec(arb_reply(), 0..6),
    ) {
        let mut d = ReplyDecoder::new();
        for event in d.feed(&garbage) {
            if let ReplyEvent::Garbage(g) = event {
                prop_assert!(!g.bytes.is_empty() && g.bytes.len() <= reply::MAX_REPLY_LINE + 1);
                prop_assert!(!g.to_string().is_empty());
            }
        }
        // One CR ends whatever line the garbage left open.
        d.feed(b"\r");
        prop_assert!(d.pending().is_empty());
        prop_assert_eq!(only_replies(d.feed(&encode_all(&replies))), replies);
    }

    #[test]
    fn a_ready_anywhere_between_lines_is_kept_apart(
        replies in prop::collection::vec(arb_reply(), 1..6),
        at in any::<prop::sample::Index>(),
    ) {
        let mut with_ready = replies.clone();
        with_ready.insert(at.index(replies.len() + 1), Reply::Ready);
        let events = only_replies(ReplyDecoder::new().feed(&encode_all(&with_ready)));
        prop_assert_eq!(events, with_ready);
    }
}
