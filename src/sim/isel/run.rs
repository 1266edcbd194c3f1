//! Jobs in progress and the events that move them on: legs of motion that
//! end or cross a switch, delays, the flash erase, stored program runs; and
//! the ways they end early (soft stop, break, limit switch, machine fault).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::motion::Ramp;
use crate::proto::isel::{CncCommand, PortWatch, ReplyCode, SyncChar};

use super::io::{PortCondition, SPINDLE_BIT};
use super::path::{LegRun, Path};
use super::plan::{Action, LegSpec, Until};
use super::program::ProgramRun;
use super::{Activity, IselSim, Paused, ReplyTo};

/// What an activity is doing right now.
#[derive(Debug, Clone)]
pub enum Step {
    Motion(Box<MotionJob>),
    /// `@0k`: the flash is being erased (manual 2.2.17).
    Erase {
        until: Instant,
    },
    /// A program waits: a delay `5` (not `stoppable`, manual 3.2.6) or the
    /// time a command takes.
    Wait {
        until: Instant,
        stoppable: bool,
    },
    /// A program waits for a character from the host (`2`, manual 3.2.4).
    Sync {
        sync: SyncChar,
        offset: i16,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JobKind {
    /// A move; a soft stop keeps its rest.
    Move,
    /// `@0R` / CNC `7`.
    Reference,
    /// `@0F`.
    Clear,
}

/// Why a job is ramping down.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopCause {
    /// 0xFD or the stop key: the move answers `F`, its rest is kept.
    Soft,
    /// 0xFF: answers `F`, nothing is kept.
    Break,
    /// The port condition of `@0Z` or CNC `6` came true: the move is done.
    Condition,
    /// The abort input of `@0IA` (manual 4.2.11): `F`, the run ends.
    Abort,
    /// The hood input of `@0IH` (manual 4.2.13): `H`, the run ends.
    Hood,
}

/// Legs of motion travelled one after the other.
#[derive(Debug, Clone)]
pub struct MotionJob {
    pub kind: JobKind,
    pub legs: VecDeque<LegSpec>,
    pub current: Option<(LegSpec, LegRun)>,
    pub condition: Option<PortCondition>,
    pub stopping: Option<StopCause>,
    /// A limit switch that trips stops the job with `2` (not in test mode
    /// and not while referencing, manual 2.2.24, 4.2.2).
    pub monitor_limits: bool,
}

impl MotionJob {
    pub fn new(kind: JobKind, legs: Vec<LegSpec>, monitor_limits: bool) -> MotionJob {
        MotionJob {
            kind,
            legs: legs.into(),
            current: None,
            condition: None,
            stopping: None,
            monitor_limits,
        }
    }
}

/// Something due at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    LegEnd,
    Switch {
        axis: usize,
        side: usize,
    },
    /// The probe touches or leaves the work piece (`probe-surface`).
    Surface,
    EraseDone,
    WaitDone,
    /// A key `press`ed is let go (`controls::START_KEY`, `STOP_KEY`).
    KeyRelease(usize),
}

/// The inputs as they were before a change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Snapshot {
    ports: [u8; 4],
    monitored: u8,
    fault: bool,
    motion_allowed: bool,
}

/// One tenth of a second, the unit of CNC `5` (manual 3.2.6).
const TENTH: Duration = Duration::from_millis(100);

impl IselSim {
    pub(super) fn motion_run(&self) -> Option<&LegRun> {
        match &self.activity {
            Some(Activity {
                step: Step::Motion(job),
                ..
            }) => job.current.as_ref().map(|(_, run)| run),
            _ => None,
        }
    }

    fn motion_job_mut(&mut self) -> Option<&mut MotionJob> {
        match &mut self.activity {
            Some(Activity {
                step: Step::Motion(job),
                ..
            }) => Some(job),
            _ => None,
        }
    }

    pub(super) fn snapshot(&self) -> Snapshot {
        Snapshot {
            ports: self.ports(),
            monitored: self.monitored_byte(),
            fault: self.inputs.machine_fault(),
            motion_allowed: self.hood_circuit_allows_motion(),
        }
    }

    pub(super) fn compute_next(&self, now: Instant) -> Option<(Instant, Event)> {
        let release = self
            .key_release
            .iter()
            .enumerate()
            .filter_map(|(key, at)| at.map(|at| (at.max(now), Event::KeyRelease(key))))
            .min_by_key(|(at, _)| *at);
        match (self.next_activity_event(now), release) {
            (Some(a), Some(r)) => Some(if r.0 < a.0 { r } else { a }),
            (a, r) => a.or(r),
        }
    }

    fn next_activity_event(&self, now: Instant) -> Option<(Instant, Event)> {
        let activity = self.activity.as_ref()?;
        match &activity.step {
            Step::Erase { until } => Some((*until, Event::EraseDone)),
            Step::Wait { until, .. } => Some((*until, Event::WaitDone)),
            Step::Sync { .. } => None,
            Step::Motion(job) => {
                let (_, run) = job.current.as_ref()?;
                let end = run.end_time().max(now);
                let switch = run
                    .next_switch_change(&self.axes, now)
                    .map(|(f, axis, side)| (f, Event::Switch { axis, side }));
                let surface = self.surface().and_then(|s| {
                    run.next_surface_change(&s, &self.axes, self.surface_touch, now)
                        .map(|f| (f, Event::Surface))
                });
                // The earlier of the two; a switch first where both fall
                // on the same point.
                let first = [switch, surface]
                    .into_iter()
                    .flatten()
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                if let Some((f, event)) = first {
                    let at = run.time_of_fraction(f, now);
                    if at <= end {
                        return Some((at, event));
                    }
                }
                Some((end, Event::LegEnd))
            }
        }
    }

    pub(super) fn handle_event(&mut self, event: Event, t: Instant) {
        match event {
            Event::LegEnd => self.leg_end(t),
            Event::Switch { axis, side } => {
                let before = self.snapshot();
                if let Some(p) = self
                    .axes
                    .get_mut(axis)
                    .and_then(|a| a.pressed.get_mut(side))
                {
                    *p = !*p;
                }
                self.inputs_changed(before, t);
            }
            Event::Surface => {
                // Like a switch: the change goes through the same reaction,
                // so the condition of `@0Z` or CNC `6` on port 1 bit 5
                // brakes the move from the speed it has here.
                let before = self.snapshot();
                self.surface_touch = !self.surface_touch;
                self.inputs_changed(before, t);
            }
            Event::EraseDone => {
                // The flash is empty now: a new program may be stored.
                self.flash.program = None;
                self.finish(ReplyCode::Ok, t);
            }
            Event::KeyRelease(key) => self.release_key(key, t),
            Event::WaitDone => {
                if let Some(act) = self.activity.take() {
                    match act.program {
                        Some(run) => self.run_program(act.reply, run, t),
                        None => self.finish_with(act.reply, false, ReplyCode::Ok),
                    }
                }
            }
        }
    }

    /// Start `job`'s first leg that moves: the step to wait on, or `None`
    /// when nothing moves (its actions are done).
    pub(super) fn begin_job(&mut self, mut job: MotionJob, t: Instant) -> Option<Step> {
        self.start_leg(&mut job, t)
            .then(|| Step::Motion(Box::new(job)))
    }

    fn start_leg(&mut self, job: &mut MotionJob, t: Instant) -> bool {
        while let Some(spec) = job.legs.pop_front() {
            match spec {
                LegSpec::Act(action) => {
                    self.act(action);
                    continue;
                }
                LegSpec::Seek { until, .. } if self.until_met(until) => continue,
                _ => {}
            }
            let Some(layout) = spec.layout(self.counters()) else {
                continue;
            };
            let speed = f64::from(layout.speed);
            let ramp = Ramp {
                start_hz: if layout.constant {
                    speed
                } else {
                    f64::from(self.start_stop)
                },
                max_hz: speed,
                accel_hz_per_s: f64::from(self.acceleration) * 1000.0,
            };
            let run = LegRun::new(layout.path, layout.end, layout.distance, ramp, t);
            job.current = Some((spec, run));
            return true;
        }
        false
    }

    fn act(&mut self, action: Action) {
        match action {
            Action::Reference(i) => {
                if let Some(axis) = self.axes.get_mut(i) {
                    axis.set_counter(0);
                }
                if let Some(a) = Axis::from_index(i) {
                    self.referenced = self.referenced.with(a);
                }
                if let Some(z) = self.virtual_zero.get_mut(i) {
                    *z = 0;
                }
            }
        }
    }

    /// Whether a seek's switch reads as it waits for. A switch `@0IE`
    /// disables is never seen (manual 2.2.22: the axis runs on).
    fn until_met(&self, until: Until) -> bool {
        match until {
            Until::Active { axis, input } => self.input_seen(axis, input),
            Until::Released { axis, input } => !self.input_seen(axis, input),
        }
    }

    fn leg_end(&mut self, t: Instant) {
        let Some(Activity {
            reply,
            mut program,
            step,
        }) = self.activity.take()
        else {
            return;
        };
        let mut job = match step {
            Step::Motion(job) => job,
            other => {
                self.activity = Some(Activity {
                    reply,
                    program,
                    step: other,
                });
                return;
            }
        };
        let Some((spec, run)) = job.current.take() else {
            self.activity = Some(Activity {
                reply,
                program,
                step: Step::Motion(job),
            });
            return;
        };
        let at = run.final_counters();
        self.set_counters(at);
        let ran_program = program.is_some();
        match job.stopping {
            None => {
                if self.start_leg(&mut job, t) {
                    self.activity = Some(Activity {
                        reply,
                        program,
                        step: Step::Motion(job),
                    });
                } else {
                    self.step_done(reply, program, t);
                }
            }
            Some(StopCause::Condition) => self.step_done(reply, program, t),
            Some(StopCause::Soft) => {
                if job.kind == JobKind::Move {
                    let mut legs: Vec<LegSpec> = remainder(&spec, &run, at).into_iter().collect();
                    legs.extend(job.legs);
                    self.paused = Some(Paused {
                        legs,
                        condition: job.condition,
                        program: program.take(),
                    });
                }
                self.finish_with(reply, ran_program, ReplyCode::UserStop);
            }
            Some(StopCause::Break | StopCause::Abort) => {
                self.finish_with(reply, ran_program, ReplyCode::UserStop)
            }
            Some(StopCause::Hood) => self.finish_with(reply, ran_program, ReplyCode::HoodOpen),
        }
    }

    /// A step finished without error: a program goes on, anything else
    /// answers `0`.
    fn step_done(&mut self, reply: ReplyTo, program: Option<ProgramRun>, t: Instant) {
        match program {
            Some(run) => self.run_program(reply, run, t),
            None => self.finish_with(reply, false, ReplyCode::Ok),
        }
    }

    /// React to inputs that changed (the carriage crossed a switch, or the
    /// operator set something).
    pub(super) fn inputs_changed(&mut self, before: Snapshot, t: Instant) {
        let now = self.snapshot();
        if now.fault && !before.fault {
            self.fault_event(t);
            return;
        }
        if before.motion_allowed && !now.motion_allowed && self.motion_run().is_some() {
            // The hood opened in automatic mode while the axes move: the
            // safety circuit stops them like an E-stop (chapter 5, code 9).
            self.abort_activity(t, ReplyCode::MachineFault);
            self.lose_reference();
            return;
        }
        let newly = now.monitored & !before.monitored;
        let condition_met =
            |sim: &IselSim, c: Option<PortCondition>| c.is_some_and(|c| c.met(sim.port(c.port)));
        if let Some(job) = self.motion_job_mut() {
            let monitor = job.monitor_limits;
            let until = job.current.as_ref().and_then(|(spec, _)| match spec {
                LegSpec::Seek { until, .. } => Some(*until),
                _ => None,
            });
            let condition = job.condition;
            let stopping = job.stopping;
            if monitor && newly != 0 {
                // A limit switch during a move: stop without a ramp, `2`
                // (chapter 5), re-initialise and reference.
                self.abort_activity(t, ReplyCode::LimitSwitch);
                self.lose_reference();
                return;
            }
            if until.is_some_and(|u| self.until_met(u)) {
                self.halt_leg(t);
            } else if stopping.is_none() && condition_met(self, condition) {
                self.brake(t, StopCause::Condition);
            }
        }
        if self.activity.as_ref().is_some_and(|a| a.program.is_some()) {
            self.check_watches(t);
        }
    }

    /// The watches of `@0IN`, `@0IH`, `@0IA` while a program runs
    /// (manual 4.2.11-4.2.14): the set value differs under the mask.
    fn check_watches(&mut self, t: Instant) {
        let ports = self.ports();
        let off_target = |w: PortWatch| {
            let port = ports
                .get(usize::from(w.port.number()))
                .copied()
                .unwrap_or(0);
            w.mask != 0 && port & w.mask != w.value & w.mask
        };
        if off_target(self.init.estop_input) {
            self.abort_activity(t, ReplyCode::MachineFault);
            self.lose_reference();
            self.outputs.control &= !SPINDLE_BIT;
        } else if off_target(self.init.hood_input) {
            self.stop_activity(t, StopCause::Hood, ReplyCode::HoodOpen);
        } else if off_target(self.init.abort_input) {
            self.stop_activity(t, StopCause::Abort, ReplyCode::UserStop);
        }
    }

    /// Ramp a moving job down for `cause`, or end a waiting one with `code`.
    fn stop_activity(&mut self, t: Instant, cause: StopCause, code: ReplyCode) {
        if self.motion_run().is_some() {
            self.brake(t, cause);
        } else if self.activity.is_some() {
            self.finish(code, t);
        }
    }

    /// Start ramping the current leg down (decision 6: without step loss).
    fn brake(&mut self, t: Instant, cause: StopCause) {
        if let Some(job) = self.motion_job_mut() {
            job.stopping = Some(cause);
            if let Some((_, run)) = job.current.as_mut() {
                let elapsed = run.elapsed(t);
                run.motion.brake(elapsed);
            }
        }
    }

    /// Stop the current leg at once; the job goes on with its next leg.
    fn halt_leg(&mut self, t: Instant) {
        if let Some(job) = self.motion_job_mut()
            && let Some((_, run)) = job.current.as_mut()
        {
            let elapsed = run.elapsed(t);
            run.motion.halt(elapsed);
        }
    }

    /// Stop any motion at once (limit switch, E-stop, reset), leaving the
    /// counters where the axes stand. The activity itself stays.
    pub(super) fn halt_motion(&mut self, t: Instant) {
        let mut at = None;
        if let Some(job) = self.motion_job_mut()
            && let Some((_, mut run)) = job.current.take()
        {
            let elapsed = run.elapsed(t);
            run.motion.halt(elapsed);
            at = Some(run.final_counters());
            job.legs.clear();
        }
        if let Some(at) = at {
            self.set_counters(at);
        }
    }

    /// Stop at once and answer `code`; a program run ends.
    fn abort_activity(&mut self, t: Instant, code: ReplyCode) {
        if matches!(
            self.activity,
            Some(Activity {
                step: Step::Erase { .. },
                ..
            })
        ) {
            // Erasing the flash is not motion: it goes on.
            return;
        }
        self.halt_motion(t);
        self.finish(code, t);
    }

    /// An E-stop circuit opened, the power failed or the power stages
    /// overheated (chapter 5, code 9): motion stops at once and answers
    /// `9`, the spindle stops, the controller needs re-initialising and
    /// referencing.
    pub(super) fn fault_event(&mut self, t: Instant) {
        self.abort_activity(t, ReplyCode::MachineFault);
        self.lose_reference();
        self.outputs.control &= !SPINDLE_BIT;
    }

    /// 0xFD or the stop key (manual 2.2.31, decision 6).
    pub(super) fn soft_stop(&mut self, t: Instant, from_key: bool) {
        let Some(act) = self.activity.as_mut() else {
            return;
        };
        match &mut act.step {
            Step::Motion(job) => {
                let seeking_switch = matches!(
                    job.current,
                    Some((
                        LegSpec::Seek {
                            until: Until::Active { .. },
                            ..
                        },
                        _
                    ))
                );
                if from_key && job.kind == JobKind::Reference && seeking_switch {
                    // Manual 2.2.22: the stop key stands in for a missing
                    // reference switch.
                    self.halt_leg(t);
                } else if job.stopping.is_none() {
                    self.brake(t, StopCause::Soft);
                }
            }
            Step::Erase { .. }
            | Step::Wait {
                stoppable: false, ..
            } => {}
            Step::Wait { .. } | Step::Sync { .. } => {
                let program = act.program.take();
                let reply = act.reply;
                self.activity = None;
                self.paused = Some(Paused {
                    legs: Vec::new(),
                    condition: None,
                    program,
                });
                self.finish_with(reply, true, ReplyCode::UserStop);
            }
        }
    }

    /// 0xFF (manual 2.2.31, decision 6): ramp down and forget the rest; with
    /// nothing moving, forget what a soft stop kept.
    pub(super) fn break_off(&mut self, t: Instant) {
        match self.activity.as_ref().map(|a| &a.step) {
            None => self.paused = None,
            Some(Step::Motion(_)) => self.brake(t, StopCause::Break),
            Some(Step::Erase { .. }) => {}
            Some(Step::Wait { .. } | Step::Sync { .. }) => self.finish(ReplyCode::UserStop, t),
        }
    }

    /// End the current activity with `code`.
    pub(super) fn finish(&mut self, code: ReplyCode, _t: Instant) {
        if let Some(act) = self.activity.take() {
            self.finish_with(act.reply, act.program.is_some(), code);
        }
    }

    /// Answer `code` (if the host asked) and, after a program run, set the
    /// error signal of `@0Ia` (manual 4.2.12).
    pub(super) fn finish_with(&mut self, reply: ReplyTo, program: bool, code: ReplyCode) {
        self.activity = None;
        if program {
            self.signal_error(!matches!(code, ReplyCode::Ok | ReplyCode::UserStop));
        }
        if reply == ReplyTo::Host {
            self.answer_code(code);
        }
    }

    /// `@0S` or the start key (manual 2.2.23): resume what a soft stop
    /// kept, else run the stored program; `G` when there is neither.
    pub(super) fn start(&mut self, reply: ReplyTo, t: Instant) -> Result<(), ReplyCode> {
        if self.activity.is_some() {
            return Ok(());
        }
        if let Some(paused) = self.paused.take() {
            if paused.legs.is_empty() {
                match paused.program {
                    Some(run) => self.run_program(reply, run, t),
                    None => self.finish_with(reply, false, ReplyCode::Ok),
                }
                return Ok(());
            }
            if let Err(code) = self.motion_gate(true) {
                if code == ReplyCode::HoodOpen {
                    self.paused = Some(paused);
                }
                return Err(code);
            }
            let mut job = MotionJob::new(JobKind::Move, paused.legs, !self.test_mode);
            job.condition = paused.condition;
            match self.begin_job(job, t) {
                Some(step) => {
                    self.activity = Some(Activity {
                        reply,
                        program: paused.program,
                        step,
                    })
                }
                None => match paused.program {
                    Some(run) => self.run_program(reply, run, t),
                    None => self.finish_with(reply, false, ReplyCode::Ok),
                },
            }
            return Ok(());
        }
        match &self.flash.program {
            Some(p) if p.valid => {
                self.reference_speeds = p.reference_speeds;
                self.signal_error(false);
                self.run_program(reply, ProgramRun::new(), t);
                Ok(())
            }
            _ => Err(ReplyCode::InvalidDataField),
        }
    }

    /// Run the stored program from `run.pc` until something takes time.
    pub(super) fn run_program(&mut self, reply: ReplyTo, run: ProgramRun, t: Instant) {
        // The watches of chapter 4 are read before every command.
        self.activity = Some(Activity {
            reply,
            program: Some(run),
            step: Step::Wait {
                until: t,
                stoppable: true,
            },
        });
        self.check_watches(t);
        let Some(Activity {
            program: Some(mut run),
            ..
        }) = self.activity.take()
        else {
            return;
        };
        let (command, len) = match &self.flash.program {
            Some(p) => (p.lines.get(run.pc).cloned(), p.lines.len()),
            None => (None, 0),
        };
        let Some(command) = command else {
            return self.finish_with(reply, true, ReplyCode::Ok);
        };
        let pause = Step::Wait {
            until: t + self.config.program_step,
            stoppable: true,
        };
        let next = match command {
            CncCommand::End => return self.finish_with(reply, true, ReplyCode::Ok),
            CncCommand::SendSync(sync) => {
                self.sync_char(sync);
                run.pc += 1;
                Ok(pause)
            }
            CncCommand::WaitSync { sync, offset } => Ok(Step::Sync { sync, offset }),
            CncCommand::Loop { count, offset } => {
                run.take_loop(run.pc, count, offset, len).map(|pc| {
                    run.pc = pc;
                    pause
                })
            }
            CncCommand::Delay(tenths) => {
                run.pc += 1;
                Ok(Step::Wait {
                    until: t + TENTH * u32::from(tenths),
                    stoppable: false,
                })
            }
            CncCommand::PortCondition { port, bits, value } => {
                run.condition = Some(PortCondition::from_bits(port, bits, value));
                run.pc += 1;
                Ok(pause)
            }
            CncCommand::BranchOnPort {
                port,
                bits,
                value,
                offset,
            } => {
                let met = PortCondition::from_bits(port, bits, value).met(self.port(port));
                let target = if met {
                    ProgramRun::target(run.pc, offset, len)
                } else {
                    Ok(run.pc + 1)
                };
                target.map(|pc| {
                    run.pc = pc;
                    pause
                })
            }
            CncCommand::SetPort { port, bits, value } => {
                let value = self.outputs.with_bits(port, bits, value);
                self.write_output(port, value).map(|()| {
                    run.pc += 1;
                    pause
                })
            }
            other => match other.as_dnc() {
                Some(command) => {
                    run.pc += 1;
                    if command.needs_reference() {
                        self.next_move_condition = run.condition.take();
                    }
                    let exec = self.execute(&command, t);
                    self.next_move_condition = None;
                    match exec {
                        super::exec::Exec::Reply(r) if r.code().is_ok() => Ok(pause),
                        super::exec::Exec::Reply(r) => Err(r.code()),
                        super::exec::Exec::Step(step) => Ok(step),
                    }
                }
                // Every storable command is either handled above or has a
                // DNC twin (CncCommand::as_dnc).
                None => Err(ReplyCode::NotStorable),
            },
        };
        match next {
            Ok(step) => {
                self.activity = Some(Activity {
                    reply,
                    program: Some(run),
                    step,
                })
            }
            Err(code) => self.finish_with(reply, true, code),
        }
    }

    /// A character while a program waits for one (`2`, manual 3.2.4): the
    /// right one jumps, any other goes on with the next command.
    pub(super) fn sync_received(&mut self, byte: u8, sync: SyncChar, offset: i16, t: Instant) {
        let Some(act) = self.activity.take() else {
            return;
        };
        let Some(mut run) = act.program else {
            return;
        };
        let len = self.flash.program.as_ref().map_or(0, |p| p.lines.len());
        let next = if byte == sync.byte() {
            ProgramRun::target(run.pc, offset, len)
        } else {
            Ok(run.pc + 1)
        };
        match next {
            Ok(pc) => {
                run.pc = pc;
                self.activity = Some(Activity {
                    reply: act.reply,
                    program: Some(run),
                    step: Step::Wait {
                        until: t + self.config.program_step,
                        stoppable: true,
                    },
                });
            }
            Err(code) => self.finish_with(act.reply, true, code),
        }
    }

    /// The physical side the axis stands in a switch on, if it does.
    pub(super) fn pressed_side(&self, axis: usize) -> Option<usize> {
        let a = self.axes.get(axis)?;
        let swapped = Axis::from_index(axis).is_some_and(|x| self.init.swap_limits.contains(x));
        (0..2)
            .find(|&input| a.contact(input, swapped))
            .map(|input| input ^ usize::from(swapped))
    }
}

/// What is left of a leg stopped at `at`: the same absolute target for a
/// line, the rest of the sweep for an arc; seeks and steps of a reference
/// run are not kept.
fn remainder(spec: &LegSpec, run: &LegRun, at: [i64; 4]) -> Option<LegSpec> {
    match (spec, &run.path) {
        (LegSpec::Line { .. }, _) => Some(spec.clone()),
        (LegSpec::Arc { end, speed, .. }, Path::Arc(arc)) => {
            let f = run.fraction_at(run.end_time());
            (f < 1.0).then(|| {
                let arc = arc.remainder(f, at.map(|v| v as f64));
                LegSpec::Arc {
                    distance: arc.steps.max(1),
                    arc: Box::new(arc),
                    end: *end,
                    speed: *speed,
                }
            })
        }
        _ => None,
    }
}
