//! Requests waiting for their turn (`docs/device.md`, "Request
//! conventions"). While something moves, runs or is being stored, a request
//! is refused `Busy` at once (never queued behind a long move), except a step
//! during a step (coalesced by the running move) and a jog while the previous
//! jog brakes (it waits, a newer one replaces it, and it starts only if its
//! lease is still alive). Other requests queue, at most [`MAX_QUEUED`], and
//! are checked against the state when it is their turn.
//!
//! Step presses are bounded here too: presses that arrive while the driver
//! is between moves (a poll being answered, the position read after a step)
//! are merged into one waiting step of at most `jog.step_queue` presses;
//! more are refused `StepQueueFull`, as the running step's own coalescing
//! refuses them. Ten presses that came together while a poll was answered
//! used to wait as ten moves and all ran (issue 13); now at most
//! `step_queue` presses wait, wherever they wait (`docs/jogging.md`).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event, JogEnd, JogId, PerAxis, Refusal, Request};

use super::limits::shifted;
use super::sink::{Sink, refuse};

/// Requests waiting for their turn; more are refused.
pub const MAX_QUEUED: usize = 64;

/// A request waiting.
#[derive(Debug, Clone, PartialEq)]
pub struct Queued {
    pub request: Request,
    /// For a jog: when its lease runs out while it waits.
    pub lease_until: Option<Instant>,
    /// For a step: the presses merged into it (its delta is their sum).
    pub presses: usize,
}

impl Queued {
    /// The lease a jog holds when its turn comes at `now`: when it runs out,
    /// and what is left of it (the jog may have waited behind a braking
    /// one, so this can be less than it was given, or nothing).
    pub fn held_lease(&self, now: Instant) -> (Instant, Duration) {
        let until = self.lease_until.unwrap_or(now);
        (until, until.saturating_duration_since(now))
    }
}

/// What the driver is doing when a request arrives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Running {
    /// Nothing that refuses requests.
    Idle,
    Busy {
        activity: Activity,
        /// A move the driver planned runs (it may take a step).
        motion: bool,
        /// That move is a jog being stopped (the next jog may wait for it).
        braking_jog: bool,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub struct RequestQueue {
    items: VecDeque<Queued>,
    /// Step presses that may wait (`jog.step_queue`, at least 1).
    step_bound: usize,
}

/// The least motion: one press may wait.
impl Default for RequestQueue {
    fn default() -> Self {
        RequestQueue::new(1)
    }
}

impl RequestQueue {
    /// A queue in which at most `step_queue` step presses wait.
    pub fn new(step_queue: usize) -> Self {
        RequestQueue {
            items: VecDeque::new(),
            step_bound: step_queue.max(1),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Take `request` for later, or refuse it. A step while a move runs is
    /// handed back (delta and speeds) for the running move to coalesce.
    pub fn admit(
        &mut self,
        request: Request,
        now: Instant,
        running: Running,
        sink: &mut impl Sink,
    ) -> Option<(PerAxis<i64>, PerAxis<f64>)> {
        let lease_until = match &request {
            Request::Jog { lease, .. } | Request::Checkout { lease, .. } => Some(now + *lease),
            _ => None,
        };
        if let Running::Busy {
            activity,
            motion,
            braking_jog,
        } = running
        {
            match request {
                Request::Step { delta, speed_hz } if motion => return Some((delta, speed_hz)),
                request @ Request::Jog { .. } if braking_jog => {
                    // The next jog waits for the one that is braking; a newer
                    // one replaces it.
                    if let Some(i) = self
                        .items
                        .iter()
                        .position(|q| matches!(q.request, Request::Jog { .. }))
                        && let Some(old) = self.items.remove(i)
                    {
                        refuse(sink, &old.request, Refusal::Busy { activity });
                    }
                    self.items.push_front(Queued {
                        request,
                        lease_until,
                        presses: 0,
                    });
                }
                request => refuse(sink, &request, Refusal::Busy { activity }),
            }
            return None;
        }
        if let Request::Step { delta, speed_hz } = &request
            && let Some(waiting) = self
                .items
                .iter_mut()
                .find(|q| matches!(q.request, Request::Step { .. }))
        {
            if waiting.presses >= self.step_bound {
                refuse(sink, &request, Refusal::StepQueueFull);
            } else if let Request::Step {
                delta: total,
                speed_hz: speeds,
            } = &mut waiting.request
            {
                // One move for them all, at the speeds of the last press
                // (as `StepQueue::take_merged`); its soft limits are
                // checked when it starts.
                *total = shifted(total, delta);
                *speeds = *speed_hz;
                waiting.presses += 1;
            }
            return None;
        }
        if self.items.len() >= MAX_QUEUED {
            refuse(
                sink,
                &request,
                Refusal::Invalid {
                    reason: format!("{MAX_QUEUED} requests are already waiting"),
                },
            );
            return None;
        }
        let presses = usize::from(matches!(request, Request::Step { .. }));
        self.items.push_back(Queued {
            request,
            lease_until,
            presses,
        });
        None
    }

    /// The next request whose turn it is. A jog whose lease ran out while it
    /// waited ends (`DeadMan`) instead.
    pub fn pop(&mut self, now: Instant, sink: &mut impl Sink) -> Option<Queued> {
        while let Some(q) = self.items.pop_front() {
            if let (Request::Jog { id, .. }, Some(until)) = (&q.request, q.lease_until)
                && until <= now
            {
                sink.emit(Event::JogEnded {
                    id: *id,
                    end: JogEnd::DeadMan,
                });
                continue;
            }
            return Some(q);
        }
        None
    }

    /// A renewal for a jog that is still waiting.
    pub fn renew(&mut self, id: JogId, lease: Duration, now: Instant) {
        for q in self.items.iter_mut() {
            if matches!(q.request, Request::Jog { id: qid, .. } | Request::Checkout { id: qid, .. } if qid == id)
            {
                q.lease_until = Some(now + lease);
            }
        }
    }

    /// A waiting jog was released: it never starts. False when none waited.
    pub fn release(&mut self, id: JogId, sink: &mut impl Sink) -> bool {
        let Some(i) = self
            .items
            .iter()
            .position(|q| matches!(q.request, Request::Jog { id: qid, .. } if qid == id))
        else {
            return false;
        };
        self.items.remove(i);
        sink.emit(Event::JogEnded {
            id,
            end: JogEnd::Released,
        });
        true
    }

    /// Every waiting request is refused (a stop, a lost link); waiting jogs
    /// end with `jog_end`.
    pub fn refuse_all(
        &mut self,
        reason: impl Fn() -> Refusal,
        jog_end: JogEnd,
        sink: &mut impl Sink,
    ) {
        for q in std::mem::take(&mut self.items) {
            if let Some(id) = q.request.jog_id() {
                sink.emit(Event::JogEnded {
                    id,
                    end: jog_end.clone(),
                });
            }
            if let Some(id) = q.request.checkout_id() {
                let end = match jog_end {
                    JogEnd::LinkLost => crate::device::api::CheckoutEnd::LinkLost,
                    _ => crate::device::api::CheckoutEnd::Refused(reason()),
                };
                sink.emit(Event::Checkout { id, end });
            }
            if let Some(id) = q.request.probe_id() {
                let end = match jog_end {
                    JogEnd::LinkLost => crate::device::api::ProbeEnd::LinkLost,
                    _ => crate::device::api::ProbeEnd::Refused(reason()),
                };
                sink.emit(Event::ProbeEnded { id, end });
            }
            sink.emit(Event::Refused {
                request: crate::device::describe::describe(&q.request),
                reason: reason(),
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{Axis, AxisSet};
    use crate::device::api::Dir;

    fn jog(id: u64) -> Request {
        Request::Jog {
            id: JogId(id),
            axes: vec![(Axis::X, Dir::Plus)],
            speed_hz: PerAxis::new(),
            lease: Duration::from_millis(100),
        }
    }

    const BUSY: Running = Running::Busy {
        activity: Activity::Jogging,
        motion: true,
        braking_jog: false,
    };

    #[test]
    fn a_jog_holds_what_is_left_of_its_lease_when_its_turn_comes() {
        let given = Instant::now();
        let queued = Queued {
            request: jog(1),
            lease_until: Some(given + Duration::from_millis(100)),
            presses: 0,
        };
        let at = |ms| given + Duration::from_millis(ms);
        assert_eq!(queued.held_lease(at(30)).1, Duration::from_millis(70));
        // Waited past its lease behind a braking jog: it holds nothing.
        assert_eq!(queued.held_lease(at(250)), (at(100), Duration::ZERO));
    }

    #[test]
    fn busy_refuses_at_once_but_hands_steps_to_the_move() {
        let mut q = RequestQueue::default();
        let mut events = VecDeque::new();
        let now = Instant::now();
        q.admit(Request::Home { axes: AxisSet::XYZ }, now, BUSY, &mut events);
        assert!(matches!(
            events.pop_front(),
            Some(Event::Refused {
                reason: Refusal::Busy {
                    activity: Activity::Jogging
                },
                ..
            })
        ));
        let step = Request::Step {
            delta: PerAxis::new().with(Axis::X, 1),
            speed_hz: PerAxis::new(),
        };
        assert!(q.admit(step, now, BUSY, &mut events).is_some());
        assert!(q.is_empty() && events.is_empty());
    }

    fn step_x(n: i64) -> Request {
        Request::Step {
            delta: PerAxis::new().with(Axis::X, n),
            speed_hz: PerAxis::new().with(Axis::X, n as f64),
        }
    }

    /// Ten presses while a poll is answered: one waiting step of
    /// `step_queue` presses, the rest refused, whatever waits beside it.
    #[test]
    fn presses_between_moves_merge_into_one_bounded_step() {
        let mut q = RequestQueue::new(2);
        let mut events = VecDeque::new();
        let now = Instant::now();
        q.admit(Request::Initialise, now, Running::Idle, &mut events);
        for _ in 0..10 {
            assert_eq!(q.admit(step_x(1), now, Running::Idle, &mut events), None);
        }
        let refused: Vec<_> = events.drain(..).collect();
        assert_eq!(refused.len(), 8, "{refused:?}");
        assert!(refused.iter().all(|e| matches!(
            e,
            Event::Refused {
                reason: Refusal::StepQueueFull,
                ..
            }
        )));
        assert_eq!(
            q.pop(now, &mut events).map(|q| q.request),
            Some(Request::Initialise)
        );
        let step = q.pop(now, &mut events).expect("the merged step");
        assert_eq!(step.presses, 2);
        assert_eq!(
            step.request,
            Request::Step {
                delta: PerAxis::new().with(Axis::X, 2),
                speed_hz: PerAxis::new().with(Axis::X, 1.0),
            }
        );
        assert!(q.pop(now, &mut events).is_none());
        // Once it has left the queue, presses wait again.
        q.admit(step_x(3), now, Running::Idle, &mut events);
        assert!(events.is_empty());
        assert_eq!(q.pop(now, &mut events).map(|q| q.presses), Some(1));
    }

    #[test]
    fn the_default_queue_keeps_one_press() {
        let mut q = RequestQueue::default();
        let mut events = VecDeque::new();
        let now = Instant::now();
        q.admit(step_x(1), now, Running::Idle, &mut events);
        q.admit(step_x(1), now, Running::Idle, &mut events);
        assert_eq!(events.len(), 1);
        assert_eq!(RequestQueue::new(0), RequestQueue::default());
    }

    #[test]
    fn a_jog_waits_for_a_braking_jog_and_a_newer_one_replaces_it() {
        let mut q = RequestQueue::default();
        let mut events = VecDeque::new();
        let now = Instant::now();
        let braking = Running::Busy {
            activity: Activity::Stopping,
            motion: true,
            braking_jog: true,
        };
        q.admit(jog(1), now, braking, &mut events);
        q.admit(jog(2), now, braking, &mut events);
        assert!(matches!(
            events.pop_front(),
            Some(Event::JogEnded {
                id: JogId(1),
                end: JogEnd::Refused(_)
            })
        ));
        let next = q.pop(now, &mut events).expect("jog 2 waits");
        assert!(matches!(next.request, Request::Jog { id: JogId(2), .. }));
    }

    #[test]
    fn an_expired_lease_ends_the_waiting_jog() {
        let mut q = RequestQueue::default();
        let mut events = VecDeque::new();
        let now = Instant::now();
        q.admit(jog(7), now, Running::Idle, &mut events);
        q.admit(Request::Initialise, now, Running::Idle, &mut events);
        q.renew(JogId(7), Duration::from_millis(300), now);
        let later = now + Duration::from_millis(200);
        assert!(matches!(
            q.pop(later, &mut events).map(|q| q.request),
            Some(Request::Jog { .. })
        ));
        q.admit(jog(8), now, Running::Idle, &mut events);
        let next = q.pop(later, &mut events).expect("initialise");
        assert_eq!(next.request, Request::Initialise);
        assert!(q.pop(later, &mut events).is_none());
        assert_eq!(
            Vec::from(events),
            vec![Event::JogEnded {
                id: JogId(8),
                end: JogEnd::DeadMan
            }]
        );
    }

    #[test]
    fn release_and_refuse_all_end_waiting_jogs() {
        let mut q = RequestQueue::default();
        let mut events = VecDeque::new();
        let now = Instant::now();
        q.admit(jog(1), now, Running::Idle, &mut events);
        q.admit(jog(2), now, Running::Idle, &mut events);
        assert!(q.release(JogId(1), &mut events));
        assert!(!q.release(JogId(1), &mut events));
        q.refuse_all(|| Refusal::NotConnected, JogEnd::LinkLost, &mut events);
        assert_eq!(events.len(), 3);
        assert!(q.is_empty());
        for _ in 0..MAX_QUEUED {
            q.admit(Request::Initialise, now, Running::Idle, &mut events);
        }
        events.clear();
        q.admit(Request::Initialise, now, Running::Idle, &mut events);
        assert!(matches!(events.pop_front(), Some(Event::Refused { .. })));
    }
}
