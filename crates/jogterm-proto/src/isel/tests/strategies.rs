//! proptest strategies for every command and reply shape the types allow
//! and the parser reads back (1–4 pairs, 1–4 speeds, printable user info …).

use proptest::collection::vec;
use proptest::prelude::*;

use crate::axis::{Axis, AxisSet};
use crate::isel::*;

pub fn device() -> impl Strategy<Value = DeviceNumber> {
    (0u8..=9).prop_map(|n| DeviceNumber::new(n).unwrap_or_default())
}

fn pairs() -> impl Strategy<Value = Vec<MovePair>> {
    vec(
        (any::<i32>(), any::<u32>()).prop_map(|(s, v)| MovePair::new(s, v)),
        1..=4,
    )
}

fn mask() -> impl Strategy<Value = AxisSet> {
    (0u8..=15).prop_map(AxisSet::from_mask)
}

fn input_port() -> impl Strategy<Value = InputPort> + Clone {
    prop::sample::select(InputPort::ALL.to_vec())
}

fn output_port() -> impl Strategy<Value = OutputPort> {
    prop::sample::select(OutputPort::ALL.to_vec())
}

fn sign() -> impl Strategy<Value = Sign> {
    prop_oneof![Just(Sign::Minus), Just(Sign::Plus)]
}

fn direction() -> impl Strategy<Value = CircleDirection> {
    prop_oneof![Just(CircleDirection::Cw), Just(CircleDirection::Ccw)]
}

fn plane() -> impl Strategy<Value = Plane> {
    prop::sample::select(Plane::ALL.to_vec())
}

fn circle_params() -> impl Strategy<Value = CircleParams> {
    (
        any::<u32>(),
        any::<u32>(),
        any::<i32>(),
        any::<i32>(),
        any::<i32>(),
        sign(),
        sign(),
    )
        .prop_map(|(arc_length, speed, d, xs, ys, rx, ry)| CircleParams {
            arc_length,
            speed,
            d,
            xs,
            ys,
            rx,
            ry,
        })
}

fn helix_params() -> impl Strategy<Value = HelixParams> {
    (circle_params(), any::<i32>()).prop_map(|(circle, s3)| HelixParams { circle, s3 })
}

fn bits() -> impl Strategy<Value = PortBits> {
    prop_oneof![(0u8..=7).prop_map(PortBits::Bit), Just(PortBits::Byte)]
}

fn sync_char() -> impl Strategy<Value = SyncChar> {
    (33u8..=126).prop_map(|c| SyncChar::new(c).unwrap_or_else(|| unreachable!()))
}

fn diagnosis() -> impl Strategy<Value = Diagnosis> {
    let code = prop::sample::select(
        b"0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz".to_vec(),
    );
    (code.clone(), code)
        .prop_map(|(a, b)| Diagnosis::new(a, b).unwrap_or(Diagnosis::POSITIVE_LIMITS))
}

fn axis() -> impl Strategy<Value = Axis> {
    prop::sample::select(Axis::ALL.to_vec())
}

fn setting() -> impl Strategy<Value = AxisSetting> {
    prop::sample::select(vec![
        AxisSetting::X,
        AxisSetting::XY,
        AxisSetting::XYZ,
        AxisSetting::A,
    ])
}

fn init() -> impl Strategy<Value = InitCommand> {
    use InitCommand as I;
    let watch = || {
        (input_port(), any::<u8>(), any::<u8>()).prop_map(|(port, mask, value)| PortWatch {
            port,
            mask,
            value,
        })
    };
    prop_oneof![
        any::<[u32; 4]>().prop_map(I::DefaultReferenceSpeeds),
        any::<[u32; 4]>().prop_map(I::ReferenceClearSteps),
        any::<u32>().prop_map(I::DefaultAcceleration),
        any::<u32>().prop_map(I::DefaultStartStop),
        any::<bool>().prop_map(I::IoOnly),
        any::<u16>().prop_map(I::LimitSwitches),
        mask().prop_map(I::SwapLimitSwitches),
        mask().prop_map(I::InvertDirections),
        mask().prop_map(I::InvertReferenceDirections),
        mask().prop_map(I::RotaryAxes),
        watch().prop_map(I::AbortInput),
        (output_port(), any::<u8>(), any::<u8>())
            .prop_map(|(port, mask, value)| I::ErrorOutput(PortSignal { port, mask, value })),
        watch().prop_map(I::HoodInput),
        watch().prop_map(I::EmergencyStopInput),
        any::<bool>().prop_map(I::Baud9600),
        "[ -~]{0,40}".prop_map(I::SetUserInfo),
        Just(I::LoadFromFlash),
        Just(I::WriteToFlash),
        Just(I::RestoreDefaults),
    ]
}

pub fn command() -> impl Strategy<Value = Command> {
    use Command as C;
    prop_oneof![
        setting().prop_map(C::SetAxes),
        pairs().prop_map(C::MoveRelative),
        input_port().prop_map(C::ReadPort),
        (output_port(), any::<u8>()).prop_map(|(port, value)| C::WritePort { port, value }),
        vec(any::<u32>(), 1..=4).prop_map(C::SetReferenceSpeeds),
        diagnosis().prop_map(C::Diagnose),
        plane().prop_map(C::SetPlane),
        direction().prop_map(C::SetCircleDirection),
        axis().prop_map(C::ClearLimitSwitch),
        any::<bool>().prop_map(C::SetBrake),
        device().prop_map(C::SetDeviceNumber),
        Just(C::LimitSwitchStatus),
        Just(C::Status),
        Just(C::StoreProgram),
        init().prop_map(C::Init),
        any::<u32>().prop_map(C::SetStartStop),
        any::<u32>().prop_map(C::SetAcceleration),
        Just(C::EraseProgram),
        pairs().prop_map(C::MoveAbsolute),
        mask().prop_map(C::SetZero),
        mask().prop_map(C::SimulateReference),
        Just(C::ReadPosition),
        mask().prop_map(C::Reference),
        Just(C::Start),
        any::<bool>().prop_map(C::SetTestMode),
        Just(C::ReadUserInfo),
        Just(C::ReadVersion),
        helix_params().prop_map(C::Helix),
        circle_params().prop_map(C::Circle),
        any::<bool>().prop_map(C::Set3dInterpolation),
        (
            input_port(),
            any::<u8>(),
            any::<u8>(),
            any::<u32>(),
            vec(any::<i32>(), 1..=4)
        )
            .prop_map(
                |(port, mask, value, speed, steps)| C::MoveUntilPort(PortMove {
                    port,
                    mask,
                    value,
                    speed,
                    steps
                })
            ),
    ]
}

pub fn cnc_command() -> impl Strategy<Value = CncCommand> {
    use CncCommand as C;
    prop_oneof![
        pairs().prop_map(C::MoveRelative),
        sync_char().prop_map(C::SendSync),
        (sync_char(), any::<i16>()).prop_map(|(sync, offset)| C::WaitSync { sync, offset }),
        (any::<u16>(), any::<i16>()).prop_map(|(count, offset)| C::Loop { count, offset }),
        any::<u16>().prop_map(C::Delay),
        (input_port(), bits(), any::<u8>()).prop_map(|(port, bits, value)| C::PortCondition {
            port,
            bits,
            value
        }),
        mask().prop_map(C::Reference),
        Just(C::End),
        vec(any::<u32>(), 1..=4).prop_map(C::SetReferenceSpeeds),
        plane().prop_map(C::SetPlane),
        direction().prop_map(C::SetCircleDirection),
        any::<bool>().prop_map(C::SetBrake),
        any::<u32>().prop_map(C::SetStartStop),
        any::<u32>().prop_map(C::SetAcceleration),
        pairs().prop_map(C::MoveAbsolute),
        mask().prop_map(C::SetZero),
        mask().prop_map(C::SimulateReference),
        (input_port(), bits(), any::<u8>(), any::<i16>()).prop_map(
            |(port, bits, value, offset)| C::BranchOnPort {
                port,
                bits,
                value,
                offset
            }
        ),
        (output_port(), bits(), any::<u8>()).prop_map(|(port, bits, value)| C::SetPort {
            port,
            bits,
            value
        }),
        any::<bool>().prop_map(C::SetTestMode),
        helix_params().prop_map(C::Helix),
        circle_params().prop_map(C::Circle),
        any::<bool>().prop_map(C::Set3dInterpolation),
    ]
}

/// A text line: any Latin-1 character but CR and LF.
fn line() -> impl Strategy<Value = String> {
    vec(
        any::<u8>().prop_filter("no line breaks", |b| *b != b'\r' && *b != b'\n'),
        0..30,
    )
    .prop_map(|bytes| bytes.into_iter().map(char::from).collect())
}

pub fn reply() -> impl Strategy<Value = (Expect, Reply)> {
    let code = prop::sample::select(ReplyCode::ALL.to_vec());
    let digit_code = prop::sample::select(
        ReplyCode::ALL
            .into_iter()
            .filter(|c| c.byte().is_ascii_digit())
            .collect::<Vec<_>>(),
    );
    let position = Positions::MIN..=Positions::MAX;
    prop_oneof![
        code.prop_map(|c| (Expect::Handshake, Reply::Code(c))),
        (
            position.clone(),
            position.clone(),
            position.clone(),
            prop::option::of(position)
        )
            .prop_map(|(x, y, z, a)| (
                Expect::Positions {
                    with_a: a.is_some()
                },
                Reply::Positions(Positions { x, y, z, a })
            )),
        any::<u8>().prop_map(|b| (Expect::Byte, Reply::Byte(b))),
        (
            vec(
                line().prop_filter("a text line cannot start with a digit", |l| {
                    !l.starts_with(|c: char| c.is_ascii_digit())
                }),
                1..5
            ),
            digit_code
        )
            .prop_map(|(lines, c)| (
                Expect::TextThenCode,
                Reply::Text {
                    lines,
                    end: TextEnd::Code(c)
                }
            )),
        vec(line(), 0..5).prop_map(|lines| (
            Expect::TextUntilSilence,
            Reply::Text {
                lines,
                end: TextEnd::Silence
            }
        )),
    ]
}

pub fn expect() -> impl Strategy<Value = Expect> {
    prop::sample::select(vec![
        Expect::Handshake,
        Expect::Positions { with_a: false },
        Expect::Positions { with_a: true },
        Expect::Byte,
        Expect::TextThenCode,
        Expect::TextUntilSilence,
        Expect::ProgramRun,
    ])
}

pub fn config() -> impl Strategy<Value = Option<AxisConfig>> {
    prop::option::of(prop::sample::select(AxisConfig::ALL.to_vec()))
}
