//! Polling while nothing else happens: a cycle reads the positions, and on
//! every `ports_every`th cycle the port or status items too. At line speed
//! the next poll follows the previous reply at once; at a rate, cycles start
//! at that rate and late cycles do not burst. Requests always go first,
//! between two polls, so polling never starves them. Once a second the
//! position rate is reported with the rate the line allows for the plan
//! (`Event::Stats`).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::device::api::PollStats;

/// How often to poll.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PollRate {
    /// The next poll right after the previous reply.
    LineSpeed,
    /// Poll cycles per second.
    Hz(f64),
    /// No polling (the `send` command, scripts).
    Off,
}

/// What a session polls when it is not the profile's plan (the CLI's
/// commands): positions at `rate`, and with `ports` the family's ports or
/// status every cycle. Each family's settings apply it (`poll_as`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polling {
    pub rate: PollRate,
    pub ports: bool,
    /// Without: the inputs alone, every one the controller has (isel ports
    /// 1, 3, 2 and 0), as often as `rate` allows.
    pub positions: bool,
}

impl Polling {
    /// No polling at all (`send`).
    pub const OFF: Polling = Polling {
        rate: PollRate::Off,
        ports: false,
        positions: true,
    };

    /// Every input as fast as the line allows, no positions (`watch`,
    /// `commission`).
    pub const INPUTS: Polling = Polling {
        rate: PollRate::LineSpeed,
        ports: true,
        positions: false,
    };
}

impl PollRate {
    /// The profile's convention: 0 = as fast as the line allows.
    pub fn from_profile(rate_hz: f64) -> PollRate {
        if rate_hz > 0.0 && rate_hz.is_finite() {
            PollRate::Hz(rate_hz)
        } else {
            PollRate::LineSpeed
        }
    }

    /// `Request::Poll`'s convention (`docs/device.md`): `None` = as fast as
    /// the line allows, a positive rate = that rate, anything else = off.
    pub fn from_request(rate_hz: Option<f64>) -> PollRate {
        match rate_hz {
            None => PollRate::LineSpeed,
            Some(hz) if hz > 0.0 && hz.is_finite() => PollRate::Hz(hz),
            Some(_) => PollRate::Off,
        }
    }
}

/// What one poll cycle reads: the rate, and which port or status items every
/// `ports_every`th cycle reads after the positions (in the family's terms).
#[derive(Debug, Clone, PartialEq)]
pub struct PollPlan<P> {
    pub rate: PollRate,
    /// Read the positions every cycle; without, a cycle is its port items
    /// alone (`jogterm watch`: the inputs as often as the line allows).
    pub positions: bool,
    /// Read `ports` every Nth cycle (at least 1).
    pub ports_every: u32,
    /// Read on a port cycle, in this order; empty = never.
    pub ports: Vec<P>,
}

const STATS_EVERY: Duration = Duration::from_secs(1);

/// Hands out the poll items of the plan's cycles, `I` being the family's
/// poll command.
#[derive(Debug)]
pub struct Poller<I> {
    rate: PollRate,
    ports_every: u32,
    positions: Vec<I>,
    ports: Vec<I>,
    items: VecDeque<I>,
    cycle: u64,
    next_cycle: Option<Instant>,
    window_start: Option<Instant>,
    samples: u32,
}

impl<I: Copy> Poller<I> {
    /// `positions` are read every cycle, `ports` every `ports_every`th.
    pub fn new(rate: PollRate, ports_every: u32, positions: Vec<I>, ports: Vec<I>) -> Poller<I> {
        Poller {
            rate,
            ports_every: ports_every.max(1),
            positions,
            ports,
            items: VecDeque::new(),
            cycle: 0,
            next_cycle: None,
            window_start: None,
            samples: 0,
        }
    }

    pub fn set_rate(&mut self, rate: PollRate, ports_every: u32) {
        self.rate = rate;
        self.ports_every = ports_every.max(1);
        self.next_cycle = None;
    }

    pub fn rate(&self) -> PollRate {
        self.rate
    }

    pub fn ports_every(&self) -> u32 {
        self.ports_every
    }

    /// The port items of a port cycle.
    pub fn ports(&self) -> &[I] {
        &self.ports
    }

    /// Read these port items from now on (a controller that has not got
    /// one of them, a reconnect that may have brought another controller).
    pub fn set_ports(&mut self, ports: Vec<I>)
    where
        I: PartialEq,
    {
        self.items
            .retain(|i| ports.contains(i) || self.positions.contains(i));
        self.ports = ports;
    }

    /// Start afresh (after a reconnect).
    pub fn reset(&mut self) {
        self.items.clear();
        self.cycle = 0;
        self.next_cycle = None;
        self.window_start = None;
        self.samples = 0;
    }

    /// The next poll command, if one is due.
    pub fn next(&mut self, now: Instant) -> Option<I> {
        if let Some(item) = self.items.pop_front() {
            return Some(item);
        }
        let period = match self.rate {
            PollRate::Off => return None,
            PollRate::LineSpeed => None,
            PollRate::Hz(hz) => Some(Duration::from_secs_f64(1.0 / hz)),
        };
        if let (Some(at), Some(_)) = (self.next_cycle, period)
            && now < at
        {
            return None;
        }
        if let Some(period) = period {
            // Late by more than a period: do not catch up in a burst.
            let next = self.next_cycle.map_or(now + period, |at| at + period);
            self.next_cycle = Some(if next <= now { now + period } else { next });
        }
        let ports_cycle = self.cycle.is_multiple_of(u64::from(self.ports_every));
        self.cycle += 1;
        self.items.extend(self.positions.iter().copied());
        if ports_cycle {
            self.items.extend(self.ports.iter().copied());
        }
        self.items.pop_front()
    }

    /// Whether the item just answered ended its cycle.
    pub fn cycle_done(&self) -> bool {
        self.items.is_empty()
    }

    /// Forget the rest of the cycle under way (its answers were lost).
    pub fn abandon_cycle(&mut self) {
        self.items.clear();
    }

    /// When the next cycle is due (only with a rate).
    pub fn due(&self) -> Option<Instant> {
        if !self.items.is_empty() {
            return None;
        }
        match self.rate {
            PollRate::Hz(_) => self.next_cycle,
            PollRate::LineSpeed | PollRate::Off => None,
        }
    }

    /// A complete position sample was read.
    pub fn position_read(&mut self, now: Instant) {
        self.window_start.get_or_insert(now);
        self.samples += 1;
    }

    /// When statistics are next due.
    pub fn stats_due(&self) -> Option<Instant> {
        self.window_start.map(|s| s + STATS_EVERY)
    }

    /// The position rate over the last second, against `wire_limit_hz` (the
    /// rate the line allows for this plan), once a second.
    pub fn take_stats(&mut self, now: Instant, wire_limit_hz: f64) -> Option<PollStats> {
        let start = self.window_start?;
        let elapsed = now.saturating_duration_since(start);
        if elapsed < STATS_EVERY {
            return None;
        }
        let rate = f64::from(self.samples) / elapsed.as_secs_f64();
        self.window_start = None;
        self.samples = 0;
        Some(PollStats {
            position_rate_hz: rate,
            wire_limit_hz,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Item {
        Position(u8),
        Port(u8),
    }

    fn poller(rate: PollRate, every: u32) -> Poller<Item> {
        Poller::new(
            rate,
            every,
            vec![Item::Position(1), Item::Position(2)],
            vec![Item::Port(1), Item::Port(3)],
        )
    }

    #[test]
    fn ports_come_every_nth_cycle_after_the_positions() {
        let t = Instant::now();
        let mut p = poller(PollRate::LineSpeed, 2);
        let got: Vec<_> = (0..7).map(|_| p.next(t)).collect();
        use Item::*;
        assert_eq!(
            got,
            [
                Some(Position(1)),
                Some(Position(2)),
                Some(Port(1)),
                Some(Port(3)),
                Some(Position(1)),
                Some(Position(2)),
                Some(Position(1)),
            ]
        );
        assert!(!p.cycle_done());
        p.abandon_cycle();
        assert!(p.cycle_done());
    }

    #[test]
    fn a_rate_spaces_the_cycles_and_never_bursts() {
        let t = Instant::now();
        let mut p = Poller::new(PollRate::Hz(10.0), 1000, vec![1u8], vec![2u8]);
        assert_eq!(p.next(t), Some(1));
        // Cycle 0 also read the port.
        assert_eq!(p.next(t), Some(2));
        assert_eq!(p.next(t), None);
        assert_eq!(p.due(), Some(t + Duration::from_millis(100)));
        assert_eq!(p.next(t + Duration::from_millis(99)), None);
        assert_eq!(p.next(t + Duration::from_millis(100)), Some(1));
        // Five periods late: one cycle now, the next a period later.
        let late = t + Duration::from_millis(700);
        assert_eq!(p.next(late), Some(1));
        assert_eq!(p.due(), Some(late + Duration::from_millis(100)));
    }

    #[test]
    fn off_polls_nothing() {
        let mut p = poller(PollRate::Off, 1);
        assert_eq!(p.next(Instant::now()), None);
    }

    #[test]
    fn stats_come_once_a_second() {
        let t = Instant::now();
        let mut p = poller(PollRate::LineSpeed, 1);
        assert_eq!(p.take_stats(t, 50.0), None);
        for i in 0..40u32 {
            p.position_read(t + Duration::from_millis(u64::from(i) * 25));
        }
        assert_eq!(p.stats_due(), Some(t + Duration::from_secs(1)));
        assert_eq!(p.take_stats(t + Duration::from_millis(999), 50.0), None);
        let stats = p
            .take_stats(t + Duration::from_secs(1), 50.0)
            .expect("stats");
        assert!((stats.position_rate_hz - 40.0).abs() < 1e-9);
        assert_eq!(stats.wire_limit_hz, 50.0);
        assert_eq!(p.stats_due(), None);
    }

    #[test]
    fn poll_rate_conventions() {
        assert_eq!(PollRate::from_request(None), PollRate::LineSpeed);
        assert_eq!(PollRate::from_request(Some(10.0)), PollRate::Hz(10.0));
        assert_eq!(PollRate::from_request(Some(0.0)), PollRate::Off);
        assert_eq!(PollRate::from_request(Some(f64::NAN)), PollRate::Off);
        assert_eq!(PollRate::from_profile(0.0), PollRate::LineSpeed);
    }
}
