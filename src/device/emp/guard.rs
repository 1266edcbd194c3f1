//! What guards one long action once it was sent, for the raw frames
//! ([`super::raw`]) and the planned reference run ([`super::home`]) alike:
//! its deadline ([`super::deadline::raw`], from the frame and what the
//! driver knows of the drive) and, for a reference run, the stall watchdog
//! ([`super::stall`]). Giving up is [`super::deadline::give_up`]: the
//! operation stops its drives, the fault names drive and frame and blocks
//! motion until the operator initialises and references.

use std::time::{Duration, Instant};

use crate::device::api::ControllerFault;
use crate::proto::emp::{Command, DriveAddress, Request};

use super::context::Context;
use super::deadline::{self, GivenUp, LongKind};
use super::script::Outcome;
use super::stall::{READ_EVERY, STILL_READS, StallWatch};

#[derive(Debug)]
pub struct LongGuard {
    request: Request,
    kind: LongKind,
    timeout: Duration,
    deadline: Instant,
    /// Reference runs only.
    watch: Option<StallWatch>,
    /// The watchdog's own `2C` on its way.
    reading: Option<Request>,
    /// The poller reads the drive often enough to stand for the
    /// watchdog's reads (as last seen: polling may be switched meanwhile).
    polled: bool,
    /// Given up: the stop is asked for and the fault told.
    given_up: bool,
    /// The operator stopped: nothing more to guard.
    disarmed: bool,
}

/// Whether the poller reads every drive's position at least once per
/// watchdog interval, so its samples can stand for the watchdog's reads.
fn polled(cx: &Context) -> bool {
    cx.position_poll.is_some_and(|p| p <= READ_EVERY)
}

impl LongGuard {
    /// The guard of `request` sent at `now`; `None` for a frame that starts
    /// no long action.
    pub fn arm(cx: &Context, request: &Request, now: Instant) -> Option<LongGuard> {
        let (kind, timeout) = deadline::raw(cx, request)?;
        Some(LongGuard {
            request: *request,
            kind,
            timeout,
            deadline: deadline::due(now, timeout),
            watch: (kind == LongKind::Homing).then(|| StallWatch::new(now)),
            reading: None,
            polled: polled(cx),
            given_up: false,
            disarmed: false,
        })
    }

    pub fn request(&self) -> &Request {
        &self.request
    }

    /// Neither given up nor disarmed.
    pub fn live(&self) -> bool {
        !self.given_up && !self.disarmed
    }

    pub fn given_up(&self) -> bool {
        self.given_up
    }

    /// The operator stopped: nothing more to guard.
    pub fn disarm(&mut self) {
        self.disarmed = true;
    }

    /// The watchdog's own read when one is due; `running`: the long action
    /// has answered `55` and not ended.
    pub fn read(&mut self, cx: &Context, running: bool, now: Instant) -> Option<Request> {
        self.polled = polled(cx);
        if !self.live() || !running {
            return None;
        }
        let w = self.watch.as_mut()?;
        if w.read_due(self.polled).is_none_or(|t| t > now) {
            return None;
        }
        w.read_sent();
        let read = Request::new(self.request.ds, Command::ReadPosition);
        self.reading = Some(read);
        Some(read)
    }

    /// Whether `request` is the watchdog's own read.
    pub fn is_read(&self, request: &Request) -> bool {
        self.reading.as_ref() == Some(request)
    }

    /// The watchdog's read came back (`Answered`: the driver has recorded
    /// the position). `Some` when the run is now stalled.
    pub fn read_answered(
        &mut self,
        cx: &Context,
        outcome: Outcome,
        now: Instant,
    ) -> Option<GivenUp> {
        self.reading = None;
        let position = match outcome {
            Outcome::Answered => cx.drive(self.request.ds).and_then(|d| d.position),
            _ => None,
        };
        let stalled = self.watch.as_mut().is_some_and(|w| w.sample(position, now));
        self.stalled(stalled)
    }

    /// The poller read drive `ds`'s position. `Some` when the run is now
    /// stalled.
    pub fn polled(&mut self, cx: &Context, ds: DriveAddress, now: Instant) -> Option<GivenUp> {
        if ds != self.request.ds || !self.live() {
            return None;
        }
        let position = cx.drive(ds).and_then(|d| d.position);
        let stalled = self.watch.as_mut().is_some_and(|w| w.polled(position, now));
        self.stalled(stalled)
    }

    fn stalled(&self, stalled: bool) -> Option<GivenUp> {
        (stalled && self.live()).then_some(GivenUp::Stalled { reads: STILL_READS })
    }

    /// When the deadline passes (while the guard is live).
    pub fn timer(&self) -> Option<Instant> {
        self.live().then_some(self.deadline)
    }

    /// When the watchdog's own read is due (`running`: the long action has
    /// answered `55` and not ended).
    pub fn read_due(&self, running: bool) -> Option<Instant> {
        if !self.live() || !running {
            return None;
        }
        self.watch.as_ref()?.read_due(self.polled)
    }

    /// `Some` when the deadline has passed.
    pub fn expired(&self, now: Instant) -> Option<GivenUp> {
        (self.live() && self.deadline <= now).then_some(GivenUp::Deadline(self.timeout))
    }

    /// Give up: the fault (`deadline::give_up`); the caller stops the
    /// drives first (its `take_stops`, sent ahead of everything).
    pub fn give_up(&mut self, cx: &mut Context, why: GivenUp) -> ControllerFault {
        self.given_up = true;
        deadline::give_up(cx, &self.request, self.kind, why)
    }
}
