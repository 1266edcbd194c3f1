//! Go-tos one after the other, as the console's frame (`ui::frame`) and the
//! measure of a new tool at a tool change (`editor::update::measure`)
//! drive them: each leg is sent when the controller has reported the one
//! before moving and then idle. A leg that would end where the axes stand
//! is skipped when its turn comes, since it reports no motion to end it.
//! This file imports no other of `ui`'s.

use crate::axis::Axis;
use crate::device::api::{Activity, PerAxis, Request};

/// One go-to: where it ends (machine steps), and the request that goes.
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    pub target: PerAxis<i64>,
    pub request: Request,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Legs {
    legs: Vec<Leg>,
    /// The leg sent last (its index).
    current: usize,
    /// The controller has reported the leg's motion: its next idle state
    /// is the leg's end.
    moving: bool,
}

impl Legs {
    pub fn new(legs: Vec<Leg>) -> Legs {
        Legs {
            legs,
            current: 0,
            moving: false,
        }
    }

    /// The first leg from `from` on that moves from where the axes stand
    /// (`at` says where an axis stands, `None`: not reported): its index
    /// and request, now the current leg.
    pub fn send_from(
        &mut self,
        from: usize,
        at: impl Fn(Axis) -> Option<i64>,
    ) -> Option<(usize, Request)> {
        for (index, leg) in self.legs.iter().enumerate().skip(from) {
            if leg
                .target
                .iter()
                .all(|(axis, steps)| at(axis) == Some(steps))
            {
                continue;
            }
            self.current = index;
            self.moving = false;
            return Some((index, leg.request.clone()));
        }
        None
    }

    /// The activity the controller reported: `true` when it ends the
    /// current leg (idle again after it was seen moving).
    pub fn ended_by(&mut self, activity: Activity) -> bool {
        if activity != Activity::Idle {
            self.moving = true;
            return false;
        }
        std::mem::take(&mut self.moving)
    }

    /// The leg sent last.
    pub fn current(&self) -> usize {
        self.current
    }

    pub fn len(&self) -> usize {
        self.legs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.legs.is_empty()
    }

    /// The request of the leg sent last, as the device names a refusal of
    /// it.
    pub fn current_request(&self) -> Option<&Request> {
        self.legs.get(self.current).map(|l| &l.request)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::Frame;

    fn to_x(x: i64) -> Leg {
        let target = PerAxis::new().with(Axis::X, x);
        Leg {
            target,
            request: Request::MoveTo {
                target,
                frame: Frame::Machine,
                speed_hz: PerAxis::new().with(Axis::X, 1000.0),
            },
        }
    }

    #[test]
    fn a_leg_ends_when_the_machine_was_seen_moving_and_then_idle() {
        let mut legs = Legs::new(vec![to_x(0), to_x(100), to_x(200)]);
        // X stands at 0: the first leg is skipped.
        let (index, _) = legs.send_from(0, |_| Some(0)).expect("a leg");
        assert_eq!(index, 1);
        // Idle before any motion was seen ends nothing (a state report
        // from before the go-to took effect).
        assert!(!legs.ended_by(Activity::Idle));
        assert!(!legs.ended_by(Activity::Moving));
        assert!(legs.ended_by(Activity::Idle));
        assert!(!legs.ended_by(Activity::Idle));
        let (index, _) = legs.send_from(2, |_| Some(100)).expect("the last");
        assert_eq!(index, 2);
        assert!(legs.send_from(3, |_| Some(200)).is_none());
        // Not reported: the leg goes.
        assert!(legs.send_from(0, |_| None).is_some());
    }
}
