//! What an operation of the EMP driver is: it hands out the frames it wants
//! sent (one at a time, [`Script`]), takes the outcomes of its own requests,
//! and may ask for its drives to be stopped (release, lease expiry, soft
//! limit). The driver owns the line and the stops; operations own the meaning.

use std::time::Instant;

use crate::device::api::Activity;
use crate::proto::emp::{DriveAddress, Reply, Request};

use super::context::Context;
use super::drive_stops::DriveStops;
use super::script::{Next, Outcome};

pub trait Operation {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next;

    /// An outcome of a request this operation sent (`reply` when one came).
    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        reply: Option<&Reply>,
        now: Instant,
    );

    fn owns(&self, request: &Request) -> bool;

    fn activity(&self) -> Activity;

    /// When `on_timer` is due (a jog lease, a move's deadline).
    fn timer(&self) -> Option<Instant> {
        None
    }

    fn on_timer(&mut self, _cx: &mut Context, _now: Instant) {}

    /// When a frame of its own becomes due to be sent (a watchdog's read):
    /// the driver wakes for it only while the line is free, as for a poll.
    fn send_due(&self) -> Option<Instant> {
        None
    }

    /// A new position sample.
    fn position(&mut self, _cx: &mut Context, _now: Instant) {}

    /// The poller has read drive `ds`'s position (`Context` holds it): a
    /// sample for a stall watchdog, so it needs no reads of its own.
    fn polled(&mut self, _cx: &mut Context, _ds: DriveAddress, _now: Instant) {}

    /// The stop frames of an operation that stops its drives itself.
    fn drive_stops(&mut self) -> Option<&mut DriveStops> {
        None
    }

    /// The drives this operation wants stopped now (release, lease expiry,
    /// soft limit, a failed leg); the driver sends the stop frames.
    fn take_stops(&mut self) -> Vec<DriveAddress> {
        self.drive_stops().map(DriveStops::take).unwrap_or_default()
    }

    /// The operator stopped everything: send nothing more, end what is
    /// reported (a jog ends `Stopped`), wait for the stop frames' answers.
    fn stopped(&mut self, cx: &mut Context, drives: &[DriveAddress]);

    /// A stop frame to `ds` was answered (or rejected).
    fn stop_answered(&mut self, ds: DriveAddress) {
        if let Some(stops) = self.drive_stops() {
            stops.answer(ds);
        }
    }

    /// The link is gone: report the end, forget the rest.
    fn link_lost(&mut self, _cx: &mut Context) {}

    /// A limit switch became active on `ds` while this ran.
    fn limit_hit(&mut self, _cx: &mut Context, _ds: DriveAddress) {}
}
