//! The port timeline's state: the device task's input changes as the
//! console received them (`Event::Input`, never dropped, fed whether or not
//! the timeline is shown), the levels read last, and where the operator has
//! scrolled and zoomed to. Drawn by `view::timeline`.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::device::api::{InputChange, InputChannel, InputKey, InputRole, InputSource, IoSnapshot};
use crate::device::inputs::{InputHistory, input_bits};

use super::keymap::Action;

/// Time per column the operator can zoom through, in ms.
pub const SCALES_MS: [u64; 13] = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10_000];

/// 100 ms a column: 6 s on an 80-column terminal, 13 s on 160.
pub const DEFAULT_SCALE: usize = 6;

#[derive(Debug, Clone)]
pub struct Timeline {
    /// What is drawn, one lane each: the profile's wired inputs, E-stop
    /// circuits and limit switches first, then any other input once it
    /// changed (an unwired input that moves is a finding).
    pub lanes: Vec<Arc<InputChannel>>,
    pub history: InputHistory,
    /// The level each input read last.
    pub levels: HashMap<InputKey, bool>,
    /// Per input group: its last reading and the interval before it.
    reads: HashMap<InputSource, (Instant, Option<Duration>)>,
    /// What `t` counts from: the link coming up, exactly once a change
    /// came (its `seen - t`).
    epoch: Option<Instant>,
    /// Index into [`SCALES_MS`].
    pub scale: usize,
    /// The right edge, in `t`; `None` follows the newest readings.
    pub end: Option<Duration>,
    /// The first lane shown.
    pub top: usize,
}

fn rank(channel: &InputChannel) -> u8 {
    match channel.role {
        InputRole::Estop => 0,
        InputRole::Limit => 1,
        _ => 2,
    }
}

impl Timeline {
    pub fn new(channels: &[Arc<InputChannel>]) -> Timeline {
        let mut lanes: Vec<Arc<InputChannel>> =
            channels.iter().filter(|c| c.wired).cloned().collect();
        lanes.sort_by_key(|c| rank(c));
        Timeline {
            lanes,
            history: InputHistory::default(),
            levels: HashMap::new(),
            reads: HashMap::new(),
            epoch: None,
            scale: DEFAULT_SCALE,
            end: None,
            top: 0,
        }
    }

    /// The link came up (as the console saw it: within milliseconds of the
    /// device task's own time, which the first change then gives).
    pub fn connected(&mut self, now: Instant) {
        self.epoch.get_or_insert(now);
    }

    pub fn record(&mut self, change: &InputChange) {
        self.history.push(change);
        self.epoch = self.history.epoch().or(self.epoch);
        if !self.lanes.iter().any(|l| l.key == change.channel.key) {
            self.lanes.push(change.channel.clone());
        }
    }

    /// A snapshot: the levels read, and how often each group is read.
    pub fn observe(&mut self, snapshot: &IoSnapshot) {
        for group in &snapshot.groups {
            let Some(read) = group.read else { continue };
            let interval = match self.reads.get(&read.source) {
                Some((last, _)) if read.at <= *last => continue,
                Some((last, _)) => Some(read.at.saturating_duration_since(*last)),
                None => None,
            };
            self.reads.insert(read.source, (read.at, interval));
            for (key, bit) in input_bits(group) {
                self.levels.insert(key, bit.value);
            }
        }
    }

    /// The lanes to draw: of [`Timeline::lanes`], those read (their group
    /// is polled) or changed. An input this session never reads (isel port
    /// 0 when the profile gives no user input a role) would only say `?`.
    pub fn shown(&self) -> Vec<&Arc<InputChannel>> {
        self.lanes
            .iter()
            .filter(|c| self.levels.contains_key(&c.key) || self.history.count(c.key) > 0)
            .collect()
    }

    /// Inputs of the profile this session does not read.
    pub fn unread(&self) -> usize {
        self.lanes.len() - self.shown().len()
    }

    /// The longest interval between the last two readings of any group:
    /// pulses shorter than this may not show.
    pub fn read_every(&self) -> Option<Duration> {
        self.reads.values().filter_map(|(_, i)| *i).max()
    }

    pub fn scale(&self) -> Duration {
        Duration::from_millis(SCALES_MS[self.scale.min(SCALES_MS.len() - 1)])
    }

    /// `now` in `t`.
    pub fn t_of(&self, now: Instant) -> Option<Duration> {
        self.epoch.map(|e| now.saturating_duration_since(e))
    }

    /// The right edge in `t`, on a whole column (so that the picture moves
    /// by whole columns and a change never hops between two).
    pub fn right_edge(&self, now: Instant) -> Duration {
        let scale = self.scale().as_micros().max(1);
        let t = self
            .end
            .or_else(|| self.t_of(now))
            .unwrap_or(Duration::ZERO)
            .as_micros();
        let columns = t.div_ceil(scale);
        Duration::from_micros(u64::try_from(columns * scale).unwrap_or(u64::MAX))
    }

    /// The level of `key` just before `t`: from its changes, else as read
    /// last (it has not changed since the link came up).
    pub fn level_before(&self, key: InputKey, t: Duration) -> Option<bool> {
        self.history
            .level_before(key, t)
            .or_else(|| self.levels.get(&key).copied())
    }

    /// Back in time by `columns`; stops at the oldest change kept.
    pub fn earlier(&mut self, columns: u16, now: Instant) {
        let step = self.scale() * u32::from(columns.max(1));
        let right = self.right_edge(now);
        let oldest = self.history.earliest().unwrap_or(Duration::ZERO);
        self.end = Some(right.saturating_sub(step).max(oldest + step));
    }

    /// Forward in time; back to following the readings at the newest.
    pub fn later(&mut self, columns: u16, now: Instant) {
        let Some(end) = self.end else { return };
        let next = end + self.scale() * u32::from(columns.max(1));
        self.end = match self.t_of(now) {
            Some(live) if next < live => Some(next),
            _ => None,
        };
    }

    pub fn live(&mut self) {
        self.end = None;
    }

    /// Finer (`-1`) or coarser (`+1`) columns.
    pub fn zoom(&mut self, delta: isize) {
        self.scale = self
            .scale
            .saturating_add_signed(delta)
            .min(SCALES_MS.len() - 1);
    }

    /// One lane up or down, `shown` lanes fitting.
    pub fn scroll(&mut self, delta: isize, shown: usize) {
        let last = self.lanes.len().saturating_sub(shown.max(1));
        self.top = self.top.saturating_add_signed(delta).min(last);
    }
}

/// What the timeline reads for a key: the time, the room on the screen.
#[derive(Debug, Clone, Copy)]
pub struct Context {
    pub now: Instant,
    /// Columns of time a lane has.
    pub columns: u16,
    /// Lanes that fit.
    pub rows: usize,
}

impl Timeline {
    /// The timeline as a component: a key while it has the focus; `true`
    /// when it closes (its own key again), the focus going back.
    pub fn update(&mut self, ctx: &Context, action: Action) -> bool {
        // A quarter of the picture per key.
        let step = ctx.columns / 4;
        match action {
            Action::Timeline => return true,
            Action::TimeEarlier => self.earlier(step, ctx.now),
            Action::TimeLater => self.later(step, ctx.now),
            Action::TimeLive => self.live(),
            Action::ZoomIn => self.zoom(-1),
            Action::ZoomOut => self.zoom(1),
            Action::ScrollUp => self.scroll(-1, ctx.rows),
            Action::ScrollDown => self.scroll(1, ctx.rows),
            _ => {}
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::inputs::channels;

    fn timeline() -> (Timeline, Vec<Arc<InputChannel>>) {
        let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
        let ch = channels::shared(&profile);
        (Timeline::new(&ch), ch)
    }

    #[test]
    fn lanes_are_the_wired_inputs_safety_first() {
        let (t, _) = timeline();
        let names: Vec<&str> = t.lanes.iter().take(4).map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "E-stop circuit 1",
                "E-stop circuit 2",
                "limit X1",
                "limit X2"
            ]
        );
        assert!(t.lanes.iter().all(|c| c.wired));
        assert_eq!(t.lanes.len(), 20);
    }

    #[test]
    fn an_unwired_input_that_changes_gets_a_lane() {
        let (mut t, ch) = timeline();
        let a1 = ch
            .iter()
            .find(|c| c.address == "in3.6")
            .expect("A1")
            .clone();
        let now = Instant::now();
        t.record(&InputChange {
            seq: 1,
            channel: a1.clone(),
            level: true,
            seen: now,
            before: now - Duration::from_millis(20),
            t: Duration::from_millis(500),
            chatter: None,
            skew: None,
        });
        assert_eq!(t.lanes.last(), Some(&a1));
        assert_eq!(t.t_of(now), Some(Duration::from_millis(500)));
    }

    #[test]
    fn inputs_never_read_get_no_lane() {
        let (mut t, _) = timeline();
        assert!(t.shown().is_empty(), "nothing read yet");
        let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
        let wiring = profile.wiring().expect("wiring");
        let at = Instant::now();
        let read = |port: crate::proto::isel::InputPort, v: u8| {
            crate::device::isel::input_group(port, v, &wiring)
                .read_from(InputSource::IselPort(port.number()), Some(at))
        };
        use crate::proto::isel::InputPort;
        t.observe(&IoSnapshot {
            at,
            groups: vec![
                read(InputPort::Status1, 3),
                read(InputPort::LimitSwitches, 0),
                read(InputPort::Status2, 0x62),
            ],
        });
        // Port 0 is not polled: its eight user inputs have no lane.
        assert_eq!((t.shown().len(), t.unread()), (12, 8));
        assert!(t.shown().iter().all(|c| !c.address.starts_with("in0.")));
    }

    #[test]
    fn scrolling_zooming_and_going_live() {
        let (mut t, _) = timeline();
        let now = Instant::now();
        t.connected(now);
        let later = now + Duration::from_secs(30);
        assert_eq!(t.right_edge(later), Duration::from_secs(30));
        t.earlier(40, later);
        assert_eq!(t.end, Some(Duration::from_secs(26)));
        t.later(20, later);
        assert_eq!(t.end, Some(Duration::from_secs(28)));
        t.later(40, later);
        assert_eq!(t.end, None, "past the newest: live again");
        t.zoom(-1);
        assert_eq!(t.scale(), Duration::from_millis(50));
        t.zoom(100);
        assert_eq!(t.scale(), Duration::from_secs(10));
        t.scroll(3, 10);
        assert_eq!(t.top, 3);
        t.scroll(100, 10);
        assert_eq!(t.top, 10);
        // Whole columns: 1.234 s at 100 ms a column ends at 1.3 s.
        t.zoom(-100);
        t.scale = DEFAULT_SCALE;
        assert_eq!(
            t.right_edge(now + Duration::from_millis(1234)),
            Duration::from_millis(1300)
        );
    }
}
