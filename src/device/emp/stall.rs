//! The stall watchdog of a reference run (`26`, planned or typed raw): while
//! the drive reports busy (`55`, EMP decision 1) its position is sampled
//! every [`READ_EVERY`]; when it has stood still for [`STILL_READS`] samples
//! in a row, the run is stalled. A homing axis is never at rest that long: it
//! searches at Vfast, brakes to reverse (a servo brakes within
//! `BRAKE_TIME`, 100 ms) and creeps off the switch at Vslow, at least one
//! count per sample, 190 counts/s at the slowest sample rate
//! (docs/protocols.md EMP).
//!
//! The samples are the poller's `2C` reads of the drive when they come (no
//! extra traffic): one counts once an interval has passed since the last
//! counted one, so a fast poll does not make the second shorter. When the
//! poller does not read the drive at least every interval (polling off, as
//! in `jogterm send`, or slow), the watchdog reads `2C` itself ("kann
//! jederzeit angewendet werden", manual "2C"); when it does, its own read
//! is only a fallback an interval later, should the poll samples stop.

use std::time::{Duration, Instant};

/// How often the position is sampled while a reference run is busy.
pub const READ_EVERY: Duration = Duration::from_millis(100);

/// Samples in a row with the same position that make a stall (one second).
pub const STILL_READS: u32 = 10;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StallWatch {
    last: Option<i64>,
    still: u32,
    next_read: Instant,
    reading: bool,
}

impl StallWatch {
    /// Watching from `now`: the first sample counts one interval later.
    pub fn new(now: Instant) -> StallWatch {
        StallWatch {
            last: None,
            still: 0,
            next_read: now + READ_EVERY,
            reading: false,
        }
    }

    /// When the watchdog's own read is due (`polled`: the poller reads the
    /// drive at least every interval, so its own read is a fallback);
    /// `None` while one is on its way.
    pub fn read_due(&self, polled: bool) -> Option<Instant> {
        if self.reading {
            return None;
        }
        Some(if polled {
            self.next_read + READ_EVERY
        } else {
            self.next_read
        })
    }

    pub fn read_sent(&mut self) {
        self.reading = true;
    }

    /// The watchdog's own read was answered with `position` (`None`: not
    /// readable, which neither proves motion nor a stall). True when the
    /// axis has now stood still for [`STILL_READS`] samples.
    pub fn sample(&mut self, position: Option<i64>, now: Instant) -> bool {
        self.reading = false;
        self.count(position, now)
    }

    /// The poller read `position`: a changed position proves motion at
    /// once; an unchanged one counts only once an interval has passed since
    /// the last counted sample. True when stalled.
    pub fn polled(&mut self, position: Option<i64>, now: Instant) -> bool {
        match position {
            Some(p) if self.last != Some(p) => {
                self.last = Some(p);
                self.still = 0;
            }
            _ if now >= self.next_read => return self.count(position, now),
            _ => {}
        }
        self.still >= STILL_READS
    }

    fn count(&mut self, position: Option<i64>, now: Instant) -> bool {
        self.next_read = now + READ_EVERY;
        if let Some(p) = position {
            self.still = if self.last == Some(p) {
                self.still + 1
            } else {
                0
            };
            self.last = Some(p);
        }
        self.still >= STILL_READS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ten_unchanged_reads_in_a_row_are_a_stall() {
        let t0 = Instant::now();
        let mut w = StallWatch::new(t0);
        assert_eq!(w.read_due(false), Some(t0 + READ_EVERY));
        let mut t = t0;
        // Moving, then standing for a braking reversal (3 reads): no stall.
        for p in [10, 20, 30, 30, 30, 30, 25, 20] {
            t += READ_EVERY;
            w.read_sent();
            assert_eq!(w.read_due(false), None);
            assert!(!w.sample(Some(p), t), "at {p}");
        }
        for i in 1..STILL_READS {
            t += READ_EVERY;
            assert!(!w.sample(Some(20), t), "read {i}");
        }
        // An unreadable answer neither counts nor resets the stand-still.
        assert!(!w.sample(None, t));
        assert!(w.sample(Some(20), t + READ_EVERY));
        assert_eq!(w.read_due(false), Some(t + READ_EVERY * 2));
    }

    #[test]
    fn poll_samples_count_once_an_interval_and_push_the_own_read_back() {
        let t0 = Instant::now();
        let mut w = StallWatch::new(t0);
        // Polled: the own read is a fallback one interval after the due sample.
        assert_eq!(w.read_due(true), Some(t0 + READ_EVERY * 2));
        // A poll every 10 ms with the axis standing: only one sample per
        // interval counts, so the stall takes the same second.
        let mut t = t0;
        let mut stalled_at = None;
        for i in 1..=150u32 {
            t = t0 + Duration::from_millis(u64::from(i) * 10);
            if w.polled(Some(5), t) {
                stalled_at = Some(t);
                break;
            }
        }
        // The first sample sets the position; ten counted ones follow, one
        // per interval: a second.
        assert_eq!(stalled_at, Some(t0 + Duration::from_millis(1000)));
        assert_eq!(w.read_due(true), Some(t + READ_EVERY * 2));
        // A changed position between counted samples resets at once.
        let mut w = StallWatch::new(t0);
        for i in 1..=9u64 {
            assert!(!w.polled(Some(5), t0 + Duration::from_millis(i * 100)));
        }
        assert!(!w.polled(Some(6), t0 + Duration::from_millis(905)));
        assert!(!w.polled(Some(6), t0 + READ_EVERY * 10));
    }
}
