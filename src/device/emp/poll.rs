//! Polling: a cycle reads every drive's position with `2C` (allowed at any
//! time, also during a move: manual "2C", so positions are always
//! measured), and every `ports_every`th cycle the switches and inputs of
//! every drive with `40 01`.

use std::time::Duration;

use crate::device::common::{PollRate, Poller};
use crate::proto::emp::{Command, DriveAddress, Request};
use crate::wire::LineSettings;

use super::settings::{EmpSettings, PROCESSING};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PollItem {
    Position(DriveAddress),
    Io(DriveAddress),
}

impl PollItem {
    pub fn request(self) -> Request {
        match self {
            PollItem::Position(ds) => Request::new(ds, Command::ReadPosition),
            PollItem::Io(ds) => Request::new(ds, Command::ReadInputs),
        }
    }
}

pub fn poller(settings: &EmpSettings) -> Poller<PollItem> {
    let ds: Vec<DriveAddress> = settings.drives.iter().map(|d| d.ds).collect();
    Poller::new(
        settings.poll,
        settings.ports_every,
        ds.iter().map(|d| PollItem::Position(*d)).collect(),
        ds.iter().map(|d| PollItem::Io(*d)).collect(),
    )
}

/// Position samples per second the line allows for this poll plan: every
/// drive's `2C` round trip per cycle, and the `40` round trips spread over
/// `ports_every` cycles.
pub fn wire_limit_hz(poller: &Poller<PollItem>, line: LineSettings, drives: usize) -> f64 {
    let round_trip =
        (line.transfer_time(2 * crate::proto::emp::FRAME_WIRE_LEN) + PROCESSING).as_secs_f64();
    let ports = poller.ports().len() as f64 / f64::from(poller.ports_every());
    1.0 / (round_trip * (drives as f64 + ports))
}

/// About how often the poller reads each drive's position: its rate, or
/// at line speed a cycle's round trips; `None` when polling is off.
pub fn position_period(
    poller: &Poller<PollItem>,
    line: LineSettings,
    drives: usize,
) -> Option<Duration> {
    let hz = match poller.rate() {
        PollRate::Off => return None,
        PollRate::Hz(hz) => hz,
        PollRate::LineSpeed => wire_limit_hz(poller, line, drives),
    };
    (hz > 0.0 && hz.is_finite())
        .then(|| Duration::try_from_secs_f64(1.0 / hz).ok())
        .flatten()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    #[test]
    fn one_drive_polls_at_most_once_per_round_trip() {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        let s = EmpSettings::from_profile(&profile).expect("settings");
        let p = poller(&s);
        // 1 / 10.45 ms with a quarter of a `40` round trip per cycle.
        let hz = wire_limit_hz(&p, s.line, 1);
        assert!((hz - 1.0 / (0.010_453 * 1.25)).abs() < 0.5, "{hz}");
    }
}
