//! A line that streams bytes and answers nothing (issue 37): a wrong baud
//! rate, a controller of another family, a device that babbles. Every
//! family's decoder waits for the end of a reply that never ends, or drops
//! the bytes as garbage and waits for the next; a deadline that bytes keep
//! pushing out never fires, and the session would wait for ever without a
//! word. The device task feeds every read here with whether it held an
//! answer; a stream of [`STREAM_LIMIT`] without a pause of [`STREAM_GAP`]
//! and without an answer ends the link (`docs/device.md`, "Link
//! supervision"). Sans-IO: times come in with the bytes.

use std::time::{Duration, Instant};

use crate::wire::LineSettings;

/// How long bytes may stream without an answer among them, at least: a
/// reply is at most a few hundred bytes, and a text reply (isel `@0V`,
/// manual 2.2.27) is answered line by line, each line an answer.
pub const STREAM_LIMIT: Duration = Duration::from_secs(2);

/// The longest reply, in bytes, that must not trip the guard on a slow
/// line: the limit is at least its wire time ([`StreamGuard::new`]).
const LONGEST_REPLY: usize = 256;

/// A pause that ends a stream: longer than a USB serial adapter holds bytes
/// (16 ms latency timer, `docs/network.md`), far shorter than the gap
/// between two polls of a line that answers nothing.
pub const STREAM_GAP: Duration = Duration::from_millis(100);

#[derive(Debug)]
pub struct StreamGuard {
    limit: Duration,
    since: Option<Instant>,
    last: Option<Instant>,
    bytes: u64,
}

impl StreamGuard {
    /// For a line at `line`'s rate: [`STREAM_LIMIT`], or the wire time of
    /// the longest reply when that is longer (below about 1200 baud).
    pub fn new(line: LineSettings) -> StreamGuard {
        StreamGuard {
            limit: STREAM_LIMIT.max(line.transfer_time(LONGEST_REPLY)),
            since: None,
            last: None,
            bytes: 0,
        }
    }

    /// `n` bytes read at `at`; `answered` when a message of them answered
    /// something jogterm sent. `Some(reason)` when the line streams.
    pub fn read(&mut self, n: usize, at: Instant, answered: bool) -> Option<String> {
        let paused = self
            .last
            .is_none_or(|l| at.saturating_duration_since(l) > STREAM_GAP);
        self.last = Some(at);
        if answered || paused {
            self.since = (!answered).then_some(at);
            self.bytes = if answered { 0 } else { n as u64 };
            return None;
        }
        self.bytes += n as u64;
        let since = *self.since.get_or_insert(at);
        let streamed = at.saturating_duration_since(since);
        (streamed >= self.limit).then(|| {
            format!(
                "the line streams bytes that answer nothing ({} bytes in {:.1} s without a \
                 pause or a reply): a wrong baud rate, or a device that babbles",
                self.bytes,
                streamed.as_secs_f64()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(t0: Instant, ms: u64) -> Instant {
        t0 + Duration::from_millis(ms)
    }

    #[test]
    fn a_stream_without_answers_trips_after_the_limit() {
        let t0 = Instant::now();
        let mut g = StreamGuard::new(LineSettings::new(19200));
        let mut tripped = None;
        for i in 0..=210u64 {
            if let Some(r) = g.read(20, ms(t0, i * 10), false) {
                tripped = Some((i, r));
                break;
            }
        }
        let (i, reason) = tripped.expect("tripped");
        assert_eq!(i, 200, "at 2 s");
        assert!(reason.contains("4020 bytes in 2.0 s"), "{reason}");
    }

    #[test]
    fn answers_and_pauses_end_a_stream() {
        let t0 = Instant::now();
        let mut g = StreamGuard::new(LineSettings::new(19200));
        // Replies every 10 ms, each an answer: a line polled as fast as it
        // goes.
        for i in 0..1000u64 {
            assert_eq!(g.read(20, ms(t0, i * 10), i % 5 == 0), None);
        }
        // Stray bytes with pauses between them: never a stream.
        let t1 = ms(t0, 20_000);
        for i in 0..100u64 {
            assert_eq!(g.read(3, ms(t1, i * 150), false), None);
        }
    }

    #[test]
    fn a_slow_line_waits_for_its_longest_reply() {
        let t0 = Instant::now();
        let mut g = StreamGuard::new(LineSettings::new(300));
        // 30 bytes a second: a 256-byte reply takes 8.5 s.
        let tripped = (0..120u64).find(|i| g.read(3, ms(t0, i * 100), false).is_some());
        assert_eq!(tripped, Some(86));
    }
}
