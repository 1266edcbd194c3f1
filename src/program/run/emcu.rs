//! What an EMCU interface does with a job's buffered commands (manual 1.5,
//! `docs/decisions.md` EMCU 3). A job has no jumps: it runs once, top
//! to bottom. Master commands in a job are not stored (the linter reports
//! them) and do nothing here.

use crate::axis::AxisSet;
use crate::proto::emcu::{Command as EmcuCommand, MoveMode};

use super::value::{Iv, Reach, Val};
use super::{Finish, Motion, MotionKind, Observer, Outcome};
use crate::program::model::Program;

/// Run the job from the counters `start` (unknown when `None`); the counters
/// equal machine coordinates (the reference point is counter 0 once the
/// reference offset has been driven, manual 1.4.2, 1.5.9).
pub(crate) fn run(
    program: &Program,
    start: Option<[i64; 4]>,
    budget: usize,
    observer: &mut dyn Observer,
) -> Outcome {
    let mut counter: [Val; 4] = start.map_or([None; 4], |p| p.map(|v| Some(Iv::exact(v))));
    let mut executed = 0;
    for (_, statement) in program.statements() {
        if executed >= budget {
            return Outcome {
                executed,
                finish: Finish::Bound(statement.index),
                bound: Some(statement.index),
            };
        }
        executed += 1;
        let Some(command) = statement.command.as_ref().ok().and_then(|c| c.as_emcu()) else {
            continue;
        };
        match command {
            EmcuCommand::Move(mv) => {
                let from = counter;
                let mut to = from;
                let mut reach = [None; 4];
                for (axis, steps) in mv.targets() {
                    let i = axis.index();
                    let steps = i64::from(steps.get());
                    to[i] = match mv.mode() {
                        MoveMode::Absolute => Some(Iv::exact(steps)),
                        MoveMode::Relative => from[i].map(|v| v.offset(steps)),
                    };
                    if let (Some(f), Some(t)) = (from[i], to[i])
                        && f != t
                    {
                        reach[i] = Some(Reach::line(f, t));
                    }
                }
                counter = to;
                observer.motion(&Motion {
                    index: statement.index,
                    kind: MotionKind::Line,
                    from,
                    to,
                    reach,
                    until_port: false,
                });
            }
            EmcuCommand::Reference(order) => {
                // One axis after the other, in the order written (1.5.9).
                for axis in order.axes() {
                    let from = counter;
                    counter[axis.index()] = Some(Iv::ZERO);
                    observer.motion(&Motion {
                        index: statement.index,
                        kind: MotionKind::Reference(AxisSet::EMPTY.with(axis.axis())),
                        from,
                        to: counter,
                        reach: [None; 4],
                        until_port: false,
                    });
                }
            }
            _ => {}
        }
    }
    Outcome {
        executed,
        finish: Finish::RanOff,
        bound: None,
    }
}
