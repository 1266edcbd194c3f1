//! Lines a controller refuses, grouped by the reply code it answers. Each
//! row names the axis configuration (`None`: nothing initialised).

use crate::isel::*;

use AxisConfig::{X, XY, XYZ, XYZA};

fn dnc_code(line: &str, config: Option<AxisConfig>) -> Option<ReplyCode> {
    validate_frame(line, config).err().map(|e| {
        assert!(!e.message.is_empty(), "{line}: empty message");
        e.code
    })
}

fn cnc_code(line: &str, config: AxisConfig) -> Option<ReplyCode> {
    validate_cnc(line, config).err().map(|e| {
        assert!(!e.message.is_empty(), "{line}: empty message");
        e.code
    })
}

fn expect_dnc(code: ReplyCode, rows: &[(&str, Option<AxisConfig>)]) {
    for (line, config) in rows {
        assert_eq!(
            dnc_code(line, *config),
            Some(code),
            "{line} with {config:?}"
        );
    }
}

fn expect_cnc(code: ReplyCode, rows: &[(&str, AxisConfig)]) {
    for (line, config) in rows {
        assert_eq!(
            cnc_code(line, *config),
            Some(code),
            "{line} with {config:?}"
        );
    }
}

#[test]
fn parameter_counts_depend_on_the_axes() {
    // One pair with X, two with XY, four with XYZ (x, y, z1, z2) and XYZA.
    let moves = [
        ("@0A5000,900", [true, false, false, false]),
        ("@0A5000,900,20,900", [false, true, false, false]),
        ("@0A1,900,2,900,3,900", [false, false, false, false]),
        ("@0A1,900,2,900,3,900,0,900", [false, false, true, true]),
        ("@0M1,900,2,900,3,900,0,900", [false, false, true, true]),
        ("@0d900", [true, false, false, false]),
        ("@0d900,900", [false, true, false, false]),
        ("@0d900,900,900", [false, false, true, false]),
        ("@0d900,900,900,900", [false, false, false, true]),
        ("@0Z0,1,1,600,5", [true, false, false, false]),
        ("@0Z0,1,1,600,5,5", [false, true, false, false]),
        ("@0Z0,1,1,600,5,5,5", [false, false, true, false]),
        ("@0Z0,1,1,600,5,5,5,5", [false, false, false, true]),
    ];
    for (line, ok) in moves {
        for (config, ok) in AxisConfig::ALL.into_iter().zip(ok) {
            let got = dnc_code(line, Some(config));
            let want = (!ok).then_some(ReplyCode::ParameterCount);
            assert_eq!(got, want, "{line} with {config}");
        }
    }
    // Counts that fit no configuration fail in the parser already.
    expect_dnc(
        ReplyCode::ParameterCount,
        &[
            ("@0A5000", Some(X)),
            ("@0A", Some(X)),
            ("@0A1,1,1,1,1,1,1,1,1,1", Some(XYZA)),
            ("@0d", Some(X)),
            ("@0d1,1,1,1,1", Some(XYZA)),
            ("@0Z0,1,1,600", Some(X)),
            ("@0Z0,1,1,600,1,1,1,1,1", Some(XYZA)),
            ("@0P0", Some(X)),
            ("@0b", Some(X)),
            ("@0b0,1", Some(X)),
            ("@0B1", Some(X)),
            ("@0R", Some(X)),
            ("@0y400,1500,119,-141,141,-1", Some(XY)),
            ("@0w400,1500,119,-141,141,-1,-1", Some(XYZ)),
            ("@0Id1000,900,500", Some(X)),
            ("@0IA0,1", Some(X)),
            ("@0IW1", Some(X)),
            ("@0j", Some(X)),
        ],
    );
    expect_cnc(
        ReplyCode::ParameterCount,
        &[
            ("05000,900", XY),
            ("m5000,900,1,900", XYZ),
            ("d900", XY),
            ("9 1", X),
            ("3 25", X),
            ("133,-10", X),
            ("60,1", X),
            ("o0,0,1", X),
        ],
    );
}

#[test]
fn axis_settings_and_masks_answer_3() {
    expect_dnc(
        ReplyCode::BadAxis,
        &[
            // Decision 3: 0, 2, 4, 6, 9 are not axis settings, nor is anything above 8.
            ("@00", None),
            ("@02", None),
            ("@04", None),
            ("@06", None),
            ("@09", None),
            ("@015", None),
            // 8 only after 7.
            ("@08", None),
            ("@08", Some(X)),
            ("@08", Some(XY)),
            // Masks: A together with others, axes not initialised, no axis.
            ("@0R9", Some(XYZA)),
            ("@0R15", Some(XYZA)),
            ("@0n12", Some(XYZA)),
            ("@0N10", Some(XYZA)),
            ("@0R4", Some(XY)),
            ("@0R8", Some(XYZ)),
            ("@0R0", Some(XYZA)),
            ("@0R16", Some(XYZA)),
            ("@0n2", Some(X)),
            ("@0F2", Some(X)),
            ("@0F3", Some(XYZ)),
            ("@0F8", Some(XYZ)),
            // Circles need two axes, helices three.
            ("@0y400,1500,119,-141,141,-1,-1", Some(X)),
            ("@0w32000,600,-1000,-2000,0,1,-1,6000", Some(XY)),
        ],
    );
    expect_cnc(
        ReplyCode::BadAxis,
        &[
            ("79", XYZA),
            ("74", XY),
            ("70", X),
            ("n8", XYZ),
            ("N3", X),
            ("y400,1500,119,-141,141,-1,-1", X),
        ],
    );
    // The axis settings that exist are accepted in any state.
    for line in ["@01", "@03", "@07"] {
        assert_eq!(dnc_code(line, None), None, "{line}");
    }
}

#[test]
fn commands_that_need_axes_answer_4_before_the_axis_setting() {
    expect_dnc(
        ReplyCode::NoAxes,
        &[
            ("@0A5000,900", None),
            ("@0M5000,900", None),
            ("@0R1", None),
            ("@0n1", None),
            ("@0N1", None),
            ("@0d900", None),
            ("@0F1", None),
            ("@0Z0,1,1,600,5", None),
            ("@0y400,1500,119,-141,141,-1,-1", None),
            ("@0w32000,600,-1000,-2000,0,1,-1,6000", None),
            ("@0i", None),
        ],
    );
    for line in ["@0P", "@0b1", "@0V", "@0j300", "@0IX", "@0B2,0", "@0S"] {
        assert_eq!(dnc_code(line, None), None, "{line}");
    }
}

#[test]
fn speeds_out_of_range_answer_d() {
    expect_dnc(
        ReplyCode::BadSpeed,
        &[
            ("@0A5000,0", Some(X)),
            ("@0A5000,40001", Some(X)),
            ("@0A5000,-900", Some(X)),
            ("@0A5000,99999999999", Some(X)),
            // Every pair's speed counts, also of an axis that does not move.
            ("@0A5000,900,0,0", Some(XY)),
            ("@0M5000,900,0,40001", Some(XY)),
            ("@0d0", Some(X)),
            ("@0d900,50000", Some(XY)),
            ("@0j19", Some(X)),
            ("@0j4001", Some(X)),
            ("@0J0", Some(X)),
            ("@0J4001", Some(X)),
            ("@0Id1000,900,0,900", Some(X)),
            ("@0Ij10", Some(X)),
            ("@0IJ5000", Some(X)),
            ("@0Z0,1,1,0,5", Some(X)),
            ("@0y400,0,119,-141,141,-1,-1", Some(XY)),
            ("@0w32000,40001,-1000,-2000,0,1,-1,6000", Some(XYZ)),
        ],
    );
    expect_cnc(
        ReplyCode::BadSpeed,
        &[
            ("05000,0", X),
            ("m5000,40001", X),
            ("j4001", X),
            ("J0", X),
            ("d0", X),
            ("y400,0,119,-141,141,-1,-1", XY),
        ],
    );
    // The limits themselves are allowed.
    for line in [
        "@0A5000,1",
        "@0A5000,40000",
        "@0j20",
        "@0j4000",
        "@0J1",
        "@0J4000",
    ] {
        assert_eq!(dnc_code(line, Some(X)), None, "{line}");
    }
}

#[test]
fn bad_numbers_answer_1() {
    expect_dnc(
        ReplyCode::BadNumber,
        &[
            ("@0A50x0,900", Some(X)),
            ("@0A5000,", Some(X)),
            ("@0A,900", Some(X)),
            ("@0A5000, 900", Some(X)),
            ("@0A+5000,900", Some(X)),
            ("@0A1234567890123,900", Some(X)),
            // 24-bit steps and positions (decision 2).
            ("@0A8388608,900", Some(X)),
            ("@0A-8388609,900", Some(X)),
            ("@0A99999999999,900", Some(X)),
            // M with 3 axes: the 4th pair's position must be 0 (decision 5).
            ("@0M30,800,10,900,4,90,4,30", Some(XYZ)),
            // Ports and values (2.2.3, 2.2.4).
            ("@0b4", Some(X)),
            ("@0b-1", Some(X)),
            ("@0B7,1", Some(X)),
            ("@0B99,1", Some(X)),
            ("@0B1,2", Some(X)),
            ("@0B6,5", Some(X)),
            ("@0B0,256", Some(X)),
            ("@0B4,-1", Some(X)),
            // Flags, planes, directions, device numbers.
            ("@0e3", Some(X)),
            ("@0f2", Some(X)),
            ("@0f-2", Some(X)),
            ("@0g2", Some(X)),
            ("@0T-1", Some(X)),
            ("@0z2", Some(X)),
            ("@0G10", Some(X)),
            ("@0IO2", Some(X)),
            ("@0IC5", Some(X)),
            // Circle parameters.
            ("@0y0,1500,119,-141,141,-1,-1", Some(XY)),
            ("@0y400,1500,119,-141,141,0,-1", Some(XY)),
            ("@0y400,1500,119,-141,141,-1,2", Some(XY)),
            ("@0y400,1500,119,-9000000,141,-1,-1", Some(XY)),
            ("@0w32000,600,-1000,-2000,0,1,-1,9000000", Some(XYZ)),
            // Init values.
            ("@0IE65536", Some(X)),
            ("@0Ie16", Some(X)),
            ("@0IT-1", Some(X)),
            ("@0IF20,50,50,65536", Some(X)),
            ("@0IA4,1,1", Some(X)),
            ("@0IH0,256,1", Some(X)),
            ("@0Ia7,1,1", Some(X)),
            ("@0IU123456789012345678901234567890123", Some(X)),
        ],
    );
    expect_cnc(
        ReplyCode::BadNumber,
        &[
            // Sync characters 33-126 (3.2.3).
            ("132", X),
            ("1127", X),
            ("2126,40000", X),
            // Loops (3.2.5, decision 11): 0-32767, loops go backwards.
            ("3 32768,-1", X),
            ("3 -1,-1", X),
            ("3 2,5", X),
            ("3 2,0", X),
            ("30,32768", X),
            ("5-1", X),
            ("570000", X),
            // Port bits: `6` counts 1-8, `o` and `p` 0-7, 128 = byte.
            ("60,0,0", X),
            ("60,9,0", X),
            ("60,1,2", X),
            ("64,1,0", X),
            ("o0,8,1,3", X),
            ("o0,0,2,3", X),
            ("p0,8,1", X),
            ("p0,0,2", X),
            ("p7,0,1", X),
            ("p2,3,1", X),
            ("p2,128,2", X),
            ("m30,800,10,900,4,90,4,30", XYZ),
            ("0x,900", X),
        ],
    );
}

#[test]
fn syntax_errors_answer_5() {
    expect_dnc(
        ReplyCode::Syntax,
        &[
            ("", Some(X)),
            ("A5000,900", Some(X)),
            ("@", Some(X)),
            ("@A5000,900", Some(X)),
            ("@0", Some(X)),
            ("@0x", Some(X)),
            ("@0xyz", Some(X)),
            ("@0 A5000,900", Some(X)),
            ("@07,1", Some(X)),
            ("@0I", Some(X)),
            ("@0Iq5", Some(X)),
            ("@0D", Some(X)),
            ("@0DR", Some(X)),
            ("@0DR-", Some(X)),
            ("@0DRpx", Some(X)),
            ("@0le4", Some(X)),
            ("@0A5000,900\u{1}", Some(X)),
            ("@0A5000,900\r@0P", Some(X)),
            ("@0P\t", Some(X)),
        ],
    );
    expect_cnc(
        ReplyCode::Syntax,
        &[
            ("", X),
            ("#1", X),
            (" 05000,900", X),
            ("-1", X),
            ("\u{7f}", X),
        ],
    );
}

#[test]
fn non_cnc_commands_answer_8_in_a_program() {
    expect_cnc(
        ReplyCode::NotStorable,
        &[
            ("@0P", X),
            ("@0A5000,900", X),
            ("A5000,900", X),
            ("a5000,900", X),
            ("R7", XYZ),
            ("S", X),
            ("s", X),
            ("i", X),
            ("k", X),
            ("I", X),
            ("IW", X),
            ("b0", X),
            ("B1,1", X),
            ("D", X),
            ("G1", X),
            ("H", X),
            ("h", X),
            ("U", X),
            ("V", X),
            ("?", X),
            ("4", X),
            ("8", X),
            ("E1", X),
            ("t1", X),
        ],
    );
}
