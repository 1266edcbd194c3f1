//! The changes the recorder saw, kept per input (a lane, as a logic
//! analyzer draws it) in bounded memory.
//!
//! A change takes 16 bytes. At most [`MAX_CHANGES`] are kept (32 MiB);
//! beyond that the oldest go first and are counted. Every bit of every input
//! changes at most once per sample, so ten minutes ([`KEPT_AT_LEAST`]) fit as
//! long as fewer than 3495 changes a second arrive: more than the fastest
//! line of the three families can carry (isel: 32 bits every 16.7 ms, 1920
//! changes/s if every bit toggled at every sample).

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::device::api::{InputChange, InputChannel, InputKey};

/// Changes kept at most, over all inputs.
pub const MAX_CHANGES: usize = 1 << 21;

/// What the bound guarantees at any rate the lines allow.
pub const KEPT_AT_LEAST: Duration = Duration::from_secs(600);

/// Skew marks kept at most (one per E-stop opening).
const MAX_SKEWS: usize = 4096;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stored {
    /// First seen, µs since the epoch.
    seen_us: u64,
    /// From the last sample with the old level, µs.
    window_us: u32,
    level: bool,
    chatter: bool,
}

/// One recorded change, as the history gives it out.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    pub channel: Arc<InputChannel>,
    pub level: bool,
    /// First seen, since the link first came up.
    pub t: Duration,
    /// The change happened within this before `t`.
    pub window: Duration,
    /// The input chattered then.
    pub chatter: bool,
}

impl Recorded {
    pub fn activated(&self) -> bool {
        self.level == self.channel.active
    }
}

/// An E-stop skew, in the history's time.
#[derive(Debug, Clone, PartialEq)]
pub struct SkewMark {
    pub first: Arc<InputChannel>,
    pub second: Arc<InputChannel>,
    /// When the first channel was seen open.
    pub t_first: Duration,
    /// When the second was.
    pub t_second: Duration,
    pub measured: Duration,
    pub min: Duration,
    pub max: Duration,
}

#[derive(Debug, Clone)]
struct Lane {
    channel: Arc<InputChannel>,
    changes: VecDeque<Stored>,
}

/// The recorded changes of every input, oldest first per input.
#[derive(Debug, Clone)]
pub struct InputHistory {
    lanes: Vec<Lane>,
    index: HashMap<InputKey, usize>,
    skews: VecDeque<SkewMark>,
    epoch: Option<Instant>,
    total: usize,
    dropped: u64,
    cap: usize,
}

impl Default for InputHistory {
    fn default() -> Self {
        InputHistory::with_capacity(MAX_CHANGES)
    }
}

fn micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

impl InputHistory {
    /// A history that keeps at most `cap` changes (at least one).
    pub fn with_capacity(cap: usize) -> InputHistory {
        InputHistory {
            lanes: Vec::new(),
            index: HashMap::new(),
            skews: VecDeque::new(),
            epoch: None,
            total: 0,
            dropped: 0,
            cap: cap.max(1),
        }
    }

    /// Keep a change (in the order the recorder reported them).
    pub fn push(&mut self, change: &InputChange) {
        let epoch = *self
            .epoch
            .get_or_insert_with(|| change.seen.checked_sub(change.t).unwrap_or(change.seen));
        let seen = change.seen.saturating_duration_since(epoch);
        let lane = self.lane_index(&change.channel);
        if let Some(skew) = &change.skew {
            let second = self.lanes[lane].channel.clone();
            if self.skews.len() >= MAX_SKEWS {
                self.skews.pop_front();
            }
            self.skews.push_back(SkewMark {
                first: skew.first.clone(),
                second,
                t_first: seen.saturating_sub(skew.measured),
                t_second: seen,
                measured: skew.measured,
                min: skew.min,
                max: skew.max,
            });
        }
        if self.total >= self.cap {
            self.drop_oldest();
        }
        self.lanes[lane].changes.push_back(Stored {
            seen_us: micros(seen),
            window_us: u32::try_from(change.window().as_micros()).unwrap_or(u32::MAX),
            level: change.level,
            chatter: change.chatter.is_some(),
        });
        self.total += 1;
    }

    fn lane_index(&mut self, channel: &Arc<InputChannel>) -> usize {
        if let Some(i) = self.index.get(&channel.key) {
            return *i;
        }
        self.lanes.push(Lane {
            channel: channel.clone(),
            changes: VecDeque::new(),
        });
        let i = self.lanes.len() - 1;
        self.index.insert(channel.key, i);
        i
    }

    fn drop_oldest(&mut self) {
        let oldest = self
            .lanes
            .iter_mut()
            .filter(|l| !l.changes.is_empty())
            .min_by_key(|l| l.changes.front().map_or(u64::MAX, |s| s.seen_us));
        if let Some(lane) = oldest {
            lane.changes.pop_front();
            self.total -= 1;
            self.dropped += 1;
        }
    }

    /// Changes kept.
    pub fn len(&self) -> usize {
        self.total
    }

    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// Changes dropped to stay within the bound.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// The instant `t` counts from, once a change was kept.
    pub fn epoch(&self) -> Option<Instant> {
        self.epoch
    }

    fn recorded(lane: &Lane, s: &Stored) -> Recorded {
        Recorded {
            channel: lane.channel.clone(),
            level: s.level,
            t: Duration::from_micros(s.seen_us),
            window: Duration::from_micros(u64::from(s.window_us)),
            chatter: s.chatter,
        }
    }

    /// How many changes of `key` are kept.
    pub fn count(&self, key: InputKey) -> usize {
        self.lane(key).map_or(0, |l| l.changes.len())
    }

    fn lane(&self, key: InputKey) -> Option<&Lane> {
        self.index.get(&key).and_then(|i| self.lanes.get(*i))
    }

    /// The changes of `key` first seen in `from..to`, oldest first.
    pub fn between(
        &self,
        key: InputKey,
        from: Duration,
        to: Duration,
    ) -> impl Iterator<Item = Recorded> + '_ {
        let lane = self.lane(key);
        let (from, to) = (micros(from), micros(to));
        let start = lane.map_or(0, |l| l.changes.partition_point(|s| s.seen_us < from));
        lane.into_iter().flat_map(move |l| {
            l.changes
                .iter()
                .skip(start)
                .take_while(move |s| s.seen_us < to)
                .map(move |s| Self::recorded(l, s))
        })
    }

    /// The level of `key` just before `t`: that of its last change before
    /// `t`, else the opposite of its first change; `None` when it never
    /// changed.
    pub fn level_before(&self, key: InputKey, t: Duration) -> Option<bool> {
        let lane = self.lane(key)?;
        let t = micros(t);
        let i = lane.changes.partition_point(|s| s.seen_us < t);
        match i.checked_sub(1).and_then(|j| lane.changes.get(j)) {
            Some(s) => Some(s.level),
            None => lane.changes.front().map(|s| !s.level),
        }
    }

    /// The newest `n` changes of all inputs first seen before `to`, newest
    /// first.
    pub fn newest_before(&self, to: Duration, n: usize) -> Vec<Recorded> {
        let to = micros(to);
        let mut cursors: Vec<usize> = self
            .lanes
            .iter()
            .map(|l| l.changes.partition_point(|s| s.seen_us < to))
            .collect();
        let mut out = Vec::with_capacity(n.min(self.total));
        while out.len() < n {
            let next = cursors
                .iter()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .filter_map(|(i, c)| Some((i, self.lanes[i].changes.get(c - 1)?.seen_us)))
                .max_by_key(|(_, t)| *t);
            let Some((i, _)) = next else { break };
            cursors[i] -= 1;
            if let Some(s) = self.lanes[i].changes.get(cursors[i]) {
                out.push(Self::recorded(&self.lanes[i], s));
            }
        }
        out
    }

    /// The oldest change kept.
    pub fn earliest(&self) -> Option<Duration> {
        self.lanes
            .iter()
            .filter_map(|l| l.changes.front())
            .map(|s| Duration::from_micros(s.seen_us))
            .min()
    }

    /// E-stop skews, oldest first.
    pub fn skews(&self) -> impl DoubleEndedIterator<Item = &SkewMark> {
        self.skews.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::{InputRole, InputSource};

    fn channel(bit: u8) -> Arc<InputChannel> {
        Arc::new(InputChannel {
            key: InputKey {
                source: InputSource::IselPort(3),
                bit,
            },
            address: format!("in3.{bit}"),
            name: format!("limit {bit}"),
            role: InputRole::Limit,
            wired: true,
            active: true,
        })
    }

    fn change(epoch: Instant, channel: &Arc<InputChannel>, ms: u64, level: bool) -> InputChange {
        let seen = epoch + Duration::from_millis(ms);
        InputChange {
            seq: 0,
            channel: channel.clone(),
            level,
            seen,
            before: seen - Duration::from_millis(20),
            t: Duration::from_millis(ms),
            chatter: None,
            skew: None,
        }
    }

    #[test]
    fn lanes_answer_levels_and_ranges() {
        let epoch = Instant::now();
        let (a, b) = (channel(0), channel(1));
        let mut h = InputHistory::default();
        h.push(&change(epoch, &a, 100, true));
        h.push(&change(epoch, &b, 150, false));
        h.push(&change(epoch, &a, 1100, false));
        assert_eq!(h.len(), 3);
        assert_eq!(h.epoch(), Some(epoch));
        let ms = Duration::from_millis;
        assert_eq!(h.level_before(a.key, ms(50)), Some(false));
        assert_eq!(h.level_before(a.key, ms(500)), Some(true));
        assert_eq!(h.level_before(a.key, ms(1100)), Some(true));
        assert_eq!(h.level_before(a.key, ms(1101)), Some(false));
        assert_eq!(h.level_before(b.key, ms(0)), Some(true));
        assert_eq!(h.level_before(channel(2).key, ms(0)), None);
        let got: Vec<_> = h.between(a.key, ms(100), ms(1100)).collect();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].t, ms(100));
        assert_eq!(got[0].window, ms(20));
        let newest: Vec<_> = h
            .newest_before(Duration::MAX, 2)
            .iter()
            .map(|r| r.t)
            .collect();
        assert_eq!(newest, [ms(1100), ms(150)]);
        let before: Vec<_> = h.newest_before(ms(1100), 5).iter().map(|r| r.t).collect();
        assert_eq!(before, [ms(150), ms(100)]);
        assert_eq!(h.earliest(), Some(ms(100)));
    }

    #[test]
    fn the_bound_drops_the_oldest_of_all_inputs() {
        let epoch = Instant::now();
        let (a, b) = (channel(0), channel(1));
        let mut h = InputHistory::with_capacity(3);
        h.push(&change(epoch, &a, 10, true));
        h.push(&change(epoch, &b, 20, true));
        h.push(&change(epoch, &b, 30, false));
        h.push(&change(epoch, &a, 40, false));
        assert_eq!((h.len(), h.dropped()), (3, 1));
        assert_eq!(h.count(a.key), 1);
        assert_eq!(h.earliest(), Some(Duration::from_millis(20)));
    }

    #[test]
    fn ten_minutes_fit_at_the_fastest_line() {
        // isel, 4 ports of 8 bits read in 16.7 ms (32 bytes at 19200 baud),
        // every bit toggling at every sample.
        let per_second = 32.0 / (32.0 * 10.0 / 19_200.0);
        assert!(per_second * KEPT_AT_LEAST.as_secs_f64() < MAX_CHANGES as f64);
        assert_eq!(std::mem::size_of::<Stored>(), 16);
    }
}
