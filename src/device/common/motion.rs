//! What a move the driver planned itself is, in the terms every family
//! shares: a step (with the presses coalesced behind it), a go-to move, or a
//! continuous jog kept alive by leases. The family's operation owns the
//! commands and the phases; this owns the bookkeeping a client sees: the
//! jog's end (reported once), the lease, and the steps waiting.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event, JogEnd, JogId, PerAxis, Refusal};

use super::limits::shifted;
use super::op::Abandon;
use super::sink::{Sink, refuse_step};

/// Step presses that arrived while a step ran: delta and speeds each.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepQueue {
    pending: Vec<(PerAxis<i64>, PerAxis<f64>)>,
}

impl StepQueue {
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// Where the steps remembered so far end, starting at `from`.
    pub fn end_of(&self, from: &PerAxis<i64>) -> PerAxis<i64> {
        self.pending
            .iter()
            .fold(*from, |base, (delta, _)| shifted(&base, delta))
    }

    pub fn push(&mut self, delta: PerAxis<i64>, speeds: PerAxis<f64>) {
        self.pending.push((delta, speeds));
    }

    /// All remembered steps as one: their sum, at the speeds of the last.
    pub fn take_merged(&mut self) -> Option<(PerAxis<i64>, PerAxis<f64>)> {
        if self.pending.is_empty() {
            return None;
        }
        let mut total = PerAxis::new();
        let mut speeds = PerAxis::new();
        for (delta, s) in self.pending.drain(..) {
            total = shifted(&total, &delta);
            speeds = s;
        }
        Some((total, speeds))
    }

    /// Every remembered step is refused with `reason`.
    pub fn refuse_all(&mut self, sink: &mut impl Sink, reason: &Refusal) {
        for (delta, _) in self.pending.drain(..) {
            refuse_step(sink, &delta, reason.clone());
        }
    }
}

/// A continuous jog's identity, lease and end.
#[derive(Debug, Clone, PartialEq)]
pub struct JogLease {
    pub id: JogId,
    pub until: Instant,
    end: Option<JogEnd>,
    reported: bool,
}

impl JogLease {
    pub fn new(id: JogId, until: Instant) -> JogLease {
        JogLease {
            id,
            until,
            end: None,
            reported: false,
        }
    }

    pub fn expired(&self, now: Instant) -> bool {
        self.until <= now
    }
}

/// The kind of a planned move.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionKind {
    Step(StepQueue),
    MoveTo,
    Jog(JogLease),
}

/// What a step press while a move runs needs to know about that move.
#[derive(Debug, Clone, Copy)]
pub struct Coalescing<'a> {
    /// The move may still take steps: it is a step that has not been stopped
    /// or failed, and is running or has steps waiting.
    pub open: bool,
    pub bound: usize,
    /// Where the axes are (the last measured position).
    pub position: &'a PerAxis<i64>,
    /// The change the running step will still make, if it runs.
    pub in_flight: Option<&'a PerAxis<i64>>,
    /// What the client is told when the move is busy otherwise.
    pub activity: Activity,
}

impl MotionKind {
    pub fn step() -> MotionKind {
        MotionKind::Step(StepQueue::default())
    }

    pub fn jog(id: JogId, until: Instant) -> MotionKind {
        MotionKind::Jog(JogLease::new(id, until))
    }

    pub fn jog_id(&self) -> Option<JogId> {
        match self {
            MotionKind::Jog(l) => Some(l.id),
            _ => None,
        }
    }

    /// When the jog's lease runs out.
    pub fn lease_until(&self) -> Option<Instant> {
        match self {
            MotionKind::Jog(l) => Some(l.until),
            _ => None,
        }
    }

    /// A renewal for jog `id`; false when this is not that jog.
    pub fn renew(&mut self, id: JogId, lease: Duration, now: Instant) -> bool {
        match self {
            MotionKind::Jog(l) if l.id == id => {
                l.until = now + lease;
                true
            }
            _ => false,
        }
    }

    /// How the jog ends, once that is known.
    pub fn jog_end(&self) -> Option<&JogEnd> {
        match self {
            MotionKind::Jog(l) => l.end.as_ref(),
            _ => None,
        }
    }

    /// Record how the jog ends; an end already known stays unless `overwrite`.
    pub fn set_jog_end(&mut self, value: JogEnd, overwrite: bool) {
        if let MotionKind::Jog(l) = self
            && (overwrite || l.end.is_none())
        {
            l.end = Some(value);
        }
    }

    /// Tell the clients the jog has ended (once; `Stopped` if no end was set).
    pub fn report_jog(&mut self, sink: &mut impl Sink) {
        if let MotionKind::Jog(l) = self
            && !l.reported
        {
            l.reported = true;
            let end = l.end.clone().unwrap_or(JogEnd::Stopped);
            sink.emit(Event::JogEnded { id: l.id, end });
        }
    }

    /// Steps waiting behind the move.
    pub fn pending_steps(&self) -> usize {
        match self {
            MotionKind::Step(q) => q.len(),
            _ => 0,
        }
    }

    /// The waiting steps will not run.
    pub fn drop_pending(&mut self, sink: &mut impl Sink, reason: Refusal) {
        if let MotionKind::Step(q) = self {
            q.refuse_all(sink, &reason);
        }
    }

    /// The waiting steps as one move, for after the running one.
    pub fn take_pending(&mut self) -> Option<(PerAxis<i64>, PerAxis<f64>)> {
        match self {
            MotionKind::Step(q) => q.take_merged(),
            _ => None,
        }
    }

    /// The operator stopped everything: the jog ends `Stopped`, the steps
    /// waiting behind the move will not run.
    pub fn stopped(&mut self, sink: &mut impl Sink) {
        self.drop_pending(
            sink,
            Refusal::Invalid {
                reason: "cancelled by stop".into(),
            },
        );
        self.set_jog_end(JogEnd::Stopped, false);
    }

    /// The move ends without another byte (`cause`; `device` names what a
    /// reset reset): its end told, the steps waiting behind it refused.
    pub fn abandoned(&mut self, sink: &mut impl Sink, cause: &Abandon, device: &str) {
        match cause {
            Abandon::LinkLost(_) => {
                self.set_jog_end(JogEnd::LinkLost, true);
                self.drop_pending(sink, Refusal::NotConnected);
            }
            Abandon::Reset => {
                self.set_jog_end(JogEnd::Stopped, false);
                let reason = format!("cancelled: {}", cause.reason(device));
                self.drop_pending(sink, Refusal::Invalid { reason });
            }
        }
        self.report_jog(sink);
    }

    /// Whether the jog's lease has run out at `now` with no stop under
    /// way: the dead-man ends it, and the family stops the move.
    pub fn lease_ran_out(&mut self, now: Instant, stopping: bool) -> bool {
        let ran_out = !stopping && self.lease_until().is_some_and(|t| t <= now);
        if ran_out {
            self.set_jog_end(JogEnd::DeadMan, false);
        }
        ran_out
    }

    /// A step pressed while this move runs: remembered (up to the bound)
    /// after `check` has found it within the soft limits from where the
    /// steps before it end.
    pub fn coalesce(
        &mut self,
        at: Coalescing<'_>,
        delta: PerAxis<i64>,
        speeds: PerAxis<f64>,
        check: impl FnOnce(&PerAxis<i64>) -> Result<(), Refusal>,
    ) -> Result<(), Refusal> {
        let MotionKind::Step(queue) = self else {
            return Err(Refusal::Busy {
                activity: at.activity,
            });
        };
        if !at.open {
            return Err(Refusal::Busy {
                activity: at.activity,
            });
        }
        if queue.len() >= at.bound {
            return Err(Refusal::StepQueueFull);
        }
        let from = match at.in_flight {
            Some(d) => shifted(at.position, d),
            None => *at.position,
        };
        check(&queue.end_of(&from))?;
        queue.push(delta, speeds);
        Ok(())
    }

    /// What the move means for `MachineState::activity`: `moving` while its
    /// command runs or is about to, `stopping` once a stop is under way.
    pub fn activity(&self, moving: bool, stopping: bool) -> Activity {
        if stopping && moving {
            return Activity::Stopping;
        }
        match (self, moving) {
            (MotionKind::Step(q), false) if !q.is_empty() => Activity::Stepping,
            (_, false) => Activity::Idle,
            (MotionKind::Step(_), true) => Activity::Stepping,
            (MotionKind::MoveTo, true) => Activity::Moving,
            (MotionKind::Jog(_), true) => Activity::Jogging,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use std::collections::VecDeque;

    fn x(v: i64) -> PerAxis<i64> {
        PerAxis::new().with(Axis::X, v)
    }

    #[test]
    fn steps_are_coalesced_up_to_the_bound_from_where_the_others_end() {
        let mut kind = MotionKind::step();
        let position = x(100);
        let running = x(40);
        let at = Coalescing {
            open: true,
            bound: 2,
            position: &position,
            in_flight: Some(&running),
            activity: Activity::Stepping,
        };
        let mut bases = Vec::new();
        for _ in 0..2 {
            kind.coalesce(at, x(10), PerAxis::new(), |base| {
                bases.push(base.get(Axis::X));
                Ok(())
            })
            .expect("taken");
        }
        assert_eq!(bases, [Some(140), Some(150)]);
        assert_eq!(
            kind.coalesce(at, x(10), PerAxis::new(), |_| Ok(())),
            Err(Refusal::StepQueueFull)
        );
        assert_eq!(kind.pending_steps(), 2);
        let (total, _) = kind.take_pending().expect("merged");
        assert_eq!(total, x(20));
        assert_eq!(kind.pending_steps(), 0);
    }

    #[test]
    fn a_closed_or_other_move_takes_no_steps() {
        let position = x(0);
        let at = Coalescing {
            open: false,
            bound: 2,
            position: &position,
            in_flight: None,
            activity: Activity::Stepping,
        };
        let mut step = MotionKind::step();
        assert_eq!(
            step.coalesce(at, x(1), PerAxis::new(), |_| Ok(())),
            Err(Refusal::Busy {
                activity: Activity::Stepping
            })
        );
        let mut to = MotionKind::MoveTo;
        let open = Coalescing { open: true, ..at };
        assert!(to.coalesce(open, x(1), PerAxis::new(), |_| Ok(())).is_err());
    }

    #[test]
    fn a_jog_ends_once_with_the_first_end_unless_overwritten() {
        let now = Instant::now();
        let mut jog = MotionKind::jog(JogId(4), now);
        assert!(jog.renew(JogId(4), Duration::from_millis(50), now));
        assert!(!jog.renew(JogId(5), Duration::from_millis(50), now));
        assert_eq!(jog.lease_until(), Some(now + Duration::from_millis(50)));
        jog.set_jog_end(JogEnd::Released, false);
        jog.set_jog_end(JogEnd::DeadMan, false);
        let mut events = VecDeque::new();
        jog.report_jog(&mut events);
        jog.report_jog(&mut events);
        assert_eq!(
            Vec::from(events),
            vec![Event::JogEnded {
                id: JogId(4),
                end: JogEnd::Released
            }]
        );
    }

    #[test]
    fn waiting_steps_are_refused_by_name() {
        let mut kind = MotionKind::step();
        if let MotionKind::Step(q) = &mut kind {
            q.push(x(5), PerAxis::new());
        }
        let mut events = VecDeque::new();
        kind.drop_pending(&mut events, Refusal::NotConnected);
        assert!(matches!(
            events.pop_front(),
            Some(Event::Refused { request, .. }) if request == "step X+5"
        ));
    }

    #[test]
    fn activity_follows_the_kind_and_phase() {
        assert_eq!(MotionKind::MoveTo.activity(true, false), Activity::Moving);
        assert_eq!(MotionKind::MoveTo.activity(true, true), Activity::Stopping);
        assert_eq!(MotionKind::MoveTo.activity(false, false), Activity::Idle);
        let jog = MotionKind::jog(JogId(1), Instant::now());
        assert_eq!(jog.activity(true, false), Activity::Jogging);
    }
}
