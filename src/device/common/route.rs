//! Where a client's request goes in a driver, the same for every family:
//! polling, jog leases, resets and raw lines to their own handling,
//! everything else to admission (`admit`: run now, queue, coalesce or
//! refuse); then the driver brings its state up to date. A family says
//! what each of these does ([`Requests`]); [`route`] is `Driver::request`.

use std::time::{Duration, Instant};

use crate::device::api::{JogId, Request};

use super::PollRate;

/// What a driver does with each kind of request.
pub trait Requests {
    /// `Request::Poll`: the poller's new rate.
    fn set_poll(&mut self, rate: PollRate, ports_every: u32);
    /// `Request::JogRenew`: the running (or waiting) jog's lease.
    fn renew_jog(&mut self, id: JogId, lease: Duration, now: Instant);
    /// `Request::JogRelease`: the jog's key was let go.
    fn release_jog(&mut self, id: JogId, now: Instant);
    /// `Request::Reset`.
    fn reset(&mut self, now: Instant);
    /// `Request::Raw`: a line of the family's syntax.
    fn raw_line(&mut self, line: String, now: Instant);
    /// Anything else that runs on the machine: checked, then run, queued or
    /// refused.
    fn admit_request(&mut self, request: Request, now: Instant);
    /// After every request: the state, and the clients told of a change.
    fn after_request(&mut self, now: Instant);
}

/// `Driver::request` for a driver that says what [`Requests`] do.
pub fn route(driver: &mut impl Requests, request: Request, now: Instant) {
    match request {
        // The task ends the session; nothing for the driver to do.
        // The task keeps holds itself; nothing for the driver to do.
        Request::Shutdown | Request::Hold { .. } | Request::HoldEnd => {}
        Request::Poll {
            rate_hz,
            ports_every,
        } => driver.set_poll(PollRate::from_request(rate_hz), ports_every),
        Request::JogRenew { id, lease } => driver.renew_jog(id, lease, now),
        Request::JogRelease { id } => driver.release_jog(id, now),
        Request::Reset => driver.reset(now),
        Request::Raw { line } => driver.raw_line(line, now),
        other => driver.admit_request(other, now),
    }
    driver.after_request(now);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisSet;

    /// Writes down where each request went.
    #[derive(Default)]
    struct Log(Vec<String>);

    impl Requests for Log {
        fn set_poll(&mut self, rate: PollRate, ports_every: u32) {
            self.0.push(format!("poll {rate:?} {ports_every}"));
        }
        fn renew_jog(&mut self, id: JogId, lease: Duration, _now: Instant) {
            self.0.push(format!("renew {} {}", id.0, lease.as_millis()));
        }
        fn release_jog(&mut self, id: JogId, _now: Instant) {
            self.0.push(format!("release {}", id.0));
        }
        fn reset(&mut self, _now: Instant) {
            self.0.push("reset".into());
        }
        fn raw_line(&mut self, line: String, _now: Instant) {
            self.0.push(format!("raw {line}"));
        }
        fn admit_request(&mut self, request: Request, _now: Instant) {
            self.0.push(format!(
                "admit {}",
                crate::device::describe::describe(&request)
            ));
        }
        fn after_request(&mut self, _now: Instant) {
            self.0.push("settle".into());
        }
    }

    #[test]
    fn every_request_goes_to_its_handling_and_the_state_is_settled_after() {
        let now = Instant::now();
        let mut log = Log::default();
        for request in [
            Request::Poll {
                rate_hz: Some(0.0),
                ports_every: 3,
            },
            Request::JogRenew {
                id: JogId(4),
                lease: Duration::from_millis(150),
            },
            Request::JogRelease { id: JogId(4) },
            Request::Reset,
            Request::Raw { line: "@0P".into() },
            Request::Home { axes: AxisSet::XYZ },
            Request::Shutdown,
        ] {
            route(&mut log, request, now);
        }
        assert_eq!(
            log.0,
            [
                "poll Off 3",
                "settle",
                "renew 4 150",
                "settle",
                "release 4",
                "settle",
                "reset",
                "settle",
                "raw @0P",
                "settle",
                "admit home XYZ",
                "settle",
                "settle",
            ]
        );
    }
}
