//! What the isel driver polls (`common::poll` schedules it): a cycle is
//! `@0P`, and on every `ports_every`th cycle the input ports of the plan.

use crate::device::common::Poller;
use crate::proto::isel::InputPort;
use crate::wire::LineSettings;

use super::settings::PollPlan;

/// One poll command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PollItem {
    Position,
    Port(InputPort),
}

/// The poller for a plan.
pub fn poller(plan: &PollPlan) -> Poller<PollItem> {
    let positions = if plan.positions {
        vec![PollItem::Position]
    } else {
        Vec::new()
    };
    Poller::new(
        plan.rate,
        plan.ports_every,
        positions,
        plan.ports.iter().map(|p| PollItem::Port(*p)).collect(),
    )
}

/// Position cycles per second the line can carry: `@0P` CR and its
/// reply, plus the port reads spread over `ports_every` cycles.
pub fn wire_limit_hz(poller: &Poller<PollItem>, line: LineSettings, with_a: bool) -> f64 {
    let position = 4.0 + if with_a { 25.0 } else { 19.0 };
    let ports = 8.0 * poller.ports().len() as f64 / f64::from(poller.ports_every());
    line.bytes_per_second() / (position + ports)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::isel::PollRate;
    use std::time::Instant;

    fn plan(rate: PollRate, every: u32, ports: Vec<InputPort>) -> PollPlan {
        PollPlan {
            rate,
            positions: true,
            ports_every: every,
            ports,
        }
    }

    #[test]
    fn ports_come_every_nth_cycle_in_the_plans_order() {
        let t = Instant::now();
        let mut p = poller(&plan(
            PollRate::LineSpeed,
            2,
            PollPlan::DEFAULT_PORTS.to_vec(),
        ));
        let got: Vec<_> = (0..6).map(|_| p.next(t)).collect();
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
    fn without_positions_a_cycle_is_the_ports_alone() {
        let t = Instant::now();
        let mut plan = plan(PollRate::LineSpeed, 1, PollPlan::ALL_INPUT_PORTS.to_vec());
        plan.positions = false;
        let mut p = poller(&plan);
        let got: Vec<_> = (0..5).map(|_| p.next(t)).collect();
        use PollItem::*;
        assert_eq!(
            got,
            [
                Some(Port(InputPort::Status1)),
                Some(Port(InputPort::LimitSwitches)),
                Some(Port(InputPort::Status2)),
                Some(Port(InputPort::User)),
                Some(Port(InputPort::Status1)),
            ]
        );
    }

    #[test]
    fn the_wire_limit_matches_the_isel_figures() {
        let line = LineSettings::new(19200);
        let only_position = poller(&plan(PollRate::LineSpeed, 1, Vec::new()));
        assert!((wire_limit_hz(&only_position, line, false) - 83.48).abs() < 0.01);
        let with_ports = poller(&plan(
            PollRate::LineSpeed,
            1,
            vec![InputPort::Status1, InputPort::LimitSwitches],
        ));
        assert!((wire_limit_hz(&with_ports, line, false) - 49.23).abs() < 0.01);
    }
}
