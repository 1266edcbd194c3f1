//! Matching replies to requests on one link (`docs/decisions.md` EMP
//! decision 1).
//!
//! Every request is answered by CMD+1 from the same DS. Long actions (`26`
//! homing, `2A 01` positioning, and `2A 00` in TPWM mode) answer `55` at once
//! and later send the same reply code with `22` on their own, so replies
//! arrive that nothing was just sent for. The correlator keeps the outstanding
//! requests of all drives in send order and matches each incoming frame to the
//! oldest request with the same reply code and DS. Sans-IO: time comes in as
//! `Instant` arguments.

use std::fmt;
use std::time::{Duration, Instant};

use super::decoder::Incoming;
use super::error::ReplyError;
use super::reply::{Info, Reply};
use super::request::{Command, Request};

/// Why an incoming message was matched to no request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnexpectedReason {
    /// An even CMD: a request, not a reply (an echo or a second host).
    NotAReply,
    /// No request with this reply code is outstanding.
    NothingOutstanding,
    /// Requests with this reply code are outstanding, but for other drives.
    OtherDrive,
    /// A second `55` for an action already known to be running.
    AlreadyBusy,
}

impl fmt::Display for UnexpectedReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            UnexpectedReason::NotAReply => "a request code, not a reply",
            UnexpectedReason::NothingOutstanding => "no such request is outstanding",
            UnexpectedReason::OtherDrive => "the request is outstanding for another drive",
            UnexpectedReason::AlreadyBusy => "the action was already reported busy",
        })
    }
}

/// What an incoming message, a sent request or the passing of time meant.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// The first reply, INFO `22` (or the identity text): done.
    Answered { request: Request, reply: Reply },
    /// INFO `55`: a long action is running; `Completed`, `Failed` or `Ended`
    /// follows.
    Started { request: Request, reply: Reply },
    /// INFO `22` after `55`: the long action has finished.
    Completed { request: Request, reply: Reply },
    /// The first reply, INFO `EE`: not taken; `0A` tells why.
    Rejected { request: Request, reply: Reply },
    /// INFO `EE` after `55`: the long action could not finish
    /// (docs/protocols.md, EMP); `0A` tells why.
    Failed { request: Request, reply: Reply },
    /// A long action was ended by a later request to the same drive that
    /// stops or re-moves the axis; no completion will come for it.
    Ended { request: Request, by: Request },
    /// No first reply within the reply timeout.
    TimedOut { request: Request },
    /// The message was matched to `request` but is no valid answer to it.
    Malformed {
        request: Request,
        incoming: Incoming,
        error: ReplyError,
    },
    /// Nobody asked for this message.
    Unexpected {
        incoming: Incoming,
        reason: UnexpectedReason,
    },
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::Answered { request, reply } => write!(f, "{request} -> {reply}"),
            Event::Started { request, reply } => write!(f, "{request} -> started, {reply}"),
            Event::Completed { request, reply } => write!(f, "{request} -> completed, {reply}"),
            Event::Rejected { request, reply } => write!(f, "{request} -> {reply}"),
            Event::Failed { request, reply } => write!(f, "{request} -> failed, {reply}"),
            Event::Ended { request, by } => write!(f, "{request} -> ended by {}", by.command),
            Event::TimedOut { request } => write!(f, "{request} -> no reply"),
            Event::Malformed {
                request,
                incoming,
                error,
            } => write!(f, "{request} -> bad reply {incoming}: {error}"),
            Event::Unexpected { incoming, reason } => {
                write!(f, "unexpected {incoming}: {reason}")
            }
        }
    }
}

#[derive(Debug, Clone)]
struct Pending {
    request: Request,
    sent_at: Instant,
    /// `55` came; waiting for the completion, with no timeout.
    busy: bool,
    /// A later request ended this one before its first reply came: if that
    /// reply is `55`, no completion will follow.
    ended_by: Option<Request>,
}

/// Outstanding requests of one link.
#[derive(Debug, Clone)]
pub struct Correlator {
    pending: Vec<Pending>,
    reply_timeout: Duration,
}

impl Correlator {
    /// `reply_timeout` bounds the wait for a first reply. A round trip takes
    /// about 10.8 ms at 38400 baud (14 ms for slow analogue readings, manual
    /// "Chronologischer Befehlsumfang"); requests queued behind others wait
    /// longer. Running long actions have no timeout here.
    pub fn new(reply_timeout: Duration) -> Correlator {
        Correlator {
            pending: Vec::new(),
            reply_timeout,
        }
    }

    /// Record a request that has just been written to the link. Returns the
    /// long actions it ends (docs/protocols.md, EMP).
    pub fn sent(&mut self, request: Request, now: Instant) -> Vec<Event> {
        let mut events = Vec::new();
        if request.command.ends_motion() {
            let mut kept = Vec::with_capacity(self.pending.len());
            for mut p in std::mem::take(&mut self.pending) {
                if p.request.ds != request.ds {
                    kept.push(p);
                } else if p.busy {
                    events.push(Event::Ended {
                        request: p.request,
                        by: request,
                    });
                } else {
                    p.ended_by.get_or_insert(request);
                    kept.push(p);
                }
            }
            self.pending = kept;
        }
        self.pending.push(Pending {
            request,
            sent_at: now,
            busy: false,
            ended_by: None,
        });
        events
    }

    /// `request` has left the writer at `now` (its last byte is on the
    /// line): its first reply is awaited from then, not from when it was
    /// handed over, which may be a frame or a busy moment earlier.
    pub fn transmitted(&mut self, request: &Request, now: Instant) {
        if let Some(p) = self
            .pending
            .iter_mut()
            .find(|p| p.request == *request && !p.busy)
        {
            p.sent_at = p.sent_at.max(now);
        }
    }

    /// Match one incoming message.
    pub fn received(&mut self, incoming: Incoming) -> Event {
        let index = match self.find(&incoming) {
            Ok(i) => i,
            Err(reason) => return Event::Unexpected { incoming, reason },
        };
        let Some(p) = self.pending.get_mut(index) else {
            return Event::Unexpected {
                incoming,
                reason: UnexpectedReason::NothingOutstanding,
            };
        };
        let request = p.request;
        let reply = match Reply::decode(&incoming, &request) {
            Ok(reply) => reply,
            Err(error) => {
                self.pending.remove(index);
                return Event::Malformed {
                    request,
                    incoming,
                    error,
                };
            }
        };
        let info = reply.info();
        if p.busy {
            return match info {
                Some(Info::Ready) => {
                    self.pending.remove(index);
                    Event::Completed { request, reply }
                }
                Some(Info::Rejected) => {
                    self.pending.remove(index);
                    Event::Failed { request, reply }
                }
                _ => Event::Unexpected {
                    incoming,
                    reason: UnexpectedReason::AlreadyBusy,
                },
            };
        }
        match (info, p.ended_by) {
            (Some(Info::Busy), None) => {
                p.busy = true;
                Event::Started { request, reply }
            }
            (Some(Info::Busy), Some(by)) => {
                self.pending.remove(index);
                Event::Ended { request, by }
            }
            (Some(Info::Rejected), _) => {
                self.pending.remove(index);
                Event::Rejected { request, reply }
            }
            _ => {
                self.pending.remove(index);
                Event::Answered { request, reply }
            }
        }
    }

    fn find(&self, incoming: &Incoming) -> Result<usize, UnexpectedReason> {
        match incoming {
            // The text carries no DS: it answers the oldest `00`.
            Incoming::Identity(_) => self
                .pending
                .iter()
                .position(|p| matches!(p.request.command, Command::Identify(_)))
                .ok_or(UnexpectedReason::NothingOutstanding),
            Incoming::Frame(f) if !f.is_reply() => Err(UnexpectedReason::NotAReply),
            Incoming::Frame(f) => {
                let same_code = |p: &&Pending| p.request.reply_code() == f.cmd;
                self.pending
                    .iter()
                    .position(|p| same_code(&p) && p.request.ds.byte() == f.ds)
                    .ok_or_else(|| {
                        if self.pending.iter().any(|p| same_code(&p)) {
                            UnexpectedReason::OtherDrive
                        } else {
                            UnexpectedReason::NothingOutstanding
                        }
                    })
            }
        }
    }

    /// Requests whose first reply is overdue at `now`; they are dropped.
    pub fn poll_timeouts(&mut self, now: Instant) -> Vec<Event> {
        let timeout = self.reply_timeout;
        let mut events = Vec::new();
        self.pending.retain(|p| {
            let overdue = !p.busy && now.saturating_duration_since(p.sent_at) >= timeout;
            if overdue {
                events.push(Event::TimedOut { request: p.request });
            }
            !overdue
        });
        events
    }

    /// When the next first reply becomes overdue.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.pending
            .iter()
            .filter(|p| !p.busy)
            .map(|p| p.sent_at + self.reply_timeout)
            .min()
    }

    /// Requests waiting for a reply or a completion, oldest first.
    pub fn outstanding(&self) -> impl Iterator<Item = &Request> {
        self.pending.iter().map(|p| &p.request)
    }

    /// Long actions reported running (`55`) and not yet finished.
    pub fn running(&self) -> impl Iterator<Item = &Request> {
        self.pending.iter().filter(|p| p.busy).map(|p| &p.request)
    }

    pub fn is_idle(&self) -> bool {
        self.pending.is_empty()
    }

    /// Forget everything (the link was lost or reopened); returns what was
    /// outstanding.
    pub fn clear(&mut self) -> Vec<Request> {
        self.pending.drain(..).map(|p| p.request).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::*;
    use super::*;

    const TIMEOUT: Duration = Duration::from_millis(100);

    fn drive(module: u8) -> DriveAddress {
        DriveAddress::module(module).unwrap()
    }

    fn frame(s: &str) -> Incoming {
        Incoming::Frame(s.parse().unwrap())
    }

    fn home(ds: DriveAddress) -> Request {
        Request::new(
            ds,
            Command::Home {
                fast: Speed::new(0x40).unwrap(),
                slow: Speed::new(4).unwrap(),
            },
        )
    }

    fn move_to(ds: DriveAddress, target: i64) -> Request {
        Request::new(
            ds,
            Command::MoveTo {
                vmax: Speed::new(1).unwrap(),
                target: Position::new(target).unwrap(),
            },
        )
    }

    fn read_position(ds: DriveAddress) -> Request {
        Request::new(ds, Command::ReadPosition)
    }

    fn position_of(event: &Event) -> Option<i32> {
        match event {
            Event::Answered { reply, .. }
            | Event::Started { reply, .. }
            | Event::Completed { reply, .. } => reply
                .body()
                .and_then(|b| b.position())
                .map(Position::increments),
            _ => None,
        }
    }

    #[test]
    fn polls_of_several_drives_match_by_ds_in_any_order() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        for m in 1..=3 {
            assert!(c.sent(read_position(drive(m)), t).is_empty());
        }
        let e = c.received(frame("2D31002200000003"));
        assert!(matches!(e, Event::Answered { request, .. } if request.ds == drive(3)));
        assert_eq!(position_of(&e), Some(3));
        let e = c.received(frame("2D11002201FFFFFF"));
        assert_eq!(position_of(&e), Some(-1));
        let e = c.received(frame("2D21002200000002"));
        assert!(matches!(e, Event::Answered { request, .. } if request.ds == drive(2)));
        assert!(c.is_idle());
    }

    #[test]
    fn homing_answers_busy_then_completes_on_its_own() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let h = home(drive(1));
        c.sent(h, t);
        let e = c.received(frame("2711005500000000"));
        assert!(matches!(e, Event::Started { request, .. } if request == h));
        // Positions may be polled meanwhile (manual "2C": "jederzeit").
        c.sent(read_position(drive(1)), t);
        assert_eq!(
            position_of(&c.received(frame("2D11002200000100"))),
            Some(0x100)
        );
        assert_eq!(c.running().copied().collect::<Vec<_>>(), [h]);
        // A running action never times out; only first replies do.
        assert!(c.poll_timeouts(t + TIMEOUT * 50).is_empty());
        assert_eq!(c.next_deadline(), None);
        let e = c.received(frame("2711002200000000"));
        assert!(matches!(e, Event::Completed { request, .. } if request == h));
        assert_eq!(position_of(&e), Some(0));
        assert!(c.is_idle());
    }

    #[test]
    fn beispiel_4_waits_for_the_info_byte_22() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let tp = Request::new(
            DriveAddress::SINGLE,
            Command::Drive {
                velocity: Velocity::new(1),
                target: Position::new(100_000).unwrap(),
            },
        );
        c.sent(tp, t);
        assert!(matches!(
            c.received(frame("2B11005500000000")),
            Event::Started { .. }
        ));
        let e = c.received(frame("2B110022000186A0"));
        assert!(matches!(e, Event::Completed { .. }));
        assert_eq!(position_of(&e), Some(100_000));
    }

    #[test]
    fn a_completion_nobody_asked_for_is_unexpected() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let e = c.received(frame("2711002200000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::NothingOutstanding,
                ..
            }
        ));
        // Also when something else is outstanding on that drive.
        c.sent(read_position(drive(1)), t);
        let e = c.received(frame("2B11002200000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::NothingOutstanding,
                ..
            }
        ));
        assert_eq!(c.outstanding().count(), 1);
    }

    #[test]
    fn a_completion_from_the_wrong_drive_is_unexpected_and_changes_nothing() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let h = home(drive(1));
        c.sent(h, t);
        c.received(frame("2711005500000000"));
        let e = c.received(frame("2721002200000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::OtherDrive,
                ..
            }
        ));
        assert_eq!(c.running().count(), 1);
        assert!(matches!(
            c.received(frame("2711002200000000")),
            Event::Completed { .. }
        ));
    }

    #[test]
    fn unknown_reply_codes_and_requests_on_the_line_are_unexpected() {
        let mut c = Correlator::new(TIMEOUT);
        c.sent(read_position(drive(1)), Instant::now());
        let e = c.received(frame("1311002200000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::NothingOutstanding,
                ..
            }
        ));
        let e = c.received(frame("2C11000000000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::NotAReply,
                ..
            }
        ));
        assert_eq!(c.outstanding().count(), 1);
    }

    #[test]
    fn rejection_then_last_error() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let m = move_to(drive(1), 5);
        c.sent(m, t);
        let e = c.received(frame("2B1100EE00000000"));
        assert!(matches!(e, Event::Rejected { request, .. } if request == m));
        c.sent(Request::new(drive(1), Command::LastError), t);
        let e = c.received(frame("0B11002200000004"));
        let Event::Answered { reply, .. } = e else {
            panic!("{e:?}")
        };
        assert_eq!(
            reply.body(),
            Some(&ReplyBody::LastError(ErrorCode::WRONG_MODE))
        );
    }

    #[test]
    fn a_long_action_that_fails_ends_with_ee() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        c.sent(move_to(drive(1), 5), t);
        c.received(frame("2B11005500000000"));
        assert!(matches!(
            c.received(frame("2B1100EE00000000")),
            Event::Failed { .. }
        ));
        assert!(c.is_idle());
    }

    #[test]
    fn a_stop_ends_a_running_action_which_then_sends_no_completion() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let h = home(drive(1));
        let other = home(drive(2));
        c.sent(h, t);
        c.sent(other, t);
        c.received(frame("2711005500000000"));
        c.received(frame("2721005500000000"));
        let hold = Request::new(drive(1), Command::Hold);
        let events = c.sent(hold, t);
        assert_eq!(
            events,
            [Event::Ended {
                request: h,
                by: hold
            }]
        );
        assert!(matches!(
            c.received(frame("0911002200000000")),
            Event::Answered { .. }
        ));
        // The other drive's homing runs on.
        assert_eq!(c.running().copied().collect::<Vec<_>>(), [other]);
        // A late completion of the ended homing is nobody's.
        assert!(matches!(
            c.received(frame("2711002200000000")),
            Event::Unexpected { .. }
        ));
    }

    #[test]
    fn a_fast_stop_sent_before_the_busy_reply_still_ends_the_move() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let m = move_to(drive(1), 1000);
        let stop = Request::new(drive(1), Command::FastStop);
        c.sent(m, t);
        assert!(c.sent(stop, t).is_empty());
        // Both answer with 2B, in the order they were sent.
        let e = c.received(frame("2B11005500000000"));
        assert_eq!(
            e,
            Event::Ended {
                request: m,
                by: stop
            }
        );
        let e = c.received(frame("2B11002200000010"));
        assert!(matches!(e, Event::Answered { request, .. } if request == stop));
        assert!(c.is_idle());
    }

    #[test]
    fn a_move_that_finishes_before_the_stop_is_answered_normally() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let m = move_to(drive(1), 0);
        c.sent(m, t);
        c.sent(Request::new(drive(1), Command::Hold), t);
        let e = c.received(frame("2B11002200000000"));
        assert!(matches!(e, Event::Answered { request, .. } if request == m));
    }

    #[test]
    fn a_second_busy_reply_is_unexpected() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        c.sent(home(drive(1)), t);
        c.received(frame("2711005500000000"));
        let e = c.received(frame("2711005500000000"));
        assert!(matches!(
            e,
            Event::Unexpected {
                reason: UnexpectedReason::AlreadyBusy,
                ..
            }
        ));
        assert_eq!(c.running().count(), 1);
    }

    #[test]
    fn first_replies_time_out() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        c.sent(read_position(drive(1)), t);
        c.sent(read_position(drive(2)), t + Duration::from_millis(30));
        assert_eq!(c.next_deadline(), Some(t + TIMEOUT));
        assert!(c.poll_timeouts(t + Duration::from_millis(99)).is_empty());
        let e = c.poll_timeouts(t + TIMEOUT);
        assert_eq!(
            e,
            [Event::TimedOut {
                request: read_position(drive(1))
            }]
        );
        assert_eq!(c.next_deadline(), Some(t + Duration::from_millis(130)));
        assert_eq!(c.clear(), [read_position(drive(2))]);
        assert!(c.is_idle());
    }

    #[test]
    fn the_wait_for_a_first_reply_starts_when_the_request_is_on_the_line() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        c.sent(read_position(drive(1)), t);
        // The writer took 40 ms to get it out (a busy machine).
        c.transmitted(&read_position(drive(1)), t + Duration::from_millis(40));
        assert_eq!(
            c.next_deadline(),
            Some(t + Duration::from_millis(40) + TIMEOUT)
        );
        assert!(c.poll_timeouts(t + TIMEOUT).is_empty());
        // Never earlier than handed over.
        c.transmitted(&read_position(drive(1)), t);
        assert_eq!(
            c.next_deadline(),
            Some(t + Duration::from_millis(40) + TIMEOUT)
        );
    }

    #[test]
    fn identity_text_answers_the_oldest_identify() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        let text = Incoming::Identity(IdentText::version(8, 2).unwrap());
        assert!(matches!(
            c.received(text),
            Event::Unexpected {
                reason: UnexpectedReason::NothingOutstanding,
                ..
            }
        ));
        let v = Request::new(drive(2), Command::Identify(IdentityQuery::Version));
        let n = Request::new(drive(2), Command::Identify(IdentityQuery::DeviceNumber));
        c.sent(v, t);
        c.sent(n, t);
        let e = c.received(text);
        assert!(matches!(e, Event::Answered { request, .. } if request == v));
        let number = Incoming::Identity(IdentText::device_number(650).unwrap());
        let e = c.received(number);
        let Event::Answered { request, reply } = e else {
            panic!("{e:?}")
        };
        assert_eq!(request, n);
        let Reply::Identity(text) = reply else {
            panic!("{reply:?}")
        };
        assert_eq!(text.device_number_value(), Some(650));
    }

    #[test]
    fn a_malformed_answer_consumes_its_request() {
        let t = Instant::now();
        let mut c = Correlator::new(TIMEOUT);
        c.sent(read_position(drive(1)), t);
        let e = c.received(frame("2D11002202000000"));
        assert!(matches!(e, Event::Malformed { .. }));
        assert!(c.is_idle());
        c.sent(read_position(drive(1)), t);
        assert!(matches!(
            c.received(frame("2D11001100000000")),
            Event::Malformed {
                error: ReplyError::UnknownInfo(0x11),
                ..
            }
        ));
        assert!(c.is_idle());
    }
}
