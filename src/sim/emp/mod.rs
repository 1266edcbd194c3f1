//! Simulator of an EMP link: one to fifteen MSR DRS-500-ECS servo drives on one
//! serial line (`SimDevice`, sans-IO).
//!
//! Every byte goes through the EMP core: the core's [`FrameDecoder`] frames
//! what arrives, [`Request::decode`] validates it, and replies are the core's
//! [`Reply`] encoded with [`Reply::encode`] (`Reply::rejecting` for frames
//! that are no valid request). The link is modelled as the manual's daisy
//! chain ("Die Befehle werden dabei durch alle Module durchgereicht, bis das
//! Modul mit der richtigen Adresse die Daten herausfiltert"): a request is
//! answered by the drive with its DS only, a frame for an address nobody has
//! is answered by nobody, and frames with an odd CMD (replies travelling the
//! chain) are passed on without reaction.
//!
//! Each drive answers a request [`PROCESSING_TIME`] (1.6 ms) after its EOF
//! has arrived: "Die gesamte Datenübertragung dauert bei 38.400 Baud ca. 10,8
//! ms (4,6 ms Empfang, 1,6 ms Verarbeitung in der Steuerung, 4,6 ms
//! Rückantwort)". The request takes effect at that moment too, and the reply
//! carries the state of that moment. Long actions then send their completion
//! on their own when the axis gets there (`docs/decisions.md` EMP
//! decision 1). Wire time is the shell's business.
//!
//! Modules: [`config`] (what a link is built from), [`drive`] (one drive's
//! commands and replies), `servo` (the axis, its switches, homing),
//! `kinematics` (trajectories over time), `analog` (ADC and joystick),
//! `clock` (RTC), `controls` (operator inputs).

mod analog;
mod clock;
pub mod config;
mod controls;
mod drive;
mod kinematics;
mod servo;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::time::Instant;

pub use config::{DriveConfig, EmpSimConfig, EmpSimError, SurfaceProbe};
pub use drive::{DriveSnapshot, PROCESSING_TIME, SLOW_ADC_PROCESSING_TIME};

use self::drive::Drive;
use super::{InputControl, SimDevice};
use crate::config::Profile;
use crate::proto::emp::{
    self, DriveAddress, Frame, FrameDecoder, Incoming, OperatingMode, Request, RequestError,
};
use crate::wire::LineSettings;

/// Events handled in one `advance` at most. Far more than any real interval
/// needs; if it is ever reached the rest waits for the next call (the
/// deadline stays due), so the model can never hang its caller.
const MAX_STEPS_PER_ADVANCE: usize = 100_000;

/// A request waiting for its drive to finish processing it.
#[derive(Debug, Clone)]
struct Queued {
    due: Instant,
    drive: usize,
    frame: Frame,
    request: Result<Request, RequestError>,
}

/// What the link dropped without answering, for `describe` and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Runs of bytes the decoder could not frame (garbage, wrong length,
    /// lower case).
    pub framing_errors: u64,
    /// Frames for an address no drive has, and replies on the line.
    pub ignored_frames: u64,
}

/// The simulated link.
#[derive(Debug, Clone)]
pub struct EmpSim {
    /// Sorted by address.
    drives: Vec<Drive>,
    /// When each drive finishes what it is processing.
    busy_until: Vec<Option<Instant>>,
    decoder: FrameDecoder,
    /// Sorted by due time; equal times keep arrival order.
    queue: Vec<Queued>,
    output: VecDeque<Vec<u8>>,
    /// The time the model has been brought up to.
    clock: Option<Instant>,
    stats: LinkStats,
    /// `fault stall`: the next long action on the link, whichever drive
    /// starts it, stays busy without moving.
    stall: bool,
    /// A work piece under the probe (variant `probe-surface`): the probe
    /// input follows the axes' positions whenever it is read.
    surface: Option<SurfaceProbe>,
}

impl EmpSim {
    pub fn new(config: EmpSimConfig) -> Result<EmpSim, EmpSimError> {
        config.validate()?;
        let mut drives = config
            .drives
            .into_iter()
            .map(|cfg| cfg.reload_value().map(|reload| Drive::new(cfg, reload)))
            .collect::<Result<Vec<_>, _>>()?;
        drives.sort_by_key(Drive::ds);
        Ok(EmpSim {
            busy_until: vec![None; drives.len()],
            drives,
            decoder: FrameDecoder::new(),
            queue: Vec::new(),
            output: VecDeque::new(),
            clock: None,
            stats: LinkStats::default(),
            stall: false,
            surface: None,
        })
    }

    /// The link of a machine profile's EMP axes (see
    /// [`EmpSimConfig::from_profile`]), with the probe surface of its
    /// `[sim] variants` ([`SurfaceProbe::from_profile`]).
    pub fn from_profile(profile: &Profile) -> Result<EmpSim, EmpSimError> {
        let config = EmpSimConfig::from_profile(profile)?;
        let surface = SurfaceProbe::from_profile(profile, &config)?;
        Ok(EmpSim::new(config)?.with_surface(surface))
    }

    /// The same link with a work piece under the probe (or none).
    pub fn with_surface(mut self, surface: Option<SurfaceProbe>) -> EmpSim {
        self.surface = surface;
        if let Some(t) = self.clock {
            self.follow_surface(t);
        }
        self
    }

    /// The probe input as the work piece sets it at `t`: the drive's
    /// index, the input (1-4) and its level. Touched while the probing
    /// axis stands inside the material over the X and Y drives' positions
    /// (0 for an axis the link lacks).
    fn surface_input(&self, t: Instant) -> Option<(usize, u8, bool)> {
        let p = self.surface?;
        let at = |ds: Option<DriveAddress>| {
            ds.and_then(|ds| self.drives.iter().find(|d| d.ds() == ds))
                .map_or(0.0, |d| d.physical(t))
        };
        let touched = p.surface.touches(at(p.x), at(p.y), at(Some(p.axis)));
        let index = self.drive_index(p.drive.byte())?;
        Some((index, p.input, touched == p.active_high))
    }

    /// Bring the probe input up to `t`, before anything reads it.
    fn follow_surface(&mut self, t: Instant) {
        if let Some((index, n, level)) = self.surface_input(t)
            && let Some(d) = self.drives.get_mut(index)
        {
            d.set_input(n, level);
        }
    }

    /// A drive's state at `t`, its probe input as the work piece sets it.
    fn drive_snapshot(&self, index: usize, t: Instant) -> Option<DriveSnapshot> {
        let mut s = self.drives.get(index)?.snapshot(t);
        if let Some((i, n, level)) = self.surface_input(t)
            && i == index
        {
            s.inputs = s.inputs.with(n, level);
        }
        Some(s)
    }

    /// The addresses on the link, lowest first.
    pub fn addresses(&self) -> Vec<DriveAddress> {
        self.drives.iter().map(Drive::ds).collect()
    }

    /// One drive's state at `now` (as far as the model has been advanced).
    pub fn snapshot(&self, ds: DriveAddress, now: Instant) -> Option<DriveSnapshot> {
        let index = self.drive_index(ds.byte())?;
        self.drive_snapshot(index, self.at_least_clock(now))
    }

    pub fn stats(&self) -> LinkStats {
        self.stats
    }

    fn at_least_clock(&self, now: Instant) -> Instant {
        self.clock.map_or(now, |c| c.max(now))
    }

    fn drive_index(&self, ds: u8) -> Option<usize> {
        self.drives.iter().position(|d| d.ds().byte() == ds)
    }

    /// A complete frame has arrived at `now`.
    fn accept(&mut self, frame: Frame, now: Instant) {
        let Some(index) = self.drive_index(frame.ds).filter(|_| !frame.is_reply()) else {
            self.stats.ignored_frames += 1;
            return;
        };
        let request = Request::decode(&frame);
        let Some(drive) = self.drives.get(index) else {
            return;
        };
        let processing = drive.processing_time(request.as_ref().ok().map(|r| &r.command));
        let start = match self.busy_until.get(index).copied().flatten() {
            Some(busy) => busy.max(now),
            None => now,
        };
        let due = start + processing;
        if let Some(slot) = self.busy_until.get_mut(index) {
            *slot = Some(due);
        }
        let at = self.queue.partition_point(|q| q.due <= due);
        self.queue.insert(
            at,
            Queued {
                due,
                drive: index,
                frame,
                request,
            },
        );
    }

    fn process(&mut self, q: Queued) {
        // `40 01` reads the inputs as the axes stand when it is processed.
        self.follow_surface(q.due);
        let Some(drive) = self.drives.get_mut(q.drive) else {
            return;
        };
        // The drive takes the armed stall when it starts a long action.
        drive.stall_next = self.stall;
        let replies = match q.request {
            Ok(request) => drive.execute(request.command, q.due),
            Err(e) => vec![drive.reject_frame(&q.frame, &e)],
        };
        if self.stall && !drive.stall_next {
            self.stall = false;
        }
        drive.stall_next = false;
        self.output
            .extend(replies.iter().map(|r| r.encode().to_vec()));
    }

    fn drive_event(&mut self, t: Instant, index: usize) {
        if let Some(reply) = self.drives.get_mut(index).and_then(|d| d.on_event(t)) {
            self.output.push_back(reply.encode().to_vec());
        }
    }

    /// The earliest drive event at or before `now`: (time, drive index).
    fn next_drive_event(&self, now: Instant) -> Option<(Instant, usize)> {
        self.drives
            .iter()
            .enumerate()
            .filter_map(|(i, d)| d.next_event().map(|t| (t, i)))
            .filter(|(t, _)| *t <= now)
            .min_by_key(|(t, _)| *t)
    }
}

impl SimDevice for EmpSim {
    fn line(&self) -> LineSettings {
        emp::LINE
    }

    fn on_byte(&mut self, byte: u8, now: Instant) {
        self.advance(now);
        let now = self.at_least_clock(now);
        match self.decoder.push(byte) {
            Some(Ok(Incoming::Frame(frame))) => self.accept(frame, now),
            // Another drive's identity text travelling the chain.
            Some(Ok(Incoming::Identity(_))) => self.stats.ignored_frames += 1,
            Some(Err(_)) => self.stats.framing_errors += 1,
            None => {}
        }
    }

    fn advance(&mut self, now: Instant) {
        let now = self.at_least_clock(now);
        if self.clock.is_none() {
            for d in &mut self.drives {
                d.start_clock(now);
            }
        }
        for _ in 0..MAX_STEPS_PER_ADVANCE {
            let request = self.queue.first().map(|q| q.due).filter(|t| *t <= now);
            let event = self.next_drive_event(now);
            match (request, event) {
                (None, None) => break,
                // The axis moves before a request of the same moment reads it.
                (Some(r), Some((t, i))) if t <= r => self.drive_event(t, i),
                (None, Some((t, i))) => self.drive_event(t, i),
                (Some(_), _) => {
                    let q = self.queue.remove(0);
                    self.process(q);
                }
            }
        }
        self.clock = Some(now);
    }

    fn next_deadline(&self) -> Option<Instant> {
        let request = self.queue.first().map(|q| q.due);
        let event = self.drives.iter().filter_map(Drive::next_event).min();
        match (request, event) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn poll_output(&mut self) -> Option<Vec<u8>> {
        self.output.pop_front()
    }

    fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
        self.advance(now);
        let now = self.at_least_clock(now);
        let parsed = controls::parse(control)?;
        let index = match parsed.drive {
            None => 0,
            Some(ds) => self.drive_index(ds.byte()).ok_or_else(|| {
                let known: Vec<String> = self.addresses().iter().map(|a| a.to_string()).collect();
                format!("no drive {ds} on this link (drives: {})", known.join(", "))
            })?,
        };
        if let (controls::Action::Input(n, _), Some((probe, input, _)), Some(s)) =
            (parsed.action, self.surface_input(now), self.surface)
            && (probe, input) == (index, n)
        {
            return Err(format!(
                "`{}` is the probe: it follows the probe surface {} (variant probe-surface) \
                 while one is set",
                control.name(),
                s.surface
            ));
        }
        let drive = self
            .drives
            .get_mut(index)
            .ok_or_else(|| "the link has no drives".to_string())?;
        match parsed.action {
            controls::Action::Input(n, level) => drive.set_input(n, level),
            controls::Action::AdcSet(channel, mv) => {
                drive.set_analog(channel, mv, now);
            }
            controls::Action::AdcStep(channel, step) => {
                let mv = drive.analog_mv(channel) + step;
                drive.set_analog(channel, mv, now);
            }
        }
        Ok(())
    }

    fn stall_next(&mut self, now: Instant) -> Result<(), String> {
        self.advance(now);
        self.stall = true;
        Ok(())
    }

    fn input_names(&self) -> Vec<&'static str> {
        controls::INPUT_NAMES.to_vec()
    }

    fn input_level(&self, name: &str) -> Option<bool> {
        let (drive, n) = controls::digital_input(name)?;
        let index = match drive {
            None => 0,
            Some(ds) => self.drive_index(ds.byte())?,
        };
        // The probe is the work piece's, not a level the operator left.
        if let Some(p) = self.surface
            && self.drive_index(p.drive.byte()) == Some(index)
            && p.input == n
        {
            return None;
        }
        Some(self.drives.get(index)?.input(n))
    }

    fn describe(&self, now: Instant) -> String {
        let now = self.at_least_clock(now);
        let mut out = String::new();
        for i in 0..self.drives.len() {
            if i > 0 {
                out.push_str(" | ");
            }
            if let Some(s) = self.drive_snapshot(i, now) {
                describe_drive(&mut out, &s);
            }
        }
        if let (Some(p), Some((_, _, level))) = (self.surface, self.surface_input(now)) {
            let touched = level == p.active_high;
            let _ = write!(
                out,
                " | probe surface {} on {}.I{}: {}",
                p.surface,
                p.drive,
                p.input,
                if touched { "touched" } else { "clear" }
            );
        }
        if self.stall {
            out.push_str(" | stall armed");
        }
        let s = self.stats;
        if s.framing_errors + s.ignored_frames > 0 {
            let _ = write!(
                out,
                " | dropped: {} framing, {} not for a drive",
                s.framing_errors, s.ignored_frames
            );
        }
        out
    }
}

fn describe_drive(out: &mut String, s: &DriveSnapshot) {
    let _ = write!(out, "{}", s.ds);
    if let Some(axis) = s.axis {
        let _ = write!(out, " {axis}");
    }
    if !s.on {
        out.push_str(" off");
    } else {
        match s.mode {
            Some(OperatingMode::Joystick { channel, sub_mode }) => {
                let _ = write!(out, " joystick{}/{sub_mode:?}", channel.byte());
            }
            Some(mode) => {
                let _ = write!(out, " {mode}");
            }
            None => out.push_str(" no mode"),
        }
    }
    let counter = s.counter.increments();
    let _ = write!(out, " pos {counter}");
    let physical = s.physical.round();
    if physical != f64::from(counter) {
        let _ = write!(out, " (physical {physical})");
    }
    if s.speed != 0.0 {
        let _ = write!(out, " {:+.0}/s", s.speed);
    }
    if s.activity != "idle" {
        let _ = write!(out, " {}", s.activity);
    }
    for (on, name) in [
        (s.limits.plus, "LIMIT+"),
        (s.limits.minus, "LIMIT-"),
        (s.limits.reference, "REF"),
    ] {
        if on {
            let _ = write!(out, " {name}");
        }
    }
    let _ = write!(out, " I{} O{}", s.inputs, s.outputs);
    if s.analog_mv.iter().any(|mv| *mv != 0.0) {
        let [a, b, c] = s.analog_mv;
        let _ = write!(out, " adc {a}/{b}/{c} mV");
    }
    if !s.last_error.is_none() {
        let _ = write!(out, " err {:02X}", s.last_error.0);
    }
}
