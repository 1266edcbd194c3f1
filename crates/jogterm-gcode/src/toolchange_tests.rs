//! The job cut at its waits: what each piece holds, the moves around a
//! tool change, the shift after a measured tool, and the host's steps.

use super::*;
use crate::interp::interpret;
use crate::setup::{NamedOutput, Setup, Units};
use crate::tools::tool_table;
use jogterm_proto::wiring::Role;

fn setup() -> Setup {
    let mut s = Setup {
        default_units: Some(Units::Mm),
        ..Setup::default()
    };
    s.outputs = vec![NamedOutput {
        address: "out2".into(),
        name: "spindle".into(),
        role: Some(Role::Spindle),
        number: 0,
    }];
    s
}

/// Two tools: T1 cuts at Z-1 from line 5, T2 (from line 9) at Z-2.
const TWO_TOOLS: &str = "(T1 D=6 - flat end mill)\n(T2 D=3.175 CR=0 - ZMIN=-2 - ball mill)\n\
M6 T1\nM3 S8000\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F100\nG1 X20 F300\nG0 Z5\nM6 T2\nM3 S9000\n\
G0 X30 Y10\nG1 Z-2 F120\nG1 X40 F300\nG0 Z5\nM0\nG0 X0 Y0\nM30\n";

fn plan(change_at: ChangeAt) -> (Toolpath, Plan) {
    let path = interpret(TWO_TOOLS, &setup()).expect("the job");
    let plan = Plan::of(&path, &tool_table(TWO_TOOLS), change_at, 50.0);
    (path, plan)
}

fn moves(path: &Toolpath) -> Vec<(char, [f64; 3])> {
    path.ops
        .iter()
        .filter_map(|op| match op {
            Op::Rapid(m) => Some(('r', [m.to.x, m.to.y, m.to.z])),
            Op::Line(m) => Some(('l', [m.to.x, m.to.y, m.to.z])),
            _ => None,
        })
        .collect()
}

fn outputs(path: &Toolpath) -> Vec<bool> {
    path.ops
        .iter()
        .filter_map(|op| match op {
            Op::Output(o) => Some(o.on),
            _ => None,
        })
        .collect()
}

const AT: ChangeAt = ChangeAt {
    x: Some(100.0),
    y: Some(0.0),
    z: Some(50.0),
};

#[test]
fn the_job_is_cut_at_every_tool_change_and_pause_with_their_lines() {
    let (path, plan) = plan(AT);
    assert_eq!(plan.segments(), 4);
    let lines: Vec<u32> = plan.waits.iter().map(|w| w.origin.line).collect();
    assert_eq!(lines, [3, 10, 16]);
    assert_eq!(
        plan.waits[0].what(),
        "M6: change to tool T1 flat end mill, D=6"
    );
    assert_eq!(
        plan.waits[1].what(),
        "M6: change to tool T2 ball mill, D=3.175"
    );
    assert_eq!(plan.waits[2].what(), "M0: program pause");
    assert_eq!(plan.waits[1].tool_name().as_deref(), Some("T2"));
    // The spindle was on at T2's change, at 8000 rpm; not at T1's.
    assert!(plan.waits[0].outputs.is_empty());
    assert_eq!(plan.waits[1].outputs.len(), 1);
    assert_eq!(plan.waits[1].spindle_rpm, Some(8000.0));
    assert_eq!(
        plan.waits[1].at,
        Point {
            x: 20.0,
            y: 10.0,
            z: 5.0
        }
    );
    assert_eq!(
        plan.waits[1].next,
        Some(Point {
            x: 20.0,
            y: 10.0,
            z: 5.0
        })
    );
    assert_eq!(plan.waits[1].descent_feed, 100.0);
    // Before the first move the file has named no axis: nothing to go
    // back to, the file's own first moves lead from the change position.
    assert_eq!(plan.waits[0].next, None);
    assert_eq!(plan.first_line(&path, 2), Some(12));
    assert_eq!(plan.first_line(&path, 3), Some(17));
    assert_eq!(plan.safe_z, 5.0);
}

#[test]
fn a_tool_change_leaves_retracted_to_the_change_position_and_comes_back_shifted() {
    let (path, plan) = plan(AT);
    // Piece 1: T1's cut, then up (already at 5), spindle off, to X100 Y0 at
    // the safe height, down to Z50... here up to it: 50 is the travel height.
    let first = plan.segment(&path, 1, 0.0, 0.0);
    let m = moves(&first);
    assert_eq!(m.last(), Some(&('r', [100.0, 0.0, 50.0])), "{m:?}");
    assert_eq!(outputs(&first), [true, false]);
    assert!(matches!(first.ops.last(), Some(Op::End { .. })));
    // Piece 2 after a tool 1 mm longer: from the change position up, over
    // the next point, spindle on, down to the safe height 6 and at the
    // plunge feed no further (the next move starts at the safe height).
    let second = plan.segment(&path, 2, 0.0, 1.0);
    let m = moves(&second);
    assert_eq!(m[0], ('r', [100.0, 0.0, 50.0]));
    assert_eq!(m[1], ('r', [20.0, 10.0, 50.0]));
    assert_eq!(m[2], ('r', [20.0, 10.0, 6.0]));
    // The job's own moves, every Z one higher: the cut at Z-2 at -1.
    assert!(m.contains(&('l', [30.0, 10.0, -1.0])), "{m:?}");
    assert!(m.contains(&('l', [40.0, 10.0, -1.0])), "{m:?}");
    // The spindle on again, then the file's own M3.
    assert_eq!(outputs(&second), [true, true]);
    let speeds: Vec<f64> = second
        .ops
        .iter()
        .filter_map(|op| match op {
            Op::SpindleSpeed { rpm, .. } => Some(*rpm),
            _ => None,
        })
        .collect();
    assert_eq!(speeds, [8000.0, 9000.0]);
    // An M0 waits in place: the piece before ends where the tool stands.
    let m = moves(&second);
    assert_eq!(m.last(), Some(&('r', [40.0, 10.0, 6.0])));
    let after_pause = plan.segment(&path, 3, 1.0, 1.0);
    assert_eq!(moves(&after_pause), [('r', [0.0, 0.0, 6.0])]);
}

#[test]
fn without_a_change_position_the_tool_waits_above_where_it_stood() {
    let (_, plan) = plan(ChangeAt::default());
    assert_eq!(
        plan.waits_at(1, 0.0),
        Some(Point {
            x: 20.0,
            y: 10.0,
            z: 5.0
        })
    );
    // Z named alone: X and Y stay.
    let (_, plan) = plan_with_z(60.0);
    assert_eq!(
        plan.waits_at(1, 0.0),
        Some(Point {
            x: 20.0,
            y: 10.0,
            z: 60.0
        })
    );
}

fn plan_with_z(z: f64) -> (Toolpath, Plan) {
    plan(ChangeAt {
        z: Some(z),
        ..ChangeAt::default()
    })
}

#[test]
fn the_whole_job_keeps_its_pauses_between_the_moves() {
    let (path, plan) = plan(AT);
    let whole = plan.expanded(&path, 0.0);
    let pauses: Vec<u32> = whole
        .ops
        .iter()
        .filter_map(|op| match op {
            Op::Pause(p) => Some(op.origin().line)
                .filter(|_| matches!(p, Pause::ToolChange { .. } | Pause::Program { .. })),
            _ => None,
        })
        .collect();
    assert_eq!(pauses, [3, 10, 16]);
    // One end only, the file's.
    let ends = whole
        .ops
        .iter()
        .filter(|op| matches!(op, Op::End { .. }))
        .count();
    assert_eq!(ends, 1);
    // Without waits the job is one piece, unchanged.
    let plain = interpret("G0 Z5\nG1 X1 F100\nM30\n", &setup()).expect("job");
    let one = Plan::of(&plain, &BTreeMap::new(), AT, 50.0);
    assert_eq!(one.segments(), 1);
    assert_eq!(one.expanded(&plain, 0.0).ops, plain.ops);
}

#[test]
fn the_whole_job_one_op_at_a_time_is_the_expanded_job() {
    let (path, plan) = plan(AT);
    let ops: Vec<Op> = plan
        .expanded_slices(&path)
        .iter()
        .flat_map(|s| s.iter().cloned())
        .collect();
    assert!(ops.len() > path.ops.len(), "the moves around the waits");
    assert_eq!(ops, plan.expanded(&path, 0.0).ops);
    let plain = interpret("G0 Z5\nG1 X1 F100\nM30\n", &setup()).expect("job");
    let one = Plan::of(&plain, &BTreeMap::new(), AT, 50.0);
    let ops: Vec<Op> = one
        .expanded_slices(&plain)
        .iter()
        .flat_map(|s| s.iter().cloned())
        .collect();
    assert_eq!(ops, plain.ops);
}

#[test]
fn the_host_runs_measures_and_shifts_in_order() {
    let (_, plan) = plan(AT);
    let mut s = Sequence::new(plan.clone(), true, 0.5);
    assert_eq!(
        s.step(),
        Step::Run {
            index: 0,
            dz_before: 0.5,
            dz: 0.5
        }
    );
    s.done();
    assert_eq!(s.step(), Step::Confirm { index: 0 });
    // Steps out of turn change nothing.
    s.measured(9.0);
    s.returned();
    assert_eq!(s.step(), Step::Confirm { index: 0 });
    s.confirmed();
    assert_eq!(
        s.step(),
        Step::Measure {
            index: 0,
            tool: "T1".into()
        }
    );
    s.measured(0.0);
    assert_eq!(
        s.step(),
        Step::Return {
            index: 0,
            to: Point {
                x: 100.0,
                y: 0.0,
                z: 50.0
            }
        }
    );
    s.returned();
    assert_eq!(
        s.step(),
        Step::Run {
            index: 1,
            dz_before: 0.5,
            dz: 0.0
        }
    );
    s.done();
    s.confirmed();
    s.measured(1.0);
    s.returned();
    assert_eq!(
        s.step(),
        Step::Run {
            index: 2,
            dz_before: 0.0,
            dz: 1.0
        }
    );
    s.done();
    // The M0: confirmed, nothing measured.
    s.confirmed();
    assert_eq!(
        s.step(),
        Step::Run {
            index: 3,
            dz_before: 1.0,
            dz: 1.0
        }
    );
    s.done();
    assert_eq!(s.step(), Step::Done);
    // Without a sensor a tool change is confirmed and the shift stays.
    let mut s = Sequence::new(plan, false, 0.0);
    s.done();
    s.confirmed();
    assert_eq!(
        s.step(),
        Step::Run {
            index: 1,
            dz_before: 0.0,
            dz: 0.0
        }
    );
}
