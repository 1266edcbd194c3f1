//! The admission glue every family's driver shares (`docs/device.md`,
//! "Request conventions"): what runs when a request arrives, a step handed
//! back by the queue coalesced into the running move, and the start of a
//! typed raw line. Each driver keeps what only it knows (what makes it busy,
//! which lines bypass the queue, how a parsed line is sent).

use std::time::Instant;

use crate::device::api::{Activity, JogId, PerAxis, Refusal, Request};

use super::queue::{RequestQueue, Running};
use super::sink::{Sink, refuse};

/// What admission needs from a family's running move.
pub trait RunningMove {
    /// The driver state the move checks a coalesced step against.
    type Cx: Sink;

    /// The jog this move is, if it is one.
    fn jog_id(&self) -> Option<JogId>;

    /// The move is being stopped.
    fn is_stopping(&self) -> bool;

    /// A step pressed while this move runs.
    fn coalesce(
        &mut self,
        cx: &Self::Cx,
        delta: PerAxis<i64>,
        speeds: PerAxis<f64>,
    ) -> Result<(), Refusal>;
}

impl Running {
    /// `busy`: the activity that refuses requests, if any; `motion`: the
    /// move running, if the driver's operation is one.
    pub fn new<M: RunningMove>(busy: Option<Activity>, motion: Option<&M>) -> Running {
        match busy {
            None => Running::Idle,
            Some(activity) => Running::Busy {
                activity,
                motion: motion.is_some(),
                // A jog that is stopping lets the next jog wait for it.
                braking_jog: motion.is_some_and(|m| m.jog_id().is_some() && m.is_stopping()),
            },
        }
    }
}

/// Queue or refuse `request` given what runs; a step the queue hands back is
/// coalesced into the running move, or refused if it does not fit.
pub fn admit<M: RunningMove>(
    queue: &mut RequestQueue,
    request: Request,
    now: Instant,
    busy: Option<Activity>,
    mut motion: Option<&mut M>,
    cx: &mut M::Cx,
) {
    let running = Running::new(busy, motion.as_deref());
    if let Some((delta, speed_hz)) = queue.admit(request, now, running, cx)
        && let Some(m) = motion.as_mut()
        && let Err(reason) = m.coalesce(cx, delta, speed_hz)
    {
        refuse(cx, &Request::Step { delta, speed_hz }, reason);
    }
}

/// The start of a typed raw line: refused while not connected, refused if
/// `parse` rejects it; otherwise the request and what `parse` made of it.
pub fn parse_raw_request<T>(
    line: String,
    link_up: bool,
    sink: &mut impl Sink,
    parse: impl FnOnce(&str) -> Result<T, Refusal>,
) -> Option<(Request, T)> {
    let parsed = if link_up {
        parse(&line)
    } else {
        Err(Refusal::NotConnected)
    };
    let request = Request::Raw { line };
    match parsed {
        Ok(p) => Some((request, p)),
        Err(reason) => {
            refuse(sink, &request, reason);
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::*;
    use crate::device::api::Event;

    /// A move that takes steps while it is not stopping.
    struct Move {
        jog: Option<JogId>,
        stopping: bool,
        taken: Vec<PerAxis<i64>>,
    }

    impl RunningMove for Move {
        type Cx = VecDeque<Event>;

        fn jog_id(&self) -> Option<JogId> {
            self.jog
        }

        fn is_stopping(&self) -> bool {
            self.stopping
        }

        fn coalesce(
            &mut self,
            _cx: &VecDeque<Event>,
            delta: PerAxis<i64>,
            _speeds: PerAxis<f64>,
        ) -> Result<(), Refusal> {
            if self.stopping {
                return Err(Refusal::Invalid {
                    reason: "stopping".into(),
                });
            }
            self.taken.push(delta);
            Ok(())
        }
    }

    fn step() -> Request {
        Request::Step {
            delta: PerAxis::default(),
            speed_hz: PerAxis::default(),
        }
    }

    #[test]
    fn running_tells_a_braking_jog_from_a_stopping_step() {
        let busy = Some(Activity::Stopping);
        let jog = Move {
            jog: Some(JogId(1)),
            stopping: true,
            taken: Vec::new(),
        };
        let braking = |m: &Move| match Running::new(busy, Some(m)) {
            Running::Busy { braking_jog, .. } => Some(braking_jog),
            Running::Idle => None,
        };
        assert_eq!(braking(&jog), Some(true));
        let stepping = Move { jog: None, ..jog };
        assert_eq!(braking(&stepping), Some(false));
        assert_eq!(Running::new::<Move>(None, Some(&stepping)), Running::Idle);
        assert_eq!(
            Running::new::<Move>(busy, None),
            Running::Busy {
                activity: Activity::Stopping,
                motion: false,
                braking_jog: false
            }
        );
    }

    #[test]
    fn a_step_goes_to_the_running_move_or_is_refused_by_it() {
        let mut queue = RequestQueue::default();
        let mut events = VecDeque::new();
        let mut m = Move {
            jog: None,
            stopping: false,
            taken: Vec::new(),
        };
        let now = Instant::now();
        let busy = Some(Activity::Stepping);
        admit(&mut queue, step(), now, busy, Some(&mut m), &mut events);
        assert_eq!(m.taken.len(), 1);
        assert!(events.is_empty());
        m.stopping = true;
        admit(&mut queue, step(), now, busy, Some(&mut m), &mut events);
        assert_eq!(m.taken.len(), 1);
        assert!(matches!(events.pop_front(), Some(Event::Refused { .. })));
        assert!(queue.is_empty());
    }

    #[test]
    fn a_raw_line_is_refused_offline_and_when_it_does_not_parse() {
        let mut events = VecDeque::new();
        let parse = |l: &str| {
            l.parse::<u8>().map_err(|e| Refusal::Invalid {
                reason: e.to_string(),
            })
        };
        let offline = parse_raw_request("7".into(), false, &mut events, parse);
        assert_eq!(offline, None);
        assert!(matches!(
            events.pop_front(),
            Some(Event::Refused {
                reason: Refusal::NotConnected,
                ..
            })
        ));
        assert_eq!(
            parse_raw_request("x".into(), true, &mut events, parse),
            None
        );
        assert!(matches!(
            events.pop_front(),
            Some(Event::Refused {
                reason: Refusal::Invalid { .. },
                ..
            })
        ));
        let ok = parse_raw_request("7".into(), true, &mut events, parse);
        assert_eq!(ok, Some((Request::Raw { line: "7".into() }, 7)));
        assert!(events.is_empty());
    }
}
