//! The EMP manual's own strings, byte for byte, with DS = 11: Beispiel 1-5, the
//! VB code's send strings, and the syntax and reply tables of every command.

use super::request::{I2C_15_KHZ, code};
use super::*;

const DS: DriveAddress = DriveAddress::SINGLE;

fn req(command: Command) -> Request {
    Request::new(DS, command)
}

fn pos(p: i64) -> Position {
    Position::new(p).unwrap()
}

fn speed(v: u8) -> Speed {
    Speed::new(v).unwrap()
}

/// The manual's string encodes from the typed request, decodes back to it, and
/// goes on the wire as its 16 characters and EOF.
#[track_caller]
fn check(manual: &str, request: Request) {
    let manual = manual.replace("DS", "11").replace(' ', "");
    assert_eq!(request.to_frame().to_string(), manual, "{request}");
    let frame: Frame = manual.parse().unwrap();
    assert_eq!(Request::decode(&frame), Ok(request), "{manual}");
    let mut wire = manual.clone().into_bytes();
    wire.push(EOF);
    assert_eq!(request.encode().as_slice(), wire.as_slice());
}

#[test]
fn beispiel_1_constant_torque() {
    check("02DS110000000000", req(Command::On(OnScope::Single)));
    check(
        "22DS040000000000",
        req(Command::MotorEnable(OperatingMode::Pwm)),
    );
    // RL10, RL15, LL10: the torque byte is signed, F0 = -0x10.
    check(
        "2ADS001000000000",
        Request::velocity(DS, Velocity::new(0x10)),
    );
    check(
        "2ADS001500000000",
        Request::velocity(DS, Velocity::new(0x15)),
    );
    check(
        "2ADS00F000000000",
        Request::velocity(DS, Velocity::new(-0x10)),
    );
}

#[test]
fn beispiel_2_iv_velocities() {
    check(
        "22DS030000000000",
        req(Command::MotorEnable(OperatingMode::Iv)),
    );
    check("2ADS000200000000", Request::velocity(DS, Velocity::new(2)));
    check("2ADS000500000000", Request::velocity(DS, Velocity::new(5)));
    check("2ADS00FE00000000", Request::velocity(DS, Velocity::new(-2)));
    check("2ADS00FB00000000", Request::velocity(DS, Velocity::new(-5)));
    // Scaled: 2, -2 and 5 Umdr/min at 14:1 and 5 mm/Umdr.
    let reload = |v| Command::SampleRate(ReloadValue::new(v).unwrap());
    check("20DS190000001A28", req(reload(0x1A28)));
    check("2ADS000100000000", Request::velocity(DS, Velocity::new(1)));
    check("2ADS00FF00000000", Request::velocity(DS, Velocity::new(-1)));
    check("20DS190000000A76", req(reload(0x0A76)));

    // And the reload values come out of the feed computation.
    let m = Mechanics::new(14.0, 5.0, 1000).unwrap();
    for (rpm, v, hex) in [
        (2.0, 0x01, 0x1A28),
        (-2.0, 0xFF, 0x1A28),
        (5.0, 0x01, 0x0A76),
    ] {
        let s = feed_setting(m.feed_for_spindle_rpm(rpm), &m, 54).unwrap();
        assert_eq!(
            (s.velocity.byte(), s.reload.value()),
            (v, hex),
            "{rpm} Umdr/min"
        );
    }
}

#[test]
fn beispiel_3_read_position_while_moving() {
    check("2CDS000000000000", req(Command::ReadPosition));
}

#[test]
fn beispiel_4_positioning_in_tpwm() {
    check(
        "22DS070000000000",
        req(Command::MotorEnable(OperatingMode::Tpwm)),
    );
    check(
        "20DS190000001A28",
        req(Command::SampleRate(ReloadValue::new(0x1A28).unwrap())),
    );
    // "Bewegungskommando an Anlage senden: V und Posi", 500 mm = 186A0h.
    let to = |v: i8, p| {
        req(Command::Drive {
            velocity: Velocity::new(v),
            target: pos(p),
        })
    };
    check("2ADS0001000186A0", to(1, 100_000));
    check("2CDS000000000000", req(Command::ReadPosition));
    check(
        "20DS190000003450",
        req(Command::SampleRate(ReloadValue::new(0x3450).unwrap())),
    );
    check("2ADS000100009C40", to(1, 40_000));

    let m = Mechanics::new(14.0, 5.0, 1000).unwrap();
    for (feed, hex) in [(10.0, 0x1A28), (5.0, 0x3450)] {
        let s = feed_setting(feed, &m, 54).unwrap();
        assert_eq!(
            (s.velocity.byte(), s.reload.value()),
            (0x01, hex),
            "{feed} mm/min"
        );
    }
}

#[test]
fn beispiel_5_joystick_on_and_off() {
    // EEPROMDaten & Baugruppe & Achse & "11" + "000000" + ADCFreq + "00"
    check("44DS110000002600", req(Command::I2cFrequency(I2C_15_KHZ)));
    // Parameter & … & "02" + LOOPCycles + ADCTyp + ADCMode + MULTIPLIER + HYSTERese
    let params = JoystickParameters {
        loop_cycles: 0x0C,
        polarity: AdcPolarity::Bipolar,
        multiplier: Gain::X1,
        hysteresis_mv: 0x40,
    };
    check("20DS020C04000140", req(Command::JoystickParameters(params)));
    // AnalogLesen & … & ADCTyp & "00" & ADCRange & "00" & "00" & "00"
    let ch1 = AdcMode {
        input: AdcInput::Ain0Ain1,
        resolution: AdcResolution::Bits12,
        gain: Gain::X1,
    };
    check("50DS040000000000", req(Command::ReadAdc(ch1)));
    // MotorEnable & … & "05" + ADCKanal + BetriebsArt + "000000"
    let joystick = OperatingMode::Joystick {
        channel: JoystickChannel::One,
        sub_mode: SubMode::Iv,
    };
    check("22DS050103000000", req(Command::MotorEnable(joystick)));
    // Parameter & … & "19" + "00" + "0000" + AbtastFrequ (C350 = 250 Hz)
    check(
        "20DS19000000C350",
        req(Command::SampleRate(
            ReloadValue::for_frequency(250.0).unwrap(),
        )),
    );
    // MotorMove & … & "00" & "01" & "00000000"
    check("2ADS000100000000", Request::velocity(DS, Velocity::new(1)));
    // MotorEnable & … & "06" + "0000000000"
    check(
        "22DS060000000000",
        req(Command::MotorEnable(OperatingMode::JoystickOff)),
    );
}

#[test]
fn vb_send_strings_of_eeprom_and_rtc() {
    // setrtc & Baugruppe & Achse & "000000000000" / "010000000000"
    check("54DS000000000000", req(Command::ReadTime));
    check("54DS010000000000", req(Command::ReadDate));
    // EEPROMDaten & … & "08" + Memory + EEpromAdr + "0000"
    check(
        "44DS080123A00000",
        req(Command::EepromRead {
            address: 0x0123,
            device: 0xA0,
        }),
    );
    // EEPROMDaten & … & "09" + Memory + EEpromAdr + "00" + MemDat
    check(
        "44DS090123A0005A",
        req(Command::EepromWrite {
            address: 0x0123,
            device: 0xA0,
            data: 0x5A,
        }),
    );
}

#[test]
fn syntax_tables_of_every_command() {
    check(
        "00DS000000000000",
        req(Command::Identify(IdentityQuery::Version)),
    );
    check(
        "00DS010000000000",
        req(Command::Identify(IdentityQuery::DeviceNumber)),
    );
    check("02DS000000000000", req(Command::On(OnScope::Link)));
    check("02DS110000000000", req(Command::On(OnScope::Single)));
    check("04DS000000000000", req(Command::Off));
    check("08DS000000000000", req(Command::Hold));
    check("0ADS000000000000", req(Command::LastError));
    // 20 DS 05 01 _ 00 00 00 clears, 20 DS 05 01 _ PosMSB PosMID PosLSB sets.
    check(
        "20DS050100000000",
        req(Command::SetPosition(Position::ZERO)),
    );
    check("20DS0501000186A0", req(Command::SetPosition(pos(100_000))));
    check("20DS050101FFFFFF", req(Command::SetPosition(pos(-1))));
    check(
        "22DS020000000000",
        req(Command::MotorEnable(OperatingMode::Pv)),
    );
    check(
        "22DS050204000000",
        req(Command::MotorEnable(OperatingMode::Joystick {
            channel: JoystickChannel::Two,
            sub_mode: SubMode::Pwm,
        })),
    );
    check("24DS000000000000", req(Command::MotorDisable));
    // 26 DS _ _ _ Vfast Vslow _
    check(
        "26DS000000400800",
        req(Command::Home {
            fast: speed(0x40),
            slow: speed(0x08),
        }),
    );
    // 2A DS 01 Vmax PosMSB PosMIDH PosMIDL PosLSB
    check(
        "2ADS017F01FFFF9C",
        req(Command::MoveTo {
            vmax: speed(0x7F),
            target: pos(-100),
        }),
    );
    // 2A DS 02 Vpwm, 2A DS 03
    check(
        "2ADS02F000000000",
        req(Command::Torque(Velocity::new(-0x10))),
    );
    check("2ADS030000000000", req(Command::FastStop));
    check("40DS010000000000", req(Command::ReadInputs));
    // 42 DS 01 _ _ _ O4O3 O2O1
    let outputs = Outputs::NONE.with(1, true).with(3, true);
    check("42DS010000000101", req(Command::WriteOutputs(outputs)));
    check(
        "42DS010000001110",
        req(Command::WriteOutputs(Lines::from_bits(0b1110))),
    );
    // 50 DS Typ _ Mode: unipolar channel 2, 16-bit, factor 8.
    let mode = AdcMode::from_byte(0x6F).unwrap();
    check("50DS04006F000000", req(Command::ReadAdc(mode)));
    // 54 DS 02 _ WT HH MM SS, 54 DS 03 _ CC JJ MO TT (BCD)
    check(
        "54DS020005235959",
        req(Command::WriteTime(RtcTime::new(5, 23, 59, 59).unwrap())),
    );
    check(
        "54DS030020261120",
        req(Command::WriteDate(RtcDate::new(2026, 11, 20).unwrap())),
    );
}

/// The reply encodes to the manual's "Rückgabe" row and decodes back against
/// its request.
#[track_caller]
fn check_reply(manual: &str, request: Request, reply: Reply) {
    let manual = manual.replace("DS", "11").replace(' ', "");
    assert_eq!(reply.to_incoming().to_string(), manual, "{reply}");
    let incoming = FrameDecoder::new()
        .feed(&reply.encode())
        .pop()
        .unwrap()
        .unwrap();
    assert_eq!(Reply::decode(&incoming, &request), Ok(reply), "{manual}");
}

#[test]
fn reply_tables_of_every_command() {
    let ready = |body| Reply::Ready { ds: DS, body };
    let version = IdentText::version(8, 2).unwrap();
    check_reply(
        "DRS-500-EC_V08.2",
        req(Command::Identify(IdentityQuery::Version)),
        Reply::Identity(version),
    );
    check_reply(
        "03DS002200000000",
        req(Command::On(OnScope::Link)),
        ready(ReplyBody::On),
    );
    check_reply("05DS002200000000", req(Command::Off), ready(ReplyBody::Off));
    check_reply(
        "09DS002200000000",
        req(Command::Hold),
        ready(ReplyBody::Hold),
    );
    // Decision 2: INFO 22 and the code in D0.
    check_reply(
        "0BDS002200000003",
        req(Command::LastError),
        ready(ReplyBody::LastError(ErrorCode::BAD_PARAMETER)),
    );
    check_reply(
        "21DS002200000000",
        req(Command::SampleRate(ReloadValue::new(0xC350).unwrap())),
        ready(ReplyBody::Settings),
    );
    check_reply(
        "21DS0022000186A0",
        req(Command::SetPosition(pos(100_000))),
        ready(ReplyBody::PositionSet(pos(100_000))),
    );
    check_reply(
        "23DS002201FFFFFF",
        req(Command::MotorEnable(OperatingMode::Tpwm)),
        ready(ReplyBody::MotorEnabled(pos(-1))),
    );
    check_reply(
        "25DS002200000000",
        req(Command::MotorDisable),
        ready(ReplyBody::MotorDisabled),
    );
    let home = req(Command::Home {
        fast: speed(0x40),
        slow: speed(8),
    });
    // 27 DS _ 55 / 22 00 PosMSB PosMID PosLSB
    check_reply(
        "27DS005500001234",
        home,
        Reply::Busy {
            ds: DS,
            body: ReplyBody::Homing(pos(0x1234)),
        },
    );
    check_reply(
        "27DS002200000000",
        home,
        ready(ReplyBody::Homing(Position::ZERO)),
    );
    check_reply(
        "2BDS0022000186A0",
        req(Command::MoveTo {
            vmax: speed(1),
            target: pos(100_000),
        }),
        ready(ReplyBody::Moved(pos(100_000))),
    );
    check_reply(
        "2BDS002200000010",
        req(Command::FastStop),
        ready(ReplyBody::Moved(pos(16))),
    );
    check_reply(
        "2DDS002200009C40",
        req(Command::ReadPosition),
        ready(ReplyBody::Position(pos(40_000))),
    );
    // 41 DS Limits 22 … I4 I3 I2 I1 (decision 5)
    check_reply(
        "41DS05220000000A",
        req(Command::ReadInputs),
        ready(ReplyBody::Inputs {
            limits: Limits {
                plus: true,
                minus: false,
                reference: true,
            },
            inputs: Lines::from_bits(0b1010),
        }),
    );
    let outputs = Lines::from_bits(0b1001);
    check_reply(
        "43DS022200001001",
        req(Command::WriteOutputs(outputs)),
        ready(ReplyBody::Outputs {
            limits: Limits {
                minus: true,
                ..Limits::default()
            },
            outputs,
        }),
    );
    check_reply(
        "45DS00220000005A",
        req(Command::EepromRead {
            address: 1,
            device: 0xA0,
        }),
        ready(ReplyBody::EepromData(0x5A)),
    );
    check_reply(
        "45DS002200000000",
        req(Command::I2cFrequency(I2C_15_KHZ)),
        ready(ReplyBody::EepromDone),
    );
    // 51 DS _ 22 _ _ DatLSB DatMSB
    let adc = AdcMode::from_byte(0x0C).unwrap();
    check_reply(
        "51DS002200003412",
        req(Command::ReadAdc(adc)),
        ready(ReplyBody::Adc(AdcCode(0x1234))),
    );
    check_reply(
        "55DS002203140509",
        req(Command::ReadTime),
        ready(ReplyBody::Time(RtcTime::new(3, 14, 5, 9).unwrap())),
    );
    check_reply(
        "55DS002220261120",
        req(Command::ReadDate),
        ready(ReplyBody::Date(RtcDate::new(2026, 11, 20).unwrap())),
    );
    check_reply(
        "55DS002200000000",
        req(Command::WriteTime(RtcTime::new(1, 0, 0, 0).unwrap())),
        ready(ReplyBody::RtcDone),
    );
}

#[test]
fn adc_reading_of_beispiel_5_in_millivolts() {
    // Channel 1, 12-bit, factor 1: code 0x0400 = 1024 of MinCode 2048 = 1024 mV.
    let mode = AdcMode::from_byte(0x00).unwrap();
    let f: Frame = "5111002200000004".parse().unwrap();
    let reply = Reply::decode(&Incoming::Frame(f), &req(Command::ReadAdc(mode))).unwrap();
    let Some(ReplyBody::Adc(code)) = reply.body() else {
        panic!("{reply:?}")
    };
    assert_eq!(mode.millivolts(*code), 1024.0);
}

#[test]
fn info_ee_is_a_typed_rejection_with_meaning() {
    let request = req(Command::MoveTo {
        vmax: speed(1),
        target: pos(5),
    });
    let f: Frame = "2B1100EE00000000".parse().unwrap();
    let reply = Reply::decode(&Incoming::Frame(f), &request).unwrap();
    assert_eq!(
        reply,
        Reply::Rejected {
            ds: DS,
            cmd: code::MOVE
        }
    );
    assert_eq!(reply.info(), Some(Info::Rejected));
    assert_eq!(
        reply.to_string(),
        "11: 2A rejected: read the error code with 0A"
    );
    // A simulator answers an unknown command the same way.
    let unknown: Frame = "1211000000000000".parse().unwrap();
    assert_eq!(
        Request::decode(&unknown),
        Err(RequestError::UnknownCommand { cmd: 0x12 })
    );
    let reject = Reply::rejecting(&unknown).unwrap();
    assert_eq!(reject.to_incoming().to_string(), "131100EE00000000");
    let error = Request::decode(&unknown).unwrap_err();
    assert_eq!(ErrorCode::from(&error), ErrorCode::UNKNOWN_COMMAND);
}

#[test]
fn reply_that_does_not_fit_its_request_is_an_error() {
    let request = req(Command::ReadPosition);
    let frame = |s: &str| Incoming::Frame(s.parse().unwrap());
    assert_eq!(
        Reply::decode(&frame("2B11002200000000"), &request),
        Err(ReplyError::WrongCode {
            request: 0x2C,
            got: 0x2B
        })
    );
    assert_eq!(
        Reply::decode(&frame("2D21002200000000"), &request),
        Err(ReplyError::WrongDrive {
            expected: 0x11,
            got: 0x21
        })
    );
    assert_eq!(
        Reply::decode(&frame("2D11003300000000"), &request),
        Err(ReplyError::UnknownInfo(0x33))
    );
    assert!(matches!(
        Reply::decode(&frame("2D11002202000000"), &request),
        Err(ReplyError::BadValue { cmd: 0x2D, .. })
    ));
    let text = Incoming::Identity(IdentText::version(1, 0).unwrap());
    assert_eq!(
        Reply::decode(&text, &request),
        Err(ReplyError::UnexpectedText(0x2C))
    );
    let identify = req(Command::Identify(IdentityQuery::Version));
    assert!(matches!(
        Reply::decode(&frame("0111002200000000"), &identify),
        Err(ReplyError::ExpectedText(_))
    ));
    // A drive may still reject `00` with a frame.
    assert!(matches!(
        Reply::decode(&frame("011100EE00000000"), &identify),
        Ok(Reply::Rejected { .. })
    ));
    // Unused reply bytes are ignored; a bad BCD field is not.
    assert!(Reply::decode(&frame("0511FF22FFFFFFFF"), &req(Command::Off)).is_ok());
    assert!(Reply::decode(&frame("551100220314050A"), &req(Command::ReadTime)).is_err());
}

#[test]
fn invalid_requests_are_refused_with_a_reason() {
    let decode = |s: &str| s.parse::<Request>();
    let err = |s: &str| decode(s).unwrap_err().to_string();
    assert_eq!(
        err("2d11000000000000"),
        "EMP framing: lower-case hex digit at character 2 (only 0-9 and A-F are valid); dropped `2d11000000000000`"
    );
    assert_eq!(
        err("2D11000000000000"),
        "2D is a reply code (odd), not a request"
    );
    assert_eq!(err("3011000000000000"), "30 is not an EMP command");
    assert_eq!(err("2A11040000000000"), "2A has no sub-code 04");
    assert_eq!(
        err("2C01000000000000"),
        "DS 01: module number (high nibble) must be 1-F"
    );
    assert_eq!(
        err("2C17000000000000"),
        "DS 17: drive number (low nibble) must be 1-6"
    );
    assert_eq!(
        err("2C11000000000001"),
        "2C: D0 must be 00 (unused), got 01"
    );
    assert_eq!(
        err("2A11010002000000"),
        "2A: speed 0 is out of range: expected 1..=127 (01-7F)"
    );
    assert_eq!(
        err("2A11000102000000"),
        "2A: position bytes 02000000 set bits above the 25-bit sign bit (D3 may only be 00 or 01)"
    );
    assert!(decode("26110000007F0000").is_err()); // Vslow 0
    assert!(decode("2011190000000000").is_err()); // reload 0
    assert!(decode("2011050000000000").is_err()); // INFO of 20 05 must be 01
    assert!(decode("2211050303000000").is_err()); // joystick channel 3
    assert!(decode("2211050105000000").is_err()); // sub-mode 05
    assert!(decode("2211080000000000").is_err()); // mode 08
    assert!(decode("4211010000000002").is_err()); // output nibble 2
    assert!(decode("5011030000000000").is_err()); // ADC type 03
    assert!(decode("5011048000000000").is_err()); // mode high nibble 8
    assert!(decode("54110200080000000").is_err()); // 17 characters
    assert!(decode("5411020008000000").is_err()); // weekday 8
    assert!(decode("5411030020260230").is_err()); // 30 February
    assert!(decode("541103002026111A").is_err()); // not BCD
    assert!(decode("0211010000000000").is_err()); // on with PROP 01
    assert!(decode("0011020000000000").is_err()); // identify sub-code 02
    assert!(decode("4411110000002601").is_err()); // D0 of 44 11 must be 00
}

#[test]
fn commands_know_their_codes_and_what_they_do_to_motion() {
    assert_eq!(req(Command::ReadPosition).reply_code(), 0x2D);
    assert!(Command::Hold.is_stop() && Command::FastStop.is_stop());
    assert!(!Command::MotorDisable.is_stop());
    assert!(
        Command::Hold.ends_motion()
            && Command::Drive {
                velocity: Velocity::STOP,
                target: Position::ZERO
            }
            .ends_motion()
    );
    assert!(!Command::ReadPosition.ends_motion());
    assert!(!Command::SampleRate(ReloadValue::new(1).unwrap()).ends_motion());
    assert!(!Request::velocity(DS, Velocity::STOP).command.may_move());
    assert!(Request::velocity(DS, Velocity::new(-1)).command.may_move());
    assert!(
        Command::MotorEnable(OperatingMode::Joystick {
            channel: JoystickChannel::One,
            sub_mode: SubMode::Pv
        })
        .may_move()
    );
    assert!(!Command::MotorEnable(OperatingMode::Iv).may_move());
    assert_eq!(
        req(Command::MoveTo {
            vmax: speed(1),
            target: pos(100_000)
        })
        .to_string(),
        "11: move to 100000 at Vmax 1"
    );
    for cmd in code::ALL {
        assert_eq!(cmd % 2, 0);
    }
}
