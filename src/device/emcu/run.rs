//! A batch of buffered commands and the run it starts (manual 1.4.2,
//! decision 1): every line waits for its CR, the last is ended by 0x01 (or
//! is a master command that starts a run, `@J`); then the interface runs the
//! commands and sends 0x02 CR on its own when it has finished.
//!
//! The end is confirmed with `@X` (no job, no motion, no reference run, no
//! wait): a 0x02 CR also means "room again" after a memory-full 0x03 CR, and
//! one that was garbled must not leave the run waiting for ever, so a run
//! that has not reported its end reads `@X` once a second too
//! (`docs/protocols.md`, EMCU). A command that fills the data memory is
//! answered 0x03 CR and starts the memory; the next line then waits for the
//! 0x02 CR that says there is room again.

use std::time::{Duration, Instant};

use crate::proto::emcu::{Command, Reply, Status, Terminator};

use super::context::{Cmd, Context};
use super::op::Next;

/// How often a run that has not reported its end is checked with `@X`.
pub const CHECK_EVERY: Duration = Duration::from_secs(1);
/// Confirmations that may be lost in a row before the run is given up.
const MAX_LOST_CHECKS: u32 = 3;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The next line is due.
    Send,
    /// Its acknowledgement is awaited.
    Ack,
    /// 0x03 CR filled the memory: the next line waits for 0x02 CR.
    Room,
    /// The run is under way.
    Running,
    /// `@X` is to be sent (`false`) or has been (`true`).
    Confirm(bool),
    Done,
}

/// What an answer meant for the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunEvent {
    Nothing,
    /// The last line was acknowledged: the run is under way.
    Started,
    /// `@X` shows the run still going; `overdue` once it took longer than
    /// planned.
    StillRunning {
        overdue: bool,
    },
    /// `@X` shows the interface idle.
    Ended(Status),
    /// Answers were lost: the run's state is unknown.
    Lost,
}

/// Whether `@X` shows nothing under way (manual 1.5.3).
pub fn idle(status: &Status) -> bool {
    !(status.moving || status.job_running || status.referencing || status.waiting)
}

#[derive(Debug)]
pub struct Run {
    lines: Vec<Cmd>,
    next: usize,
    phase: Phase,
    /// How long the run should take once started; `None`: no limit (a job).
    planned: Option<Duration>,
    margin: Duration,
    deadline: Option<Instant>,
    check_at: Option<Instant>,
    overdue: bool,
    stopping: bool,
    started: bool,
    lost_checks: u32,
}

impl Run {
    pub fn new(lines: Vec<Cmd>, planned: Option<Duration>, margin: Duration) -> Run {
        Run {
            lines,
            next: 0,
            phase: Phase::Send,
            planned,
            margin,
            deadline: None,
            check_at: None,
            overdue: false,
            stopping: false,
            started: false,
            lost_checks: 0,
        }
    }

    /// A batch of buffered commands, the last ended by 0x01.
    pub fn batch(cx: &Context, commands: &[Command], planned: Option<Duration>) -> Run {
        let last = commands.len().saturating_sub(1);
        let lines = commands
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let end = if i == last {
                    Terminator::RunBuffer
                } else {
                    Terminator::Cr
                };
                cx.cmd(c, end)
            })
            .collect();
        Run::new(lines, planned, cx.settings.timing.run_margin)
    }

    /// A run already under way (a raw line that started it was answered).
    pub fn watching(planned: Option<Duration>, margin: Duration, now: Instant) -> Run {
        let mut run = Run::new(Vec::new(), planned, margin);
        run.begin(now);
        run
    }

    fn begin(&mut self, now: Instant) {
        self.started = true;
        self.phase = Phase::Running;
        self.deadline = self.planned.map(|d| now + d + self.margin);
        self.check_at = Some(now + CHECK_EVERY);
    }

    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// The run has been started (its last line was acknowledged).
    pub fn is_running(&self) -> bool {
        matches!(self.phase, Phase::Running | Phase::Confirm(_) | Phase::Room)
    }

    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// The run was started (its last line was acknowledged, or may have been).
    pub fn started(&self) -> bool {
        self.started
    }

    /// Nothing of the batch has been handed out yet.
    pub fn untouched(&self) -> bool {
        self.phase == Phase::Send && self.next == 0
    }

    /// Lines acknowledged so far.
    pub fn acked_count(&self) -> usize {
        self.next
    }

    /// The line whose answer is awaited.
    pub fn current(&self) -> Option<&Cmd> {
        self.lines.get(self.next)
    }

    pub fn next(&mut self, cx: &Context) -> Next {
        match self.phase {
            Phase::Send => match self.lines.get(self.next) {
                Some(line) => {
                    self.phase = Phase::Ack;
                    Next::Send(line.clone())
                }
                None => {
                    self.phase = Phase::Done;
                    Next::Done
                }
            },
            Phase::Confirm(false) => {
                self.phase = Phase::Confirm(true);
                Next::Send(cx.cmd(&Command::Status, Terminator::Cr))
            }
            Phase::Ack | Phase::Room | Phase::Running | Phase::Confirm(true) => Next::Wait,
            Phase::Done => Next::Done,
        }
    }

    pub fn reply(&mut self, reply: &Reply, now: Instant) -> RunEvent {
        match (self.phase, reply) {
            (Phase::Ack, Reply::Ack | Reply::MemoryFull) => {
                let last = self.next + 1 >= self.lines.len();
                self.next += 1;
                if last {
                    self.begin(now);
                    return RunEvent::Started;
                }
                if self.stopping {
                    // The rest is not sent; `@B` drops what was stored.
                    self.phase = Phase::Done;
                    return RunEvent::Nothing;
                }
                self.phase = if *reply == Reply::MemoryFull {
                    // The memory runs now; more fits when 0x02 CR comes.
                    Phase::Room
                } else {
                    Phase::Send
                };
                RunEvent::Nothing
            }
            (Phase::Confirm(true), Reply::Status(status)) => {
                self.lost_checks = 0;
                if idle(status) {
                    self.phase = Phase::Done;
                    RunEvent::Ended(*status)
                } else {
                    self.phase = Phase::Running;
                    RunEvent::StillRunning {
                        overdue: self.overdue,
                    }
                }
            }
            _ => RunEvent::Nothing,
        }
    }

    /// 0x02 CR came.
    pub fn ready(&mut self) {
        match self.phase {
            Phase::Room if !self.stopping => self.phase = Phase::Send,
            Phase::Room | Phase::Running => self.phase = Phase::Confirm(false),
            _ => {}
        }
    }

    /// The answer to the current line was lost.
    pub fn lost_reply(&mut self) -> RunEvent {
        match self.phase {
            Phase::Confirm(true) => {
                self.lost_checks += 1;
                if self.lost_checks >= MAX_LOST_CHECKS {
                    self.phase = Phase::Done;
                    return RunEvent::Lost;
                }
                self.phase = Phase::Confirm(false);
                RunEvent::Nothing
            }
            Phase::Ack if self.next + 1 >= self.lines.len() => {
                // Whether the run started is unknown: watch it as if it had.
                self.next += 1;
                self.started = true;
                self.phase = Phase::Confirm(false);
                RunEvent::Nothing
            }
            _ => {
                self.phase = Phase::Done;
                RunEvent::Lost
            }
        }
    }

    /// The operator (or jogterm) sent `@B`: no more lines; a run under way
    /// comes to rest within `brake`.
    pub fn stop(&mut self, brake: Duration, now: Instant) {
        self.stopping = true;
        match self.phase {
            Phase::Send => self.phase = Phase::Done,
            Phase::Room | Phase::Running | Phase::Confirm(_) => {
                self.deadline = Some(now + brake + self.margin);
                self.overdue = false;
            }
            Phase::Ack | Phase::Done => {}
        }
    }

    pub fn timer(&self) -> Option<Instant> {
        if self.phase != Phase::Running {
            return None;
        }
        let deadline = self.deadline.filter(|_| !self.overdue);
        match (self.check_at, deadline) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// A check or the deadline is due: read `@X`.
    pub fn on_timer(&mut self, now: Instant) {
        if self.phase != Phase::Running {
            return;
        }
        if self.deadline.is_some_and(|d| d <= now) {
            self.overdue = true;
        }
        if self.overdue || self.check_at.is_some_and(|t| t <= now) {
            self.check_at = Some(now + CHECK_EVERY);
            self.phase = Phase::Confirm(false);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::emcu::EmcuSettings;

    fn cx() -> Context {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        Context::new(EmcuSettings::from_profile(&profile).expect("settings"))
    }

    fn sent(next: Next) -> Vec<u8> {
        match next {
            Next::Send(c) => c.bytes,
            other => panic!("expected a line, got {other:?}"),
        }
    }

    fn busy() -> Status {
        Status {
            moving: true,
            job_running: true,
            ..Status::default()
        }
    }

    #[test]
    fn a_batch_runs_at_its_last_line_and_ends_when_at_reads_idle() {
        let cx = cx();
        let now = Instant::now();
        let commands = ["#E9,800", "L9,x100"].map(|c| c.parse().expect("command"));
        let mut run = Run::batch(&cx, &commands, Some(Duration::from_secs(1)));
        assert_eq!(sent(run.next(&cx)), b"#E9,800\r");
        assert_eq!(run.next(&cx), Next::Wait);
        assert_eq!(run.reply(&Reply::Ack, now), RunEvent::Nothing);
        assert_eq!(sent(run.next(&cx)), b"L9,x100\x01");
        assert_eq!(run.reply(&Reply::Ack, now), RunEvent::Started);
        assert!(run.is_running());
        assert_eq!(run.timer(), Some(now + CHECK_EVERY));
        run.ready();
        assert_eq!(sent(run.next(&cx)), b"@X\r");
        assert_eq!(
            run.reply(&Reply::Status(busy()), now),
            RunEvent::StillRunning { overdue: false }
        );
        run.ready();
        assert_eq!(sent(run.next(&cx)), b"@X\r");
        assert_eq!(
            run.reply(&Reply::Status(Status::default()), now),
            RunEvent::Ended(Status::default())
        );
        assert!(run.is_done());
    }

    #[test]
    fn memory_full_waits_for_room() {
        let cx = cx();
        let now = Instant::now();
        let commands = ["W10", "W10"].map(|c| c.parse().expect("command"));
        let mut run = Run::batch(&cx, &commands, None);
        run.next(&cx);
        run.reply(&Reply::MemoryFull, now);
        assert_eq!(run.next(&cx), Next::Wait);
        run.ready();
        assert_eq!(sent(run.next(&cx)), b"W10\x01");
    }

    #[test]
    fn a_run_without_its_end_is_checked_and_then_overdue() {
        let cx = cx();
        let now = Instant::now();
        let mut run = Run::watching(Some(Duration::from_secs(2)), Duration::from_secs(1), now);
        run.on_timer(now + CHECK_EVERY);
        assert_eq!(sent(run.next(&cx)), b"@X\r");
        assert_eq!(
            run.reply(&Reply::Status(busy()), now + CHECK_EVERY),
            RunEvent::StillRunning { overdue: false }
        );
        run.on_timer(now + Duration::from_secs(3));
        run.next(&cx);
        assert_eq!(
            run.reply(&Reply::Status(busy()), now + Duration::from_secs(3)),
            RunEvent::StillRunning { overdue: true }
        );
    }

    #[test]
    fn a_stop_sends_no_more_lines() {
        let cx = cx();
        let now = Instant::now();
        let commands = ["#E9,800", "L9,x100"].map(|c| c.parse().expect("command"));
        let mut run = Run::batch(&cx, &commands, None);
        run.next(&cx);
        run.stop(Duration::from_millis(500), now);
        run.reply(&Reply::Ack, now);
        assert!(run.is_done());
        let mut lost = Run::watching(None, Duration::from_secs(1), now);
        for _ in 0..3 {
            lost.on_timer(now + Duration::from_secs(10));
            lost.next(&cx);
            let _ = lost.lost_reply();
        }
        assert!(lost.is_done());
    }
}
