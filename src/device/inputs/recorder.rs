//! The input recorder: every change of every input bit, found by comparing
//! each fresh reading of an input group with the one before it. Sans-IO: it
//! is handed the `IoSnapshot`s the driver reports and the times the link came
//! up and went down, and returns the changes.
//!
//! A change is timed by the two readings around it: the last that read the
//! old level (`before`) and the first that read the new one (`seen`). The
//! input changed in between; how long that window is depends on how often
//! the group is read, which is why a pulse shorter than the interval between
//! two readings may be missed and a longer one never is.
//!
//! Derived on the way:
//! - **chatter**: more than `chatter_changes` changes of one input within
//!   `chatter_window` (the profile's `[diagnostics]`);
//! - **E-stop skew**: from the moment one E-stop channel opens until all are
//!   closed again, every other channel that opens gets the time since the
//!   first one opened, with the range the two windows allow.

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::config::Profile;
use crate::device::api::{
    Chatter, EstopSkew, InputChange, InputChannel, InputKey, InputRole, InputSource, IoSnapshot,
};

use super::channels;
use super::history::InputHistory;
use super::input_bits;

/// Intervals between readings kept per group, for [`Sampling`]: the
/// recent ones, so that the slower read-back after connecting is not
/// taken for the polling's rate.
const INTERVALS_KEPT: usize = 8;

/// What the recorder needs to know.
#[derive(Debug, Clone)]
pub struct RecorderConfig {
    /// The inputs by name (`channels::channels`); bits not listed are named
    /// as the driver names them.
    pub channels: Vec<Arc<InputChannel>>,
    pub chatter_changes: u32,
    pub chatter_window: Duration,
}

impl RecorderConfig {
    pub fn from_profile(profile: &Profile) -> RecorderConfig {
        RecorderConfig {
            channels: channels::shared(profile),
            chatter_changes: profile.diagnostics.chatter_changes,
            chatter_window: Duration::from_millis(profile.diagnostics.chatter_ms),
        }
    }

    /// No names: what a device task started without a profile records
    /// (the shipped defaults for chatter, no E-stop channels known).
    pub fn unnamed() -> RecorderConfig {
        RecorderConfig {
            channels: Vec::new(),
            chatter_changes: 5,
            chatter_window: Duration::from_millis(500),
        }
    }
}

/// How often the inputs are read, from the last readings of every group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampling {
    /// Groups read at least twice in a row on this link.
    pub groups: usize,
    /// Fewest readings of any of them on this link.
    pub readings: u64,
    /// The longest of the recent intervals between two readings of any
    /// group: a pulse at least this long is always seen, a shorter one may
    /// fall between two readings.
    pub longest: Duration,
}

#[derive(Debug, Clone)]
struct Group {
    read: Instant,
    levels: Vec<bool>,
    intervals: VecDeque<Duration>,
    /// Readings since the link came up.
    readings: u64,
    /// The link went down since `read`: the next interval is no sample
    /// interval (the levels are still compared: the window then spans the
    /// outage).
    gap: bool,
}

#[derive(Debug, Clone)]
struct Episode {
    first: Arc<InputChannel>,
    before: Instant,
    seen: Instant,
    opened: BTreeSet<InputKey>,
}

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct InputRecorder {
    config: RecorderConfig,
    known: HashMap<InputKey, Arc<InputChannel>>,
    groups: BTreeMap<InputSource, Group>,
    recent: HashMap<InputKey, VecDeque<Instant>>,
    episode: Option<Episode>,
    history: InputHistory,
    epoch: Option<Instant>,
    seq: u64,
}

impl InputRecorder {
    pub fn new(config: RecorderConfig) -> InputRecorder {
        InputRecorder::with_history(config, InputHistory::default())
    }

    /// With a history of another bound (tests).
    pub fn with_history(config: RecorderConfig, history: InputHistory) -> InputRecorder {
        let known = config.channels.iter().map(|c| (c.key, c.clone())).collect();
        InputRecorder {
            config,
            known,
            groups: BTreeMap::new(),
            recent: HashMap::new(),
            episode: None,
            history,
            epoch: None,
            seq: 0,
        }
    }

    /// The link came up at `at`; `t` counts from the first time it did.
    pub fn connected(&mut self, at: Instant) {
        self.epoch.get_or_insert(at);
    }

    /// The link went down: what was in flight is lost, the levels read last
    /// stay to compare the next readings with.
    pub fn disconnected(&mut self) {
        for g in self.groups.values_mut() {
            g.gap = true;
            g.readings = 0;
        }
    }

    /// What the recorder has seen so far.
    pub fn history(&self) -> &InputHistory {
        &self.history
    }

    /// How often the groups are read; `None` before any was read twice.
    pub fn sampling(&self) -> Option<Sampling> {
        let measured: Vec<&Group> = self
            .groups
            .values()
            .filter(|g| !g.intervals.is_empty())
            .collect();
        let longest = measured
            .iter()
            .flat_map(|g| g.intervals.iter())
            .max()
            .copied()?;
        Some(Sampling {
            groups: measured.len(),
            readings: measured.iter().map(|g| g.readings).min().unwrap_or(0),
            longest,
        })
    }

    /// The level `key` read last.
    pub fn level(&self, key: InputKey) -> Option<bool> {
        self.groups
            .get(&key.source)
            .and_then(|g| g.levels.get(usize::from(key.bit)))
            .copied()
    }

    /// A snapshot the driver reported: every group read since the last one
    /// is compared with it, bit by bit.
    pub fn observe(&mut self, snapshot: &IoSnapshot) -> Vec<InputChange> {
        let mut changes = Vec::new();
        for group in &snapshot.groups {
            let Some(read) = group.read else { continue };
            let levels: Vec<(InputKey, bool, &str)> = input_bits(group)
                .map(|(key, bit)| (key, bit.value, bit.name.as_str()))
                .collect();
            for (key, _, name) in &levels {
                self.known
                    .entry(*key)
                    .or_insert_with(|| Arc::new(InputChannel::unnamed(*key, name)));
            }
            let epoch = *self.epoch.get_or_insert(read.at);
            let new_levels: Vec<bool> = levels.iter().map(|(_, v, _)| *v).collect();
            let previous = match self.groups.get_mut(&read.source) {
                Some(g) if read.at <= g.read => continue,
                Some(g) => {
                    if !g.gap {
                        if g.intervals.len() >= INTERVALS_KEPT {
                            g.intervals.pop_front();
                        }
                        g.intervals
                            .push_back(read.at.saturating_duration_since(g.read));
                    }
                    g.gap = false;
                    g.readings += 1;
                    let before = g.read;
                    let old = std::mem::replace(&mut g.levels, new_levels);
                    g.read = read.at;
                    Some((before, old))
                }
                None => {
                    self.groups.insert(
                        read.source,
                        Group {
                            read: read.at,
                            levels: new_levels,
                            intervals: VecDeque::new(),
                            readings: 1,
                            gap: false,
                        },
                    );
                    None
                }
            };
            let Some((before, old)) = previous else {
                continue;
            };
            for (i, (key, level, _)) in levels.iter().enumerate() {
                if old.get(i).is_some_and(|was| was != level) {
                    changes.push(self.change(*key, *level, before, read.at, epoch));
                }
            }
        }
        for c in &changes {
            self.history.push(c);
        }
        changes
    }

    fn change(
        &mut self,
        key: InputKey,
        level: bool,
        before: Instant,
        seen: Instant,
        epoch: Instant,
    ) -> InputChange {
        let channel = self
            .known
            .get(&key)
            .cloned()
            .unwrap_or_else(|| Arc::new(InputChannel::unnamed(key, "")));
        self.seq += 1;
        let chatter = self.chatter(key, seen);
        let skew = self.skew(&channel, level, before, seen);
        InputChange {
            seq: self.seq,
            channel,
            level,
            seen,
            before,
            t: seen.saturating_duration_since(epoch),
            chatter,
            skew,
        }
    }

    fn chatter(&mut self, key: InputKey, seen: Instant) -> Option<Chatter> {
        let window = self.config.chatter_window;
        let times = self.recent.entry(key).or_default();
        times.push_back(seen);
        while times
            .front()
            .is_some_and(|t| seen.saturating_duration_since(*t) > window)
        {
            times.pop_front();
        }
        let changes = u32::try_from(times.len()).unwrap_or(u32::MAX);
        (changes > self.config.chatter_changes).then(|| Chatter {
            changes,
            within: times
                .front()
                .map_or(Duration::ZERO, |t| seen.saturating_duration_since(*t)),
        })
    }

    fn is_estop(&self, channel: &InputChannel) -> bool {
        channel.role == InputRole::Estop && channel.wired
    }

    fn skew(
        &mut self,
        channel: &Arc<InputChannel>,
        level: bool,
        before: Instant,
        seen: Instant,
    ) -> Option<EstopSkew> {
        if !self.is_estop(channel) {
            return None;
        }
        if level != channel.active {
            // Closed again: the episode ends when every channel is.
            let any_open = self
                .known
                .values()
                .filter(|c| self.is_estop(c))
                .any(|c| self.level(c.key) == Some(c.active));
            if !any_open {
                self.episode = None;
            }
            return None;
        }
        match &mut self.episode {
            None => {
                self.episode = Some(Episode {
                    first: channel.clone(),
                    before,
                    seen,
                    opened: BTreeSet::from([channel.key]),
                });
                None
            }
            Some(ep) => ep.opened.insert(channel.key).then(|| EstopSkew {
                first: ep.first.clone(),
                measured: seen.saturating_duration_since(ep.seen),
                min: before.saturating_duration_since(ep.seen),
                max: seen.saturating_duration_since(ep.before),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::api::InputRead;
    use crate::device::isel::input_group;
    use crate::proto::isel::InputPort;

    fn recorder() -> InputRecorder {
        let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
        InputRecorder::new(RecorderConfig::from_profile(&profile))
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// Ports 1 and 3 read at `t0 + at_ms`.
    fn snap(t0: Instant, at_ms: u64, port1: u8, port3: u8) -> IoSnapshot {
        let at = t0 + ms(at_ms);
        let wiring = crate::wiring::Wiring::defaults(
            crate::proto::Protocol::Isel,
            crate::axis::AxisSet::XYZ,
            &[],
        );
        let read = |p: InputPort, v: u8| {
            let mut g = input_group(p, v, &wiring);
            g.read = Some(InputRead {
                source: InputSource::IselPort(p.number()),
                at,
            });
            g
        };
        IoSnapshot {
            at,
            groups: vec![
                read(InputPort::Status1, port1),
                read(InputPort::LimitSwitches, port3),
            ],
        }
    }

    #[test]
    fn a_pulse_is_timed_by_the_readings_around_its_edges() {
        let t0 = Instant::now();
        let mut r = recorder();
        r.connected(t0);
        assert!(
            r.observe(&snap(t0, 0, 3, 0)).is_empty(),
            "the first reading is no change"
        );
        assert!(r.observe(&snap(t0, 20, 3, 0)).is_empty());
        let on = r.observe(&snap(t0, 40, 3, 1));
        assert_eq!(on.len(), 1);
        assert_eq!(on[0].channel.name, "limit X1");
        assert!(on[0].level && on[0].activated());
        assert_eq!((on[0].t, on[0].window()), (ms(40), ms(20)));
        assert!(r.observe(&snap(t0, 60, 3, 1)).is_empty());
        let off = r.observe(&snap(t0, 1040, 3, 0));
        assert_eq!(off.len(), 1);
        assert!(!off[0].level);
        assert_eq!(off[0].seq, 2);
        assert_eq!(off[0].t - on[0].t, ms(1000));
        assert_eq!(off[0].window(), ms(980));
        assert_eq!(r.history().len(), 2);
        let s = r.sampling().expect("sampled");
        assert_eq!((s.groups, s.readings, s.longest), (2, 5, ms(980)));
        // Only the recent intervals count.
        for i in 1..=INTERVALS_KEPT as u64 {
            r.observe(&snap(t0, 1040 + i * 20, 3, 0));
        }
        assert_eq!(r.sampling().map(|s| s.longest), Some(ms(20)));
    }

    #[test]
    fn a_group_not_read_again_is_no_new_sample() {
        // The isel driver repeats port 0 in every snapshot after a single
        // `@0b0`; its old reading must not narrow the next window.
        let t0 = Instant::now();
        let mut r = recorder();
        let stale = snap(t0, 0, 3, 0);
        r.observe(&stale);
        let mut later = stale.clone();
        later.at = t0 + ms(500);
        assert!(r.observe(&later).is_empty());
        let changed = r.observe(&snap(t0, 900, 3, 4));
        assert_eq!(changed[0].window(), ms(900));
        assert_eq!(changed[0].channel.name, "limit Y1");
    }

    #[test]
    fn chatter_is_more_changes_than_the_profile_allows_in_its_window() {
        let t0 = Instant::now();
        let mut r = recorder();
        r.observe(&snap(t0, 0, 3, 0));
        let mut flags = Vec::new();
        for i in 1..=8u64 {
            let level = (i % 2) as u8;
            let c = r.observe(&snap(t0, i * 20, 3, level));
            flags.push(c[0].chatter.map(|c| c.changes));
        }
        // Five changes within 500 ms are allowed, the sixth chatters.
        assert_eq!(
            flags,
            [None, None, None, None, None, Some(6), Some(7), Some(8)]
        );
        // Quiet for longer than the window: no longer chattering.
        let c = r.observe(&snap(t0, 2000, 3, 1));
        assert_eq!(c[0].chatter, None);
    }

    #[test]
    fn estop_skew_is_measured_from_the_first_channel_to_open() {
        let t0 = Instant::now();
        let mut r = recorder();
        r.observe(&snap(t0, 0, 3, 0));
        let first = r.observe(&snap(t0, 17, 2, 0));
        assert_eq!(first[0].channel.name, "E-stop circuit 1");
        assert!(first[0].activated() && first[0].skew.is_none());
        assert!(r.observe(&snap(t0, 34, 2, 0)).is_empty());
        let second = r.observe(&snap(t0, 51, 0, 0));
        let skew = second[0].skew.clone().expect("skew");
        assert_eq!(skew.first.name, "E-stop circuit 1");
        assert_eq!(
            (skew.measured, skew.min, skew.max),
            (ms(34), ms(17), ms(51))
        );
        // Closed again, both: a new opening is a new episode.
        r.observe(&snap(t0, 68, 3, 0));
        let again = r.observe(&snap(t0, 85, 0, 0));
        assert_eq!(again.len(), 2);
        let skew = again
            .iter()
            .find_map(|c| c.skew.clone())
            .expect("the second channel of the same reading");
        assert_eq!((skew.measured, skew.min, skew.max), (ms(0), ms(0), ms(17)));
    }

    #[test]
    fn a_reconnect_is_no_sample_interval_but_still_a_window() {
        let t0 = Instant::now();
        let mut r = recorder();
        r.observe(&snap(t0, 0, 3, 0));
        r.observe(&snap(t0, 20, 3, 0));
        r.disconnected();
        let c = r.observe(&snap(t0, 3000, 3, 2));
        assert_eq!(c[0].window(), ms(2980));
        assert_eq!(r.sampling().map(|s| s.longest), Some(ms(20)));
    }

    #[test]
    fn bits_no_profile_names_are_named_as_the_driver_names_them() {
        let t0 = Instant::now();
        let mut r = InputRecorder::new(RecorderConfig::unnamed());
        r.observe(&snap(t0, 0, 3, 0));
        let c = r.observe(&snap(t0, 20, 3, 0x80));
        assert_eq!(c[0].channel.name, "limit A2");
        assert_eq!(c[0].channel.address, "in3.7");
        assert!(c[0].skew.is_none());
    }
}
