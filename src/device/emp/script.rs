//! A sequence of frames an operation sends, one at a time, each after the
//! previous was answered, with barriers that wait for the long actions
//! (`26`, TP positioning) started so far to finish (EMP decision 1: `55` at
//! once, `22` on its own when done).

use std::collections::VecDeque;

use crate::proto::emp::Request;

/// The frame as typed, for replies and faults.
pub fn frame_text(request: &Request) -> String {
    request.to_frame().to_string()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    Send(Request),
    /// Wait until every long action started so far has ended.
    Barrier,
}

/// What a script or operation wants next: a frame to send.
pub type Next = crate::device::common::op::Next<Request>;

/// How a request the script sent ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The first answer was `22`.
    Answered,
    /// `55`: running; a completion follows.
    Started,
    /// The long action finished (`22` after `55`).
    Completed,
    /// `EE` as first answer or after `55`.
    Rejected,
    /// Ended by a later request to its drive (a stop); no completion comes.
    Ended,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Script {
    steps: VecDeque<Step>,
    awaiting: Option<Request>,
    running: Vec<Request>,
    failed: bool,
}

impl Script {
    pub fn new(steps: impl IntoIterator<Item = Step>) -> Script {
        Script {
            steps: steps.into_iter().collect(),
            ..Script::default()
        }
    }

    pub fn sends(requests: impl IntoIterator<Item = Request>) -> Script {
        Script::new(requests.into_iter().map(Step::Send))
    }

    pub fn next(&mut self) -> Next {
        if self.awaiting.is_some() {
            return Next::Wait;
        }
        if self.failed {
            self.steps.clear();
        }
        loop {
            match self.steps.front() {
                Some(Step::Barrier) if !self.running.is_empty() => return Next::Wait,
                Some(Step::Barrier) => {
                    self.steps.pop_front();
                }
                Some(Step::Send(r)) => {
                    let r = *r;
                    self.steps.pop_front();
                    self.awaiting = Some(r);
                    return Next::Send(r);
                }
                None if self.running.is_empty() => return Next::Done,
                None => return Next::Wait,
            }
        }
    }

    /// Nothing more to send or to wait for.
    pub fn idle(&self) -> bool {
        self.awaiting.is_none() && self.running.is_empty() && (self.failed || self.steps.is_empty())
    }

    /// Every frame has been sent and answered; at most long actions are
    /// still running (and barriers wait for them).
    pub fn settled(&self) -> bool {
        self.awaiting.is_none()
            && !self.failed
            && self.steps.iter().all(|s| matches!(s, Step::Barrier))
    }

    /// What is left to do becomes `steps` (a running jog changing its
    /// speed): barriers not yet passed are dropped with it, long actions
    /// running are still awaited until they end or are ended.
    pub fn replace_rest(&mut self, steps: impl IntoIterator<Item = Step>) {
        self.steps = steps.into_iter().collect();
    }

    /// Whether `request` is one this script waits for.
    pub fn owns(&self, request: &Request) -> bool {
        self.awaiting.as_ref() == Some(request) || self.running.contains(request)
    }

    /// Take an outcome of one of the script's requests. A rejection ends the
    /// script: nothing more is sent, long actions still running are awaited.
    pub fn outcome(&mut self, request: &Request, outcome: Outcome) {
        if self.awaiting.as_ref() == Some(request) {
            self.awaiting = None;
        } else if let Some(i) = self.running.iter().position(|r| r == request) {
            self.running.remove(i);
        }
        match outcome {
            Outcome::Started => self.running.push(*request),
            Outcome::Rejected => self.failed = true,
            Outcome::Answered | Outcome::Completed | Outcome::Ended => {}
        }
    }

    /// Send nothing more (a stop): what is awaited is still awaited.
    pub fn cancel(&mut self) {
        self.steps.clear();
    }

    /// The request answered last was the last one sent and it failed.
    pub fn failed(&self) -> bool {
        self.failed
    }

    pub fn running(&self) -> &[Request] {
        &self.running
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::emp::{Command, DriveAddress, Position, Speed};

    fn home() -> Request {
        let s = Speed::new(4).expect("speed");
        Request::new(DriveAddress::SINGLE, Command::Home { fast: s, slow: s })
    }

    #[test]
    fn one_at_a_time_and_barriers_wait_for_long_actions() {
        let pos = Request::new(DriveAddress::SINGLE, Command::ReadPosition);
        let mut s = Script::new([Step::Send(home()), Step::Barrier, Step::Send(pos)]);
        assert_eq!(s.next(), Next::Send(home()));
        assert_eq!(s.next(), Next::Wait);
        s.outcome(&home(), Outcome::Started);
        assert_eq!(s.next(), Next::Wait);
        assert!(s.owns(&home()));
        s.outcome(&home(), Outcome::Completed);
        assert_eq!(s.next(), Next::Send(pos));
        s.outcome(&pos, Outcome::Answered);
        assert_eq!(s.next(), Next::Done);
    }

    #[test]
    fn a_rejection_sends_nothing_more() {
        let a = Request::new(DriveAddress::SINGLE, Command::ReadPosition);
        let b = Request::new(DriveAddress::SINGLE, Command::SetPosition(Position::ZERO));
        let mut s = Script::sends([a, b]);
        assert_eq!(s.next(), Next::Send(a));
        s.outcome(&a, Outcome::Rejected);
        assert!(s.failed());
        assert_eq!(s.next(), Next::Done);
    }

    #[test]
    fn a_running_action_can_be_followed_by_new_frames_before_its_barrier() {
        let pos = Request::new(DriveAddress::SINGLE, Command::ReadPosition);
        let mut s = Script::new([Step::Send(home()), Step::Barrier]);
        assert!(!s.settled());
        assert_eq!(s.next(), Next::Send(home()));
        assert!(!s.settled());
        s.outcome(&home(), Outcome::Started);
        assert!(s.settled());
        s.replace_rest([Step::Send(pos), Step::Barrier]);
        assert_eq!(s.next(), Next::Send(pos));
        s.outcome(&pos, Outcome::Answered);
        assert_eq!(s.next(), Next::Wait);
        s.outcome(&home(), Outcome::Ended);
        assert_eq!(s.next(), Next::Done);
    }

    #[test]
    fn a_stop_ends_what_runs() {
        let mut s = Script::sends([home()]);
        assert_eq!(s.next(), Next::Send(home()));
        s.outcome(&home(), Outcome::Started);
        s.cancel();
        assert_eq!(s.next(), Next::Wait);
        s.outcome(&home(), Outcome::Ended);
        assert_eq!(s.next(), Next::Done);
    }
}
