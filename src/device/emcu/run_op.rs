//! One operation for everything that is a batch and its run: initialise,
//! outputs, reference runs, the stored job, raw lines that start a run.
//! What differs is the [`Purpose`]: what the end means, what the machine is
//! doing meanwhile, whether the positions are read afterwards.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event};
use crate::device::common::Sink;
use crate::device::common::link::unreadable;
use crate::proto::emcu::{Reply, Status};

use super::context::Context;
use super::measure::Measure;
use super::op::{Abandon, Next, Operation};
use super::plan;
use super::run::{Run, RunEvent};

/// What a run is for.
pub trait Purpose: Send + std::fmt::Debug {
    /// The line the run stands for, for faults (`$HZYX`, `@J`).
    fn text(&self) -> String;

    /// Line `index` of the batch was acknowledged.
    fn acked(&mut self, _cx: &mut Context, _index: usize) {}

    /// The run is over: `status` is the `@X` that showed the interface
    /// idle; `stopped` when a stop came first.
    fn ended(&mut self, cx: &mut Context, status: Status, stopped: bool);

    /// The run's state is unknown (answers lost, the link gone, a reset).
    fn unknown(&mut self, _cx: &mut Context) {}

    /// What the machine does while the run is under way.
    fn activity(&self) -> Activity;

    /// Whether the positions are read when it is over.
    fn measure(&self) -> bool {
        self.activity() != Activity::Idle
    }
}

#[derive(Debug)]
enum Phase {
    Running(Run),
    Measure(Measure),
    Done,
}

#[derive(Debug)]
pub struct RunOp<P> {
    purpose: P,
    phase: Phase,
}

impl<P: Purpose> RunOp<P> {
    pub fn new(purpose: P, run: Run) -> RunOp<P> {
        RunOp {
            purpose,
            phase: Phase::Running(run),
        }
    }

    fn ended(&mut self, cx: &mut Context, status: Status, stopped: bool, now: Instant) {
        // What the run did first, so that the flags and the I/O snapshot
        // the `@X` brings show it.
        self.purpose.ended(cx, status, stopped);
        cx.status_read(status, now);
        self.phase = if self.purpose.measure() {
            Phase::Measure(Measure::new(cx))
        } else {
            Phase::Done
        };
    }

    fn lost(&mut self, cx: &mut Context, what: &str) {
        cx.emit(Event::Fault(unreadable(&self.purpose.text(), what)));
        self.purpose.unknown(cx);
        // Whether it moves is unknown: halt it and read the state back.
        cx.halt_wanted = self.purpose.activity() != Activity::Idle;
        cx.readback_wanted = true;
        self.phase = Phase::Done;
    }
}

impl<P: Purpose> Operation for RunOp<P> {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        match &mut self.phase {
            Phase::Running(run) => match run.next(cx) {
                // Stopped before its run was started: nothing changed.
                Next::Done => {
                    self.phase = Phase::Done;
                    Next::Done
                }
                other => other,
            },
            Phase::Measure(m) => match m.next(cx) {
                Some(cmd) => Next::Send(cmd),
                None => {
                    self.phase = Phase::Done;
                    Next::Done
                }
            },
            Phase::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        let run = match &mut self.phase {
            Phase::Running(run) => run,
            Phase::Measure(m) => return m.reply(cx, &reply, now),
            Phase::Done => return,
        };
        let index = run.acked_count();
        match run.reply(&reply, now) {
            RunEvent::Nothing | RunEvent::Started => {
                if run.acked_count() > index {
                    self.purpose.acked(cx, index);
                }
            }
            RunEvent::Ended(status) => {
                let stopped = run.is_stopping();
                self.ended(cx, status, stopped, now);
            }
            RunEvent::StillRunning { overdue: false } => {}
            RunEvent::StillRunning { overdue: true } if run.is_stopping() => {
                self.lost(cx, "still running after @B");
            }
            RunEvent::StillRunning { overdue: true } => {
                let text = format!("{} did not end in time: halting it", self.purpose.text());
                cx.notice(text);
                cx.halt_wanted = true;
            }
            RunEvent::Lost => self.lost(cx, "answers lost"),
        }
    }

    fn ready(&mut self, _cx: &mut Context, _now: Instant) {
        if let Phase::Running(run) = &mut self.phase {
            run.ready();
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        match &mut self.phase {
            Phase::Running(run) => {
                if run.lost_reply() == RunEvent::Lost {
                    self.lost(cx, "garbled answer");
                }
            }
            Phase::Measure(m) => {
                m.give_up();
                self.phase = Phase::Done;
            }
            Phase::Done => {}
        }
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) {
        if let Phase::Running(run) = &mut self.phase {
            let brake = if self.purpose.activity() == Activity::Idle {
                Duration::ZERO
            } else {
                plan::brake_time(cx)
            };
            run.stop(brake, now);
        }
    }

    fn timer(&self) -> Option<Instant> {
        match &self.phase {
            Phase::Running(run) => run.timer(),
            _ => None,
        }
    }

    fn on_timer(&mut self, _cx: &mut Context, now: Instant) -> bool {
        if let Phase::Running(run) = &mut self.phase {
            run.on_timer(now);
        }
        false
    }

    fn abandon(&mut self, cx: &mut Context, _cause: &Abandon) {
        if let Phase::Running(run) = &mut self.phase
            && run.started()
        {
            self.purpose.unknown(cx);
        }
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        match &self.phase {
            Phase::Running(run) => {
                let activity = self.purpose.activity();
                if run.is_stopping() && activity != Activity::Idle {
                    Activity::Stopping
                } else {
                    activity
                }
            }
            _ => Activity::Idle,
        }
    }
}
