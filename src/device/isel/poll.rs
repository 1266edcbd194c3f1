//! Polling while nothing else happens: a cycle is `@0P`, and on every
//! `ports_every`th cycle the input ports of the plan. At line speed the next
//! poll follows the previous reply at once; at a rate, cycles start at that
//! rate. Requests always go first, between two polls, so polling never
//! starves them.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::device::api::PollStats;
use crate::proto::isel::InputPort;
use crate::wire::LineSettings;

use super::settings::{PollPlan, PollRate};

/// One poll command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PollItem {
    Position,
    Port(InputPort),
}

const STATS_EVERY: Duration = Duration::from_secs(1);

#[derive(Debug)]
pub struct Poller {
    plan: PollPlan,
    items: VecDeque<PollItem>,
    cycle: u64,
    next_cycle: Option<Instant>,
    window_start: Option<Instant>,
    positions: u32,
}

impl Poller {
    pub fn new(plan: PollPlan) -> Poller {
        Poller {
            plan,
            items: VecDeque::new(),
            cycle: 0,
            next_cycle: None,
            window_start: None,
            positions: 0,
        }
    }

    pub fn set_rate(&mut self, rate: PollRate, ports_every: u32) {
        self.plan.rate = rate;
        self.plan.ports_every = ports_every.max(1);
        self.next_cycle = None;
    }

    /// Start afresh (after a reconnect).
    pub fn reset(&mut self) {
        self.items.clear();
        self.cycle = 0;
        self.next_cycle = None;
        self.window_start = None;
        self.positions = 0;
    }

    /// The next poll command, if one is due.
    pub fn next(&mut self, now: Instant) -> Option<PollItem> {
        if let Some(item) = self.items.pop_front() {
            return Some(item);
        }
        let period = match self.plan.rate {
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
        let ports_cycle = self.cycle.is_multiple_of(u64::from(self.plan.ports_every));
        self.cycle += 1;
        self.items.push_back(PollItem::Position);
        if ports_cycle {
            self.items
                .extend(self.plan.ports.iter().map(|p| PollItem::Port(*p)));
        }
        self.items.pop_front()
    }

    /// Whether the item just answered completed a cycle with port reads.
    pub fn cycle_done(&self) -> bool {
        self.items.is_empty()
    }

    /// When the next cycle is due (only with a rate).
    pub fn due(&self) -> Option<Instant> {
        if !self.items.is_empty() {
            return None;
        }
        match self.plan.rate {
            PollRate::Hz(_) => self.next_cycle,
            PollRate::LineSpeed | PollRate::Off => None,
        }
    }

    pub fn position_read(&mut self, now: Instant) {
        self.window_start.get_or_insert(now);
        self.positions += 1;
    }

    /// When statistics are next due.
    pub fn stats_due(&self) -> Option<Instant> {
        self.window_start.map(|s| s + STATS_EVERY)
    }

    /// The position rate over the last second and the rate the line allows
    /// for this plan, once a second.
    pub fn take_stats(
        &mut self,
        now: Instant,
        line: LineSettings,
        with_a: bool,
    ) -> Option<PollStats> {
        let start = self.window_start?;
        let elapsed = now.saturating_duration_since(start);
        if elapsed < STATS_EVERY {
            return None;
        }
        let rate = f64::from(self.positions) / elapsed.as_secs_f64();
        self.window_start = None;
        self.positions = 0;
        Some(PollStats {
            position_rate_hz: rate,
            wire_limit_hz: self.wire_limit_hz(line, with_a),
        })
    }

    /// Position cycles per second the line can carry: `@0P` CR and its
    /// reply, plus the port reads spread over `ports_every` cycles.
    pub fn wire_limit_hz(&self, line: LineSettings, with_a: bool) -> f64 {
        let position = 4.0 + if with_a { 25.0 } else { 19.0 };
        let ports = 8.0 * self.plan.ports.len() as f64 / f64::from(self.plan.ports_every.max(1));
        line.bytes_per_second() / (position + ports)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(rate: PollRate, every: u32) -> PollPlan {
        PollPlan {
            rate,
            ports_every: every,
            ports: PollPlan::DEFAULT_PORTS.to_vec(),
        }
    }

    #[test]
    fn ports_come_every_nth_cycle_in_the_plans_order() {
        let t = Instant::now();
        let mut p = Poller::new(plan(PollRate::LineSpeed, 2));
        let mut got = Vec::new();
        for _ in 0..6 {
            got.push(p.next(t));
        }
        use PollItem::*;
        assert_eq!(
            got,
            [
                Some(Position),
                Some(Port(InputPort::Status1)),
                Some(Port(InputPort::LimitSwitches)),
                Some(Port(InputPort::Status2)),
                Some(Position),
                Some(Position),
            ]
        );
    }

    #[test]
    fn a_rate_spaces_the_cycles_and_never_bursts() {
        let t = Instant::now();
        let mut p = Poller::new(plan(PollRate::Hz(10.0), 1000));
        assert_eq!(p.next(t), Some(PollItem::Position));
        // Cycle 0 also read the ports.
        for _ in 0..3 {
            assert!(p.next(t).is_some());
        }
        assert_eq!(p.next(t), None);
        assert_eq!(p.due(), Some(t + Duration::from_millis(100)));
        assert_eq!(p.next(t + Duration::from_millis(99)), None);
        assert_eq!(
            p.next(t + Duration::from_millis(100)),
            Some(PollItem::Position)
        );
        // Five periods late: one cycle now, the next a period later.
        let late = t + Duration::from_millis(700);
        assert_eq!(p.next(late), Some(PollItem::Position));
        assert_eq!(p.due(), Some(late + Duration::from_millis(100)));
    }

    #[test]
    fn off_polls_nothing() {
        let mut p = Poller::new(plan(PollRate::Off, 1));
        assert_eq!(p.next(Instant::now()), None);
    }

    #[test]
    fn the_wire_limit_matches_the_isel_figures() {
        let line = LineSettings::new(19200);
        let only_position = Poller::new(PollPlan {
            rate: PollRate::LineSpeed,
            ports_every: 1,
            ports: Vec::new(),
        });
        assert!((only_position.wire_limit_hz(line, false) - 83.48).abs() < 0.01);
        let with_ports = Poller::new(PollPlan {
            rate: PollRate::LineSpeed,
            ports_every: 1,
            ports: vec![InputPort::Status1, InputPort::LimitSwitches],
        });
        assert!((with_ports.wire_limit_hz(line, false) - 49.23).abs() < 0.01);
    }
}
