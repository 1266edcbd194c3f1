//! The paced writer's arithmetic, sans-IO: a model of when the bytes handed to
//! the OS will have left the wire, and how many more may be handed over now
//! without letting the OS buffer hold more than about a millisecond.
//!
//! Why: the kernel and a USB adapter accept kilobytes at once and then
//! transmit them at line speed. A stop written behind a 1 kB upload line
//! would leave the wire half a second later at 19200 baud. Keeping the OS
//! buffer nearly empty keeps a stop within about a millisecond of the wire.

use std::time::{Duration, Instant};

use crate::wire::LineSettings;

/// How far ahead of the wire a message may be handed to the OS.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pace {
    /// Within the writer's `max_backlog`: a stop is never more than that
    /// behind bytes already handed over.
    #[default]
    Tight,
    /// Within the larger bulk backlog: for streams during which nothing
    /// moves (a program being stored), where a stop costs nothing by
    /// waiting a few milliseconds more, and one writer wake-up per byte
    /// would leave the line idle whenever a wake-up comes late.
    Bulk,
}

/// How many bytes ahead of the wire the writer may be.
#[derive(Debug, Clone)]
pub struct Pacer {
    byte_time: Duration,
    max_backlog: Duration,
    bulk_backlog: Duration,
    whole_backlog: Duration,
    wire_free: Option<Instant>,
}

impl Pacer {
    /// `max_backlog` is raised to 1.5 byte times at slow rates (9600 baud: a
    /// byte takes 1.04 ms) so that the next byte can always be handed over
    /// while the previous one is still on the wire, and the line never idles
    /// just because the writer thread woke a few microseconds late.
    pub fn new(line: LineSettings, max_backlog: Duration) -> Self {
        let byte_time = line.byte_time().max(Duration::from_nanos(1));
        let max_backlog = max_backlog.max(byte_time + byte_time / 2);
        Self {
            byte_time,
            max_backlog,
            bulk_backlog: max_backlog,
            whole_backlog: max_backlog,
            wire_free: None,
        }
    }

    /// The backlog allowed for [`Pace::Bulk`] messages (never below the
    /// tight one).
    pub fn with_bulk_backlog(mut self, bulk_backlog: Duration) -> Self {
        self.bulk_backlog = bulk_backlog.max(self.max_backlog);
        self
    }

    /// The backlog a message that may be cut runs up to, in as few writes
    /// as fit (never below the tight one): [`Pacer::chunk_allowance`].
    pub fn with_whole_backlog(mut self, whole_backlog: Duration) -> Self {
        self.whole_backlog = whole_backlog.max(self.max_backlog);
        self
    }

    fn chunk_limit(&self, pace: Pace) -> Duration {
        self.whole_backlog.max(self.limit(pace))
    }

    /// Bytes of a message paced `pace` that may go in one write at `now`
    /// when what is left of it is written in as few writes as possible:
    /// the backlog stays within the whole backlog (or the pace's own, if
    /// larger). A short command on an idle line then goes in one or two
    /// writes instead of one per byte, and a stop still waits for at most
    /// that backlog.
    pub fn chunk_allowance(&self, pace: Pace, now: Instant) -> usize {
        let room = self.chunk_limit(pace).saturating_sub(self.backlog(now));
        (room.as_nanos() / self.byte_time.as_nanos()) as usize
    }

    /// The earliest time at which [`Pacer::chunk_allowance`] is at least
    /// one byte: a writer that wakes then has the rest of the whole backlog
    /// before the line idles.
    pub fn chunk_ready_at(&self, pace: Pace, now: Instant) -> Instant {
        if self.chunk_allowance(pace, now) > 0 {
            return now;
        }
        let keep = self.chunk_limit(pace).saturating_sub(self.byte_time);
        let free = self.wire_free_at(now);
        free.checked_sub(keep).map_or(now, |t| t.max(now))
    }

    fn limit(&self, pace: Pace) -> Duration {
        match pace {
            Pace::Tight => self.max_backlog,
            Pace::Bulk => self.bulk_backlog,
        }
    }

    pub fn byte_time(&self) -> Duration {
        self.byte_time
    }

    /// The backlog limit actually in force.
    pub fn max_backlog(&self) -> Duration {
        self.max_backlog
    }

    /// Time the bytes already handed over still need on the wire.
    pub fn backlog(&self, now: Instant) -> Duration {
        self.wire_free
            .map_or(Duration::ZERO, |free| free.saturating_duration_since(now))
    }

    /// When everything handed over so far will have left the wire.
    pub fn wire_free_at(&self, now: Instant) -> Instant {
        self.wire_free.map_or(now, |free| free.max(now))
    }

    /// Bytes that may be handed over at `now`.
    pub fn allowance(&self, now: Instant) -> usize {
        self.allowance_for(Pace::Tight, now)
    }

    /// Bytes of a message paced `pace` that may be handed over at `now`.
    pub fn allowance_for(&self, pace: Pace, now: Instant) -> usize {
        let room = self.limit(pace).saturating_sub(self.backlog(now));
        (room.as_nanos() / self.byte_time.as_nanos()) as usize
    }

    /// The earliest time at which at least one byte may be handed over.
    pub fn ready_at(&self, now: Instant) -> Instant {
        self.ready_at_for(Pace::Tight, now)
    }

    /// The earliest time at which at least one byte of a message paced
    /// `pace` may be handed over.
    pub fn ready_at_for(&self, pace: Pace, now: Instant) -> Instant {
        if self.allowance_for(pace, now) > 0 {
            return now;
        }
        let keep = self.limit(pace).saturating_sub(self.byte_time);
        let free = self.wire_free_at(now);
        free.checked_sub(keep).map_or(now, |t| t.max(now))
    }

    /// Record that `n` bytes were handed over at `now`; returns when their
    /// first byte starts and their last byte ends on the wire (modelled).
    pub fn wrote(&mut self, n: usize, now: Instant) -> (Instant, Instant) {
        let start = self.wire_free_at(now);
        let bits = n as u128 * self.byte_time.as_nanos();
        let end = start + Duration::from_nanos(bits.min(u64::MAX as u128) as u64);
        self.wire_free = Some(end);
        (start, end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    #[test]
    fn at_19200_one_byte_goes_at_a_time_and_the_next_before_the_wire_idles() {
        let t0 = Instant::now();
        let mut p = Pacer::new(LineSettings::new(19200), Duration::from_millis(1));
        assert_eq!(p.allowance(t0), 1, "1 ms holds one 0.52 ms byte");
        let (start, end) = p.wrote(1, t0);
        assert_eq!(start, t0);
        assert_eq!(end - t0, us(520) + Duration::from_nanos(833));
        assert_eq!(p.allowance(t0), 0);
        // The next byte may go once 0.48 ms of backlog remain: the line stays
        // busy back to back, yet the OS never holds more than 1 ms.
        let ready = p.ready_at(t0);
        assert!(ready > t0 && ready < end, "{:?}", ready - t0);
        assert_eq!(p.allowance(ready), 1);
        p.wrote(1, ready);
        assert!(p.backlog(ready) <= Duration::from_millis(1));
    }

    #[test]
    fn at_38400_three_bytes_fit_in_a_millisecond() {
        let t0 = Instant::now();
        let p = Pacer::new(LineSettings::new(38400), Duration::from_millis(1));
        assert_eq!(p.allowance(t0), 3);
    }

    #[test]
    fn at_9600_the_budget_grows_to_one_and_a_half_bytes() {
        let t0 = Instant::now();
        let mut p = Pacer::new(LineSettings::new(9600), Duration::from_millis(1));
        assert_eq!(p.max_backlog(), us(1562) + Duration::from_nanos(499));
        assert_eq!(p.allowance(t0), 1);
        let (_, end) = p.wrote(1, t0);
        let ready = p.ready_at(t0);
        assert!(
            ready < end,
            "next byte is handed over before the line idles"
        );
    }

    #[test]
    fn bulk_runs_further_ahead_and_tight_waits_for_its_own_bound() {
        let t0 = Instant::now();
        let mut p = Pacer::new(LineSettings::new(19200), Duration::from_millis(1))
            .with_bulk_backlog(Duration::from_millis(4));
        assert_eq!(
            p.allowance_for(Pace::Bulk, t0),
            7,
            "4 ms hold seven 0.52 ms bytes"
        );
        p.wrote(7, t0);
        assert_eq!(p.allowance_for(Pace::Bulk, t0), 0);
        // A tight message behind bulk bytes waits until the backlog is back
        // under its own bound: the bulk bound is per message, not a new floor.
        let tight = p.ready_at_for(Pace::Tight, t0);
        assert!(p.backlog(tight) <= Duration::from_millis(1));
        assert!(tight - t0 >= Duration::from_millis(2), "{:?}", tight - t0);
        // Never below the tight bound.
        let q = Pacer::new(LineSettings::new(19200), Duration::from_millis(1))
            .with_bulk_backlog(Duration::ZERO);
        assert_eq!(q.allowance_for(Pace::Bulk, t0), q.allowance(t0));
    }

    #[test]
    fn a_late_writer_restarts_the_wire_at_now() {
        let t0 = Instant::now();
        let mut p = Pacer::new(LineSettings::new(19200), Duration::from_millis(1));
        p.wrote(1, t0);
        let later = t0 + Duration::from_millis(5);
        assert_eq!(p.backlog(later), Duration::ZERO);
        let (start, _) = p.wrote(1, later);
        assert_eq!(start, later);
    }

    #[test]
    fn backlog_never_exceeds_the_budget_when_following_allowance() {
        let t0 = Instant::now();
        let mut p = Pacer::new(LineSettings::new(19200), Duration::from_millis(1));
        let mut now = t0;
        for _ in 0..100 {
            now = p.ready_at(now) + us(13);
            let n = p.allowance(now);
            assert!(n >= 1);
            p.wrote(n, now);
            assert!(p.backlog(now) <= p.max_backlog());
        }
        // 100+ bytes at 0.52 ms each: the wire was never idle.
        assert!(p.wire_free_at(now) - t0 >= LineSettings::new(19200).transfer_time(100));
    }

    #[test]
    fn a_command_goes_in_chunks_of_the_whole_backlog_and_the_next_well_before_the_line_idles() {
        let t0 = Instant::now();
        let line = LineSettings::new(19200);
        let mut p = Pacer::new(line, Duration::from_millis(1))
            .with_whole_backlog(Duration::from_micros(1600));
        assert_eq!(p.chunk_allowance(Pace::Tight, t0), 3, "@0P of @0P CR");
        let (_, end) = p.wrote(3, t0);
        assert_eq!(p.chunk_allowance(Pace::Tight, t0), 0);
        // The CR may go once a byte fits again: 1.08 ms before the line
        // would idle, where the tight bound alone leaves 0.48 ms.
        let ready = p.chunk_ready_at(Pace::Tight, t0);
        assert_eq!(p.chunk_allowance(Pace::Tight, ready), 1);
        assert!(
            end - ready > Duration::from_micros(1000),
            "{:?}",
            end - ready
        );
        assert!(ready < p.ready_at(t0));
        // Never below the tight bound; bulk keeps its own.
        let q = Pacer::new(line, Duration::from_millis(1)).with_whole_backlog(Duration::ZERO);
        assert_eq!(q.chunk_allowance(Pace::Tight, t0), q.allowance(t0));
        let r = Pacer::new(line, Duration::from_millis(1))
            .with_bulk_backlog(Duration::from_millis(4))
            .with_whole_backlog(Duration::from_micros(1600));
        assert_eq!(r.chunk_allowance(Pace::Bulk, t0), 7);
    }
}
