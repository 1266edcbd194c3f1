//! Running the stored commands: the data memory once it was started (0x01 or
//! full, manual 1.4.2), or the ROM job (`@J`, manual 1.5.18). One command runs
//! at a time; moves, reference runs and waits last, the rest take no time.
//! Pause (`@A`/`@C`), halt (`@B`) and the stops without a ramp (`@S`, `@R`)
//! act on the command under way.
//!
//! 0x02 CR bookkeeping (decision 1, `docs/protocols.md` EMCU): every run that
//! was started ends with one 0x02 CR, however it ends, and every 0x03 CR is
//! followed by one 0x02 CR when room frees (or the memory is cleared).

use std::time::{Duration, Instant};

use crate::proto::emcu::{
    Command, Move, MoveMode, REFERENCE_OFFSET_STEPS, ReferenceOrder, Reply, Slot,
};

use super::EmcuSim;

/// How far a reference run searches when the low end stop keeps the carriage
/// from the switch: for ever, as far as anyone waits (decades at the start
/// speed), until `@B`, `@S` or `@R`. The real interface has no search limit.
const SEARCH_STEPS: i64 = 1_000_000_000;

/// The command under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Step {
    Move(VectorMove),
    Home(HomeRun),
    Wait(Wait),
}

/// An `L` move (manual 1.5.10), remembered by its target counters so that it
/// can go on after a pause.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct VectorMove {
    slot: Slot,
    targets: [i32; 3],
    /// `&V1` is on and the move has not started yet (manual 1.5.19).
    pub awaiting_e1: bool,
}

/// A `$H` reference run (manual 1.5.9), one axis after the other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct HomeRun {
    order: ReferenceOrder,
    /// The axis of `order` under way.
    index: usize,
    phase: HomePhase,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HomePhase {
    /// Towards the switch in the negative direction (manual 1.5.8).
    Search,
    /// Back off the switch until it releases (manual 1.5.9).
    Free,
    /// On by the reference offset; the counter becomes 0 at `target`.
    Offset { target: i32 },
}

/// A `W` wait (manual 1.5.16); `until` is `None` while paused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Wait {
    remaining: Duration,
    until: Option<Instant>,
}

/// Where the command under way came from, so that it can free its cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Source {
    Memory,
    Rom,
    /// Its job was ended by `@B`; it only comes to rest.
    Detached,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) enum Mode {
    #[default]
    Running,
    /// `@A` while moving: ramping down; `resume` once `@C` came meanwhile.
    Pausing { resume: bool },
    /// `@A`: at rest, waiting for `@C` (manual 1.5.13).
    Paused,
    /// `@B` while moving: ramping down, then the job has ended (1.5.11).
    Ending,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Active {
    pub step: Step,
    source: Source,
}

/// What runs and what is queued to run.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Executor {
    pub active: Option<Active>,
    /// The next command of a running ROM job.
    pub rom_next: Option<usize>,
    /// The data memory runs (started by 0x01 or by filling it).
    pub memory_armed: bool,
    pub mode: Mode,
}

impl Executor {
    /// A job runs: a command is under way or more are queued to run.
    pub fn is_active(&self) -> bool {
        self.active.is_some() || self.rom_next.is_some() || self.memory_armed
    }

    pub fn step(&self) -> Option<&Step> {
        self.active.as_ref().map(|a| &a.step)
    }

    pub fn is_referencing(&self) -> bool {
        matches!(self.step(), Some(Step::Home(_)))
    }

    /// A `W` time is running (not while paused).
    pub fn is_waiting(&self) -> bool {
        matches!(self.step(), Some(Step::Wait(Wait { until: Some(_), .. })))
    }

    pub fn is_awaiting_e1(&self) -> bool {
        matches!(self.step(), Some(Step::Move(m)) if m.awaiting_e1)
    }
}

impl EmcuSim {
    /// When the command under way next needs attention.
    pub(super) fn due(&self) -> Option<Instant> {
        self.mech.segment_end().or(match self.exec.step() {
            Some(Step::Wait(w)) => w.until,
            _ => None,
        })
    }

    /// Brings the model up to `now` (never back in time), event by event at
    /// the instant each happens, and returns the time it is now at.
    pub(super) fn run_until(&mut self, now: Instant) -> Instant {
        let now = self.clock.map_or(now, |c| c.max(now));
        let mut at = self.clock.unwrap_or(now);
        loop {
            self.pump(at);
            match self.due() {
                Some(due) if due <= now => {
                    at = due.max(at);
                    self.on_due(at);
                }
                _ => break,
            }
        }
        self.clock = Some(now);
        now
    }

    fn on_due(&mut self, at: Instant) {
        if self.mech.segment_end().is_some_and(|end| end <= at) {
            self.segment_ended(at);
        } else if self.exec.is_waiting()
            && self.due().is_some_and(|d| d <= at)
            && let Some(active) = self.exec.active.take()
        {
            self.finish(active.source);
        }
    }

    /// Starts queued commands until one lasts or nothing is left to run.
    /// Every pass takes a command off a finite queue or ends a run.
    fn pump(&mut self, at: Instant) {
        while self.exec.active.is_none() && self.exec.mode == Mode::Running {
            let (command, source) = if let Some(index) = self.exec.rom_next {
                match self.rom.command(index) {
                    Some(command) => {
                        self.exec.rom_next = index.checked_add(1);
                        (command, Source::Rom)
                    }
                    None => {
                        // Decision 2: 0x02 CR when the ROM job ends.
                        self.exec.rom_next = None;
                        self.send(Reply::Ready);
                        continue;
                    }
                }
            } else if self.exec.memory_armed {
                match self.memory.front() {
                    Some(command) => (command, Source::Memory),
                    None => {
                        // Manual 1.4.2: 0x02 CR when the buffer has run.
                        self.exec.memory_armed = false;
                        self.send(Reply::Ready);
                        continue;
                    }
                }
            } else {
                break;
            };
            match self.begin(command, at) {
                Some(step) => self.exec.active = Some(Active { step, source }),
                None => self.finish(source),
            }
        }
    }

    /// A command has run: its memory cell frees.
    fn finish(&mut self, source: Source) {
        if source == Source::Memory && self.memory.finish_front() {
            self.send(Reply::Ready);
        }
    }

    /// Runs a stored command; the step when it lasts.
    fn begin(&mut self, command: Command, at: Instant) -> Option<Step> {
        match command {
            Command::StartSpeed(speed) => self.settings.start = speed,
            Command::EndSpeed { slot, speed } => self.settings.set_end_speed(slot, speed),
            Command::Ramp(ms) => self.settings.ramp = ms,
            Command::LinkE1(on) => self.settings.link_e1 = on,
            Command::SetOutput { output, on } => {
                if let Some(cell) = self
                    .outputs
                    .get_mut(usize::from(output.get().saturating_sub(1)))
                {
                    *cell = on;
                }
            }
            Command::Wait(ms) => {
                let remaining = Duration::from_millis(u64::from(ms.get()));
                return Some(Step::Wait(Wait {
                    remaining,
                    until: Some(at + remaining),
                }));
            }
            Command::Move(mv) => return self.begin_move(&mv, at),
            Command::Reference(order) => {
                // Manual 1.5.3 example `@X100110`: the position is unknown
                // until the reference run has found it.
                self.position_unknown = true;
                let mut run = HomeRun {
                    order,
                    index: 0,
                    phase: HomePhase::Search,
                };
                return self.plan_home(&mut run, at).then_some(Step::Home(run));
            }
            // Master commands run when they arrive; they never reach the
            // data memory or the ROM.
            Command::Reset
            | Command::Version
            | Command::Status
            | Command::Position(_)
            | Command::Halt
            | Command::Stop
            | Command::Pause
            | Command::Resume
            | Command::StoreJob
            | Command::RunJob => {}
        }
        None
    }

    fn begin_move(&mut self, mv: &Move, at: Instant) -> Option<Step> {
        let mut targets = self.mech.counters(at);
        for (axis, steps) in mv.targets() {
            if let Some(target) = targets.get_mut(axis.index()) {
                *target = match mv.mode() {
                    MoveMode::Absolute => steps.get(),
                    MoveMode::Relative => target.wrapping_add(steps.get()),
                };
            }
        }
        let mut step = VectorMove {
            slot: mv.slot(),
            targets,
            awaiting_e1: self.settings.link_e1,
        };
        let done = self.continue_move(&mut step, at);
        (!done).then_some(Step::Move(step))
    }

    /// Starts (or restarts after a pause) the motion towards the targets
    /// unless the move still waits for E1. True when there is nothing left
    /// to do.
    fn continue_move(&mut self, mv: &mut VectorMove, at: Instant) -> bool {
        if mv.awaiting_e1 {
            if !self.e1 {
                return false;
            }
            mv.awaiting_e1 = false;
        }
        let mut delta = [0i64; 3];
        for ((d, target), counter) in delta.iter_mut().zip(mv.targets).zip(self.mech.counters(at)) {
            // 32-bit counter arithmetic, as the interface's own.
            *d = i64::from(target.wrapping_sub(counter));
        }
        !self
            .mech
            .start(delta, self.settings.vector_ramp(mv.slot), at)
    }

    /// Starts the next motion of a reference run; false once every axis is
    /// referenced. Call only at rest.
    fn plan_home(&mut self, run: &mut HomeRun, at: Instant) -> bool {
        let ramp = self.settings.reference_ramp();
        // Each pass moves the run on by a phase or an axis: at most nine.
        loop {
            let Some(axis) = run.order.axes().get(run.index).copied() else {
                self.position_unknown = false;
                return false;
            };
            match run.phase {
                HomePhase::Search => {
                    if !self.mech.on_reference_switch(axis) {
                        let steps = self.mech.steps_down_to_switch(axis).unwrap_or(SEARCH_STEPS);
                        if self.mech.start_single(axis, -steps, ramp, at) {
                            return true;
                        }
                    }
                    run.phase = HomePhase::Free;
                }
                HomePhase::Free => {
                    let steps = self.mech.steps_off_switch(axis);
                    if self.mech.start_single(axis, steps, ramp, at) {
                        return true;
                    }
                    let offset = REFERENCE_OFFSET_STEPS as i32;
                    run.phase = HomePhase::Offset {
                        target: self.mech.counter(axis, at).wrapping_add(offset),
                    };
                }
                HomePhase::Offset { target } => {
                    let left = target.wrapping_sub(self.mech.counter(axis, at));
                    if left > 0 && self.mech.start_single(axis, i64::from(left), ramp, at) {
                        return true;
                    }
                    // At the reference point: the counter's zero.
                    self.mech.set_counter(axis, 0);
                    run.index += 1;
                    run.phase = HomePhase::Search;
                }
            }
        }
    }

    /// The motion under way has come to rest at `at`.
    fn segment_ended(&mut self, at: Instant) {
        self.mech.settle(at);
        let Some(mut active) = self.exec.active.take() else {
            return;
        };
        match self.exec.mode {
            Mode::Ending => {
                // Manual 1.5.11: the job has ended; its 0x02 CR now that the
                // axes are at rest.
                self.exec.mode = Mode::Running;
                self.send(Reply::Ready);
                return;
            }
            Mode::Pausing { resume } => {
                self.exec.mode = if resume { Mode::Running } else { Mode::Paused };
            }
            Mode::Running | Mode::Paused => {}
        }
        let go_on = self.exec.mode == Mode::Running;
        let done = match &mut active.step {
            Step::Move(mv) => {
                self.mech.counters(at) == mv.targets || (go_on && self.continue_move(mv, at))
            }
            Step::Home(run) => go_on && !self.plan_home(run, at),
            Step::Wait(_) => false,
        };
        if done {
            self.finish(active.source);
        } else {
            self.exec.active = Some(active);
        }
    }

    /// `@A` (manual 1.5.13): ramp down and wait. Nothing to interrupt when no
    /// job runs.
    pub(super) fn pause(&mut self, at: Instant) {
        if !self.exec.is_active() || self.exec.mode != Mode::Running {
            return;
        }
        if self.mech.is_moving() {
            self.mech.brake(at);
            self.exec.mode = Mode::Pausing { resume: false };
            return;
        }
        if let Some(Active {
            step: Step::Wait(wait),
            ..
        }) = &mut self.exec.active
            && let Some(until) = wait.until.take()
        {
            wait.remaining = until.saturating_duration_since(at);
        }
        self.exec.mode = Mode::Paused;
    }

    /// `@C` (manual 1.5.14): go on where the pause interrupted; ignored
    /// without a pause. During the pause's ramp it takes effect at rest.
    pub(super) fn resume(&mut self, at: Instant) {
        match self.exec.mode {
            Mode::Pausing { .. } => self.exec.mode = Mode::Pausing { resume: true },
            Mode::Paused => {
                self.exec.mode = Mode::Running;
                let Some(mut active) = self.exec.active.take() else {
                    return;
                };
                let done = match &mut active.step {
                    Step::Wait(wait) => {
                        wait.until = Some(at + wait.remaining);
                        false
                    }
                    Step::Move(mv) => self.continue_move(mv, at),
                    Step::Home(run) => !self.plan_home(run, at),
                };
                if done {
                    self.finish(active.source);
                } else {
                    self.exec.active = Some(active);
                }
            }
            Mode::Running | Mode::Ending => {}
        }
    }

    /// `@B` (manual 1.5.11): ramp down, the job ends, positions kept. The
    /// queued commands are dropped; the job's 0x02 CR follows at rest.
    pub(super) fn halt_job(&mut self, at: Instant) {
        let was_active = self.exec.is_active();
        self.exec.memory_armed = false;
        self.exec.rom_next = None;
        if self.memory.clear() {
            self.send(Reply::Ready);
        }
        if self.exec.mode == Mode::Ending {
            return;
        }
        match &mut self.exec.active {
            Some(active) if self.mech.is_moving() => {
                self.mech.brake(at);
                active.source = Source::Detached;
                self.exec.mode = Mode::Ending;
            }
            _ => {
                self.exec.active = None;
                self.exec.mode = Mode::Running;
                if was_active {
                    self.send(Reply::Ready);
                }
            }
        }
    }

    /// What `@S` and `@R` share (manual 1.5.1, 1.5.12): stop without a ramp,
    /// end the job and the pause, clear the data memory, abort a ROM
    /// transfer, switch the outputs off. Owed 0x02 CRs follow at once.
    pub(super) fn abort(&mut self, at: Instant) {
        let was_active = self.exec.is_active();
        self.mech.halt(at);
        self.exec = Executor::default();
        if self.memory.clear() {
            self.send(Reply::Ready);
        }
        if was_active {
            self.send(Reply::Ready);
        }
        self.rom.abort_transfer();
        self.outputs = [false; 2];
    }

    /// `@J` (manual 1.5.18). False when there is no stored job or a job runs.
    pub(super) fn start_rom_job(&mut self) -> bool {
        if self.exec.is_active() || !self.rom.has_job() {
            return false;
        }
        self.exec.rom_next = Some(0);
        true
    }

    /// Input E1 went high: a move waiting for it starts (manual 1.5.19).
    pub(super) fn e1_rose(&mut self, at: Instant) {
        if self.exec.mode != Mode::Running || !self.exec.is_awaiting_e1() {
            return;
        }
        let Some(mut active) = self.exec.active.take() else {
            return;
        };
        let done = match &mut active.step {
            Step::Move(mv) => self.continue_move(mv, at),
            Step::Home(_) | Step::Wait(_) => false,
        };
        if done {
            self.finish(active.source);
        } else {
            self.exec.active = Some(active);
        }
    }
}
