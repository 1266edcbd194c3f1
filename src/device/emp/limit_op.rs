//! The jog off a limit switch (`Request::LimitJog`, `docs/jogging.md`,
//! "Jog off a limit switch") on an EMP drive.
//!
//! The drive brakes at an active limit switch on its own and lets the axis
//! leave it only the other way (manual introduction: "die Position kann nur
//! in der entgegengesetzten Richtung wieder verlassen werden"; a move into
//! the switch answers `05`, `docs/protocols.md` EMP). So no override is
//! needed on the wire: one TP positioning (`22 DS 07`, `2A DS 01`) of
//! `jog.limit_jog_distance` away from the switch at `jog.limit_jog_speed`
//! ([`plan::limit_jog`]), which the drive ends by itself at that distance,
//! link or no link. Meanwhile the drive's switches (`40 DS 01`, "kann
//! jederzeit" like `2C`) are read every [`READ_EVERY`]; once the switch
//! reads released the drive is stopped (`emp.stop`). A last read after the
//! positioning has arrived tells a switch that released on the last
//! stretch from one that did not.

use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::device::api::{ActiveLimit, Activity, Dir, Event, JogEnd, JogId, Refusal};
use crate::device::common::Sink;
use crate::device::common::limit_jog::{self, Reading};
use crate::device::common::limits::named_axes;
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use super::context::{Context, is_limit};
use super::deadline;
use super::drive_stops::DriveStops;
use super::io;
use super::motion_op::{overdue, script_for, timeout_for};
use super::op::Operation;
use super::plan::{self, Plan};
use super::script::{Next, Outcome, Script};

/// How often the drive's switches are read while it moves off one.
pub const READ_EVERY: Duration = Duration::from_millis(20);

#[derive(Debug)]
pub struct LimitJogOp {
    id: JogId,
    axis: Axis,
    ds: DriveAddress,
    /// The switch it leaves.
    switch: ActiveLimit,
    plan: Plan,
    script: Script,
    timeout: Duration,
    deadline: Option<Instant>,
    /// Where the axis stood when it started.
    from: Option<i64>,
    /// A read of the switches is on its way.
    reading: bool,
    next_read: Option<Instant>,
    /// The positioning has ended: one more read, then the end.
    last_read: bool,
    reading_result: Option<Reading>,
    end: Option<JogEnd>,
    stops: DriveStops,
    reported: bool,
    /// The time the op last heard of (for a reading outside `next` and
    /// `outcome`).
    last_at: Instant,
}

impl LimitJogOp {
    pub fn new(
        cx: &Context,
        id: JogId,
        axis: Axis,
        dir: Dir,
        now: Instant,
    ) -> Result<LimitJogOp, Refusal> {
        named_axes(cx.settings.axes, AxisSet::EMPTY.with(axis))?;
        let active = io::snapshot(&cx.drives, &cx.settings.wiring, now).active_limits();
        let switch = limit_jog::check(&cx.state, cx.ready(), axis, dir, &active, is_limit)?;
        let plan = plan::limit_jog(cx, axis, dir)?;
        let ds = plan
            .legs
            .first()
            .map(|l| l.ds)
            .ok_or(Refusal::NotInitialised)?;
        Ok(LimitJogOp {
            id,
            axis,
            ds,
            switch,
            script: script_for(cx, &plan),
            timeout: timeout_for(cx, &plan),
            plan,
            deadline: None,
            from: cx.drive(ds).and_then(|d| d.position),
            reading: false,
            next_read: None,
            last_read: false,
            reading_result: None,
            end: None,
            stops: DriveStops::default(),
            reported: false,
            last_at: now,
        })
    }

    fn read_request(&self) -> Request {
        Request::new(self.ds, Command::ReadInputs)
    }

    /// The positioning has answered `55` and not ended.
    fn moving(&self) -> bool {
        !self.script.running().is_empty()
    }

    /// Stop the drive (the driver sends the frame); `end` unless it has one.
    fn halt(&mut self, end: JogEnd) {
        self.end.get_or_insert(end);
        if self.stops.halt(vec![self.ds]) {
            self.script.cancel();
            self.deadline = None;
        }
    }

    fn report(&mut self, cx: &mut Context, now: Instant) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = self.end.clone().unwrap_or(JogEnd::Stopped);
        // It stood in the switch: the reference is next (the drive's `05`
        // or `40` fault asks for it already).
        cx.unreference(self.axis);
        cx.refresh();
        let here = cx.drive(self.ds).and_then(|d| d.position);
        let travelled = match (self.from, here) {
            (Some(a), Some(b)) => (b - a).abs() as f64,
            _ => 0.0,
        };
        let notice = match (&end, self.reading_result) {
            (JogEnd::OffLimit, _) => Some(Reading::Off),
            (JogEnd::StillOnLimit, r) => Some(r.unwrap_or(Reading::Still)),
            _ => None,
        };
        if let Some(r) = notice {
            cx.notice(limit_jog::end_notice(
                self.axis,
                &self.switch,
                travelled,
                &r,
            ));
        }
        cx.emit(Event::Io(io::snapshot(
            &cx.drives,
            &cx.settings.wiring,
            now,
        )));
        cx.emit(Event::JogEnded { id: self.id, end });
    }

    /// A read of the switches was answered (the driver has taken the
    /// levels into the context).
    fn switches_read(&mut self, cx: &Context, now: Instant) {
        self.last_at = now;
        self.reading = false;
        self.next_read = Some(now + READ_EVERY);
        let active = io::snapshot(&cx.drives, &cx.settings.wiring, now).active_limits();
        let reading = limit_jog::reading(self.axis, self.switch.side, &active);
        self.reading_result = Some(reading);
        if self.last_read {
            let end = match reading {
                Reading::Off => JogEnd::OffLimit,
                Reading::Still | Reading::Other => JogEnd::StillOnLimit,
            };
            self.end.get_or_insert(end);
            return;
        }
        match reading {
            Reading::Off if !self.stops.is_stopping() => self.halt(JogEnd::OffLimit),
            Reading::Other if !self.stops.is_stopping() => self.halt(JogEnd::StillOnLimit),
            _ => {}
        }
    }
}

impl Operation for LimitJogOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        self.last_at = now;
        if self.stops.is_stopping() {
            if !self.stops.answered() || self.reading {
                return Next::Wait;
            }
            self.report(cx, now);
            return Next::Done;
        }
        if self.moving() && !self.reading && self.next_read.is_none_or(|t| t <= now) {
            self.reading = true;
            return Next::Send(self.read_request());
        }
        match self.script.next() {
            Next::Send(request) => {
                if matches!(request.command, Command::MoveTo { .. }) {
                    self.deadline = Some(deadline::due(now, self.timeout));
                    self.next_read = Some(now + READ_EVERY);
                }
                Next::Send(request)
            }
            Next::Wait => Next::Wait,
            Next::Done if self.reading => Next::Wait,
            Next::Done if self.end.is_none() && !self.last_read && !self.script.failed() => {
                // Arrived at the bound: did the switch release on the way?
                self.last_read = true;
                self.reading = true;
                Next::Send(self.read_request())
            }
            Next::Done => {
                self.report(cx, now);
                Next::Done
            }
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
        if *request == self.read_request() {
            if outcome == Outcome::Answered {
                self.switches_read(cx, now);
            } else {
                self.reading = false;
                self.next_read = Some(now + READ_EVERY);
            }
            return;
        }
        self.script.outcome(request, outcome);
        match (request.command, outcome) {
            (Command::MoveTo { .. }, Outcome::Completed | Outcome::Ended) => self.deadline = None,
            (_, Outcome::Rejected) => {
                // The drive refused (its error is read and reported by the
                // driver): `05` for a move into an active switch means the
                // wiring is not what the profile says.
                self.deadline = None;
                let fault = cx.state.fault.clone().unwrap_or_else(|| {
                    crate::device::common::link::unreadable(&request.to_string(), "rejected")
                });
                self.end.get_or_insert(JogEnd::Fault(fault));
            }
            _ => {}
        }
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request) || (self.reading && *request == self.read_request())
    }

    fn activity(&self) -> Activity {
        if self.reported {
            Activity::Idle
        } else if self.stops.is_stopping() {
            Activity::Stopping
        } else {
            Activity::Jogging
        }
    }

    fn timer(&self) -> Option<Instant> {
        self.deadline
    }

    fn send_due(&self) -> Option<Instant> {
        if self.moving() && !self.reading && !self.stops.is_stopping() {
            self.next_read
        } else {
            None
        }
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        if self.deadline.is_some_and(|t| t <= now)
            && !self.stops.is_stopping()
            && let Some(fault) = overdue(cx, None, Some(&self.plan), self.timeout)
        {
            self.halt(JogEnd::Fault(fault));
        }
    }

    fn drive_stops(&mut self) -> Option<&mut DriveStops> {
        Some(&mut self.stops)
    }

    fn stopped(&mut self, _cx: &mut Context, drives: &[DriveAddress]) {
        self.end.get_or_insert(JogEnd::Stopped);
        self.stops.stopped(drives);
        self.script.cancel();
        self.deadline = None;
    }

    fn link_lost(&mut self, cx: &mut Context) {
        self.end.get_or_insert(JogEnd::LinkLost);
        self.stops.link_lost();
        self.reading = false;
        if !self.reported {
            self.reported = true;
            cx.unreference(self.axis);
            cx.refresh();
            let end = self.end.clone().unwrap_or(JogEnd::LinkLost);
            cx.emit(Event::JogEnded { id: self.id, end });
        }
    }

    fn limit_hit(&mut self, cx: &mut Context, ds: DriveAddress) {
        if ds != self.ds || self.stops.is_stopping() {
            return;
        }
        // A switch became active where none was read active: judge the
        // levels the driver has just taken.
        let reading = self.reading;
        self.switches_read(cx, self.last_at);
        self.reading = reading;
    }
}
