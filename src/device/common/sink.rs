//! Where a driver's events go, and the refusal every driver sends the same
//! way: a jog that is refused also ends (`JogEnded { Refused }`), so a keypad
//! tracking its id learns that it never ran (`docs/device.md`).

use std::collections::VecDeque;

use crate::device::api::Refusal;
use crate::device::api::{CheckoutEnd, Event, JogEnd, PerAxis, ProbeEnd, Request};
use crate::device::describe::describe;

/// Takes the events a driver produces, in order.
pub trait Sink {
    fn emit(&mut self, event: Event);

    fn notice(&mut self, text: impl Into<String>)
    where
        Self: Sized,
    {
        self.emit(Event::Notice(text.into()));
    }
}

impl Sink for VecDeque<Event> {
    fn emit(&mut self, event: Event) {
        self.push_back(event);
    }
}

/// `request` was not carried out: why, and for a jog its end.
pub fn refuse(sink: &mut impl Sink, request: &Request, reason: Refusal) {
    if let Some(id) = request.jog_id() {
        sink.emit(Event::JogEnded {
            id,
            end: JogEnd::Refused(reason.clone()),
        });
    }
    if let Some(id) = request.checkout_id() {
        sink.emit(Event::Checkout {
            id,
            end: CheckoutEnd::Refused(reason.clone()),
        });
    }
    if let Some(id) = request.probe_id() {
        sink.emit(Event::ProbeEnded {
            id,
            end: ProbeEnd::Refused(reason.clone()),
        });
    }
    sink.emit(Event::Refused {
        request: describe(request),
        reason,
    });
}

/// A coalesced step that will not run, named by its delta (`step X+10`).
pub fn refuse_step(sink: &mut impl Sink, delta: &PerAxis<i64>, reason: Refusal) {
    sink.emit(Event::Refused {
        request: format!("step {}", describe_delta(delta)),
        reason,
    });
}

/// `X+10 Y-5`.
pub fn describe_delta(delta: &PerAxis<i64>) -> String {
    delta
        .iter()
        .map(|(a, d)| format!("{a}{d:+}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::device::api::{Dir, JogId};
    use std::time::Duration;

    #[test]
    fn a_refused_jog_also_ends() {
        let mut events = VecDeque::new();
        let jog = Request::Jog {
            id: JogId(3),
            axes: vec![(Axis::X, Dir::Plus)],
            speed_hz: PerAxis::new(),
            lease: Duration::from_millis(100),
        };
        refuse(&mut events, &jog, Refusal::NotConnected);
        assert_eq!(
            events.pop_front(),
            Some(Event::JogEnded {
                id: JogId(3),
                end: JogEnd::Refused(Refusal::NotConnected)
            })
        );
        assert_eq!(
            events.pop_front(),
            Some(Event::Refused {
                request: "jog X+ (#3)".into(),
                reason: Refusal::NotConnected
            })
        );
        refuse(&mut events, &Request::Initialise, Refusal::NotConnected);
        assert_eq!(events.len(), 1);
    }

    #[test]
    fn coalesced_steps_are_named_by_their_delta() {
        let mut events = VecDeque::new();
        let delta = PerAxis::new().with(Axis::X, 10).with(Axis::Z, -5);
        refuse_step(&mut events, &delta, Refusal::StepQueueFull);
        assert_eq!(
            events.pop_front(),
            Some(Event::Refused {
                request: "step X+10 Z-5".into(),
                reason: Refusal::StepQueueFull
            })
        );
    }
}
