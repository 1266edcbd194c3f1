//! The stall watchdog of a reference run typed as a raw `26`: while the drive
//! reports busy (`55`, EMP decision 1) the operation reads the position
//! (`2C`, "kann jederzeit angewendet werden", manual "2C") every
//! [`READ_EVERY`]; when it has stood still for [`STILL_READS`] reads in a
//! row, the run is stalled. A homing axis is never at rest that long: it
//! searches at Vfast, brakes to reverse (a servo brakes within
//! `BRAKE_TIME`, 100 ms) and creeps off the switch at Vslow, at least one
//! count per sample, 190 counts/s at the slowest sample rate
//! (docs/protocols.md EMP). The reads are the operation's own, so the
//! watchdog also works with polling off (`jogterm send`).

use std::time::{Duration, Instant};

/// How often the position is read while a raw reference run is busy.
pub const READ_EVERY: Duration = Duration::from_millis(100);

/// Reads in a row with the same position that make a stall (one second).
pub const STILL_READS: u32 = 10;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StallWatch {
    last: Option<i64>,
    still: u32,
    next_read: Instant,
    reading: bool,
}

impl StallWatch {
    /// Watching from `now`: the first read is one interval later.
    pub fn new(now: Instant) -> StallWatch {
        StallWatch {
            last: None,
            still: 0,
            next_read: now + READ_EVERY,
            reading: false,
        }
    }

    /// When the next read is due; `None` while one is on its way.
    pub fn read_due(&self) -> Option<Instant> {
        (!self.reading).then_some(self.next_read)
    }

    pub fn read_sent(&mut self) {
        self.reading = true;
    }

    /// The read was answered with `position` (`None`: not readable, which
    /// neither proves motion nor a stall). True when the axis has now stood
    /// still for [`STILL_READS`] reads.
    pub fn sample(&mut self, position: Option<i64>, now: Instant) -> bool {
        self.reading = false;
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
        assert_eq!(w.read_due(), Some(t0 + READ_EVERY));
        let mut t = t0;
        // Moving, then standing for a braking reversal (3 reads): no stall.
        for p in [10, 20, 30, 30, 30, 30, 25, 20] {
            t += READ_EVERY;
            w.read_sent();
            assert_eq!(w.read_due(), None);
            assert!(!w.sample(Some(p), t), "at {p}");
        }
        for i in 1..STILL_READS {
            t += READ_EVERY;
            assert!(!w.sample(Some(20), t), "read {i}");
        }
        // An unreadable answer neither counts nor resets the stand-still.
        assert!(!w.sample(None, t));
        assert!(w.sample(Some(20), t + READ_EVERY));
        assert_eq!(w.read_due(), Some(t + READ_EVERY * 2));
    }
}
