//! Every `Anwendung:` line of the manual's chapters 2–4: it parses to the
//! command the manual describes, passes the check for an axis configuration
//! it is meant for, and re-encodes to its canonical form (no space after the
//! letter, primary letters, decision 10/11 spellings).

use crate::axis::{Axis, AxisSet};
use crate::isel::*;

use AxisConfig::{X, XY, XYZ, XYZA};

fn pairs(values: &[(i32, u32)]) -> Vec<MovePair> {
    values.iter().map(|(s, v)| MovePair::new(*s, *v)).collect()
}

fn mask(m: u8) -> AxisSet {
    AxisSet::from_mask(m)
}

fn sync(c: u8) -> SyncChar {
    SyncChar::new(c).unwrap_or_else(|| panic!("{c} is no sync char"))
}

const EXAMPLE_CIRCLE: CircleParams = CircleParams {
    arc_length: 400,
    speed: 1500,
    d: 119,
    xs: -141,
    ys: 141,
    rx: Sign::Minus,
    ry: Sign::Minus,
};

const EXAMPLE_HELIX: HelixParams = HelixParams {
    circle: CircleParams {
        arc_length: 32000,
        speed: 600,
        d: -1000,
        xs: -2000,
        ys: 0,
        rx: Sign::Plus,
        ry: Sign::Minus,
    },
    s3: 6000,
};

/// (manual line, canonical encoding, a configuration it is meant for, command)
fn dnc_examples() -> Vec<(&'static str, &'static str, AxisConfig, Command)> {
    use Command as C;
    use InitCommand as I;
    vec![
        // 2.2.1
        ("@07", "@07", XY, C::SetAxes(AxisSetting::XYZ)),
        ("@08", "@08", XYZ, C::SetAxes(AxisSetting::A)),
        // 2.2.2
        (
            "@0A 5000,900",
            "@0A5000,900",
            X,
            C::MoveRelative(pairs(&[(5000, 900)])),
        ),
        (
            "@0A 50,900,20,9000",
            "@0A50,900,20,9000",
            XY,
            C::MoveRelative(pairs(&[(50, 900), (20, 9000)])),
        ),
        (
            "@0A 30,800,10,900,4,90,-4,30",
            "@0A30,800,10,900,4,90,-4,30",
            XYZ,
            C::MoveRelative(pairs(&[(30, 800), (10, 900), (4, 90), (-4, 30)])),
        ),
        (
            "@0A 30,800,10,900,4,90,-4,30",
            "@0A30,800,10,900,4,90,-4,30",
            XYZA,
            C::MoveRelative(pairs(&[(30, 800), (10, 900), (4, 90), (-4, 30)])),
        ),
        // 2.2.3
        ("@0b0", "@0b0", X, C::ReadPort(InputPort::User)),
        ("@0b1", "@0b1", X, C::ReadPort(InputPort::Status1)),
        // 2.2.4
        (
            "@0B1,1",
            "@0B1,1",
            X,
            C::WritePort {
                port: OutputPort::HoodUnlock,
                value: 1,
            },
        ),
        // 2.2.5
        ("@0d2500", "@0d2500", X, C::SetReferenceSpeeds(vec![2500])),
        (
            "@0d2400,3000",
            "@0d2400,3000",
            XY,
            C::SetReferenceSpeeds(vec![2400, 3000]),
        ),
        (
            "@0d1000,3000,2000",
            "@0d1000,3000,2000",
            XYZ,
            C::SetReferenceSpeeds(vec![1000, 3000, 2000]),
        ),
        (
            "@0d1000,3000,2000,2000",
            "@0d1000,3000,2000,2000",
            XYZA,
            C::SetReferenceSpeeds(vec![1000, 3000, 2000, 2000]),
        ),
        // 2.2.6
        ("@0DRp", "@0DRp", X, C::Diagnose(Diagnosis::POSITIVE_LIMITS)),
        ("@0DRn", "@0DRn", X, C::Diagnose(Diagnosis::NEGATIVE_LIMITS)),
        (
            "@0DS0",
            "@0DS0",
            X,
            C::Diagnose(Diagnosis::new(b'S', b'0').unwrap_or(Diagnosis::POSITIVE_LIMITS)),
        ),
        // 2.2.7, 2.2.8
        ("@0e1", "@0e1", XYZ, C::SetPlane(Plane::XZ)),
        ("@0e0", "@0e0", XY, C::SetPlane(Plane::XY)),
        (
            "@0f-1",
            "@0f-1",
            XY,
            C::SetCircleDirection(CircleDirection::Ccw),
        ),
        (
            "@0f0",
            "@0f0",
            XY,
            C::SetCircleDirection(CircleDirection::Cw),
        ),
        // 2.2.9 - 2.2.13
        ("@0F1", "@0F1", X, C::ClearLimitSwitch(Axis::X)),
        ("@0g1", "@0g1", X, C::SetBrake(true)),
        (
            "@0G2",
            "@0G2",
            X,
            C::SetDeviceNumber(DeviceNumber::new(2).unwrap_or_default()),
        ),
        ("@0H", "@0H", X, C::Status),
        ("@0h", "@0h", X, C::LimitSwitchStatus),
        ("@0i", "@0i", X, C::StoreProgram),
        // 2.2.14
        ("@0ID3", "@0ID3", X, C::Init(I::InvertDirections(mask(3)))),
        (
            "@0IR1",
            "@0IR1",
            X,
            C::Init(I::InvertReferenceDirections(mask(1))),
        ),
        (
            "@0Id1000,900,500,900",
            "@0Id1000,900,500,900",
            X,
            C::Init(I::DefaultReferenceSpeeds([1000, 900, 500, 900])),
        ),
        ("@0IW", "@0IW", X, C::Init(I::WriteToFlash)),
        // 2.2.15 - 2.2.22
        ("@0j300", "@0j300", X, C::SetStartStop(300)),
        ("@0J100", "@0J100", X, C::SetAcceleration(100)),
        ("@0k", "@0k", X, C::EraseProgram),
        (
            "@0M 5000,900",
            "@0M5000,900",
            X,
            C::MoveAbsolute(pairs(&[(5000, 900)])),
        ),
        (
            "@0M 50,900,20,9000",
            "@0M50,900,20,9000",
            XY,
            C::MoveAbsolute(pairs(&[(50, 900), (20, 9000)])),
        ),
        (
            "@0M 30,800,10,900,4,90,0,30",
            "@0M30,800,10,900,4,90,0,30",
            XYZ,
            C::MoveAbsolute(pairs(&[(30, 800), (10, 900), (4, 90), (0, 30)])),
        ),
        (
            "@0M 30,800,10,900,4,90,4,30",
            "@0M30,800,10,900,4,90,4,30",
            XYZA,
            C::MoveAbsolute(pairs(&[(30, 800), (10, 900), (4, 90), (4, 30)])),
        ),
        ("@0n7", "@0n7", XYZ, C::SetZero(mask(7))),
        ("@0n1", "@0n1", X, C::SetZero(mask(1))),
        ("@0n8", "@0n8", XYZA, C::SetZero(mask(8))),
        ("@0N1", "@0N1", X, C::SimulateReference(mask(1))),
        ("@0P", "@0P", X, C::ReadPosition),
        ("@0R7", "@0R7", XYZ, C::Reference(mask(7))),
        ("@0r7", "@0R7", XYZ, C::Reference(mask(7))),
        ("@0R8", "@0R8", XYZA, C::Reference(mask(8))),
        // 2.2.23 - 2.2.26 (S has no example line; its text names @0S and @0s)
        ("@0S", "@0S", X, C::Start),
        ("@0s", "@0S", X, C::Start),
        ("@0T1", "@0T1", X, C::SetTestMode(true)),
        ("@0T0", "@0T0", X, C::SetTestMode(false)),
        ("@0U", "@0U", X, C::ReadUserInfo),
        ("@0V", "@0V", X, C::ReadVersion),
        ("@0?", "@0V", X, C::ReadVersion),
        // 2.2.27 - 2.2.30, 2.3.6
        (
            "@0w32000,600,-1000,-2000,0,1,-1,6000",
            "@0w32000,600,-1000,-2000,0,1,-1,6000",
            XYZ,
            C::Helix(EXAMPLE_HELIX),
        ),
        (
            "@0y400,1500,119,-141,141,-1,-1",
            "@0y400,1500,119,-141,141,-1,-1",
            XY,
            C::Circle(EXAMPLE_CIRCLE),
        ),
        ("@0z1", "@0z1", XYZ, C::Set3dInterpolation(true)),
        ("@0z0", "@0z0", XYZ, C::Set3dInterpolation(false)),
        (
            "@0Z0,4,4,600,0,0,3000,0",
            "@0Z0,4,4,600,0,0,3000,0",
            XYZA,
            C::MoveUntilPort(PortMove {
                port: InputPort::User,
                mask: 4,
                value: 4,
                speed: 600,
                steps: vec![0, 0, 3000, 0],
            }),
        ),
        // 4.2.1 - 4.2.19 (4.2.7's `@0le4` is the manual's typo for `@0Ie4`)
        (
            "@0IF20,50,50,10",
            "@0IF20,50,50,10",
            X,
            C::Init(I::ReferenceClearSteps([20, 50, 50, 10])),
        ),
        (
            "@0IJ120",
            "@0IJ120",
            X,
            C::Init(I::DefaultAcceleration(120)),
        ),
        ("@0Ij300", "@0Ij300", X, C::Init(I::DefaultStartStop(300))),
        ("@0IO1", "@0IO1", X, C::Init(I::IoOnly(true))),
        (
            "@0IE57343",
            "@0IE57343",
            X,
            C::Init(I::LimitSwitches(57343)),
        ),
        ("@0Ie4", "@0Ie4", X, C::Init(I::SwapLimitSwitches(mask(4)))),
        ("@0ID4", "@0ID4", X, C::Init(I::InvertDirections(mask(4)))),
        (
            "@0IR2",
            "@0IR2",
            X,
            C::Init(I::InvertReferenceDirections(mask(2))),
        ),
        ("@0IT8", "@0IT8", X, C::Init(I::RotaryAxes(mask(8)))),
        (
            "@0IA0,1,1",
            "@0IA0,1,1",
            X,
            C::Init(I::AbortInput(PortWatch {
                port: InputPort::User,
                mask: 1,
                value: 1,
            })),
        ),
        (
            "@0Ia0,1,1",
            "@0Ia0,1,1",
            X,
            C::Init(I::ErrorOutput(PortSignal {
                port: OutputPort::User,
                mask: 1,
                value: 1,
            })),
        ),
        (
            "@0IH0,2,1",
            "@0IH0,2,1",
            X,
            C::Init(I::HoodInput(PortWatch {
                port: InputPort::User,
                mask: 2,
                value: 1,
            })),
        ),
        (
            "@0IN0,3,1",
            "@0IN0,3,1",
            X,
            C::Init(I::EmergencyStopInput(PortWatch {
                port: InputPort::User,
                mask: 3,
                value: 1,
            })),
        ),
        ("@0IC1", "@0IC1", X, C::Init(I::Baud9600(true))),
        (
            "@0IUisel_1234_aabbcc_24122012",
            "@0IUisel_1234_aabbcc_24122012",
            X,
            C::Init(I::SetUserInfo("isel_1234_aabbcc_24122012".into())),
        ),
        ("@0IL", "@0IL", X, C::Init(I::LoadFromFlash)),
        ("@0IX", "@0IX", X, C::Init(I::RestoreDefaults)),
    ]
}

/// (manual line, canonical encoding, a configuration it is meant for, command)
fn cnc_examples() -> Vec<(&'static str, &'static str, AxisConfig, CncCommand)> {
    use CncCommand as C;
    vec![
        // 3.2.2
        (
            "05000,900",
            "05000,900",
            X,
            C::MoveRelative(pairs(&[(5000, 900)])),
        ),
        (
            "050,900,20,9000",
            "050,900,20,9000",
            XY,
            C::MoveRelative(pairs(&[(50, 900), (20, 9000)])),
        ),
        (
            "030,800,10,900,4,90,-4,30",
            "030,800,10,900,4,90,-4,30",
            XYZ,
            C::MoveRelative(pairs(&[(30, 800), (10, 900), (4, 90), (-4, 30)])),
        ),
        (
            "030,800,10,900,4,90,-4,30",
            "030,800,10,900,4,90,-4,30",
            XYZA,
            C::MoveRelative(pairs(&[(30, 800), (10, 900), (4, 90), (-4, 30)])),
        ),
        // 3.2.3, 3.2.4 (the manual's "133,-10" means 233,-10, decision 11)
        ("133", "133", X, C::SendSync(sync(33))),
        (
            "233,-10",
            "233,-10",
            X,
            C::WaitSync {
                sync: sync(33),
                offset: -10,
            },
        ),
        // 3.2.5
        (
            "3 25,-1",
            "325,-1",
            X,
            C::Loop {
                count: 25,
                offset: -1,
            },
        ),
        (
            "3 0,-5",
            "30,-5",
            X,
            C::Loop {
                count: 0,
                offset: -5,
            },
        ),
        (
            "3 0,5",
            "30,5",
            X,
            C::Loop {
                count: 0,
                offset: 5,
            },
        ),
        (
            "3 6,-5",
            "36,-5",
            X,
            C::Loop {
                count: 6,
                offset: -5,
            },
        ),
        // 3.2.6 (the manual's "3 50" means 550, decision 11)
        ("550", "550", X, C::Delay(50)),
        // 3.2.7
        (
            "60,128,1",
            "60,128,1",
            X,
            C::PortCondition {
                port: InputPort::User,
                bits: PortBits::Byte,
                value: 1,
            },
        ),
        (
            "60,1,0",
            "60,1,0",
            X,
            C::PortCondition {
                port: InputPort::User,
                bits: PortBits::Bit(0),
                value: 0,
            },
        ),
        // 3.2.8, 3.2.9
        ("77", "77", XYZ, C::Reference(mask(7))),
        ("78", "78", XYZA, C::Reference(mask(8))),
        ("9", "9", X, C::End),
        // 3.2.10 - 3.2.15
        (
            "d2500,1000,1200,800",
            "d2500,1000,1200,800",
            XYZA,
            C::SetReferenceSpeeds(vec![2500, 1000, 1200, 800]),
        ),
        ("e1", "e1", XYZ, C::SetPlane(Plane::XZ)),
        ("e0", "e0", XY, C::SetPlane(Plane::XY)),
        (
            "f-1",
            "f-1",
            XY,
            C::SetCircleDirection(CircleDirection::Ccw),
        ),
        ("f0", "f0", XY, C::SetCircleDirection(CircleDirection::Cw)),
        ("g1", "g1", X, C::SetBrake(true)),
        ("j300", "j300", X, C::SetStartStop(300)),
        ("J100", "J100", X, C::SetAcceleration(100)),
        // 3.2.16
        (
            "m5000,900",
            "m5000,900",
            X,
            C::MoveAbsolute(pairs(&[(5000, 900)])),
        ),
        (
            "m50,900,20,9000",
            "m50,900,20,9000",
            XY,
            C::MoveAbsolute(pairs(&[(50, 900), (20, 9000)])),
        ),
        (
            "m30,800,10,900,4,90,0,30",
            "m30,800,10,900,4,90,0,30",
            XYZ,
            C::MoveAbsolute(pairs(&[(30, 800), (10, 900), (4, 90), (0, 30)])),
        ),
        (
            "m30,800,10,900,4,90,4,30",
            "m30,800,10,900,4,90,4,30",
            XYZA,
            C::MoveAbsolute(pairs(&[(30, 800), (10, 900), (4, 90), (4, 30)])),
        ),
        // 3.2.17, 3.2.18
        ("n7", "n7", XYZ, C::SetZero(mask(7))),
        ("n1", "n1", X, C::SetZero(mask(1))),
        ("n8", "n8", XYZA, C::SetZero(mask(8))),
        ("N7", "N7", XYZ, C::SimulateReference(mask(7))),
        ("N1", "N1", X, C::SimulateReference(mask(1))),
        ("N8", "N8", XYZA, C::SimulateReference(mask(8))),
        // 3.2.19
        (
            "o0,128,1,-1",
            "o0,128,1,-1",
            X,
            C::BranchOnPort {
                port: InputPort::User,
                bits: PortBits::Byte,
                value: 1,
                offset: -1,
            },
        ),
        (
            "o0,0,1,-1",
            "o0,0,1,-1",
            X,
            C::BranchOnPort {
                port: InputPort::User,
                bits: PortBits::Bit(0),
                value: 1,
                offset: -1,
            },
        ),
        (
            "o0,0,1,3",
            "o0,0,1,3",
            X,
            C::BranchOnPort {
                port: InputPort::User,
                bits: PortBits::Bit(0),
                value: 1,
                offset: 3,
            },
        ),
        // 3.2.20
        (
            "p0,128,1",
            "p0,128,1",
            X,
            C::SetPort {
                port: OutputPort::User,
                bits: PortBits::Byte,
                value: 1,
            },
        ),
        (
            "p0,0,1",
            "p0,0,1",
            X,
            C::SetPort {
                port: OutputPort::User,
                bits: PortBits::Bit(0),
                value: 1,
            },
        ),
        // 3.2.21 - 3.2.24
        ("T1", "T1", X, C::SetTestMode(true)),
        ("T0", "T0", X, C::SetTestMode(false)),
        (
            "w32000,600,-1000,-2000,0,1,-1,6000",
            "w32000,600,-1000,-2000,0,1,-1,6000",
            XYZ,
            C::Helix(EXAMPLE_HELIX),
        ),
        (
            "y400,1500,119,-141,141,-1,-1",
            "y400,1500,119,-141,141,-1,-1",
            XY,
            C::Circle(EXAMPLE_CIRCLE),
        ),
        ("z1", "z1", XYZ, C::Set3dInterpolation(true)),
        ("z0", "z0", XYZ, C::Set3dInterpolation(false)),
        // Chapter 1's table spellings, accepted and reported (decision 10).
        (
            "M5000,900",
            "m5000,900",
            X,
            C::MoveAbsolute(pairs(&[(5000, 900)])),
        ),
        ("F0", "f0", XY, C::SetCircleDirection(CircleDirection::Cw)),
        ("Z1", "z1", XYZ, C::Set3dInterpolation(true)),
        (
            "O0,0,1,3",
            "o0,0,1,3",
            X,
            C::BranchOnPort {
                port: InputPort::User,
                bits: PortBits::Bit(0),
                value: 1,
                offset: 3,
            },
        ),
        (
            "P0,0,1",
            "p0,0,1",
            X,
            C::SetPort {
                port: OutputPort::User,
                bits: PortBits::Bit(0),
                value: 1,
            },
        ),
        (
            "Y400,1500,119,-141,141,-1,-1",
            "y400,1500,119,-141,141,-1,-1",
            XY,
            C::Circle(EXAMPLE_CIRCLE),
        ),
        (
            "W32000,600,-1000,-2000,0,1,-1,6000",
            "w32000,600,-1000,-2000,0,1,-1,6000",
            XYZ,
            C::Helix(EXAMPLE_HELIX),
        ),
    ]
}

#[test]
fn every_dnc_example_parses_checks_and_reencodes_canonically() {
    for (line, canonical, config, command) in dnc_examples() {
        let parsed = match validate_frame(line, Some(config)) {
            Ok(p) => p,
            Err(e) => panic!("{line} with {config}: {e}"),
        };
        assert_eq!(parsed.value.command, command, "{line}");
        assert_eq!(parsed.value.device, DeviceNumber::DEFAULT, "{line}");
        assert_eq!(parsed.value.to_string(), canonical, "{line}");
        let mut bytes = canonical.as_bytes().to_vec();
        bytes.push(b'\r');
        assert_eq!(parsed.value.encode(), bytes, "{line}");
        // The canonical form is its own canonical form and carries no notes.
        let again = parse_frame(canonical).map(|p| (p.value, p.notes.is_empty()));
        assert_eq!(again, Ok((parsed.value.clone(), true)), "{canonical}");
    }
}

#[test]
fn every_cnc_example_parses_checks_and_reencodes_canonically() {
    for (line, canonical, config, command) in cnc_examples() {
        let parsed = match validate_cnc(line, config) {
            Ok(p) => p,
            Err(e) => panic!("{line} with {config}: {e}"),
        };
        assert_eq!(parsed.value, command, "{line}");
        assert_eq!(parsed.value.to_string(), canonical, "{line}");
        let again = parse_cnc(canonical).map(|p| (p.value, p.notes.is_empty()));
        assert_eq!(again, Ok((parsed.value.clone(), true)), "{canonical}");
        let spelled_from_table =
            line.as_bytes()[0].is_ascii_uppercase() && parsed.value.code().is_ascii_lowercase();
        assert_eq!(
            parsed
                .notes
                .iter()
                .any(|n| matches!(n.kind, NoteKind::TableSpelling { .. })),
            spelled_from_table,
            "{line}"
        );
    }
}

#[test]
fn the_manuals_typos_are_not_silently_accepted() {
    // 4.2.7 writes `@0le4` with a lower-case L: there is no `l` command.
    assert_eq!(
        parse_frame("@0le4").map_err(|e| e.code),
        Err(ReplyCode::Syntax)
    );
    // 3.2.4's "133,-10" is `1` with two parameters; decision 11 reads `233,-10`.
    assert_eq!(
        parse_cnc("133,-10").map_err(|e| e.code),
        Err(ReplyCode::ParameterCount)
    );
    // 3.2.6's "3 50" is a loop without its offset; decision 11 reads `550`.
    assert_eq!(
        parse_cnc("3 50").map_err(|e| e.code),
        Err(ReplyCode::ParameterCount)
    );
}

#[test]
fn the_circle_example_of_2_3_6_comes_out_exactly() {
    let arc = circle(200, 135.0, 225.0, CircleDirection::Ccw, 1500);
    let frames = arc.map(|a| a.commands().map(|c| Frame::default_device(c).to_string()));
    assert_eq!(
        frames,
        Ok([
            "@0f-1".to_string(),
            "@0y400,1500,119,-141,141,-1,-1".to_string()
        ])
    );
    let lines = circle(200, 135.0, 225.0, CircleDirection::Ccw, 1500)
        .map(|a| a.cnc_lines().map(|c| c.to_string()));
    assert_eq!(
        lines,
        Ok([
            "f-1".to_string(),
            "y400,1500,119,-141,141,-1,-1".to_string()
        ])
    );
}

#[test]
fn both_position_examples_of_decision_2() {
    let three = decode(
        Expect::Positions { with_a: false },
        b"000010002000FFFFFFE",
        false,
    );
    assert_eq!(
        three,
        Decode::Reply {
            reply: Reply::Positions(Positions {
                x: 256,
                y: 131087,
                z: -2,
                a: None
            }),
            consumed: 19
        }
    );
    let four = decode(
        Expect::Positions { with_a: true },
        b"0000B00044000000FFE003040",
        false,
    );
    assert_eq!(
        four,
        Decode::Reply {
            reply: Reply::Positions(Positions {
                x: 2816,
                y: 278528,
                z: 4094,
                a: Some(12352)
            }),
            consumed: 25
        }
    );
    // Either case is accepted.
    let lower = decode(
        Expect::Positions { with_a: false },
        b"000010002000ffffffe",
        false,
    );
    assert_eq!(lower, three);
    // And the encoder writes what the controller writes.
    let encoded = Reply::Positions(Positions {
        x: 2816,
        y: 278528,
        z: 4094,
        a: Some(12352),
    })
    .encode();
    assert_eq!(encoded, Ok(b"0000B00044000000FFE003040".to_vec()));
}
