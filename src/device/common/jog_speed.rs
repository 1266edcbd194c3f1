//! A continuous jog's speed follows the lease it holds (`docs/jogging.md`,
//! "Speed caps: the overrun bound"). The jog starts at the speed its first
//! lease allows within `jog.max_overrun` (the terminal's repeat delay: long,
//! so slow); a renewal is never granted more time than the running speed
//! allows ([`granted`]); the first renewal with a shorter lease lets the jog
//! speed up once, to what the short lease allows and the client asked for.
//!
//! This is the bookkeeping every family shares; how a family changes the
//! speed of a running jog is its own (isel and EMCU: stop and restart from
//! where it stopped, EMP: a new velocity or positioning frame).

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{Dir, JogEnd, PerAxis, Refusal};
use crate::motion::{self, Braking};

use super::motion::MotionKind;
use super::sink::Sink;

/// A faster jog is worth changing to only when it is faster by this factor
/// (isel and EMCU pay for the change with a dip).
pub const SPEED_UP_FACTOR: f64 = 1.05;

/// Where the jog's move stands when a renewal comes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveState {
    /// Planned, nothing of it handed out: it can still be planned anew.
    Unsent,
    /// Running and not being stopped: its speed may be raised.
    Running,
    /// Anything else (on its way, stopping, ended): nothing changes.
    Other,
}

/// What a renewal asks of the family's driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Renewal {
    /// Nothing: the jog goes on as it runs.
    Keep,
    /// Plan the unsent move again for the lease it holds now.
    Replan,
    /// Raise the running jog's speed to what the lease now allows.
    SpeedUp,
}

/// What a continuous jog needs to follow its lease with its speed.
#[derive(Debug, Clone, PartialEq)]
pub struct JogSpeed {
    pub axes: Vec<(Axis, Dir)>,
    /// The speeds the client asked for (the plan may run slower).
    pub requested: PerAxis<f64>,
    /// The lease length the jog holds now; the speed cap follows it.
    pub lease: Duration,
    /// A speed-up is under way (isel, EMCU: stopping to restart faster);
    /// the stop it needs is not the jog's end.
    speeding_up: bool,
}

impl JogSpeed {
    pub fn new(axes: Vec<(Axis, Dir)>, requested: PerAxis<f64>, lease: Duration) -> JogSpeed {
        JogSpeed {
            axes,
            requested,
            lease,
            speeding_up: false,
        }
    }

    pub fn is_speeding_up(&self) -> bool {
        self.speeding_up
    }

    /// The speed-up is done (or given up): the next stop ends the jog.
    pub fn sped_up(&mut self) {
        self.speeding_up = false;
    }

    /// A renewal asking for `lease`. A shorter lease than the jog holds is
    /// kept as its lease; when the move is running, not already speeding
    /// up, and some axis may now go faster than it runs (`running_hz`)
    /// by [`SPEED_UP_FACTOR`], up to what it asked for and `cap_hz` allows
    /// for the new lease, the jog speeds up (once: later renewals with the
    /// same lease are not shorter).
    pub fn renewed(
        &mut self,
        lease: Duration,
        at: MoveState,
        running_hz: impl Fn(Axis) -> f64,
        cap_hz: impl Fn(Axis, Duration) -> f64,
    ) -> Renewal {
        if lease >= self.lease {
            return Renewal::Keep;
        }
        self.lease = lease;
        match at {
            MoveState::Unsent => Renewal::Replan,
            MoveState::Running if !self.speeding_up => {
                let faster = self.axes.iter().any(|(axis, _)| {
                    let want = self
                        .requested
                        .get(*axis)
                        .unwrap_or(0.0)
                        .min(cap_hz(*axis, lease));
                    want > running_hz(*axis) * SPEED_UP_FACTOR
                });
                self.speeding_up = faster;
                if faster {
                    Renewal::SpeedUp
                } else {
                    Renewal::Keep
                }
            }
            MoveState::Running | MoveState::Other => Renewal::Keep,
        }
    }
}

/// The lease a renewal asking for `lease` is granted: never longer than
/// the jog's running speeds allow within their axes' bounds
/// (`motion::lease_cap`); `speeds` are (Hz, max_overrun steps) per moving axis.
/// Nothing moving (no speeds): nothing to bound, the lease as asked.
pub fn granted(
    braking: &Braking,
    lease: Duration,
    speeds: impl IntoIterator<Item = (f64, f64)>,
) -> Duration {
    speeds
        .into_iter()
        .map(|(hz, bound)| motion::lease_cap(braking, hz, bound))
        .fold(lease, Duration::min)
}

/// A jog that halted to speed up (isel, EMCU) goes on with `faster`, the
/// plan for the lease it holds from where it stopped; unless it has ended
/// meanwhile (release, stop), its lease ran out (dead-man) or the plan was
/// refused (the soft limit reached, or another reason): then the jog's end
/// is told.
pub fn restart<P>(
    speed: &mut JogSpeed,
    kind: &mut MotionKind,
    sink: &mut impl Sink,
    now: Instant,
    faster: Result<P, Refusal>,
) -> Option<P> {
    speed.sped_up();
    if kind.jog_end().is_none() && kind.lease_until().is_some_and(|until| until <= now) {
        kind.set_jog_end(JogEnd::DeadMan, false);
    }
    if kind.jog_end().is_some() {
        kind.report_jog(sink);
        return None;
    }
    match faster {
        Ok(plan) => Some(plan),
        Err(reason) => {
            let end = match reason {
                Refusal::SoftLimit { .. } => JogEnd::SoftLimit,
                other => JogEnd::Refused(other),
            };
            kind.set_jog_end(end, false);
            kind.report_jog(sink);
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const EMCU: Braking = Braking::FixedTime {
        start_hz: 200.0,
        ramp: Duration::from_millis(500),
    };

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn x_jog(hz: f64, lease: Duration) -> JogSpeed {
        JogSpeed::new(
            vec![(Axis::X, Dir::Plus)],
            PerAxis::new().with(Axis::X, hz),
            lease,
        )
    }

    fn cap(_: Axis, lease: Duration) -> f64 {
        motion::speed_cap(&EMCU, lease, 600.0)
    }

    #[test]
    fn the_first_shorter_lease_speeds_up_once() {
        let grace = cap(Axis::X, ms(750));
        let mut s = x_jog(1_000.0, ms(750));
        let at = |_: Axis| grace;
        assert_eq!(
            s.renewed(ms(750), MoveState::Running, at, cap),
            Renewal::Keep
        );
        assert_eq!(
            s.renewed(ms(150), MoveState::Running, at, cap),
            Renewal::SpeedUp
        );
        assert!(s.is_speeding_up());
        s.sped_up();
        // The same short lease again is no news.
        assert_eq!(
            s.renewed(ms(150), MoveState::Running, at, cap),
            Renewal::Keep
        );
        assert_eq!(s.lease, ms(150));
    }

    #[test]
    fn no_speed_up_when_the_jog_already_runs_as_fast_as_asked() {
        let mut s = x_jog(300.0, ms(750));
        assert_eq!(
            s.renewed(ms(150), MoveState::Running, |_| 300.0, cap),
            Renewal::Keep
        );
        assert!(!s.is_speeding_up());
        let mut s = x_jog(1_000.0, ms(750));
        assert_eq!(
            s.renewed(ms(150), MoveState::Unsent, |_| 0.0, cap),
            Renewal::Replan
        );
        let mut s = x_jog(1_000.0, ms(750));
        assert_eq!(
            s.renewed(ms(150), MoveState::Other, |_| 0.0, cap),
            Renewal::Keep
        );
        assert_eq!(s.lease, ms(150));
    }

    #[test]
    fn a_renewal_gets_no_more_time_than_the_running_speed_allows() {
        let fast = cap(Axis::X, ms(150));
        let l = granted(&EMCU, ms(750), [(fast, 600.0)]);
        assert!(l <= ms(150) && l + ms(1) >= ms(150), "{l:?}");
        assert!(motion::travel(&EMCU, fast, l) <= 600.0 + 1e-6);
        // A slow jog keeps what it asked for; nothing moving bounds nothing.
        assert_eq!(granted(&EMCU, ms(150), [(300.0, 600.0)]), ms(150));
        assert_eq!(granted(&EMCU, ms(150), []), ms(150));
    }

    proptest! {
        #[test]
        fn a_granted_lease_keeps_every_axis_within_its_bound(
            start in 0.0f64..2_000.0,
            ramp_ms in 1u64..2_000,
            a in (1.0f64..20_000.0, 10.0f64..100_000.0),
            b in (1.0f64..20_000.0, 10.0f64..100_000.0),
            lease_ms in 0u64..5_000,
        ) {
            let braking = Braking::FixedTime { start_hz: start, ramp: ms(ramp_ms) };
            let lease = ms(lease_ms);
            let l = granted(&braking, lease, [a, b]);
            prop_assert!(l <= lease);
            for (hz, bound) in [a, b] {
                // A speed that cannot stop within its bound gets no lease;
                // the lease is whole nanoseconds (a few µsteps of slack).
                if l > Duration::ZERO {
                    prop_assert!(motion::travel(&braking, hz, l) <= bound + 1e-3);
                }
            }
        }

        #[test]
        fn a_jog_speeds_up_only_at_a_new_shortest_lease_and_never_above_its_cap(
            asked in 100.0f64..5_000.0,
            leases in proptest::collection::vec(50u64..1_000, 1..40),
        ) {
            let first = ms(750);
            let mut s = x_jog(asked, first);
            let mut running = asked.min(cap(Axis::X, first));
            let mut shortest = first;
            for l in leases {
                let lease = ms(l);
                let at = running;
                match s.renewed(lease, MoveState::Running, |_| at, cap) {
                    Renewal::SpeedUp => {
                        prop_assert!(lease < shortest, "{lease:?} {shortest:?}");
                        let next = asked.min(cap(Axis::X, lease));
                        prop_assert!(next > running * SPEED_UP_FACTOR);
                        running = next;
                        s.sped_up();
                    }
                    Renewal::Keep => {}
                    Renewal::Replan => prop_assert!(false, "a running jog is not planned anew"),
                }
                shortest = shortest.min(lease);
                prop_assert_eq!(s.lease, shortest);
                // Whatever runs stops within the bound for the lease it holds.
                prop_assert!(motion::travel(&EMCU, running, s.lease) <= 600.0 + 1e-6);
            }
        }
    }
}
