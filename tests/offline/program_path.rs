//! The tool's path through a program: loops and jumps as the manual's
//! examples count them (isel manual 3.2.5, `docs/decisions.md` isel 11),
//! circles and helices (manual 2.3, 3.2.22, 3.2.23), zero points and
//! reference runs, EMCU jobs.

use jogterm::axis::{Axis, AxisSet};
use jogterm::program::{Language, PathEnd, Program, SegmentKind, Start, path, path_with};
use jogterm::proto::isel::{CircleDirection, CircleParams, Sign};

fn isel(text: &str) -> Program {
    Program::parse(Language::Isel, text)
}

fn end_x(text: &str) -> i64 {
    path(&isel(text), &Start::at_zero(AxisSet::from_mask(1))).end[0]
}

#[test]
fn loops_run_their_body_once_more_than_counted() {
    // "3 25,-1: Wiederhole letzten Befehl 25 mal": 25 more times, 26 in all.
    assert_eq!(end_x("01,900\n3 25,-1\n9\n"), 26);
    // "3 6,-5: Wiederhole die letzten 5 Befehle 6 mal": 5 commands, 7 times.
    assert_eq!(
        end_x("01,900\n01,900\n01,900\n01,900\n01,900\n3 6,-5\n9\n"),
        35
    );
    // Nested: the inner loop runs 3 times per outer round, the outer 2 times.
    assert_eq!(
        end_x("01,900\n3 2,-1\n0100,900\n3 1,-3\n9\n"),
        2 * (3 + 100)
    );
}

#[test]
fn jumps_count_from_the_command_that_carries_them() {
    // "3 0,5: Überspringe die nächsten 4 Befehle".
    assert_eq!(
        end_x("3 0,5\n01,900\n01,900\n01,900\n01,900\n010,900\n9\n"),
        10
    );
    // "3 0,-5: Verzweige immer 5 Schritte zurück": for ever. With a body
    // that comes back to where it started the path sees the repetition.
    let program = isel("; back and forth\n01,900\n02,900\n03,900\n04,900\n0-10,900\n3 0,-5\n9\n");
    let p = path(&program, &Start::at_zero(AxisSet::from_mask(1)));
    assert_eq!(p.finish, PathEnd::Endless { line: 6 });
    assert_eq!(p.end, [0; 4]);
    assert_eq!(p.segments.len(), 5 * 2);
    // A body that drifts runs into the bound.
    let program = isel("01,900\n01,900\n01,900\n01,900\n01,900\n3 0,-5\n9\n");
    let p = path_with(&program, &Start::at_zero(AxisSet::from_mask(1)), 60);
    assert_eq!(p.finish, PathEnd::Cut { line: 0 });
    assert_eq!(p.executed, 60);
    assert_eq!(p.end[0], 50);
}

#[test]
fn a_program_with_a_loop_a_branch_and_a_circle_ends_where_expected() {
    let text = "\
; XY table: reference, a row of three, a branch, an arc
73
m1000,900,1000,900
0 100,900,0,900   ; row
3 2,-1
o0,0,1,2          ; port 0 bit 0 set: skip the next move
0 0,900,50,900
f-1
y400,1500,119,-141,141,-1,-1
9
";
    let program = isel(text);
    let p = path(
        &program,
        &Start::new(AxisSet::from_mask(3), [-5000, 7000, 0, 0]),
    );
    assert_eq!(p.finish, PathEnd::End { line: 9 });
    let circle = CircleParams {
        arc_length: 400,
        speed: 1500,
        d: 119,
        xs: -141,
        ys: 141,
        rx: Sign::Minus,
        ry: Sign::Minus,
    };
    let (dx, dy) = circle.end_point(CircleDirection::Ccw).from_start;
    // 135° to 225° counter-clockwise around the centre: straight down by
    // about 2 × 141 steps.
    assert_eq!(dx, 0);
    assert!((-283..=-281).contains(&dy), "{dy}");
    assert_eq!(p.end, [1300 + i64::from(dx), 1050 + i64::from(dy), 0, 0]);
    let lines: Vec<usize> = p.segments.iter().map(|s| s.line).collect();
    // Reference Y then X, the absolute move, three rows, the move after the
    // branch, the arc.
    assert_eq!(lines, [1, 1, 2, 3, 3, 3, 6, 8]);
    let arc = match &p.segments[7].kind {
        SegmentKind::Arc(arc) => *arc,
        other => panic!("{other:?}"),
    };
    assert_eq!(arc.centre, (1300 + 141, 1050 - 141));
    assert_eq!(arc.direction, CircleDirection::Ccw);
    assert!(!arc.direction_assumed);
    // The arc passes 180°: X comes within the radius of the centre.
    assert_eq!(p.segments[7].extent(Axis::X), (1300 + 141 - 200, 1300));
    assert_eq!(
        p.segments[0].kind,
        SegmentKind::Reference(Axis::Y),
        "reference order Z, Y, X (manual 3.2.8)"
    );
}

#[test]
fn zero_points_and_simulated_references_shift_absolute_moves() {
    let start = Start::at_zero(AxisSet::from_mask(1));
    let run = |text: &str| path(&isel(text), &start).end[0];
    // `n`: absolute moves count from the point it stored (manual 3.2.17);
    // the counter (`@0P`) is not changed by it.
    assert_eq!(run("m100,900\nn1\nm50,900\n9\n"), 150);
    // `N`: the current point becomes counter 0 (manual 3.2.18).
    assert_eq!(run("m100,900\nN1\nm50,900\n9\n"), 50);
    // A reference run clears the stored zero point.
    assert_eq!(run("m100,900\nn1\n71\nm50,900\n9\n"), 50);
}

#[test]
fn moves_with_three_axes_run_in_phases() {
    let program = isel("0 10,900,20,900,-5,900,5,900\nz1\n0 1,900,1,900,1,900,7,900\n9\n");
    let p = path(&program, &Start::at_zero(AxisSet::XYZ));
    let tos: Vec<[i64; 4]> = p.segments.iter().map(|s| s.to).collect();
    // 2.5D: X and Y together, then z1, then z2 (manual 3.2.2); with 3D
    // interpolation all three at once and z2 ignored (3.2.24).
    assert_eq!(
        tos,
        [
            [10, 20, 0, 0],
            [10, 20, -5, 0],
            [10, 20, 0, 0],
            [11, 21, 1, 0]
        ]
    );
}

#[test]
fn helices_move_the_third_axis_and_unset_directions_are_assumed() {
    let program =
        isel("w32000,600,-1000,-2000,0,1,-1,6000\ne1\nf-1\ny400,1500,119,-141,141,-1,-1\n9\n");
    let p = path(&program, &Start::at_zero(AxisSet::XYZ));
    match &p.segments[0].kind {
        SegmentKind::Helix { arc, axis, steps } => {
            assert_eq!((*axis, *steps), (Axis::Z, 6000));
            assert!(arc.direction_assumed);
            assert_eq!(arc.direction, CircleDirection::Cw);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(p.segments[0].to[2], 6000);
    // In the XZ plane the arc moves X and Z, not Y: 135° to 225° CCW goes
    // down the second axis of the plane, Z.
    let arc = &p.segments[1];
    assert_eq!((arc.from[0], arc.from[1]), (arc.to[0], arc.to[1]));
    assert!(
        (-283..=-281).contains(&(arc.to[2] - arc.from[2])),
        "{arc:?}"
    );
}

#[test]
fn emcu_jobs_reference_in_the_written_order_and_move_absolute_or_relative() {
    let program = Program::parse(
        Language::Emcu,
        "$HZXY\n#E1,800\nL1,X200,Y500\nL1,x-50,y-100\n",
    );
    let p = path(&program, &Start::new(AxisSet::XYZ, [7, 8, 9, 0]));
    assert_eq!(p.end, [150, 400, 0, 0]);
    assert_eq!(p.finish, PathEnd::Finished);
    let kinds: Vec<&SegmentKind> = p.segments.iter().map(|s| &s.kind).collect();
    assert_eq!(
        kinds,
        [
            &SegmentKind::Reference(Axis::Z),
            &SegmentKind::Reference(Axis::X),
            &SegmentKind::Reference(Axis::Y),
            &SegmentKind::Line,
            &SegmentKind::Line
        ]
    );
    assert_eq!(p.segments[3].line, 2);
}

#[test]
fn runs_end_at_the_end_or_where_they_cannot_go_on() {
    let x = Start::at_zero(AxisSet::from_mask(1));
    let finish = |text: &str| path(&isel(text), &x).finish;
    assert_eq!(finish("01,900\n"), PathEnd::Finished);
    assert_eq!(finish("; c\n01,900\n9\n01,900\n"), PathEnd::End { line: 2 });
    assert_eq!(
        finish("01,900\n3 0,7\n9\n"),
        PathEnd::OutOfProgram { line: 1 }
    );
    // Eight nested loops need an eighth loop counter; the controller has 7.
    let mut deep = String::from("01,900\n");
    for k in 1..=8 {
        deep.push_str(&format!("3 1,-{k}\n"));
    }
    assert_eq!(finish(&deep), PathEnd::TooDeep { line: 1 });
    let mut seven = String::from("01,900\n");
    for k in 1..=7 {
        seven.push_str(&format!("3 1,-{k}\n"));
    }
    let p = path(&isel(&seven), &x);
    assert_eq!(p.finish, PathEnd::Finished);
    assert_eq!(p.end[0], 1 << 7);
}
