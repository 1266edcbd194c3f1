//! Property tests: round trips through the wire, decoders fed any split and any
//! garbage, conversions over their whole range.

use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::sample::select;

use super::error::MAX_REPORTED_BYTES;
use super::request::code;
use super::*;

fn ds() -> impl Strategy<Value = DriveAddress> {
    (1u8..=15, 1u8..=6).prop_map(|(m, d)| DriveAddress::new(m, d).unwrap())
}

fn position() -> impl Strategy<Value = Position> {
    (i64::from(Position::MIN.increments())..=i64::from(Position::MAX.increments()))
        .prop_map(|p| Position::new(p).unwrap())
}

fn speed() -> impl Strategy<Value = Speed> {
    (1u8..=127).prop_map(|v| Speed::new(v).unwrap())
}

fn velocity() -> impl Strategy<Value = Velocity> {
    any::<i8>().prop_map(Velocity::new)
}

fn rtc_time() -> impl Strategy<Value = RtcTime> {
    (1u8..=7, 0u8..24, 0u8..60, 0u8..60).prop_map(|(w, h, m, s)| RtcTime::new(w, h, m, s).unwrap())
}

fn rtc_date() -> impl Strategy<Value = RtcDate> {
    (0u16..=9999, 1u8..=12, 1u8..=28).prop_map(|(y, m, d)| RtcDate::new(y, m, d).unwrap())
}

fn adc_mode() -> impl Strategy<Value = AdcMode> {
    (
        select(AdcInput::ALL.to_vec()),
        select(AdcResolution::ALL.to_vec()),
        select(Gain::ALL.to_vec()),
    )
        .prop_map(|(input, resolution, gain)| AdcMode {
            input,
            resolution,
            gain,
        })
}

fn operating_mode() -> impl Strategy<Value = OperatingMode> {
    prop_oneof![
        Just(OperatingMode::Pv),
        Just(OperatingMode::Iv),
        Just(OperatingMode::Pwm),
        (
            select(vec![JoystickChannel::One, JoystickChannel::Two]),
            select(SubMode::ALL.to_vec())
        )
            .prop_map(|(channel, sub_mode)| OperatingMode::Joystick { channel, sub_mode }),
        Just(OperatingMode::JoystickOff),
        Just(OperatingMode::Tpwm),
    ]
}

fn joystick_parameters() -> impl Strategy<Value = JoystickParameters> {
    (
        1u8..=255,
        select(vec![AdcPolarity::Bipolar, AdcPolarity::Unipolar]),
        select(Gain::ALL.to_vec()),
        any::<u8>(),
    )
        .prop_map(
            |(loop_cycles, polarity, multiplier, hysteresis_mv)| JoystickParameters {
                loop_cycles,
                polarity,
                multiplier,
                hysteresis_mv,
            },
        )
}

fn command() -> impl Strategy<Value = Command> {
    let simple = select(vec![
        Command::Identify(IdentityQuery::Version),
        Command::Identify(IdentityQuery::DeviceNumber),
        Command::On(OnScope::Single),
        Command::On(OnScope::Link),
        Command::Off,
        Command::Hold,
        Command::LastError,
        Command::MotorDisable,
        Command::FastStop,
        Command::ReadPosition,
        Command::ReadInputs,
        Command::ReadTime,
        Command::ReadDate,
    ]);
    let settings = prop_oneof![
        joystick_parameters().prop_map(Command::JoystickParameters),
        position().prop_map(Command::SetPosition),
        (1u16..=u16::MAX).prop_map(|v| Command::SampleRate(ReloadValue::new(v).unwrap())),
        operating_mode().prop_map(Command::MotorEnable),
    ];
    let motion = prop_oneof![
        (speed(), speed()).prop_map(|(fast, slow)| Command::Home { fast, slow }),
        (velocity(), position()).prop_map(|(velocity, target)| Command::Drive { velocity, target }),
        (speed(), position()).prop_map(|(vmax, target)| Command::MoveTo { vmax, target }),
        velocity().prop_map(Command::Torque),
    ];
    let peripherals = prop_oneof![
        (0u8..16).prop_map(|b| Command::WriteOutputs(Lines::from_bits(b))),
        (any::<u16>(), any::<u8>())
            .prop_map(|(address, device)| Command::EepromRead { address, device }),
        (any::<u16>(), any::<u8>(), any::<u8>()).prop_map(|(address, device, data)| {
            Command::EepromWrite {
                address,
                device,
                data,
            }
        }),
        any::<u8>().prop_map(Command::I2cFrequency),
        adc_mode().prop_map(Command::ReadAdc),
        rtc_time().prop_map(Command::WriteTime),
        rtc_date().prop_map(Command::WriteDate),
    ];
    prop_oneof![simple, settings, motion, peripherals]
}

fn request() -> impl Strategy<Value = Request> {
    (ds(), command()).prop_map(|(ds, command)| Request::new(ds, command))
}

fn limits() -> impl Strategy<Value = Limits> {
    (0u8..8).prop_map(Limits::from_byte)
}

/// A ready or busy body that can answer `command`.
fn body_for(command: Command) -> BoxedStrategy<ReplyBody> {
    match command {
        Command::Identify(_) => unreachable!("answered by text"),
        Command::On(_) => Just(ReplyBody::On).boxed(),
        Command::Off => Just(ReplyBody::Off).boxed(),
        Command::Hold => Just(ReplyBody::Hold).boxed(),
        Command::LastError => any::<u8>()
            .prop_map(|c| ReplyBody::LastError(ErrorCode(c)))
            .boxed(),
        Command::JoystickParameters(_) | Command::SampleRate(_) => {
            Just(ReplyBody::Settings).boxed()
        }
        Command::SetPosition(_) => position().prop_map(ReplyBody::PositionSet).boxed(),
        Command::MotorEnable(_) => position().prop_map(ReplyBody::MotorEnabled).boxed(),
        Command::MotorDisable => Just(ReplyBody::MotorDisabled).boxed(),
        Command::Home { .. } => position().prop_map(ReplyBody::Homing).boxed(),
        Command::Drive { .. } | Command::MoveTo { .. } | Command::Torque(_) | Command::FastStop => {
            position().prop_map(ReplyBody::Moved).boxed()
        }
        Command::ReadPosition => position().prop_map(ReplyBody::Position).boxed(),
        Command::ReadInputs => (limits(), 0u8..16)
            .prop_map(|(limits, i)| ReplyBody::Inputs {
                limits,
                inputs: Lines::from_bits(i),
            })
            .boxed(),
        Command::WriteOutputs(_) => (limits(), 0u8..16)
            .prop_map(|(limits, o)| ReplyBody::Outputs {
                limits,
                outputs: Lines::from_bits(o),
            })
            .boxed(),
        Command::EepromRead { .. } => any::<u8>().prop_map(ReplyBody::EepromData).boxed(),
        Command::EepromWrite { .. } | Command::I2cFrequency(_) => {
            Just(ReplyBody::EepromDone).boxed()
        }
        Command::ReadAdc(_) => any::<u16>()
            .prop_map(|c| ReplyBody::Adc(AdcCode(c)))
            .boxed(),
        Command::ReadTime => rtc_time().prop_map(ReplyBody::Time).boxed(),
        Command::ReadDate => rtc_date().prop_map(ReplyBody::Date).boxed(),
        Command::WriteTime(_) | Command::WriteDate(_) => Just(ReplyBody::RtcDone).boxed(),
    }
}

fn ident_text() -> impl Strategy<Value = IdentText> {
    proptest::collection::vec(0x20u8..=0x7E, 12).prop_map(|tail| {
        let mut text = b"DRS-".to_vec();
        text.extend(tail);
        IdentText::new(&text).unwrap()
    })
}

/// A request and a reply that answers it.
fn exchange() -> impl Strategy<Value = (Request, Reply)> {
    request().prop_flat_map(|request| {
        let ds = request.ds;
        let cmd = request.command.cmd();
        let rejected = Just(Reply::Rejected { ds, cmd });
        let reply = match request.command {
            Command::Identify(_) => {
                prop_oneof![ident_text().prop_map(Reply::Identity), rejected].boxed()
            }
            command => prop_oneof![
                body_for(command).prop_map(move |body| Reply::Ready { ds, body }),
                body_for(command).prop_map(move |body| Reply::Busy { ds, body }),
                rejected,
            ]
            .boxed(),
        };
        (Just(request), reply)
    })
}

/// Messages as they would follow each other on a line.
fn messages() -> impl Strategy<Value = Vec<Incoming>> {
    let one = prop_oneof![
        4 => any::<[u8; 8]>().prop_map(|b| Incoming::Frame(Frame::from_bytes(b))),
        1 => ident_text().prop_map(Incoming::Identity),
    ];
    proptest::collection::vec(one, 1..6)
}

fn wire(messages: &[Incoming]) -> Vec<u8> {
    messages.iter().flat_map(|m| m.encode()).collect()
}

fn decoded(results: Vec<Result<Incoming, FrameError>>) -> Vec<Incoming> {
    results.into_iter().map(|r| r.unwrap()).collect()
}

/// Frames whose bytes are mostly plausible, so that request decoding gets past
/// the CMD and DS checks often.
fn plausible_frame() -> impl Strategy<Value = Frame> {
    let byte = prop_oneof![3 => 0u8..4, 1 => any::<u8>()];
    (
        prop_oneof![select(code::ALL.to_vec()), any::<u8>()],
        prop_oneof![Just(0x11u8), any::<u8>()],
        prop_oneof![
            select(vec![0u8, 1, 2, 3, 4, 5, 7, 8, 9, 0x11, 0x19]),
            any::<u8>()
        ],
        [byte.clone(), byte.clone(), byte.clone(), byte.clone(), byte],
    )
        .prop_map(|(cmd, ds, prop, [info, d3, d2, d1, d0])| {
            Frame::new(cmd, ds, prop, info, [d3, d2, d1, d0])
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn frame_encode_decode_round_trip(bytes in any::<[u8; 8]>()) {
        let frame = Frame::from_bytes(bytes);
        let out = FrameDecoder::new().feed(&frame.encode());
        prop_assert_eq!(out, vec![Ok(Incoming::Frame(frame))]);
        prop_assert_eq!(frame.to_string().parse::<Frame>(), Ok(frame));
    }

    #[test]
    fn request_round_trip(request in request()) {
        let frame = request.to_frame();
        prop_assert!(!frame.is_reply());
        prop_assert_eq!(Request::decode(&frame), Ok(request));
        let out = FrameDecoder::new().feed(&request.encode());
        prop_assert_eq!(out, vec![Ok(Incoming::Frame(frame))]);
    }

    #[test]
    fn reply_round_trip((request, reply) in exchange()) {
        let incoming = reply.to_incoming();
        if let Incoming::Frame(f) = incoming {
            prop_assert_eq!(f.cmd, request.reply_code());
            prop_assert!(f.is_reply());
        }
        let out = decoded(FrameDecoder::new().feed(&reply.encode()));
        prop_assert_eq!(&out, &vec![incoming]);
        prop_assert_eq!(Reply::decode(&incoming, &request), Ok(reply));
    }

    #[test]
    fn a_decoded_request_encodes_to_the_same_frame(frame in plausible_frame()) {
        // Requests are strict: whatever decodes carries every bit of the frame.
        if let Ok(request) = Request::decode(&frame) {
            prop_assert_eq!(request.to_frame(), frame);
        }
    }

    #[test]
    fn reply_decoding_never_panics(frame in plausible_frame(), request in request()) {
        let mut f = frame;
        f.cmd |= 1;
        let _ = Reply::decode(&Incoming::Frame(f), &request);
        let _ = Reply::decode(&Incoming::Frame(frame), &request);
    }

    #[test]
    fn decoder_fed_split_at_every_byte_boundary(messages in messages()) {
        let bytes = wire(&messages);
        for cut in 0..=bytes.len() {
            let mut d = FrameDecoder::new();
            let mut out = d.feed(&bytes[..cut]);
            out.extend(d.feed(&bytes[cut..]));
            prop_assert_eq!(decoded(out), messages.clone());
            prop_assert!(d.pending().is_empty());
        }
    }

    #[test]
    fn decoder_fed_in_random_chunks(messages in messages(), sizes in proptest::collection::vec(1usize..20, 1..40)) {
        let bytes = wire(&messages);
        let mut d = FrameDecoder::new();
        let mut out = Vec::new();
        let mut rest = bytes.as_slice();
        for size in sizes.iter().cycle() {
            if rest.is_empty() {
                break;
            }
            let (chunk, tail) = rest.split_at((*size).min(rest.len()));
            out.extend(d.feed(chunk));
            rest = tail;
        }
        prop_assert_eq!(decoded(out), messages);
    }

    #[test]
    fn garbage_never_panics_and_the_decoder_recovers(
        garbage in proptest::collection::vec(any::<u8>(), 0..300),
        first in any::<[u8; 8]>(),
        second in any::<[u8; 8]>(),
    ) {
        let (first, second) = (Frame::from_bytes(first), Frame::from_bytes(second));
        let mut d = FrameDecoder::new();
        let mut out = d.feed(&garbage);
        for r in &out {
            if let Err(e) = r {
                prop_assert!(e.bytes.len() <= MAX_REPORTED_BYTES + 1);
            }
        }
        prop_assert!(d.pending().len() <= MAX_REPORTED_BYTES);
        // Garbage without an EOF at its end may swallow the first frame, but
        // that frame's EOF resynchronises: the second one always decodes.
        out.extend(d.feed(&first.encode()));
        out.extend(d.feed(&second.encode()));
        prop_assert_eq!(out.last(), Some(&Ok(Incoming::Frame(second))));
        // After an EOF in the garbage (or none at all), the first one too.
        let mut d = FrameDecoder::new();
        d.feed(&garbage);
        d.feed(&[EOF]);
        prop_assert_eq!(d.feed(&first.encode()), vec![Ok(Incoming::Frame(first))]);
    }

    #[test]
    fn text_never_panics_the_parsers(s in ".{0,40}", bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        let _ = s.parse::<Frame>();
        let _ = s.parse::<Request>();
        let _ = s.parse::<DriveAddress>();
        let _ = IdentText::new(&bytes);
        let _ = FrameDecoder::new().feed(&bytes);
    }

    #[test]
    fn correlator_never_panics_and_never_loses_track(
        steps in proptest::collection::vec(
            prop_oneof![
                request().prop_map(|r| (Some(r), None)),
                plausible_frame().prop_map(|f| (None, Some(Incoming::Frame(f)))),
                exchange().prop_map(|(r, reply)| (Some(r), Some(reply.to_incoming()))),
            ],
            0..40,
        )
    ) {
        let t = Instant::now();
        let mut c = Correlator::new(Duration::from_millis(50));
        let mut sent = 0usize;
        let mut finished = 0usize;
        let count = |e: &Event| !matches!(e, Event::Started { .. } | Event::Unexpected { .. });
        for (i, (request, incoming)) in steps.into_iter().enumerate() {
            let now = t + Duration::from_millis(i as u64 * 10);
            if let Some(r) = request {
                sent += 1;
                finished += c.sent(r, now).iter().filter(|e| count(e)).count();
            }
            if let Some(m) = incoming {
                finished += usize::from(count(&c.received(m)));
            }
            finished += c.poll_timeouts(now).len();
        }
        // Every request is outstanding or was finished by exactly one event.
        prop_assert_eq!(sent, finished + c.outstanding().count());
    }

    #[test]
    fn positions_round_trip_through_25_bits(p in position()) {
        prop_assert_eq!(Position::from_word(p.to_word()), Ok(p));
        prop_assert!(p.to_word() < 1 << 25);
    }

    #[test]
    fn feed_setting_gives_the_feed_it_was_asked_for(
        feed in prop_oneof![-20_000.0f64..-0.1, 0.1f64..20_000.0],
        base in 6u32..=54,
        gear in 1.0f64..50.0,
        pitch in 1.0f64..20.0,
        lines in 100u32..5000,
    ) {
        let m = Mechanics::new(gear, pitch, lines).unwrap();
        if let Ok(s) = feed_setting(feed, &m, base) {
            let v = s.velocity.value();
            prop_assert!(v != 0 && v.unsigned_abs() <= 127);
            prop_assert_eq!(v < 0, feed < 0.0);
            // Truncating the reload value runs at most 1/RelVal fast.
            let ratio = s.feed_mm_min(&m) / feed;
            let slack = 1.0 / f64::from(s.reload.value());
            prop_assert!(ratio >= 1.0 - 1e-9 && ratio <= 1.0 + slack + 1e-9, "ratio {}", ratio);
        }
    }

    #[test]
    fn reload_for_frequency_truncates(hz in 190.8f64..12.5e6) {
        let r = ReloadValue::for_frequency(hz).unwrap();
        let exact = 12.5e6 / hz;
        prop_assert!(f64::from(r.value()) <= exact && exact < f64::from(r.value()) + 1.0);
    }
}
