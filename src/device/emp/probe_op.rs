//! A probe on an EMP drive (`Request::Probe`, `docs/probing.md`): the
//! cycle of `common::probe`, each pass a series of short TP positionings
//! of the probe axis's drive (`22 DS 07`, `20 19`, `2A DS 01`, as every
//! positioning, [`plan::probe_move`]), each followed by a read of the
//! drive's inputs (`40 DS 01`), until the input reads what the pass waits
//! for or the pass's travel is used up; then the position (`2C`).
//!
//! EMP has no move that ends on an input (every command runs at once; the
//! inputs are only read), so the length of one move is how far the axis
//! may run past the trip: the fast pass's moves are what its speed covers
//! in [`FAST_MOVE`], the back-off's and the slow pass's are `probe.step`,
//! which makes the touched point accurate to one step. The drive ends each
//! move at its target on its own, so the axis never runs more than one
//! move past the trip, link or no link. The position is read once a pass
//! has ended, not after every move: a move ends at its target, and the
//! poller keeps the DRO meanwhile.

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{
    Activity, Event, InputSource, JogId, PerAxis, ProbeEnd, ProbeMove, Refusal,
};
use crate::device::common::Sink;
use crate::device::common::limits::invalid;
use crate::device::common::link;
use crate::device::common::probe::{self, Cycle, Pass, ProbeInput, Step, Until};
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use super::context::{self, Context, is_limit};
use super::deadline;
use super::drive_stops::DriveStops;
use super::io;
use super::motion_op::{overdue, script_for, timeout_for};
use super::op::Operation;
use super::plan::{self, Plan};
use super::script::{Next, Outcome, Script};

/// How long one move of the fast pass runs at the fast speed: the most the
/// fast pass runs past the trip (0.25 mm at 5 mm/s). Shorter moves waste
/// more of the pass on the frames between them (a `55`, the `22` and a
/// `40 01`, about 20 ms at 38400 baud).
pub const FAST_MOVE: Duration = Duration::from_millis(50);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// The inputs, then the position, before anything moves.
    ReadStart,
    MeasureStart,
    /// A move of a pass, or the return: its script runs.
    Moving,
    /// The inputs after a move of a pass.
    Read,
    /// The position after a pass or the return.
    Measure,
    Done,
}

/// The pass being carried out.
#[derive(Debug, Clone, Copy)]
struct Running {
    pass: Pass,
    /// Where the pass started, and where its last move ends (counts).
    start: i64,
    target: i64,
    /// Counts per move.
    length: i64,
}

impl Running {
    /// Counts left of the pass's travel.
    fn left(&self) -> i64 {
        self.pass.steps - (self.target - self.start).abs()
    }
}

#[derive(Debug)]
pub struct ProbeOp {
    id: JogId,
    probe: ProbeMove,
    input: ProbeInput,
    axis: Axis,
    ds: DriveAddress,
    /// Counts per move of the fast pass and of the slow ones.
    fast_length: i64,
    slow_length: i64,
    stage: Stage,
    cycle: Option<Cycle>,
    /// What the cycle asked for last.
    step: Option<Step>,
    running: Option<Running>,
    plan: Option<Plan>,
    script: Script,
    timeout: Duration,
    deadline: Option<Instant>,
    /// A read of the inputs or the position on its way.
    reading: Option<Request>,
    /// The input as read after the last move.
    touched: bool,
    end: Option<ProbeEnd>,
    stops: DriveStops,
    reported: bool,
}

impl ProbeOp {
    pub fn new(cx: &Context, id: JogId, probe: ProbeMove) -> Result<ProbeOp, Refusal> {
        let input = probe::probe_input(&cx.settings.wiring)?;
        let axis = probe.axis;
        let ds = cx.settings.drive_of(axis);
        if let Some(ds) = ds
            && input.key.source != InputSource::EmpDrive(ds.byte())
        {
            return Err(invalid(format!(
                "the probe input {} ({}) is not on drive {ds}, which moves {axis}: a probe reads \
                 its input between the moves of that drive, so wire the probe to one of its \
                 inputs ({ds}.I1-{ds}.I4) and give that the role `probe` in [io]",
                input.address, input.name
            )));
        }
        probe::check(
            &cx.state,
            cx.ready(),
            cx.settings.axes,
            &cx.settings.limits,
            &probe,
            ds.and_then(|ds| cx.drive(ds)).and_then(|d| d.position),
            is_limit,
        )?;
        let ds = ds.ok_or_else(|| invalid(format!("the machine has no {axis} axis")))?;
        // Both speeds as the drive runs them (refused here, before anything
        // moves, when the drive cannot run one), and the fast pass's moves
        // from the speed it runs.
        let speed = |hz: f64| {
            plan::probe_move(cx, axis, 0, 1, hz).map(|p| p.legs.first().map_or(hz, plan::Leg::hz))
        };
        let fast_hz = speed(probe.fast_hz)?;
        speed(probe.slow_hz)?;
        let slow_length = cx.settings.probe_step.get(axis).unwrap_or(1).max(1);
        let fast_length = ((fast_hz * FAST_MOVE.as_secs_f64()).round() as i64).max(slow_length);
        Ok(ProbeOp {
            id,
            probe,
            input,
            axis,
            ds,
            fast_length,
            slow_length,
            stage: Stage::ReadStart,
            cycle: None,
            step: None,
            running: None,
            plan: None,
            script: Script::default(),
            timeout: Duration::ZERO,
            deadline: None,
            reading: None,
            touched: false,
            end: None,
            stops: DriveStops::default(),
            reported: false,
        })
    }

    fn finish(&mut self, end: ProbeEnd) {
        self.end.get_or_insert(end);
        self.stage = Stage::Done;
    }

    /// Stop the drive (the driver sends the frame) and end with `end`.
    fn halt(&mut self, end: ProbeEnd) {
        self.end.get_or_insert(end);
        if self.stops.halt(vec![self.ds]) {
            self.script.cancel();
            self.deadline = None;
        }
    }

    fn report(&mut self, cx: &mut Context) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = self.end.clone().unwrap_or(ProbeEnd::Stopped);
        cx.emit(Event::ProbeEnded { id: self.id, end });
    }

    fn here(&self, cx: &Context) -> Option<i64> {
        cx.drive(self.ds).and_then(|d| d.position)
    }

    /// The probe input as last read: the drive's switches and inputs in
    /// the order the input keys number them (`40 01`: limit +, limit -,
    /// reference in PROP, I1-I4 in D0; `device::inputs::channels`).
    fn input_touched(&self, cx: &Context) -> bool {
        let word = cx.drive(self.ds).map_or(0, |d| {
            d.limits.map_or(0, |l| l.byte()) | d.inputs.map_or(0, |i| i.bits()) << 3
        });
        self.input.touched(word)
    }

    /// The inputs were read.
    fn inputs_read(&mut self, cx: &mut Context, now: Instant) {
        self.touched = self.input_touched(cx);
        cx.emit(Event::Io(io::snapshot(
            &cx.drives,
            &cx.settings.wiring,
            now,
        )));
        if self.stage == Stage::ReadStart {
            if self.touched {
                self.finish(ProbeEnd::Refused(Cycle::tripped_at_start(&self.input)));
            } else {
                self.stage = Stage::MeasureStart;
            }
            return;
        }
        let Some(r) = self.running else {
            self.finish(ProbeEnd::Stopped);
            return;
        };
        let met = match r.pass.until {
            Until::Touched => self.touched,
            Until::Released => !self.touched,
        };
        if met || r.left() <= 0 {
            self.stage = Stage::Measure;
        } else {
            self.next_move(cx);
        }
    }

    /// The position was read: where the cycle goes next.
    fn measured(&mut self, cx: &Context) {
        let Some(here) = self.here(cx) else {
            self.finish(ProbeEnd::Fault(link::unreadable("2C", "no position")));
            return;
        };
        let at = cx
            .positions()
            .unwrap_or_else(|| PerAxis::new().with(self.axis, here));
        let next = Cycle::advance(
            &mut self.cycle,
            self.probe,
            self.step.as_ref(),
            self.touched,
            &at,
            here,
        );
        match next {
            Step::Pass(pass) => {
                let length = if pass.hz > self.probe.slow_hz {
                    self.fast_length
                } else {
                    self.slow_length
                };
                self.running = Some(Running {
                    pass,
                    start: here,
                    target: here,
                    length,
                });
                self.step = Some(next);
                self.next_move(cx);
            }
            Step::Return { axis, to, hz } => {
                self.running = None;
                self.step = Some(next);
                self.start_move(cx, plan::probe_move(cx, axis, here, to, hz));
            }
            Step::End(end) => self.finish(end),
        }
    }

    /// The next move of the running pass: a move's length or what is left.
    fn next_move(&mut self, cx: &Context) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        let from = r.target;
        r.target = from + r.pass.dir.sign() * r.length.min(r.left());
        let (to, hz) = (r.target, r.pass.hz);
        self.start_move(cx, plan::probe_move(cx, self.axis, from, to, hz));
    }

    fn start_move(&mut self, cx: &Context, plan: Result<Plan, Refusal>) {
        match plan {
            Ok(plan) => {
                self.script = script_for(cx, &plan);
                self.timeout = timeout_for(cx, &plan);
                self.plan = Some(plan);
                self.stage = Stage::Moving;
            }
            Err(reason) => self.finish(ProbeEnd::Refused(reason)),
        }
    }

    /// The move's script has ended: the input after a move of a pass, the
    /// position after the return.
    fn moved(&mut self) {
        self.deadline = None;
        self.plan = None;
        self.stage = if matches!(self.step, Some(Step::Return { .. })) {
            Stage::Measure
        } else {
            Stage::Read
        };
    }

    fn read(&mut self, command: Command) -> Next {
        let request = Request::new(self.ds, command);
        self.reading = Some(request);
        Next::Send(request)
    }
}

impl Operation for ProbeOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        loop {
            if self.reading.is_some() {
                return Next::Wait;
            }
            if self.stops.is_stopping() {
                // Nothing more is sent; what runs is ended by the stop.
                if !self.stops.answered() || self.script.next() != Next::Done {
                    return Next::Wait;
                }
                self.report(cx);
                return Next::Done;
            }
            return match self.stage {
                Stage::ReadStart | Stage::Read => self.read(Command::ReadInputs),
                Stage::MeasureStart | Stage::Measure => self.read(Command::ReadPosition),
                Stage::Moving => match self.script.next() {
                    Next::Send(request) => {
                        if matches!(request.command, Command::MoveTo { .. }) {
                            self.deadline = Some(deadline::due(now, self.timeout));
                        }
                        Next::Send(request)
                    }
                    Next::Wait => Next::Wait,
                    Next::Done => {
                        self.moved();
                        continue;
                    }
                },
                Stage::Done => {
                    self.report(cx);
                    Next::Done
                }
            };
        }
    }

    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        _reply: Option<&Reply>,
        now: Instant,
    ) {
        if self.reading == Some(*request) {
            self.reading = None;
            if self.stops.is_stopping() || self.stage == Stage::Done {
                return;
            }
            if outcome != Outcome::Answered {
                // The drive no longer answers its reads (switched off):
                // nothing of the probe's moves runs.
                self.finish(ProbeEnd::Fault(
                    cx.state
                        .fault
                        .clone()
                        .unwrap_or_else(|| context::rejected(request, "the probe's frame")),
                ));
                return;
            }
            match self.stage {
                Stage::ReadStart | Stage::Read => self.inputs_read(cx, now),
                _ => self.measured(cx),
            }
            return;
        }
        self.script.outcome(request, outcome);
        match (request.command, outcome) {
            (Command::MoveTo { .. }, Outcome::Completed | Outcome::Ended) => self.deadline = None,
            (_, Outcome::Rejected) => {
                // The drive refused or broke off the move (its error is
                // read and reported by the driver): stop it.
                self.deadline = None;
                self.halt(ProbeEnd::Fault(context::rejected(
                    request,
                    "the probe's frame",
                )));
            }
            _ => {}
        }
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request) || self.reading == Some(*request)
    }

    fn activity(&self) -> Activity {
        if self.reported {
            Activity::Idle
        } else if self.stops.is_stopping() {
            Activity::Stopping
        } else {
            Activity::Probing
        }
    }

    fn timer(&self) -> Option<Instant> {
        self.deadline
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        if self.stops.is_stopping() || self.deadline.is_none_or(|t| t > now) {
            return;
        }
        let running = self.script.running().first().copied();
        if let Some(fault) = overdue(cx, running, self.plan.as_ref(), self.timeout) {
            self.halt(ProbeEnd::Fault(fault));
        }
    }

    fn drive_stops(&mut self) -> Option<&mut DriveStops> {
        Some(&mut self.stops)
    }

    /// Space and every other stop: no return afterwards (never more than
    /// the operator asked), nothing resumes.
    fn stopped(&mut self, _cx: &mut Context, drives: &[DriveAddress]) {
        self.end.get_or_insert(ProbeEnd::Stopped);
        self.stops.stopped(drives);
        self.script.cancel();
        self.deadline = None;
    }

    fn link_lost(&mut self, cx: &mut Context) {
        self.end.get_or_insert(ProbeEnd::LinkLost);
        self.stops.link_lost();
        self.reading = None;
        self.report(cx);
    }

    /// The drive braked at a limit switch on its own (the driver has
    /// reported the fault): the probe ends there.
    fn limit_hit(&mut self, cx: &mut Context, ds: DriveAddress) {
        if ds != self.ds || self.stops.is_stopping() {
            return;
        }
        let fault = (cx.state.fault.clone()).unwrap_or_else(|| context::limit_hit(ds, "probe"));
        self.halt(ProbeEnd::Fault(fault));
    }
}
