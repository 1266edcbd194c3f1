//! A program check-out's state in the editor (`docs/editor.md`,
//! "Check-out"): the program run line by line in DNC form by jogterm
//! (`program::checkout::Plan`), while a key is held.
//!
//! The hold follows the jog keypad's rules (`docs/jogging.md`): a key's
//! events that come less than the first-repeat grace apart are one hold; a
//! new hold arms on its first press and moves from its first repeat on (a
//! tap moves nothing), each line that moves is held by the repeat timeout's
//! lease, which the device task runs out when the repeats stop (the
//! dead-man is in the driver, never here). Speeds are the program's times
//! the factor, at most what keeps the overrun bound for that lease, as a
//! continuous jog's.

use std::time::{Duration, Instant};

use crate::device::api::JogId;
use crate::program::checkout::{DncCommand, Plan};
use crate::program::checkout_emcu::{EmcuPlan, JobCommand};

/// The program the check-out runs: an isel CNC program in DNC form, or an
/// EMCU job line by line.
#[derive(Debug, Clone, PartialEq)]
pub enum RunPlan {
    Isel(Plan),
    Emcu(EmcuPlan),
}

impl RunPlan {
    /// The source line to run next; `None` once ended.
    pub fn line(&self) -> Option<usize> {
        match self {
            RunPlan::Isel(p) => p.line(),
            RunPlan::Emcu(p) => p.line(),
        }
    }

    /// The current line is done (`byte`: the port an isel `o` read).
    pub fn advance(&mut self, byte: Option<u8>) {
        match self {
            RunPlan::Isel(p) => p.advance(byte),
            RunPlan::Emcu(p) => p.advance(),
        }
    }
}

/// A line sent before the plan's (run from a line): a setting in force at
/// the line, or the move to its start position.
#[derive(Debug, Clone, PartialEq)]
pub enum PreLine {
    Isel(DncCommand),
    Emcu(JobCommand),
}

/// Check-out line ids are far from the keypad's jog ids (which count from
/// 1), so that a renewal of one never reaches the other.
const ID_BASE: u64 = 1 << 48;

/// What the check-out is doing.
#[derive(Debug, Clone, PartialEq)]
pub enum RunState {
    /// Between lines: the next hold runs the next line.
    Ready,
    /// A line is with the device task.
    Running,
    /// A dwell (`5`) counts down while the key is held.
    Dwelling { left: Duration },
    /// The key was let go in a move: the controller holds its rest
    /// (`rest`: the id of the line that paused) or, without a rest, the
    /// line runs again whole.
    Paused { rest: Option<JogId> },
    /// Stopped by a stop, a refusal, a fault or a lost link: nothing runs
    /// until the operator starts again (from a line).
    Stopped { why: String },
    /// The program has ended.
    Finished,
}

/// How long a streamed line is held without a renewal: the dead man of a
/// console that stalls (the same as `jogterm run --stream`'s). The tick
/// renews it three times as often.
pub const STREAM_LEASE: Duration = Duration::from_millis(1500);

/// A check-out that runs without a key held: a job converted from G-code
/// streamed (`docs/editor.md`, "G-code"). Its lines are held by leases the
/// tick renews, so a console that stalls pauses the machine.
#[derive(Debug, Clone, PartialEq)]
pub struct Stream {
    /// The G-code line of each line of the text (the converted program's).
    pub origins: Vec<Option<u32>>,
    /// Paused by the operator (F10): no line follows until F10 again.
    pub paused: bool,
    /// The last renewal of the running line's lease.
    pub renewed: Instant,
    /// The model's time left (`gcode::eta`), told each G-code line's
    /// command as it starts.
    pub eta: Option<crate::gcode::eta::Eta>,
    /// Time spent paused before the pause under way, and when that began:
    /// the ETA's pace counts the time the job runs.
    pub paused_for: Duration,
    pub paused_since: Option<Instant>,
}

impl Stream {
    pub fn new(
        origins: Vec<Option<u32>>,
        eta: Option<crate::gcode::eta::Eta>,
        now: Instant,
    ) -> Stream {
        Stream {
            origins,
            paused: false,
            renewed: now,
            eta,
            paused_for: Duration::ZERO,
            paused_since: None,
        }
    }

    /// Paused by the operator, or going on again.
    pub fn set_paused(&mut self, paused: bool, now: Instant) {
        match (self.paused_since.take(), paused) {
            (Some(since), false) => self.paused_for += now.saturating_duration_since(since),
            (Some(since), true) => self.paused_since = Some(since),
            (None, true) => self.paused_since = Some(now),
            (None, false) => {}
        }
        self.paused = paused;
    }

    /// Seconds the stream has run since `started`, pauses left out.
    pub fn running_s(&self, started: Instant, now: Instant) -> f64 {
        let paused = self.paused_for
            + self
                .paused_since
                .map_or(Duration::ZERO, |s| now.saturating_duration_since(s));
        now.saturating_duration_since(started)
            .saturating_sub(paused)
            .as_secs_f64()
    }
}

/// A check-out under way.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkout {
    pub plan: RunPlan,
    /// Speed factor in percent, 10-100.
    pub factor: u32,
    /// Single step: one line per press.
    pub single: bool,
    pub state: RunState,
    /// The line with the device task, and its DNC text.
    pub line_id: Option<JogId>,
    pub line_text: Option<String>,
    /// The source line the current DNC line belongs to.
    pub at_line: Option<usize>,
    /// Where the axes stood (machine steps) when the current move was
    /// sent: what is left of an EMCU move is counted from it.
    pub line_start: Option<[i64; 4]>,
    /// Lines to send before the plan's (run from a line: settings and the
    /// move to the start position), with the source line they stand for.
    pub preamble: Vec<(PreLine, usize)>,
    next_id: u64,
    /// The hold key's last press or repeat.
    pub last_key: Option<Instant>,
    /// A hold confirmed by a repeat (motion allowed).
    pub held: bool,
    /// The key does nothing until it has been let go (single step done, or
    /// a line ended otherwise than by its own end).
    pub latched: bool,
    pub started: Instant,
    pub lines_done: usize,
    /// The last tick while dwelling.
    pub dwell_tick: Option<Instant>,
    /// Streamed, not held (`None`: the check-out proper).
    pub stream: Option<Stream>,
    /// A piece of a job with waits streamed: the plan's lines are the
    /// piece's text, not the buffer's (`None`: the buffer's text).
    pub piece: Option<Box<crate::ui::editor::job::PieceStream>>,
}

impl Checkout {
    pub fn new(plan: RunPlan, preamble: Vec<(PreLine, usize)>, now: Instant) -> Checkout {
        let at_line = preamble.first().map(|(_, l)| *l).or(plan.line());
        Checkout {
            plan,
            factor: 100,
            single: false,
            state: RunState::Ready,
            line_id: None,
            line_text: None,
            at_line,
            line_start: None,
            preamble,
            next_id: 0,
            last_key: None,
            held: false,
            latched: false,
            started: now,
            lines_done: 0,
            dwell_tick: None,
            stream: None,
            piece: None,
        }
    }

    /// The buffer's line shown as current: a streamed piece's line by the
    /// G-code line it came from.
    pub fn buffer_line(&self) -> Option<usize> {
        let line = self.current_line()?;
        match &self.piece {
            Some(p) => p.lines_of.get(line).copied(),
            None => Some(line),
        }
    }

    /// The program the plan's lines are lines of: the piece's, or the
    /// buffer's `buffer`.
    pub fn program<'a>(
        &'a self,
        buffer: &'a crate::program::Program,
    ) -> &'a crate::program::Program {
        self.piece.as_ref().map_or(buffer, |p| &p.program)
    }

    pub fn new_id(&mut self) -> JogId {
        self.next_id += 1;
        JogId(ID_BASE + self.next_id)
    }

    /// The source line shown as current.
    pub fn current_line(&self) -> Option<usize> {
        match self.state {
            RunState::Finished => None,
            _ => self
                .at_line
                .or(self.preamble.first().map(|(_, l)| *l))
                .or(self.plan.line()),
        }
    }

    /// A key event of the hold key at `now`: whether the key counts as held
    /// (a repeat of a hold), given the grace before the first repeat.
    pub fn key(&mut self, now: Instant, grace: Duration) -> bool {
        let repeat = self
            .last_key
            .is_some_and(|t| now.saturating_duration_since(t) <= grace);
        self.last_key = Some(now);
        if !repeat {
            // A new press: armed, not moving yet; a latch is let go.
            self.latched = false;
            self.held = false;
            return false;
        }
        self.held = true;
        !self.latched
    }

    /// The key was let go (a release event).
    pub fn released(&mut self) {
        self.last_key = None;
        self.held = false;
        self.latched = false;
    }

    /// Whether the hold is still alive at `now` (its last repeat within the
    /// repeat timeout).
    pub fn holding(&self, now: Instant, timeout: Duration) -> bool {
        self.held
            && !self.latched
            && self
                .last_key
                .is_some_and(|t| now.saturating_duration_since(t) <= timeout)
    }

    /// Whether lines follow one another at `now`: a stream's until the
    /// operator pauses it, a check-out's while its key is held.
    pub fn runs_on(&self, now: Instant, timeout: Duration) -> bool {
        match &self.stream {
            Some(s) => !s.paused,
            None => self.holding(now, timeout),
        }
    }

    /// The lease a line is held by.
    pub fn lease(&self, repeat_timeout: Duration) -> Duration {
        if self.stream.is_some() {
            STREAM_LEASE
        } else {
            repeat_timeout
        }
    }

    /// A stream's progress in `program` (the text it streams): the G-code
    /// line of the current line, the share of the commands before it, the
    /// time since the start and the time left at that pace.
    pub fn stream_progress(
        &self,
        program: &crate::program::Program,
        now: Instant,
    ) -> Option<(Option<u32>, f64, Duration, Option<Duration>)> {
        let s = self.stream.as_ref()?;
        let line = self.current_line();
        // A command the conversion added (`z1`) is at the G-code line
        // before it.
        let gcode = line.and_then(|l| {
            s.origins
                .get(..=l.min(s.origins.len().saturating_sub(1)))?
                .iter()
                .rev()
                .find_map(|o| *o)
        });
        let total = program.command_count().max(1);
        let done = match line {
            Some(l) => (0..=l).rev().find_map(|l| program.index_of(l)).unwrap_or(0),
            None => total,
        };
        let share = done as f64 / total as f64;
        let elapsed = now.saturating_duration_since(self.started);
        // The model's time left where the job is the converted G-code,
        // else the pace so far.
        // The model is by the text's lines (`Eta`), as `line` is.
        let modelled = s.eta.as_ref().and_then(|eta| {
            eta.left_s(line.unwrap_or(usize::MAX), s.running_s(self.started, now))
                .map(|left| Duration::from_secs_f64(left.max(0.0)))
        });
        let left = modelled.or_else(|| {
            (share > 0.0)
                .then(|| Duration::from_secs_f64(elapsed.as_secs_f64() * (1.0 - share) / share))
        });
        Some((gcode, share, elapsed, left))
    }

    /// The factor one step slower or faster (10-100 %).
    pub fn change_factor(&mut self, up: bool) {
        self.factor = if up {
            (self.factor + 10).min(100)
        } else {
            self.factor.saturating_sub(10).max(10)
        };
    }

    /// The word shown for the state.
    pub fn label(&self) -> &'static str {
        match self.state {
            RunState::Ready => "READY",
            RunState::Running => "RUNNING",
            RunState::Dwelling { .. } => "DWELL",
            RunState::Paused { .. } => "PAUSED",
            RunState::Stopped { .. } => "STOPPED",
            RunState::Finished => "ENDED",
        }
    }
}

/// Hz on the wire for `hz` asked by the program: the factor, at least 1,
/// at most `cap` (the overrun bound's for the hold's lease).
pub fn scaled(hz: u32, factor: u32, cap: Option<u32>) -> u32 {
    let v = (u64::from(hz) * u64::from(factor) / 100).max(1);
    let v = u32::try_from(v).unwrap_or(u32::MAX);
    cap.map_or(v, |c| v.min(c.max(1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_scale_by_the_factor_and_stay_under_the_cap() {
        assert_eq!(scaled(1000, 50, None), 500);
        assert_eq!(scaled(1000, 10, None), 100);
        assert_eq!(scaled(5, 10, None), 1);
        assert_eq!(scaled(8000, 100, Some(6000)), 6000);
    }

    #[test]
    fn a_hold_arms_on_its_press_and_runs_from_its_first_repeat() {
        let t0 = Instant::now();
        let grace = Duration::from_millis(750);
        let plan = Plan::new(
            &crate::program::Program::parse(crate::program::Language::Isel, "9\n"),
            crate::program::checkout::config_of(crate::axis::AxisSet::XYZ).unwrap(),
        );
        let mut c = Checkout::new(RunPlan::Isel(plan), Vec::new(), t0);
        assert!(!c.key(t0, grace), "the press arms");
        assert!(
            c.key(t0 + Duration::from_millis(500), grace),
            "the first repeat runs"
        );
        assert!(c.holding(t0 + Duration::from_millis(600), Duration::from_millis(150)));
        assert!(!c.holding(t0 + Duration::from_millis(700), Duration::from_millis(150)));
        c.latched = true;
        assert!(!c.key(t0 + Duration::from_millis(530), grace), "latched");
        assert!(
            !c.key(t0 + Duration::from_secs(2), grace),
            "let go: arms again"
        );
        assert!(c.key(t0 + Duration::from_millis(2400), grace));
        c.change_factor(false);
        assert_eq!(c.factor, 90);
        for _ in 0..20 {
            c.change_factor(false);
        }
        assert_eq!(c.factor, 10);
    }
}
