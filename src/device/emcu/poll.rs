//! What the EMCU driver polls (`common::poll` schedules it): a cycle is
//! `@LX`, `@LY`, `@LZ` for the machine's axes (manual 1.5.4), and every
//! `ports_every`th cycle `@X` (manual 1.5.3). Master commands run at once,
//! also during a move (manual 1.4.2), so polling goes on while the
//! interface runs a batch: positions are always measured.

use crate::device::api::PerAxis;
use crate::device::common::Poller;
use crate::proto::emcu::EmcuAxis;
use crate::wire::LineSettings;

use super::settings::EmcuSettings;

/// One poll command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PollItem {
    Position(EmcuAxis),
    Status,
}

pub fn poller(settings: &EmcuSettings) -> Poller<PollItem> {
    let positions = EmcuAxis::ALL
        .into_iter()
        .filter(|a| settings.poll.positions && settings.axes.contains(a.axis()))
        .map(PollItem::Position)
        .collect();
    let ports = settings
        .poll
        .ports
        .iter()
        .map(|_| PollItem::Status)
        .collect();
    Poller::new(
        settings.poll.rate,
        settings.poll.ports_every,
        positions,
        ports,
    )
}

/// Bytes of one position exchange: `@LX` CR out, `@LX<steps>` CR back.
fn position_bytes(steps: i64) -> usize {
    4 + 3 + steps.to_string().len() + 1
}

/// Position cycles per second the line can carry at these positions (4
/// digits where none is known yet), with `@X` (3 + 9 bytes) spread over
/// `ports_every` cycles.
pub fn wire_limit_hz(
    poller: &Poller<PollItem>,
    line: LineSettings,
    axes: &[EmcuAxis],
    position: Option<&PerAxis<i64>>,
) -> f64 {
    let positions: usize = axes
        .iter()
        .map(|a| position_bytes(position.and_then(|p| p.get(a.axis())).unwrap_or(1000)))
        .sum();
    let status = 12.0 * poller.ports().len() as f64 / f64::from(poller.ports_every());
    line.bytes_per_second() / (positions as f64 + status)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::common::PollRate;
    use std::time::Instant;

    #[test]
    fn without_positions_a_cycle_is_the_status_alone() {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        let mut s = EmcuSettings::from_profile(&profile).expect("settings");
        s.poll.rate = PollRate::LineSpeed;
        s.poll.ports_every = 1;
        s.poll.positions = false;
        let mut p = poller(&s);
        let t = Instant::now();
        let got: Vec<_> = (0..3).map(|_| p.next(t)).collect();
        assert_eq!(got, [Some(PollItem::Status); 3]);
    }

    #[test]
    fn a_cycle_reads_every_axis_then_the_status() {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        let mut s = EmcuSettings::from_profile(&profile).expect("settings");
        s.poll.rate = PollRate::LineSpeed;
        s.poll.ports_every = 2;
        let mut p = poller(&s);
        let t = Instant::now();
        let got: Vec<_> = (0..7).map(|_| p.next(t)).collect();
        use PollItem::*;
        assert_eq!(
            got,
            [
                Some(Position(EmcuAxis::X)),
                Some(Position(EmcuAxis::Y)),
                Some(Position(EmcuAxis::Z)),
                Some(Status),
                Some(Position(EmcuAxis::X)),
                Some(Position(EmcuAxis::Y)),
                Some(Position(EmcuAxis::Z)),
            ]
        );
    }

    #[test]
    fn the_wire_limit_is_53_cycles_for_four_digit_positions() {
        let p = Poller::new(PollRate::LineSpeed, 1, Vec::<PollItem>::new(), Vec::new());
        let limit = wire_limit_hz(&p, LineSettings::new(19200), &EmcuAxis::ALL, None);
        // 3 x (4 + 8) bytes at 1920 bytes/s.
        assert!((limit - 53.33).abs() < 0.01, "{limit}");
    }
}
