//! The interpreter against RS-274/NGC's own semantics, code by code, and
//! the property that an arc given by its centre and the same arc given by
//! its radius make the same move.

use proptest::prelude::*;

use super::*;
use crate::setup::{CodeRule, NamedOutput};
use jogterm_proto::wiring::Role;

fn g55() -> System {
    System::ALL[1]
}

fn setup() -> Setup {
    let mut s = Setup {
        default_units: Some(Units::Mm),
        ..Setup::default()
    };
    s.outputs = vec![
        NamedOutput {
            address: "out2".into(),
            name: "spindle".into(),
            role: Some(Role::Spindle),
            number: 0,
        },
        NamedOutput {
            address: "out0.1".into(),
            name: "coolant".into(),
            role: Some(Role::Coolant),
            number: 1,
        },
    ];
    s
}

fn ops(text: &str) -> Vec<Op> {
    ops_with(text, &setup())
}

fn ops_with(text: &str, setup: &Setup) -> Vec<Op> {
    match interpret(text, setup) {
        Ok(path) => path.ops,
        Err(e) => panic!("{text:?}: {e:?}"),
    }
}

fn errors(text: &str) -> Vec<(u32, u32, String)> {
    errors_with(text, &setup())
}

fn errors_with(text: &str, setup: &Setup) -> Vec<(u32, u32, String)> {
    match interpret(text, setup) {
        Ok(path) => panic!("{text:?} was accepted: {:?}", path.ops),
        Err(e) => e
            .into_iter()
            .map(|d| (d.origin.line, d.origin.col, d.message))
            .collect(),
    }
}

fn first_error(text: &str) -> (u32, u32, String) {
    errors(text).remove(0)
}

fn moves(ops: &[Op]) -> Vec<&Op> {
    ops.iter()
        .filter(|o| matches!(o, Op::Rapid(_) | Op::Line(_) | Op::Arc(_)))
        .collect()
}

fn p(x: f64, y: f64, z: f64) -> Point {
    Point { x, y, z }
}

fn close(a: Point, b: Point) -> bool {
    (a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9 && (a.z - b.z).abs() < 1e-9
}

fn last_to(ops: &[Op]) -> Point {
    match moves(ops).last() {
        Some(Op::Rapid(m)) => m.to,
        Some(Op::Line(m)) => m.to,
        Some(Op::Arc(a)) => a.to,
        _ => panic!("no move"),
    }
}

fn arcs(ops: &[Op]) -> Vec<Arc> {
    ops.iter()
        .filter_map(|o| match o {
            Op::Arc(a) => Some(**a),
            _ => None,
        })
        .collect()
}

#[test]
fn g0_and_g1_move_straight_and_g1_needs_a_feed() {
    let o = ops("G21 G90\nG0 X10 Y5 Z2\nG1 X20 F600\n");
    let m = moves(&o);
    assert!(matches!(m[0], Op::Rapid(r) if close(r.to, p(10.0, 5.0, 2.0))));
    assert!(matches!(m[1], Op::Line(l) if close(l.to, p(20.0, 5.0, 2.0)) && l.feed == 600.0));
    let (line, col, m) = first_error("G21\nG1 X5\n");
    assert_eq!((line, col), (2, 1));
    assert!(m.contains("before any F"), "{m}");
}

#[test]
fn g20_converts_inches_positions_and_feeds() {
    let o = ops("G20 G90\nG1 X1 Y0.5 F10\n");
    assert!(matches!(moves(&o)[0], Op::Line(l)
        if close(l.to, p(25.4, 12.7, 0.0)) && (l.feed - 254.0).abs() < 1e-9));
}

#[test]
fn a_file_without_a_unit_is_refused_unless_the_profile_names_one() {
    let mut s = setup();
    s.default_units = None;
    let e = errors_with("G0 X1\n", &s);
    assert_eq!((e[0].0, e[0].1), (1, 4));
    assert!(e[0].2.contains("G20 inch or G21 mm"), "{}", e[0].2);
    s.default_units = Some(Units::Inch);
    assert!(close(last_to(&ops_with("G0 X1\n", &s)), p(25.4, 0.0, 0.0)));
}

#[test]
fn the_profiles_unit_is_said_once_where_the_file_first_needs_it() {
    let path = interpret("(no unit)\nG0 X1\nY2\nG21\nX3\n", &setup()).expect("accepted");
    let said: Vec<_> = path
        .warnings
        .iter()
        .filter(|w| w.message.contains("the profile's [gcode] unit"))
        .collect();
    assert_eq!(said.len(), 1, "{:?}", path.warnings);
    assert_eq!((said[0].origin.line, said[0].origin.col), (2, 4));
    assert!(
        said[0].message.contains("millimetres"),
        "{}",
        said[0].message
    );

    let path = interpret("G21\nG0 X1\n", &setup()).expect("accepted");
    assert!(path.warnings.is_empty(), "{:?}", path.warnings);
}

#[test]
fn g91_moves_are_incremental_and_g90_absolute_again() {
    let o = ops("G21 G91\nG0 X10\nX5 Y2\nG90 X1\n");
    let m = moves(&o);
    assert!(matches!(m[1], Op::Rapid(r) if close(r.to, p(15.0, 2.0, 0.0))));
    assert!(matches!(m[2], Op::Rapid(r) if close(r.to, p(1.0, 2.0, 0.0))));
}

#[test]
fn axis_words_alone_continue_the_modal_motion() {
    // `X1 Y2` after G2 is another arc; `R` arcs continue too.
    let o = ops("G21 G17\nG0 X0 Y0\nG2 X10 Y0 I5 J0 F100\nX20 Y0 I5 J0\nG3 X30 Y0 R5\nX40 Y0 R5\n");
    let a = arcs(&o);
    assert_eq!(a.len(), 4);
    assert!(a[1].clockwise && !a[2].clockwise && !a[3].clockwise);
    assert!(close(a[3].to, p(40.0, 0.0, 0.0)));
}

#[test]
fn arcs_by_centre_r_negative_r_full_circles_and_helices() {
    // Clockwise half circle over the top: centre (5, 0).
    let a = arcs(&ops("G21\nG0 X0 Y0\nG2 X10 Y0 I5 J0 F100\n"))[0];
    assert!(close(a.centre, p(5.0, 0.0, 0.0)) && a.clockwise);
    // A quarter by R > 0 (the short way) and R < 0 (the long way).
    let short = arcs(&ops("G21\nG0 X0 Y0\nG3 X10 Y10 R10 F100\n"))[0];
    assert!(close(short.centre, p(0.0, 10.0, 0.0)), "{short:?}");
    assert!((sweep(&short) - PI / 2.0).abs() < 1e-9);
    let long = arcs(&ops("G21\nG0 X0 Y0\nG3 X10 Y10 R-10 F100\n"))[0];
    assert!(close(long.centre, p(10.0, 0.0, 0.0)), "{long:?}");
    assert!((sweep(&long) - 3.0 * PI / 2.0).abs() < 1e-9);
    // A full circle: I J alone, no end point.
    let full = arcs(&ops("G21\nG0 X5 Y5\nG2 I5 J0 F100\n"))[0];
    assert!(close(full.from, full.to));
    assert!((sweep(&full) - 2.0 * PI).abs() < 1e-9);
    // A helix: Z rises along a G17 arc; P2 makes two turns.
    let helix = arcs(&ops("G21\nG0 X5 Y0 Z0\nG3 X5 Y0 Z-4 I-5 J0 P2 F100\n"))[0];
    assert_eq!(helix.extra_turns, 1);
    assert!((helix.to.z + 4.0).abs() < 1e-9);
    assert!((sweep(&helix) - 4.0 * PI).abs() < 1e-9);
}

#[test]
fn g18_and_g19_take_their_own_centre_letters() {
    let zx = arcs(&ops("G21 G18\nG0 X0 Y0 Z0\nG2 X10 Z0 I5 K0 F100\n"))[0];
    assert_eq!(zx.plane, Plane::Zx);
    assert!(close(zx.centre, p(5.0, 0.0, 0.0)));
    let yz = arcs(&ops("G21 G19\nG0 X0 Y0 Z0\nG3 Y10 Z0 J5 K0 F100\n"))[0];
    assert_eq!(yz.plane, Plane::Yz);
    assert!(close(yz.centre, p(0.0, 5.0, 0.0)));
    let (_, col, m) = first_error("G21 G18\nG0 X0\nG2 X10 Z0 I5 J1 F100\n");
    assert_eq!(col, 14);
    assert!(m.contains("not a centre offset of the plane"), "{m}");
}

#[test]
fn g90_1_takes_arc_centres_absolute() {
    let a = arcs(&ops("G21 G90.1\nG0 X10 Y10\nG2 X20 Y10 I15 J10 F100\n"))[0];
    assert!(close(a.centre, p(15.0, 10.0, 0.0)));
    let a = arcs(&ops("G21 G91.1\nG0 X10 Y10\nG2 X20 Y10 I5 J0 F100\n"))[0];
    assert!(close(a.centre, p(15.0, 10.0, 0.0)));
}

#[test]
fn an_arc_off_its_circle_is_refused_by_linuxcnc_s_tolerance() {
    // 0.02 mm apart passes, 0.04 mm does not (0.028 mm).
    ops("G21\nG0 X0 Y0\nG2 X10.02 Y0 I5 J0 F100\n");
    let (line, col, m) = first_error("G21\nG0 X0 Y0\nG2 X10.04 Y0 I5 J0 F100\n");
    assert_eq!((line, col), (3, 1));
    assert!(m.contains("not on its circle"), "{m}");
    // In inches: 0.0028 in.
    ops("G20\nG0 X0 Y0\nG2 X1.002 Y0 I0.5 J0 F10\n");
    let (_, _, m) = first_error("G20\nG0 X0 Y0\nG2 X1.004 Y0 I0.5 J0 F10\n");
    assert!(m.contains("in"), "{m}");
}

#[test]
fn g4_dwells_in_seconds() {
    let o = ops("G21\nG4 P1.5\n");
    assert!(
        o.iter()
            .any(|op| matches!(op, Op::Dwell(d) if d.seconds == 1.5))
    );
    assert!(first_error("G21\nG4\n").2.contains("needs P"));
}

#[test]
fn work_offsets_and_g53_machine_coordinates() {
    let mut s = setup();
    s.zeros[System::G54.index()] = p(50.0, 50.0, 60.0);
    s.zeros[g55().index()] = p(100.0, 0.0, 10.0);
    let o = ops_with(
        "G21\nG0 X1 Y1 Z1\nG55 G0 X1 Y1 Z1\nG53 G0 X5 Y5 Z5\nG0 X0\n",
        &s,
    );
    let m = moves(&o);
    assert!(matches!(m[0], Op::Rapid(r) if close(r.to, p(51.0, 51.0, 61.0))));
    assert!(matches!(m[1], Op::Rapid(r) if close(r.to, p(101.0, 1.0, 11.0))));
    assert!(matches!(m[2], Op::Rapid(r) if close(r.to, p(5.0, 5.0, 5.0))));
    // G53 is for its block only: G55 is still in force.
    assert!(matches!(m[3], Op::Rapid(r) if close(r.to, p(100.0, 5.0, 5.0))));
    let systems: Vec<System> = o
        .iter()
        .filter_map(|op| match op {
            Op::WorkOffset { system, .. } => Some(*system),
            _ => None,
        })
        .collect();
    assert_eq!(systems, vec![System::G54, g55()]);
    assert!(first_error("G21\nG53 G2 X1 Y1 I1 F100\n").2.contains("G53"));
}

#[test]
fn g81_drills_rapid_to_r_feed_to_z_and_back() {
    let o = ops("G21\nG0 X0 Y0 Z10\nG98 G81 X5 Y5 Z-3 R2 F100\nX8\nG80\n");
    let m = moves(&o);
    let ends: Vec<Point> = m
        .iter()
        .map(|op| match op {
            Op::Rapid(r) => r.to,
            Op::Line(l) => l.to,
            _ => panic!("no arcs"),
        })
        .collect();
    // Hole 1: above it, down to R, feed to Z, back to the initial Z (G98);
    // hole 2 likewise from there.
    let expected = [
        p(0.0, 0.0, 10.0),
        p(5.0, 5.0, 10.0),
        p(5.0, 5.0, 2.0),
        p(5.0, 5.0, -3.0),
        p(5.0, 5.0, 10.0),
        p(8.0, 5.0, 10.0),
        p(8.0, 5.0, 2.0),
        p(8.0, 5.0, -3.0),
        p(8.0, 5.0, 10.0),
    ];
    assert_eq!(ends.len(), expected.len(), "{ends:?}");
    for (a, b) in ends.iter().zip(expected) {
        assert!(close(*a, b), "{ends:?}");
    }
    assert!(matches!(m[3], Op::Line(l) if l.feed == 100.0));
    // G99 returns to R.
    let o = ops("G21\nG0 X0 Y0 Z10\nG99 G81 X5 Y5 Z-3 R2 F100\n");
    assert!(close(last_to(&o), p(5.0, 5.0, 2.0)));
}

#[test]
fn g82_dwells_at_the_bottom_and_g83_pecks() {
    let o = ops("G21\nG0 X0 Y0 Z10\nG82 X1 Y1 Z-2 R1 P0.5 F100\n");
    assert!(
        o.iter()
            .any(|op| matches!(op, Op::Dwell(d) if d.seconds == 0.5))
    );
    let o = ops("G21\nG0 X0 Y0 Z5\nG83 X1 Y1 Z-5 R1 Q2 F100\n");
    let feeds: Vec<f64> = o
        .iter()
        .filter_map(|op| match op {
            Op::Line(l) => Some(l.to.z),
            _ => None,
        })
        .collect();
    assert_eq!(feeds.len(), 3, "{feeds:?}");
    assert!((feeds[0] + 1.0).abs() < 1e-9 && (feeds[1] + 3.0).abs() < 1e-9);
    assert!((feeds[2] + 5.0).abs() < 1e-9);
    assert!(first_error("G21\nG83 X1 Y1 Z-5 R1 F100\n").2.contains("Q"));
}

fn outputs(ops: &[Op]) -> Vec<(String, bool)> {
    ops.iter()
        .filter_map(|op| match op {
            Op::Output(o) => Some((o.address.clone(), o.on)),
            _ => None,
        })
        .collect()
}

#[test]
fn spindle_coolant_and_numbered_outputs_map_to_the_profile_s_outputs() {
    let o = ops("G21\nM3 S12000\nM8\nM9\nM5\nM64 P1\nM65 P1\n");
    assert_eq!(
        outputs(&o),
        vec![
            ("out2".into(), true),
            ("out0.1".into(), true),
            ("out0.1".into(), false),
            ("out2".into(), false),
            ("out0.1".into(), true),
            ("out0.1".into(), false),
        ]
    );
    assert!(
        o.iter()
            .any(|op| matches!(op, Op::SpindleSpeed { rpm, .. } if *rpm == 12000.0))
    );
    let (line, col, m) = first_error("G21\nM64 P7\n");
    assert_eq!((line, col), (2, 5));
    assert!(m.contains("no output 7"), "{m}");
    let mut s = setup();
    s.outputs.retain(|o| o.role != Some(Role::Coolant));
    let e = errors_with("G21\nM8\n", &s);
    assert!(e[0].2.contains("coolant"), "{}", e[0].2);
}

#[test]
fn the_gcode_table_maps_or_ignores_codes_never_silently() {
    let mut s = setup();
    s.codes.insert("m8".into(), CodeRule::Ignore);
    s.codes
        .insert("m7".into(), CodeRule::Output("spindle".into()));
    let path = interpret("G21\nM8\nM8\nM7\n", &s).expect("mapped");
    assert_eq!(path.warnings.len(), 1, "one warning, at the first M8");
    assert!(path.warnings[0].message.contains("ignored"));
    assert_eq!(outputs(&path.ops), vec![("out2".into(), true)]);
}

#[test]
fn pauses_m0_m1_and_m6_with_its_tool() {
    let o = ops("G21\nT3\nM6\nM0\nM1\nM6 T4\n");
    let pauses: Vec<&Pause> = o
        .iter()
        .filter_map(|op| match op {
            Op::Pause(p) => Some(p),
            _ => None,
        })
        .collect();
    assert!(matches!(pauses[0], Pause::ToolChange { tool: Some(3), .. }));
    assert!(matches!(pauses[1], Pause::Program { .. }));
    assert!(matches!(pauses[2], Pause::Optional { .. }));
    assert!(matches!(pauses[3], Pause::ToolChange { tool: Some(4), .. }));
}

#[test]
fn m2_and_m30_end_the_program_and_later_lines_are_a_warning() {
    let path = interpret("G21\nG0 X1\nM30\nG0 X5\n", &setup()).expect("ok");
    assert!(matches!(path.ops.last(), Some(Op::End { .. })));
    assert!(close(last_to(&path.ops), p(1.0, 0.0, 0.0)));
    assert_eq!(path.warnings[0].origin.line, 4);
    let path = interpret("G21\nG0 X1\nM2\n", &setup()).expect("ok");
    assert!(matches!(path.ops.last(), Some(Op::End { .. })));
}

#[test]
fn two_codes_of_one_modal_group_on_a_line_are_an_error() {
    for (line, col, what) in [
        ("G0 G1 X1 F1", 4, "G1 and G0"),
        ("G17 G18", 5, "G18 and G17"),
        ("G20 G21", 5, "G21 and G20"),
        ("G90 G91", 5, "G91 and G90"),
        ("G54 G55", 5, "G55 and G54"),
        ("M3 M5", 4, "M5 and M3"),
        ("M0 M30", 4, "M30 and M0"),
    ] {
        let (_, c, m) = first_error(&format!("G21\n{line}\n"));
        assert_eq!(c, col, "{line}: {m}");
        assert!(m.contains(what) && m.contains("modal group"), "{line}: {m}");
    }
    // M7 and M8 may share a line (both coolants on).
    ops("G21\nM7 M8\n");
}

#[test]
fn refused_codes_name_themselves_and_why() {
    for (code, why) in [
        ("G41 D1", "cutter radius compensation"),
        ("G42 D1", "cutter radius compensation"),
        ("G43 H1", "tool length offsets"),
        ("G93", "inverse time"),
        ("G95", "feed per revolution"),
        ("G28", "G28/G30"),
        ("G30", "G28/G30"),
        ("G10 L2 P1", "G10"),
        ("G92 X0", "G92"),
        ("G38.2 Z-5 F10", "probing"),
        ("G59.1", "G59.1"),
        ("G64", ""),
        ("G5 X1", "G5 is not supported"),
        ("M60", "pallet"),
        ("M98 P100", "M98 is not supported"),
        ("X1 A5", "axis A is refused"),
    ] {
        let text = format!("G21\n{code}\n");
        if code == "G64" {
            // Path blending: read and warned about, not refused.
            let path = interpret(&text, &setup()).expect("G64 is a warning");
            assert!(path.warnings[0].message.contains("G64"));
            continue;
        }
        let all = errors(&text);
        assert!(
            all.iter().any(|(line, _, m)| *line == 2 && m.contains(why)),
            "{code}: {all:?}"
        );
    }
}

#[test]
fn errors_are_all_reported_with_their_lines_up_to_a_limit() {
    let text: String = (0..80).map(|_| "G41\n").collect();
    let e = errors(&format!("G21\n{text}"));
    assert_eq!(e.len(), ERROR_LIMIT + 1);
    assert!(
        e.last()
            .is_some_and(|(_, _, m)| m.contains("30 more errors"))
    );
    assert_eq!(e[1].0, 3);
}

#[test]
fn the_file_s_extents_leave_out_axes_it_never_named() {
    let path = interpret("G21\nG0 Z5\nG0 X2 Y3\n", &setup()).expect("ok");
    // Ops: the work offset, G0 Z5, G0 X2 Y3.
    assert!(path.named(2, 1) && !path.named(0, 1) && !path.named(1, 1));
    assert!(path.named(0, 2) && path.named(1, 2));
}

/// Start and end on a circle around (cx, cy) at angles a0, a1.
fn arc_texts(cx: f64, cy: f64, r: f64, a0: f64, a1: f64, cw: bool) -> (String, String) {
    let (sx, sy) = (cx + r * a0.cos(), cy + r * a0.sin());
    let (ex, ey) = (cx + r * a1.cos(), cy + r * a1.sin());
    let g = if cw { "G2" } else { "G3" };
    let start = format!("G21 G17\nG0 X{sx:.6} Y{sy:.6}\n");
    let by_centre = format!(
        "{start}{g} X{ex:.6} Y{ey:.6} I{:.6} J{:.6} F100\n",
        cx - sx,
        cy - sy
    );
    // The sweep in the arc's direction decides the sign of R.
    let swept = if cw { a0 - a1 } else { a1 - a0 }.rem_euclid(2.0 * PI);
    let signed = if swept > PI { -r } else { r };
    let by_radius = format!("{start}{g} X{ex:.6} Y{ey:.6} R{signed:.6} F100\n");
    (by_centre, by_radius)
}

proptest! {
    #[test]
    fn an_arc_by_centre_and_by_radius_is_the_same_arc(
        cx in -50.0..50.0f64,
        cy in -50.0..50.0f64,
        r in 0.5..40.0f64,
        a0 in 0.0..(2.0 * PI),
        span in prop_oneof![0.05..(PI - 0.1), (PI + 0.1)..(2.0 * PI - 0.05)],
        cw in any::<bool>(),
    ) {
        // Near a half circle an R arc's centre is ill-conditioned (RS-274/NGC
        // says so): the printed end's rounding of 1e-6 mm moves it by far
        // more. Spans within 0.1 rad of pi are left out.
        let a1 = if cw { a0 - span } else { a0 + span };
        let (by_centre, by_radius) = arc_texts(cx, cy, r, a0, a1, cw);
        let c = arcs(&ops(&by_centre))[0];
        let r_arc = arcs(&ops(&by_radius))[0];
        // The printed coordinates round to 1e-6 mm.
        prop_assert!((c.centre.x - r_arc.centre.x).abs() < 1e-4, "{c:?} {r_arc:?}");
        prop_assert!((c.centre.y - r_arc.centre.y).abs() < 1e-4, "{c:?} {r_arc:?}");
        prop_assert!((sweep(&c) - sweep(&r_arc)).abs() < 1e-4);
        prop_assert_eq!(c.clockwise, r_arc.clockwise);
        let extremes = |a: &Arc| {
            crate::check::arc_extreme_points(a)
                .into_iter()
                .fold((f64::MAX, f64::MIN, f64::MAX, f64::MIN), |e, p| {
                    (e.0.min(p.x), e.1.max(p.x), e.2.min(p.y), e.3.max(p.y))
                })
        };
        let (e1, e2) = (extremes(&c), extremes(&r_arc));
        prop_assert!((e1.0 - e2.0).abs() < 1e-4 && (e1.1 - e2.1).abs() < 1e-4);
        prop_assert!((e1.2 - e2.2).abs() < 1e-4 && (e1.3 - e2.3).abs() < 1e-4);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(5000))]

    /// Where the roots say an arc is plainly on its circle, the `hypot`s
    /// the checks take pass it: radii at the bounds of both checks (near
    /// 1e-9 and 2e-9, ends off the circle by about half the tolerance and
    /// by the tolerance), centres far from and near the origin.
    #[test]
    fn an_arc_plainly_on_its_circle_passes_the_checks(
        c in (prop_oneof![-1e3..1e3f64, -1e7..1e7f64], prop_oneof![-1e3..1e3f64, -1e7..1e7f64]),
        r in prop_oneof![1e-9..3e-9f64, 1e-6..1.0f64, 1.0..1e3f64, 9e5..1.1e6f64],
        a0 in 0.0..(2.0 * PI),
        a1 in 0.0..(2.0 * PI),
        off in prop_oneof![-0.51..0.51f64, -1.01..-0.99f64, 0.99..1.01f64, Just(0.5), Just(-0.5)],
        inch in any::<bool>(),
    ) {
        let tolerance = if inch {
            ARC_RADIUS_TOLERANCE_INCH * 25.4
        } else {
            ARC_RADIUS_TOLERANCE_MM
        };
        let s = (c.0 + r * a0.cos(), c.1 + r * a0.sin());
        let r_end = r + off * tolerance;
        let e = (c.0 + r_end * a1.cos(), c.1 + r_end * a1.sin());
        if plainly_on_circle(s, e, c, tolerance) {
            let r0 = (s.0 - c.0).hypot(s.1 - c.1);
            let r1 = (e.0 - c.0).hypot(e.1 - c.1);
            prop_assert!(r0 >= 1e-9, "{r0}");
            prop_assert!((r0 - r1).abs() <= tolerance, "{r0} {r1} {tolerance}");
        }
    }
}
