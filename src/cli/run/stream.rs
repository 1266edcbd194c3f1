//! A job as a DNC stream (issue 27, `docs/gcode.md` "Jobs bigger than the
//! memory"): the converted program's own commands in DNC form, each sent
//! when the one before has been answered, that is when its move has ended
//! (isel manual 2.2; EMCU manual 1.4.2: a line ended by 0x01 runs at once).
//!
//! Every command goes out as a check-out line (`Request::Checkout`), held by
//! a lease this loop renews: a pause lets it go, which the driver turns
//! into the pause without step loss the editor's check-out uses (isel 0xFD
//! alone, the rest finished by `@0S`; EMCU `@B`, the rest sent again from
//! where the axes stand). A run loop that stops renewing (a hung process)
//! pauses the machine the same way. Stop (Space, Ctrl-C, a hang-up, a lost
//! terminal) is the full stop sequence, and nothing resumes on its own.

use std::time::{Duration, Instant};

use super::keys::{Key, Keys};
use crate::axis::{Axis, AxisSet};
use crate::device::api::{CheckoutEnd, Event, JogId, LinkState, PerAxis, Request};
use crate::program::Program;
use crate::program::checkout::{DncStep, Plan, config_of, line_text};
use crate::program::checkout_emcu::{EmcuPlan, EmcuStep};

use crate::cli::out;
use crate::cli::session::{EXIT_LINK, EXIT_USAGE, Session};

/// How long a line is held without a renewal: the dead man of a run loop
/// that stalls. Renewed three times as often.
const LEASE: Duration = Duration::from_millis(1500);

/// The speed factor's bounds and step, in percent of the programmed
/// speeds: never faster than the CAM asked.
pub const FACTOR_MIN: u32 = 10;
pub const FACTOR_MAX: u32 = 100;
const FACTOR_STEP: u32 = 10;

/// What the stream sends next.
enum Next {
    Send { line: String, reads_port: bool },
    Dwell(Duration),
    Nothing,
}

/// The program as a sequence of DNC lines, per family.
enum Feed {
    Isel { plan: Box<Plan>, device: u8 },
    Emcu { plan: EmcuPlan },
}

impl Feed {
    fn new(program: &Program, isel_device: u8, axes: AxisSet) -> Result<Feed, String> {
        match program.language() {
            crate::program::Language::Isel => {
                let config = config_of(axes)
                    .ok_or_else(|| "a stream needs a machine with axes X, Y and Z".to_owned())?;
                Ok(Feed::Isel {
                    plan: Box::new(Plan::new(program, config)),
                    device: isel_device,
                })
            }
            crate::program::Language::Emcu => Ok(Feed::Emcu {
                plan: EmcuPlan::new(program),
            }),
        }
    }

    /// The program line to run next.
    fn line(&self) -> Option<usize> {
        match self {
            Feed::Isel { plan, .. } => plan.line(),
            Feed::Emcu { plan } => plan.line(),
        }
    }

    /// The next step with every speed at `percent` of the program's.
    fn step(&self, percent: u32) -> Option<Next> {
        let scale = |hz: u32| (u64::from(hz) * u64::from(percent) / 100).max(1) as u32;
        match self {
            Feed::Isel { plan, device } => Some(match plan.step(&|_: Axis, hz| scale(hz))? {
                DncStep::Send { command, .. } => Next::Send {
                    line: line_text(*device, &command),
                    reads_port: false,
                },
                DncStep::ReadPort { command } => Next::Send {
                    line: line_text(*device, &command),
                    reads_port: true,
                },
                DncStep::Dwell(d) => Next::Dwell(d),
                DncStep::Nothing => Next::Nothing,
            }),
            Feed::Emcu { plan } => Some(match plan.step(&scale)? {
                EmcuStep::Send { line, .. } => Next::Send {
                    line,
                    reads_port: false,
                },
                EmcuStep::Dwell(d) => Next::Dwell(d),
                EmcuStep::Nothing => Next::Nothing,
            }),
        }
    }

    fn advance(&mut self, port: Option<u8>) {
        match self {
            Feed::Isel { plan, .. } => plan.advance(port),
            Feed::Emcu { plan } => plan.advance(),
        }
    }

    /// After a pause that kept no rest: what goes out to finish the line
    /// (EMCU: the rest of the move from where the axes stand), or the line
    /// itself again (a line that never started).
    fn rest(&self, line: &str, start: Option<[i64; 4]>, now: Option<[i64; 4]>) -> String {
        match (self, start, now) {
            (Feed::Emcu { plan }, Some(start), Some(now)) => plan
                .rest_of_move(start, now)
                .unwrap_or_else(|| line.to_owned()),
            _ => line.to_owned(),
        }
    }
}

/// Where the stream stands, for progress and messages.
pub struct Place<'a> {
    pub name: &'a str,
    /// A job converted from G-code: the G-code line of each program line.
    pub gcode: Option<&'a crate::gcode::output::Program>,
    pub total: usize,
    /// The way's estimate in seconds: the time left until the pace of the
    /// first lines (a reference run among them) says more.
    pub estimate_s: Option<f64>,
    /// The job log, told each G-code line that ran to its end.
    pub log: Option<&'a crate::cli::log::Logged>,
    /// A G-code job's ways: the model's time left (`gcode::eta::Eta`).
    pub ways: Option<&'a crate::gcode::ways::Ways>,
}

impl Place<'_> {
    fn origin(&self, index: usize) -> Option<crate::gcode::Origin> {
        self.gcode?.lines.get(index)?.origin
    }

    /// The G-code line that has run to its end once command `index` has:
    /// `None` while the line has commands left (an arc's chords).
    fn finished_line(&self, index: usize) -> Option<u32> {
        let line = self.origin(index)?.line;
        let next = self.origin(index + 1).map(|o| o.line);
        (next != Some(line)).then_some(line)
    }

    /// Command `index` has run to its end: tell the job log.
    fn completed(&self, index: Option<usize>) {
        if let (Some(log), Some(line)) = (self.log, index.and_then(|k| self.finished_line(k))) {
            log.line(line);
        }
    }

    fn at(&self, index: usize) -> String {
        match (self.origin(index), self.gcode) {
            (Some(o), _) => format!("{}:{}:{}", self.name, o.line, o.col),
            (None, Some(_)) => format!("{} (a command the conversion adds)", self.name),
            (None, None) => format!("{}:{}", self.name, index + 1),
        }
    }
}

/// How the stream ended when it did not run to its end: the exit status,
/// said already.
pub type Status = Result<(), u8>;

/// The operator's state during a run: paused, the speed factor.
struct Control {
    percent: u32,
    paused: bool,
}

impl Control {
    /// `+` and `-`: the factor of the moves not yet sent, said when it
    /// changes; other keys change nothing here.
    fn speed(&mut self, key: Key) {
        let before = self.percent;
        self.percent = match key {
            Key::Faster => (self.percent + FACTOR_STEP).min(FACTOR_MAX),
            Key::Slower => self.percent.saturating_sub(FACTOR_STEP).max(FACTOR_MIN),
            _ => self.percent,
        };
        if before != self.percent {
            out::say(format_args!(
                "speed {} % of the program's, from the next command on",
                self.percent
            ));
        }
    }
}

/// Run `program` as a stream; `percent`: the speed factor it starts with.
pub async fn run(
    session: &mut Session,
    program: &Program,
    place: &Place<'_>,
    remedy: (u8, AxisSet),
    percent: u32,
    keys: &mut Keys,
) -> Status {
    let mut feed = match Feed::new(program, remedy.0, remedy.1) {
        Ok(f) => f,
        Err(why) => {
            out::say(format_args!("jogterm run: {why}"));
            return Err(EXIT_USAGE);
        }
    };
    let mut control = Control {
        percent: percent.clamp(FACTOR_MIN, FACTOR_MAX),
        paused: false,
    };
    let started = Instant::now();
    let mut progress = Progress::new(place.total);
    let mut eta = place.ways.zip(place.gcode).map(|(ways, program)| {
        crate::gcode::eta::Eta::new(std::sync::Arc::new(ways.clone()), program.lines.len())
    });
    // Time spent paused: the pace counts the time the job runs.
    let mut paused = Duration::ZERO;
    let mut ids = 1u64;
    let mut position: Option<[i64; 4]> = None;
    let mut last = None;
    let mut previous = None;
    while let Some(next) = feed.step(control.percent) {
        let index = feed.line().unwrap_or(0);
        // The command before this one has run to its end.
        if previous != Some(index) {
            place.completed(previous.replace(index));
        }
        // The end names the last line of the file that ran, not a command
        // the conversion added after it (the closing `9`).
        if place.gcode.is_none() || place.origin(index).is_some() {
            last = Some(index);
        }
        let clock = Clock {
            started,
            paused,
            percent: control.percent,
        };
        if let Some(eta) = eta.as_mut()
            && place.origin(index).is_some()
        {
            eta.start(index, control.percent, clock.running_s());
        }
        progress.show(place, index, &clock, eta.as_ref());
        let (line, reads_port) = match next {
            Next::Send { line, reads_port } => (line, reads_port),
            Next::Dwell(d) => {
                dwell(session, d, keys, &mut control).await?;
                feed.advance(None);
                continue;
            }
            Next::Nothing => {
                feed.advance(None);
                continue;
            }
        };
        let mut resume: Option<JogId> = None;
        let mut text = line.clone();
        let start = position;
        let byte = loop {
            let id = JogId(ids);
            ids += 1;
            let request = Request::Checkout {
                id,
                line: text.clone(),
                lease: LEASE,
                resume,
                // The position after every move is its target: no `@0P`
                // between two moves (`RawOp::skip_read_back`).
                read_back: false,
            };
            if session.handle.request(request).is_err() {
                return Err(lost("the device task ended"));
            }
            match follow(session, id, keys, &mut control, &mut position).await {
                Followed::Done(byte) => break byte,
                Followed::Paused { rest } => {
                    out::say(format_args!(
                        "paused at {} (r resumes, Space stops); the spindle and the job's outputs stay on",
                        place.at(index)
                    ));
                    let since = Instant::now();
                    wait_resume(session, keys, &mut control, &mut position).await?;
                    paused += since.elapsed();
                    out::say(format_args!("resumed at {}", place.at(index)));
                    if rest {
                        resume = Some(id);
                    } else {
                        resume = None;
                        text = feed.rest(&line, start, position);
                    }
                }
                Followed::Ended(why, code) => {
                    progress.end();
                    out::say(format_args!(
                        "{}: {why}; the stream ends here",
                        place.at(index)
                    ));
                    return Err(code);
                }
            }
        };
        if reads_port {
            if byte.is_none() {
                out::say(format_args!(
                    "{}: the port read gave no byte; the stream ends here",
                    place.at(index)
                ));
                return Err(1);
            }
            // A pause's self-loop reads the key again: not at wire speed.
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        feed.advance(byte);
    }
    place.completed(previous);
    progress.done(
        place,
        last,
        &Clock {
            started,
            paused,
            percent: control.percent,
        },
    );
    out::say(format_args!(
        "the stream ended after {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    Ok(())
}

enum Followed {
    Done(Option<u8>),
    Paused { rest: bool },
    Ended(String, u8),
}

/// One check-out line to its end, its lease renewed, keys obeyed.
async fn follow(
    session: &mut Session,
    id: JogId,
    keys: &mut Keys,
    control: &mut Control,
    position: &mut Option<[i64; 4]>,
) -> Followed {
    let mut renew = tokio::time::interval(LEASE / 3);
    renew.tick().await;
    loop {
        tokio::select! {
            biased;
            key = keys.next() => match key {
                Key::Stop | Key::Gone => {
                    let _ = session.handle.stop().written().await;
                    let why = if key == Key::Gone {
                        "the terminal went away: the machine was stopped"
                    } else {
                        "stopped by the operator"
                    };
                    return Followed::Ended(why.into(), 1);
                }
                Key::Pause if !control.paused => {
                    control.paused = true;
                    let _ = session.handle.request(Request::JogRelease { id });
                }
                other => control.speed(other),
            },
            event = session.next_event() => {
                let Some(event) = event else {
                    return Followed::Ended("the device task ended".into(), EXIT_LINK);
                };
                match event {
                    Event::Checkout { id: done, end } if done == id => return match end {
                        CheckoutEnd::Done { byte } => Followed::Done(byte),
                        CheckoutEnd::Paused { rest, dead_man } => {
                            control.paused = true;
                            if dead_man {
                                out::say("the run loop fell behind its lease: the machine paused");
                            }
                            Followed::Paused { rest }
                        }
                        CheckoutEnd::Stopped => Followed::Ended("stopped".into(), 1),
                        CheckoutEnd::Fault(f) => Followed::Ended(
                            format!("the controller answered `{}` to `{}`: {}", f.code, f.command, f.meaning),
                            1,
                        ),
                        CheckoutEnd::Refused(r) => Followed::Ended(format!("refused: {r}"), 1),
                        CheckoutEnd::LinkLost => Followed::Ended("the link was lost".into(), EXIT_LINK),
                    },
                    Event::Position(p) => *position = Some(counters(&p.steps)),
                    Event::Link(LinkState::Lost { reason }) => {
                        return Followed::Ended(format!("link failure: {reason}"), EXIT_LINK);
                    }
                    _ => {}
                }
            }
            _ = renew.tick() => {
                let _ = session.handle.request(Request::JogRenew { id, lease: LEASE });
            }
        }
    }
}

/// Paused: wait for the resume key, obeying stop and the speed keys.
async fn wait_resume(
    session: &mut Session,
    keys: &mut Keys,
    control: &mut Control,
    position: &mut Option<[i64; 4]>,
) -> Status {
    loop {
        tokio::select! {
            key = keys.next() => match key {
                Key::Resume => {
                    control.paused = false;
                    return Ok(());
                }
                Key::Stop | Key::Gone => {
                    let _ = session.handle.stop().written().await;
                    out::say("jogterm run: stopped while paused; nothing resumes");
                    return Err(1);
                }
                other => control.speed(other),
            },
            event = session.next_event() => match event {
                None => return Err(lost("the device task ended")),
                Some(Event::Position(p)) => *position = Some(counters(&p.steps)),
                Some(Event::Link(LinkState::Lost { reason })) => return Err(lost(&reason)),
                Some(_) => {}
            },
        }
    }
}

/// A dwell, during which stop and pause still work (a pause holds the
/// dwell until resumed).
async fn dwell(
    session: &mut Session,
    d: Duration,
    keys: &mut Keys,
    control: &mut Control,
) -> Status {
    let end = tokio::time::Instant::now() + d;
    loop {
        tokio::select! {
            () = tokio::time::sleep_until(end) => return Ok(()),
            key = keys.next() => match key {
                Key::Stop | Key::Gone => {
                    let _ = session.handle.stop().written().await;
                    out::say("jogterm run: stopped during a dwell");
                    return Err(1);
                }
                Key::Pause => {
                    control.paused = true;
                    out::say(
                        "paused during a dwell (r resumes, Space stops); the spindle and the \
                         job's outputs stay on",
                    );
                    let mut position = None;
                    wait_resume(session, keys, control, &mut position).await?;
                }
                other => control.speed(other),
            },
        }
    }
}

fn counters(steps: &PerAxis<i64>) -> [i64; 4] {
    let mut out = [0; 4];
    for (axis, v) in steps.iter() {
        if let Some(slot) = out.get_mut(axis.index()) {
            *slot = v;
        }
    }
    out
}

fn lost(reason: &str) -> u8 {
    out::say(format_args!("jogterm run: link failure: {reason}"));
    EXIT_LINK
}

/// The run's clock for the progress line: when it started, how long it
/// stood paused, the speed factor in force.
struct Clock {
    started: Instant,
    paused: Duration,
    percent: u32,
}

impl Clock {
    fn elapsed_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    fn running_s(&self) -> f64 {
        self.started
            .elapsed()
            .saturating_sub(self.paused)
            .as_secs_f64()
    }
}

/// Progress by G-code line: on a terminal one line rewritten in place,
/// else a line whenever the G-code line changes, at most one a second.
struct Progress {
    total: usize,
    terminal: bool,
    shown: Option<usize>,
    last: Option<Instant>,
}

impl Progress {
    fn new(total: usize) -> Progress {
        use std::io::IsTerminal;
        Progress {
            total: total.max(1),
            terminal: std::io::stderr().is_terminal(),
            shown: None,
            last: None,
        }
    }

    fn show(
        &mut self,
        place: &Place<'_>,
        index: usize,
        clock: &Clock,
        eta: Option<&crate::gcode::eta::Eta>,
    ) {
        let key = place.origin(index).map_or(index, |o| o.line as usize);
        if self.shown == Some(key) {
            return;
        }
        let now = Instant::now();
        if !self.terminal && self.last.is_some_and(|t| now < t + Duration::from_secs(1)) {
            return;
        }
        self.shown = Some(key);
        self.last = Some(now);
        let left = eta.and_then(|e| e.left_s(index, clock.running_s()));
        self.say(place, (index, self.total), clock, left);
    }

    fn say(&self, place: &Place<'_>, done: (usize, usize), clock: &Clock, left: Option<f64>) {
        let text = match left {
            Some(left) => eta_text(
                &place.at(done.0),
                done,
                clock.elapsed_s(),
                left,
                clock.percent,
            ),
            None => progress_text(&place.at(done.0), done, clock.elapsed_s(), place.estimate_s),
        };
        if self.terminal {
            out::say_raw(format_args!("\r\x1b[2K{text}"));
        } else {
            out::say(text);
        }
    }

    /// The stream ran to its end: its last line at 100 %, whatever the
    /// throttle held back.
    fn done(&mut self, place: &Place<'_>, last: Option<usize>, clock: &Clock) {
        if let Some(index) = last {
            self.say(place, (index, index), clock, None);
            self.shown = Some(index);
        }
        self.end();
    }

    fn end(&mut self) {
        if self.terminal && self.shown.is_some() {
            out::say("");
        }
    }
}

/// `part.nc:120:1: 42 % after 1:10 min, about 1:37 min left at speed 80 %`:
/// the model's time left, scaled by the speed factor and corrected by the
/// pace so far (`gcode::eta::Eta`).
pub fn eta_text(
    at: &str,
    (done, total): (usize, usize),
    elapsed_s: f64,
    left_s: f64,
    percent: u32,
) -> String {
    let share = (done * 100).checked_div(total).unwrap_or(100);
    format!(
        "{at}: {share} % after {}, about {} left at speed {percent} %",
        crate::gcode::ways::duration(elapsed_s),
        crate::gcode::ways::duration(left_s)
    )
}

/// `part.nc:120:1: 42 % after 1:10 min, about 1:37 min left`: the time
/// left from the estimate for the first 5 %, then from the pace so far (a
/// controller program, which has no model).
pub fn progress_text(
    at: &str,
    (done, total): (usize, usize),
    elapsed_s: f64,
    estimate_s: Option<f64>,
) -> String {
    let percent = (done * 100).checked_div(total).unwrap_or(100);
    let fraction = done as f64 / total.max(1) as f64;
    let left = match estimate_s {
        _ if done >= total => None,
        Some(estimate) if fraction < 0.05 => Some(estimate * (1.0 - fraction)),
        _ if done > 0 => Some(elapsed_s / fraction * (1.0 - fraction)),
        _ => None,
    };
    let left = left.map_or(String::new(), |s| {
        format!(", about {} left", crate::gcode::ways::duration(s))
    });
    format!(
        "{at}: {percent} % after {}{left}",
        crate::gcode::ways::duration(elapsed_s)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_says_line_percent_elapsed_and_left() {
        assert_eq!(
            progress_text("p.nc:12:1", (25, 100), 30.0, Some(60.0)),
            "p.nc:12:1: 25 % after 30.0 s, about 1:30 min left"
        );
        // Early on the estimate speaks, not a reference run's pace.
        assert_eq!(
            progress_text("p.nc:3:1", (1, 100), 14.0, Some(100.0)),
            "p.nc:3:1: 1 % after 14.0 s, about 1:39 min left"
        );
        assert_eq!(
            progress_text("p.nc:1:1", (0, 100), 0.0, None),
            "p.nc:1:1: 0 % after 0.0 s"
        );
        assert_eq!(
            progress_text("p.nc:9:1", (100, 100), 50.0, Some(60.0)),
            "p.nc:9:1: 100 % after 50.0 s"
        );
    }

    #[test]
    fn the_eta_says_the_speed_factor_beside_it() {
        assert_eq!(
            eta_text("p.nc:12:1", (25, 100), 30.0, 90.0, 50),
            "p.nc:12:1: 25 % after 30.0 s, about 1:30 min left at speed 50 %"
        );
    }

    #[test]
    fn the_speed_factor_stays_within_its_bounds() {
        let mut c = Control {
            percent: 100,
            paused: false,
        };
        c.speed(Key::Faster);
        assert_eq!(c.percent, 100);
        for _ in 0..20 {
            c.speed(Key::Slower);
        }
        assert_eq!(c.percent, FACTOR_MIN);
    }
}
