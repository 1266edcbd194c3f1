//! The switch walk-test, sans-IO: a guided check of every wired input of
//! the profile, one at a time ("trigger limit X1 now"), then, if asked, of
//! every output. It reads the input recorder's changes and the operator's
//! answers and says what to ask next; it moves no axis and switches an
//! output only after the operator said yes. `jogterm commission` runs it;
//! [`super::report`] writes what it found.
//!
//! An input step ends
//! - **ok** (or **inverted**: it toggles, but its active level is not the
//!   profile's) once the input has gone to a level and come back;
//! - **other input moved** when another input changed first: a swapped or
//!   mislabelled wire (the step waits for that input to come back, so the
//!   next step starts at rest);
//! - **not seen** when nothing changed within the step's time;
//! - **skipped** on an empty answer.
//!
//! The E-stop circuits are one step (one button opens them all): each
//! circuit's opening and closing is timed, and the skew between them is
//! the recorder's.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::device::api::{
    InputChange, InputChannel, InputKey, InputRole, IoSnapshot, OutputId, Request,
};

use super::{input_bits, level_word};

/// What a step found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    Ok,
    /// It toggles, but is active at the other level than the profile says.
    Inverted,
    /// Another input changed instead.
    OtherMoved,
    NotSeen,
    Skipped,
}

impl Verdict {
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Ok => "ok",
            Verdict::Inverted => "inverted",
            Verdict::OtherMoved => "other input moved",
            Verdict::NotSeen => "not seen",
            Verdict::Skipped => "skipped",
        }
    }

    /// Whether the operator must look into it.
    pub fn is_finding(self) -> bool {
        matches!(
            self,
            Verdict::Inverted | Verdict::OtherMoved | Verdict::NotSeen
        )
    }
}

/// A change as the walk-test keeps it.
#[derive(Debug, Clone, PartialEq)]
pub struct Seen {
    pub level: bool,
    /// Since the link came up.
    pub t: Duration,
    /// Within this before `t`.
    pub window: Duration,
}

impl Seen {
    fn of(c: &InputChange) -> Seen {
        Seen {
            level: c.level,
            t: c.t,
            window: c.window(),
        }
    }
}

/// One input's result.
#[derive(Debug, Clone, PartialEq)]
pub struct InputResult {
    pub channel: Arc<InputChannel>,
    pub verdict: Verdict,
    /// The level it went to when triggered: its active level as wired.
    pub active_level: Option<bool>,
    /// Where it stood when its step began.
    pub resting: Option<bool>,
    pub triggered: Option<Seen>,
    pub released: Option<Seen>,
    /// The input that changed instead, or as well.
    pub others: Vec<Arc<InputChannel>>,
    /// It chattered while it was walked.
    pub chattered: bool,
}

/// The E-stop circuits, walked together.
#[derive(Debug, Clone, PartialEq)]
pub struct EstopResult {
    pub circuits: Vec<InputResult>,
    /// From the first circuit opening to the last, as the recorder measured
    /// it, with the range the windows allow: (measured, min, max).
    pub open_skew: Option<(Duration, Duration, Duration)>,
    /// From the first circuit closing to the last (first readings).
    pub close_skew: Option<Duration>,
}

/// An output as the walk-test switched it.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputResult {
    pub name: String,
    pub output: OutputId,
    pub hazardous: bool,
    /// The value written, if it was (`None`: skipped).
    pub switched_to: Option<u8>,
    /// The operator's answer: it did what it should.
    pub confirmed: Option<bool>,
    /// Why the device task refused it.
    pub refused: Option<String>,
    /// Inputs that changed while it was switched (a feedback).
    pub inputs_followed: Vec<Arc<InputChannel>>,
}

/// An output the walk-test may switch.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputChoice {
    pub name: String,
    pub output: OutputId,
    pub hazardous: bool,
    /// The value shown now (jogterm's last write; outputs cannot be read).
    pub value: bool,
}

/// The outputs of a snapshot.
pub fn outputs_of(snapshot: &IoSnapshot) -> Vec<OutputChoice> {
    snapshot
        .groups
        .iter()
        .flat_map(|g| g.bits.iter())
        .filter_map(|b| {
            Some(OutputChoice {
                name: b.name.clone(),
                output: b.output?,
                hazardous: b.hazardous,
                value: b.value,
            })
        })
        .collect()
}

/// What the walk-test wants done.
#[derive(Debug, Clone, PartialEq)]
pub enum Do {
    /// Tell the operator (a question ends with what to answer).
    Say(String),
    Request(Request),
    /// Every step is done (or the operator ended it).
    Finished,
}

#[derive(Debug, Clone, PartialEq)]
enum Step {
    Input(Arc<InputChannel>),
    Estop(Vec<Arc<InputChannel>>),
    Output(OutputChoice),
}

#[derive(Debug, Clone, PartialEq)]
enum State {
    NotStarted,
    /// Waiting for the input (or any E-stop circuit) to change.
    Waiting,
    /// The input is active: waiting for it to come back.
    Held,
    /// Another input moved: waiting for it to come back.
    Other(Arc<InputChannel>),
    /// An output question is asked.
    Ask,
    /// The output was switched: did it do what it should?
    Check,
    Done,
}

/// How long a step waits for the operator before it counts as not seen.
pub const STEP_TIME: Duration = Duration::from_secs(60);

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct WalkTest {
    steps: Vec<Step>,
    index: usize,
    state: State,
    step_started: Option<Instant>,
    step_time: Duration,
    levels: HashMap<InputKey, bool>,
    current: Option<InputResult>,
    estop: Option<EstopResult>,
    estop_open_t: Vec<Duration>,
    estop_close_t: Vec<Duration>,
    output: Option<OutputResult>,
    pub inputs: Vec<InputResult>,
    pub outputs: Vec<OutputResult>,
    /// The operator ended it early.
    pub ended_early: bool,
}

/// The inputs a walk-test walks: every wired one an operator can move (not
/// the EMCU's status flags, not the feedback of an output).
pub fn walked(channels: &[Arc<InputChannel>]) -> Vec<Arc<InputChannel>> {
    channels
        .iter()
        .filter(|c| c.wired && !matches!(c.role, InputRole::Status | InputRole::Feedback))
        .cloned()
        .collect()
}

impl WalkTest {
    /// A walk over `channels` (the profile's, `channels::shared`), then
    /// `outputs` (empty: no outputs are switched).
    pub fn new(channels: &[Arc<InputChannel>], outputs: Vec<OutputChoice>) -> WalkTest {
        let walked = walked(channels);
        let estops: Vec<Arc<InputChannel>> = walked
            .iter()
            .filter(|c| c.role == InputRole::Estop)
            .cloned()
            .collect();
        let mut steps = Vec::new();
        if !estops.is_empty() {
            steps.push(Step::Estop(estops));
        }
        // The limit switches next (a walk round the machine), then the rest
        // in the controller's order.
        let mut rest: Vec<&Arc<InputChannel>> = walked
            .iter()
            .filter(|c| c.role != InputRole::Estop)
            .collect();
        rest.sort_by_key(|c| c.role != InputRole::Limit);
        steps.extend(rest.into_iter().map(|c| Step::Input(c.clone())));
        steps.extend(outputs.into_iter().map(Step::Output));
        WalkTest {
            steps,
            index: 0,
            state: State::NotStarted,
            step_started: None,
            step_time: STEP_TIME,
            levels: HashMap::new(),
            current: None,
            estop: None,
            estop_open_t: Vec::new(),
            estop_close_t: Vec::new(),
            output: None,
            inputs: Vec::new(),
            outputs: Vec::new(),
            ended_early: false,
        }
    }

    /// Another time per step than [`STEP_TIME`].
    pub fn with_step_time(mut self, step_time: Duration) -> WalkTest {
        self.step_time = step_time;
        self
    }

    /// Steps in all (the E-stop circuits count as one).
    pub fn steps(&self) -> usize {
        self.steps.len()
    }

    pub fn estop(&self) -> Option<&EstopResult> {
        self.estop.as_ref()
    }

    pub fn is_done(&self) -> bool {
        self.state == State::Done
    }

    /// The levels read: what an input rests at when its step begins.
    pub fn observe(&mut self, snapshot: &IoSnapshot) {
        for group in &snapshot.groups {
            for (key, bit) in input_bits(group) {
                self.levels.insert(key, bit.value);
            }
        }
    }

    /// Begin with the first step.
    pub fn start(&mut self, now: Instant) -> Vec<Do> {
        self.index = 0;
        self.begin(now)
    }

    /// When the step under way gives up waiting.
    pub fn deadline(&self) -> Option<Instant> {
        match self.state {
            State::Waiting | State::Held | State::Other(_) => {
                self.step_started.map(|t| t + self.step_time)
            }
            _ => None,
        }
    }

    fn position(&self) -> String {
        format!("[{}/{}]", self.index + 1, self.steps.len())
    }

    fn begin(&mut self, now: Instant) -> Vec<Do> {
        self.step_started = Some(now);
        let Some(step) = self.steps.get(self.index).cloned() else {
            self.state = State::Done;
            return vec![Do::Finished];
        };
        match step {
            Step::Input(c) => {
                self.state = State::Waiting;
                let resting = self.levels.get(&c.key).copied();
                self.current = Some(InputResult {
                    channel: c.clone(),
                    verdict: Verdict::NotSeen,
                    active_level: None,
                    resting,
                    triggered: None,
                    released: None,
                    others: Vec::new(),
                    chattered: false,
                });
                let mut out = vec![Do::Say(format!(
                    "{} {} ({}): {} now (Enter skips, q ends)",
                    self.position(),
                    c.label(),
                    c.address,
                    what_to_do(c.role)
                ))];
                if resting == Some(c.active) {
                    out.push(Do::Say(format!(
                        "{} reads {} ({}) already: release it first",
                        c.label(),
                        u8::from(c.active),
                        level_word(&c, c.active)
                    )));
                }
                out
            }
            Step::Estop(circuits) => {
                self.state = State::Waiting;
                let results = circuits
                    .iter()
                    .map(|c| InputResult {
                        channel: c.clone(),
                        verdict: Verdict::NotSeen,
                        active_level: None,
                        resting: self.levels.get(&c.key).copied(),
                        triggered: None,
                        released: None,
                        others: Vec::new(),
                        chattered: false,
                    })
                    .collect();
                self.estop = Some(EstopResult {
                    circuits: results,
                    open_skew: None,
                    close_skew: None,
                });
                vec![Do::Say(format!(
                    "{} {}: press the emergency stop now, then release it (Enter skips, q ends)",
                    self.position(),
                    labelled(&circuits)
                ))]
            }
            Step::Output(o) => {
                self.state = State::Ask;
                self.output = Some(OutputResult {
                    name: o.name.clone(),
                    output: o.output,
                    hazardous: o.hazardous,
                    switched_to: None,
                    confirmed: None,
                    refused: None,
                    inputs_followed: Vec::new(),
                });
                let to = if o.value { "off" } else { "on" };
                let warn = if o.hazardous {
                    " It moves or powers something on the machine: keep clear."
                } else {
                    ""
                };
                vec![Do::Say(format!(
                    "{} output {} ({}): switch it {to} to check it?{warn} (y switches, Enter skips, q ends)",
                    self.position(),
                    o.name,
                    output_address(o.output)
                ))]
            }
        }
    }

    /// Record the step under way and begin the next.
    fn next(&mut self, now: Instant) -> Vec<Do> {
        let mut out = self.record();
        self.index += 1;
        out.extend(self.begin(now));
        out
    }

    /// Keep what the step under way found, and say it.
    fn record(&mut self) -> Vec<Do> {
        let mut out = Vec::new();
        if let Some(r) = self.current.take() {
            out.push(Do::Say(input_summary(&r)));
            self.inputs.push(r);
        }
        if let Some(e) = &mut self.estop
            && matches!(self.steps.get(self.index), Some(Step::Estop(_)))
        {
            for c in &mut e.circuits {
                out.push(Do::Say(input_summary(c)));
            }
            if let (Some(first), Some(last)) = (
                self.estop_close_t.iter().min(),
                self.estop_close_t.iter().max(),
            ) && self.estop_close_t.len() == e.circuits.len()
            {
                e.close_skew = Some(*last - *first);
            }
            if let Some((m, lo, hi)) = e.open_skew {
                out.push(Do::Say(format!(
                    "E-stop skew: {} (between {} and {})",
                    ms(m),
                    ms(lo),
                    ms(hi)
                )));
            }
        }
        if let Some(o) = self.output.take() {
            out.push(Do::Say(output_summary(&o)));
            self.outputs.push(o);
        }
        out
    }

    /// An input changed (`Event::Input`).
    pub fn input(&mut self, change: &InputChange, now: Instant) -> Vec<Do> {
        if change.channel.role == InputRole::Status {
            return Vec::new();
        }
        self.levels.insert(change.channel.key, change.level);
        match self.steps.get(self.index).cloned() {
            Some(Step::Input(c)) => self.input_step(&c, change, now),
            Some(Step::Estop(circuits)) => self.estop_step(&circuits, change, now),
            Some(Step::Output(_)) => {
                if matches!(self.state, State::Check)
                    && let Some(o) = &mut self.output
                    && !o.inputs_followed.contains(&change.channel)
                {
                    o.inputs_followed.push(change.channel.clone());
                }
                Vec::new()
            }
            None => Vec::new(),
        }
    }

    fn input_step(&mut self, c: &Arc<InputChannel>, change: &InputChange, now: Instant) -> Vec<Do> {
        let Some(r) = self.current.as_mut() else {
            return Vec::new();
        };
        let ours = change.channel.key == c.key;
        r.chattered |= ours && change.chatter.is_some();
        match (&self.state, ours) {
            (State::Waiting, true) => {
                r.triggered = Some(Seen::of(change));
                r.active_level = Some(change.level);
                r.verdict = if change.level == c.active {
                    Verdict::Ok
                } else {
                    Verdict::Inverted
                };
                self.state = State::Held;
                Vec::new()
            }
            (State::Held, true) => {
                r.released = Some(Seen::of(change));
                self.next(now)
            }
            (State::Waiting, false) => {
                r.verdict = Verdict::OtherMoved;
                r.others.push(change.channel.clone());
                self.state = State::Other(change.channel.clone());
                vec![Do::Say(format!(
                    "{} ({}) moved instead of {} ({}): a swapped or mislabelled wire? Let it go",
                    change.channel.label(),
                    change.channel.address,
                    c.label(),
                    c.address
                ))]
            }
            (State::Other(other), false) if other.key == change.channel.key => {
                // Back where it was: the next step starts at rest.
                self.next(now)
            }
            (State::Other(_), true) => {
                // Ours moved as well; the other input is still out.
                if r.triggered.is_none() {
                    r.triggered = Some(Seen::of(change));
                    r.active_level = Some(change.level);
                } else {
                    r.released = Some(Seen::of(change));
                }
                Vec::new()
            }
            (_, false) => {
                if !r.others.contains(&change.channel) {
                    r.others.push(change.channel.clone());
                }
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    fn estop_step(
        &mut self,
        circuits: &[Arc<InputChannel>],
        change: &InputChange,
        now: Instant,
    ) -> Vec<Do> {
        let Some(e) = self.estop.as_mut() else {
            return Vec::new();
        };
        let Some(r) = e
            .circuits
            .iter_mut()
            .find(|r| r.channel.key == change.channel.key)
        else {
            // Something else moved while the E-stop was pressed.
            if let Some(first) = e.circuits.first_mut()
                && !first.others.contains(&change.channel)
            {
                first.others.push(change.channel.clone());
            }
            return Vec::new();
        };
        r.chattered |= change.chatter.is_some();
        if r.triggered.is_none() {
            r.triggered = Some(Seen::of(change));
            r.active_level = Some(change.level);
            r.verdict = if change.level == r.channel.active {
                Verdict::Ok
            } else {
                Verdict::Inverted
            };
            self.estop_open_t.push(change.t);
            if let Some(s) = &change.skew {
                // The recorder's skew from the first circuit to this one:
                // the last one to open sets the step's skew.
                e.open_skew = Some((s.measured, s.min, s.max));
            }
            self.state = State::Held;
        } else if r.released.is_none() {
            r.released = Some(Seen::of(change));
            self.estop_close_t.push(change.t);
        }
        let all_back = e.circuits.iter().all(|r| r.released.is_some());
        if all_back && circuits.len() == e.circuits.len() {
            return self.next(now);
        }
        Vec::new()
    }

    /// The device task refused a request of the walk-test.
    pub fn refused(&mut self, reason: &str, now: Instant) -> Vec<Do> {
        if let Some(o) = &mut self.output
            && matches!(self.state, State::Check)
        {
            o.refused = Some(reason.to_owned());
            return self.next(now);
        }
        Vec::new()
    }

    /// A line the operator typed.
    pub fn answer(&mut self, line: &str, now: Instant) -> Vec<Do> {
        let word = line.trim().to_ascii_lowercase();
        if word == "q" {
            return self.end(now);
        }
        match self.state {
            State::Waiting | State::Held | State::Other(_) if word.is_empty() => {
                if let Some(r) = self.current.as_mut() {
                    r.verdict = Verdict::Skipped;
                }
                if let Some(e) = self.estop.as_mut()
                    && matches!(self.steps.get(self.index), Some(Step::Estop(_)))
                {
                    for c in e.circuits.iter_mut().filter(|c| c.triggered.is_none()) {
                        c.verdict = Verdict::Skipped;
                    }
                }
                self.next(now)
            }
            State::Ask => {
                let Some(o) = self.output.as_mut() else {
                    return Vec::new();
                };
                if word != "y" && word != "yes" {
                    return self.next(now);
                }
                let value = match self.steps.get(self.index) {
                    Some(Step::Output(choice)) => u8::from(!choice.value),
                    _ => return self.next(now),
                };
                o.switched_to = Some(value);
                self.state = State::Check;
                let state = if value == 0 { "off" } else { "on" };
                vec![
                    Do::Request(Request::SetOutput {
                        output: o.output,
                        value,
                    }),
                    Do::Say(format!(
                        "did {} switch {state}? (y or n; it is switched back then)",
                        o.name
                    )),
                ]
            }
            State::Check => {
                let Some(o) = self.output.as_mut() else {
                    return Vec::new();
                };
                o.confirmed = Some(word == "y" || word == "yes");
                let back = o.switched_to.map(|v| u8::from(v == 0)).unwrap_or(0);
                let mut out = vec![Do::Request(Request::SetOutput {
                    output: o.output,
                    value: back,
                })];
                out.extend(self.next(now));
                out
            }
            _ => Vec::new(),
        }
    }

    /// The step under way gave up waiting.
    pub fn timed_out(&mut self, now: Instant) -> Vec<Do> {
        if self.deadline().is_none_or(|d| now < d) {
            return Vec::new();
        }
        self.next(now)
    }

    /// End the walk-test now: what is left counts as skipped.
    pub fn end(&mut self, _now: Instant) -> Vec<Do> {
        if self.state == State::Done {
            return vec![Do::Finished];
        }
        self.ended_early = true;
        let mut out = Vec::new();
        if let Some(r) = self.current.as_mut()
            && r.triggered.is_none()
        {
            r.verdict = Verdict::Skipped;
        }
        if let Some(e) = self.estop.as_mut()
            && matches!(self.steps.get(self.index), Some(Step::Estop(_)))
        {
            for c in e.circuits.iter_mut().filter(|c| c.triggered.is_none()) {
                c.verdict = Verdict::Skipped;
            }
        }
        // Switched but not answered: switch it back.
        if let (Some(o), State::Check) = (self.output.as_ref(), &self.state)
            && let Some(v) = o.switched_to
        {
            out.push(Do::Request(Request::SetOutput {
                output: o.output,
                value: u8::from(v == 0),
            }));
        }
        if self.state != State::NotStarted {
            out.extend(self.record());
            self.index += 1;
        }
        let from = self.index.min(self.steps.len());
        let rest: Vec<Step> = self.steps.drain(from..).collect();
        for step in rest {
            match step {
                Step::Input(c) => self.inputs.push(skipped(c)),
                Step::Estop(cs) => {
                    self.estop = Some(EstopResult {
                        circuits: cs.into_iter().map(skipped).collect(),
                        open_skew: None,
                        close_skew: None,
                    })
                }
                Step::Output(_) => {}
            }
        }
        self.current = None;
        self.output = None;
        self.state = State::Done;
        if !out.contains(&Do::Finished) {
            out.push(Do::Finished);
        }
        out
    }
}

fn skipped(channel: Arc<InputChannel>) -> InputResult {
    InputResult {
        channel,
        verdict: Verdict::Skipped,
        active_level: None,
        resting: None,
        triggered: None,
        released: None,
        others: Vec::new(),
        chattered: false,
    }
}

/// What the operator is asked to do with an input of `role`.
fn what_to_do(role: InputRole) -> &'static str {
    match role {
        InputRole::Limit => "trip the switch, then free it",
        InputRole::Key => "press or turn it, then let it go",
        InputRole::Probe => "touch it, then free it",
        InputRole::Hood => "open it, then close it",
        InputRole::Estop => "press the emergency stop, then release it",
        InputRole::Power => "make it report a fault, then clear it",
        _ => "switch it, then switch it back",
    }
}

/// `in3.0`, `out2`, `out0.3` (isel), the group and bit as numbers elsewhere.
pub fn output_address(o: OutputId) -> String {
    match o.bit {
        Some(b) => format!("out{}.{b}", o.group),
        None => format!("out{}", o.group),
    }
}

/// `limit X1 (in3.0), limit Y1 (in3.2)`.
pub(super) fn labelled(channels: &[Arc<InputChannel>]) -> String {
    channels
        .iter()
        .map(|c| format!("{} ({})", c.label(), c.address))
        .collect::<Vec<_>>()
        .join(", ")
}

pub(super) fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1000.0)
}

/// One input's result in words.
pub fn input_summary(r: &InputResult) -> String {
    let c = &r.channel;
    let mut text = format!("{} ({}): {}", c.label(), c.address, r.verdict.word());
    if let Some(level) = r.active_level {
        text.push_str(&format!(
            ", active at {} ({})",
            u8::from(level),
            level_word(c, level)
        ));
        if level != c.active {
            text.push_str(&format!(", the profile says {}", u8::from(c.active)));
        }
    }
    if let (Some(on), Some(off)) = (&r.triggered, &r.released) {
        text.push_str(&format!(
            ", held {:.2} s",
            off.t.saturating_sub(on.t).as_secs_f64()
        ));
    }
    if !r.others.is_empty() {
        text.push_str(&format!(", moved: {}", labelled(&r.others)));
    }
    if r.chattered {
        text.push_str(", CHATTERS");
    }
    text
}

impl OutputResult {
    /// What came of it, in words: `switched to 1: confirmed`, `skipped` …
    pub fn outcome(&self) -> String {
        match (&self.refused, self.switched_to, self.confirmed) {
            (Some(why), _, _) => format!("refused: {why}"),
            (None, None, _) => "skipped".to_owned(),
            (None, Some(v), Some(true)) => format!("switched to {v}: confirmed"),
            (None, Some(v), Some(false)) => format!("switched to {v}: NOT confirmed"),
            (None, Some(v), None) => format!("switched to {v}: no answer"),
        }
    }

    /// The operator must look into it.
    pub fn is_finding(&self) -> bool {
        self.confirmed == Some(false) || self.refused.is_some()
    }
}

/// One output's result in words.
pub fn output_summary(o: &OutputResult) -> String {
    let mut text = format!(
        "output {} ({}): {}",
        o.name,
        output_address(o.output),
        o.outcome()
    );
    if !o.inputs_followed.is_empty() {
        text.push_str(&format!(
            "; inputs that followed: {}",
            labelled(&o.inputs_followed)
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::api::EstopSkew;
    use crate::device::inputs::channels;

    fn isel() -> Vec<Arc<InputChannel>> {
        let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
        channels::shared(&profile)
    }

    fn by(ch: &[Arc<InputChannel>], address: &str) -> Arc<InputChannel> {
        ch.iter()
            .find(|c| c.address == address)
            .cloned()
            .expect(address)
    }

    fn change(c: &Arc<InputChannel>, level: bool, t_ms: u64, t0: Instant) -> InputChange {
        let seen = t0 + Duration::from_millis(t_ms);
        InputChange {
            seq: 0,
            channel: c.clone(),
            level,
            seen,
            before: seen - Duration::from_millis(17),
            t: Duration::from_millis(t_ms),
            chatter: None,
            skew: None,
        }
    }

    fn said(out: &[Do]) -> String {
        out.iter()
            .filter_map(|d| match d {
                Do::Say(s) => Some(s.as_str()),
                _ => None,
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn the_estop_circuits_come_first_then_the_limits_then_every_wired_input() {
        let ch = isel();
        let w = WalkTest::new(&ch, Vec::new());
        // Both circuits as one step, then 17 inputs: the wired ones (the
        // profile's wiring: no hood, power and temperature supervised by the
        // controller, key switch not wired) but the spindle's feedback.
        assert_eq!(w.steps(), 1 + 17);
        let mut w = w;
        let t0 = Instant::now();
        let out = w.start(t0);
        assert!(
            said(&out)
                .starts_with("[1/18] E-stop circuit 1 (in1.0), E-stop circuit 2 (in1.1): press"),
            "{}",
            said(&out)
        );
        let out = w.answer("", t0);
        assert!(
            said(&out).contains("[2/18] limit X1 (in3.0)"),
            "{}",
            said(&out)
        );
        let out = w.answer("", t0);
        assert!(
            said(&out).contains("[3/18] limit X2 (in3.1)"),
            "{}",
            said(&out)
        );
    }

    #[test]
    fn a_switch_that_toggles_a_swapped_wire_and_one_never_seen() {
        let ch = isel();
        let (x1, x2, y1) = (by(&ch, "in3.0"), by(&ch, "in3.1"), by(&ch, "in3.2"));
        let mut w = WalkTest::new(&[x1.clone(), x2.clone(), y1.clone()], Vec::new())
            .with_step_time(Duration::from_secs(5));
        let t0 = Instant::now();
        assert!(
            said(&w.start(t0))
                .contains("[1/3] limit X1 (in3.0): trip the switch, then free it now")
        );
        assert!(w.input(&change(&x1, true, 1000, t0), t0).is_empty());
        let out = w.input(&change(&x1, false, 1300, t0), t0);
        assert!(said(&out).contains("limit X1 (in3.0): ok, active at 1 (hit), held 0.30 s"));
        assert!(said(&out).contains("[2/3] limit X2 (in3.1)"));
        // The operator trips X2's switch, but Y1's bit moves.
        let out = w.input(&change(&y1, true, 2000, t0), t0);
        assert!(said(&out).contains("limit Y1 (in3.2) moved instead of limit X2 (in3.1)"));
        let out = w.input(&change(&y1, false, 2300, t0), t0);
        assert!(
            said(&out).contains("limit X2 (in3.1): other input moved, moved: limit Y1 (in3.2)")
        );
        // Nothing within the step's time.
        assert!(w.timed_out(t0 + Duration::from_secs(1)).is_empty());
        let out = w.timed_out(t0 + Duration::from_secs(6));
        assert!(said(&out).contains("limit Y1 (in3.2): not seen"));
        assert_eq!(out.last(), Some(&Do::Finished));
        let verdicts: Vec<Verdict> = w.inputs.iter().map(|r| r.verdict).collect();
        assert_eq!(
            verdicts,
            [Verdict::Ok, Verdict::OtherMoved, Verdict::NotSeen]
        );
    }

    #[test]
    fn an_inverted_input_and_a_skip() {
        let ch = isel();
        let (probe, start) = (by(&ch, "in1.5"), by(&ch, "in1.3"));
        let mut w = WalkTest::new(&[probe.clone(), start.clone()], Vec::new());
        let t0 = Instant::now();
        w.start(t0);
        // Resting at 1, active at 0: wired normally closed.
        w.input(&change(&probe, false, 100, t0), t0);
        let out = w.input(&change(&probe, true, 400, t0), t0);
        assert!(
            said(&out).contains("inverted, active at 0 (free), the profile says 1"),
            "{}",
            said(&out)
        );
        let out = w.answer("", t0);
        assert!(said(&out).contains("start key (in1.3): skipped"));
        assert!(w.is_done());
    }

    #[test]
    fn estop_circuits_are_timed_with_the_recorders_skew() {
        let ch = isel();
        let (e1, e2) = (by(&ch, "in1.0"), by(&ch, "in1.1"));
        let mut w = WalkTest::new(&[e1.clone(), e2.clone()], Vec::new());
        let t0 = Instant::now();
        w.start(t0);
        w.input(&change(&e1, false, 1000, t0), t0);
        let mut second = change(&e2, false, 1034, t0);
        second.skew = Some(EstopSkew {
            first: e1.clone(),
            measured: Duration::from_millis(34),
            min: Duration::from_millis(17),
            max: Duration::from_millis(51),
        });
        w.input(&second, t0);
        w.input(&change(&e1, true, 2000, t0), t0);
        let out = w.input(&change(&e2, true, 2017, t0), t0);
        assert!(said(&out).contains("E-stop circuit 1 (in1.0): ok, active at 0 (open)"));
        assert!(said(&out).contains("E-stop skew: 34.0 ms (between 17.0 ms and 51.0 ms)"));
        let e = w.estop().expect("estop");
        assert_eq!(e.close_skew, Some(Duration::from_millis(17)));
        assert_eq!(out.last(), Some(&Do::Finished));
    }

    #[test]
    fn an_output_is_switched_only_after_yes_and_back_after_the_answer() {
        let spindle = OutputChoice {
            name: "spindle".into(),
            output: OutputId {
                group: 2,
                bit: None,
            },
            hazardous: true,
            value: false,
        };
        let mut w = WalkTest::new(&[], vec![spindle.clone(), spindle]);
        let t0 = Instant::now();
        let out = w.start(t0);
        assert!(said(&out).contains("output spindle (out2): switch it on to check it? It moves"));
        let out = w.answer("y", t0);
        assert_eq!(
            out[0],
            Do::Request(Request::SetOutput {
                output: OutputId {
                    group: 2,
                    bit: None
                },
                value: 1
            })
        );
        let out = w.answer("y", t0);
        assert_eq!(
            out[0],
            Do::Request(Request::SetOutput {
                output: OutputId {
                    group: 2,
                    bit: None
                },
                value: 0
            })
        );
        assert!(said(&out).contains("output spindle (out2): switched to 1: confirmed"));
        // The second: skipped, nothing is switched.
        let out = w.answer("", t0);
        assert!(!out.iter().any(|d| matches!(d, Do::Request(_))));
        assert_eq!(w.outputs[1].switched_to, None);
    }

    #[test]
    fn q_ends_it_and_what_is_left_is_skipped() {
        let ch = isel();
        let mut w = WalkTest::new(&ch, Vec::new());
        let t0 = Instant::now();
        w.start(t0);
        let out = w.answer("q", t0);
        assert_eq!(out.last(), Some(&Do::Finished));
        assert!(w.ended_early);
        assert_eq!(w.inputs.len(), 17);
        assert!(w.inputs.iter().all(|r| r.verdict == Verdict::Skipped));
        let e = w.estop().expect("estop");
        assert!(e.circuits.iter().all(|r| r.verdict == Verdict::Skipped));
    }
}
