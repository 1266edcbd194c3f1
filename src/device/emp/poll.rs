//! Polling: a cycle reads every drive's position with `2C` (allowed at any
//! time, also during a move: manual "2C", so positions are always
//! measured), and every `ports_every`th cycle the switches and inputs of
//! every drive with `40 01`. A drive known to be switched off answers every
//! frame with `EE` (manual "02": "Ohne diesen Einschalt-Befehl werden keine
//! Kommandos angenommen"; some drives `0A` too), so one of its polls is sent
//! only once every [`OFF_POLL_EVERY`] ([`OffDrives`]) until it is switched on
//! again or the link is new; the other drives keep the full rate.

use std::time::{Duration, Instant};

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
    pub fn ds(self) -> DriveAddress {
        match self {
            PollItem::Position(ds) | PollItem::Io(ds) => ds,
        }
    }

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
        ds.iter()
            .filter(|_| settings.poll_positions)
            .map(|d| PollItem::Position(*d))
            .collect(),
        ds.iter().map(|d| PollItem::Io(*d)).collect(),
    )
}

/// How often a drive that is switched off is polled: one frame (its `2C`
/// or its `40 01`, whichever is due) per period. Every such poll is
/// answered `EE` and tells nothing new but that the drive is still off
/// (`02` from jogterm, or a new link, is what switches it on and restores
/// the full rate); once a second keeps the line free for the other drives
/// and still shows a drive switched on behind jogterm's back (its poll is
/// answered again) within a second.
pub const OFF_POLL_EVERY: Duration = Duration::from_secs(1);

/// When each drive was last polled, to hold back the polls of drives that
/// are switched off.
#[derive(Debug, Default)]
pub struct OffDrives {
    sent: Vec<(DriveAddress, Instant)>,
    /// When the first item held back by the last look for a poll becomes
    /// due: the driver wakes then (a line-speed poller has nothing due of
    /// its own).
    wake: Option<Instant>,
}

impl OffDrives {
    fn last(&self, ds: DriveAddress) -> Option<Instant> {
        self.sent.iter().find(|(d, _)| *d == ds).map(|(_, t)| *t)
    }

    /// A new look for a poll to send: nothing held back yet.
    pub fn look(&mut self) {
        self.wake = None;
    }

    /// Whether `item` may be sent now (`off`: its drive is known to be
    /// switched off); if so, its drive counts as polled, if not, it is
    /// held back.
    pub fn admit(&mut self, item: PollItem, off: bool, now: Instant) -> bool {
        let ds = item.ds();
        if off && let Some(t) = self.last(ds) {
            let due = t + OFF_POLL_EVERY;
            if now < due {
                self.wake = Some(self.wake.map_or(due, |w| w.min(due)));
                return false;
            }
        }
        self.sent.retain(|(d, _)| *d != ds);
        self.sent.push((ds, now));
        true
    }

    /// When an item held back by the last look becomes due, if that look
    /// found nothing to send.
    pub fn wake(&self) -> Option<Instant> {
        self.wake
    }

    /// A new link: every drive's state is unknown again.
    pub fn reset(&mut self) {
        self.sent.clear();
        self.wake = None;
    }
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
    fn a_drive_that_is_off_is_polled_once_a_second() {
        let t = Instant::now();
        let x = PollItem::Position(DriveAddress::SINGLE);
        let x_io = PollItem::Io(DriveAddress::SINGLE);
        let mut off = OffDrives::default();
        assert!(off.admit(x, true, t), "the first poll goes");
        assert_eq!(off.wake(), None);
        assert!(!off.admit(x, true, t + Duration::from_millis(999)));
        // Its other poll waits too: one frame a second for the drive.
        assert!(!off.admit(x_io, true, t + Duration::from_millis(999)));
        assert_eq!(off.wake(), Some(t + OFF_POLL_EVERY));
        off.look();
        assert_eq!(off.wake(), None);
        assert!(off.admit(x_io, true, t + OFF_POLL_EVERY));
        assert!(!off.admit(x, true, t + OFF_POLL_EVERY));
        // Switched on: at once, every time.
        let on = t + OFF_POLL_EVERY + Duration::from_millis(10);
        assert!(off.admit(x, false, on));
        assert!(off.admit(x_io, false, on));
        // Off again: a second after the last poll.
        assert!(!off.admit(x, true, on + Duration::from_millis(500)));
        off.reset();
        assert!(off.admit(x, true, on + Duration::from_millis(500)));
    }

    #[test]
    fn without_positions_a_cycle_reads_the_inputs_alone() {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).expect("profile");
        let mut s = EmpSettings::from_profile(&profile).expect("settings");
        s.poll = crate::device::common::PollRate::LineSpeed;
        s.ports_every = 1;
        s.poll_positions = false;
        let mut p = poller(&s);
        let t = Instant::now();
        let got: Vec<_> = (0..3).map(|_| p.next(t)).collect();
        let io = Some(PollItem::Io(DriveAddress::SINGLE));
        assert_eq!(got, [io, io, io]);
    }

    #[test]
    fn drives_are_held_back_each_on_its_own() {
        let t = Instant::now();
        let y = DriveAddress::new(2, 1).expect("21");
        let mut off = OffDrives::default();
        assert!(off.admit(PollItem::Position(DriveAddress::SINGLE), true, t));
        assert!(off.admit(PollItem::Position(y), true, t));
        assert!(!off.admit(PollItem::Io(y), true, t));
        assert!(off.admit(PollItem::Io(DriveAddress::SINGLE), false, t));
    }

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
