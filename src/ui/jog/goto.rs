//! The go-to prompt: a position typed in units (`X10 Y-2.5`, `x=10, z=0`),
//! in the active work offset's coordinates or, switched with Tab or typed
//! `G53` (LinuxCNC's word for it), in machine coordinates; at the jog speed
//! or at a feed typed with it (`F200`, units per minute as in G-code).
//! Checked against the machine's axes, the soft limits and the axes' top
//! speeds before a `MoveTo` goes out (always in machine coordinates: the
//! work offsets are jogterm's, `ui::jog::offsets`); and the move to the
//! work zero. The same words, without `F` and `G53`, set the work position
//! here (`s`).

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Frame, PerAxis, Request};
use crate::jog::{Gate, JogSettings, Motion};
use crate::offsets::WorkOffsets;

use super::super::keymap::Action;
use super::super::line_edit::{LineEdit, LineError, edit_line};
use super::super::msg::Effect;
use super::super::outcome::Outcome;
use super::super::traffic_log::NoteLevel;

/// The prompt's state: the line being typed and why it was refused, and
/// the coordinates it is typed in.
#[derive(Debug, Clone, PartialEq)]
pub struct GoToPrompt {
    pub line: LineEdit,
    pub frame: Frame,
}

impl Default for GoToPrompt {
    fn default() -> Self {
        GoToPrompt {
            line: LineEdit::default(),
            frame: Frame::Work,
        }
    }
}

/// What the go-to prompt reads, built per call (`Model::goto_context`).
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    pub settings: &'a JogSettings,
    /// Whether a go-to may start now.
    pub gate: Gate<'a>,
    /// The jog speed selected (units/s), for a target typed without a feed.
    pub speed: f64,
    pub offsets: &'a WorkOffsets,
}

/// The go-to prompt as a component: its state is the prompt (in the popup
/// slot while open); `g` opens it, `G` asks for the move to the work zero.
impl GoToPrompt {
    /// Tab: work ↔ machine coordinates.
    pub fn toggle_frame(&mut self) {
        self.frame = match self.frame {
            Frame::Work => Frame::Machine,
            Frame::Machine => Frame::Work,
        };
    }

    /// `g`: the prompt, unless no go-to may start now.
    pub fn open(ctx: &Context) -> Outcome<GoToPrompt> {
        match ctx.gate.check(Motion::GoTo) {
            Ok(()) => Outcome::popup(GoToPrompt::default()),
            Err(reason) => Outcome::note(NoteLevel::Danger, format!("go to refused: {reason}")),
        }
    }

    /// `G`: the move to the work zero, asked first.
    pub fn zero(ctx: &Context) -> Outcome<GoToPrompt> {
        let refused = |reason: String| Outcome::note(NoteLevel::Danger, reason);
        if let Err(reason) = ctx.gate.check(Motion::GoTo) {
            return refused(format!("go to zero refused: {reason}"));
        }
        let target = zero_target(ctx.settings);
        match request(&target, Frame::Work, ctx.settings, ctx.offsets, ctx.speed) {
            Ok(planned) => Outcome::ask(
                "Go to the work zero",
                format!(
                    "Axes {} will move to the work zero of {} ({}) at {} per second. Keep \
                     clear of the machine. Go?",
                    ctx.settings.axis_set(),
                    ctx.offsets.active(),
                    describe(&target),
                    amount(ctx.speed)
                ),
                vec![Effect::Request(planned.request)],
            ),
            Err(e) => refused(format!("go to zero refused: {e}")),
        }
    }

    /// A key of the open prompt (taken out of the popup slot, given back
    /// while it stays open): editing keys, Enter checks and goes, Esc
    /// cancels.
    pub fn update(mut self, ctx: &Context, action: Action) -> Outcome<GoToPrompt> {
        match action {
            Action::Cancel => return Outcome::note(NoteLevel::Info, "go to: cancelled"),
            Action::ToggleFrame => self.toggle_frame(),
            Action::Submit => match self.check(ctx) {
                Ok((target, planned)) => {
                    let frame = match planned.frame {
                        Frame::Work => format!("{} work coordinates", ctx.offsets.active()),
                        Frame::Machine => "machine coordinates".to_string(),
                    };
                    let text = format!(
                        "go to {} ({frame}) at {} per second",
                        describe(&target),
                        amount(planned.speed)
                    );
                    return Outcome {
                        effects: vec![Effect::Request(planned.request)],
                        ..Outcome::note(NoteLevel::Info, text)
                    };
                }
                Err(message) => {
                    let span = None;
                    self.line.error = Some(LineError { message, span });
                }
            },
            other => edit_line(&mut self.line, other),
        }
        Outcome::popup(self)
    }

    /// The typed target and its move, or why not.
    fn check(&self, ctx: &Context) -> Result<(Target, Planned), String> {
        ctx.gate.check(Motion::GoTo).map_err(|r| r.to_string())?;
        let t = parse(self.line.text(), ctx.settings).map_err(|e| e.to_string())?;
        let planned = request(&t, self.frame, ctx.settings, ctx.offsets, ctx.speed);
        planned.map(|p| (t, p)).map_err(|e| e.to_string())
    }
}

/// A target parsed from the prompt: units per axis, and what else was
/// typed with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    pub units: Vec<(Axis, f64)>,
    /// `F…`: the path speed in units per minute.
    pub feed: Option<f64>,
    /// `G53`: machine coordinates, whatever the prompt is switched to.
    pub machine: bool,
}

impl Target {
    /// Axes and values only: what setting the work position takes.
    pub fn plain(units: Vec<(Axis, f64)>) -> Target {
        Target {
            units,
            feed: None,
            machine: false,
        }
    }
}

/// Why a typed target cannot be gone to.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetError {
    #[error("type an axis and a position, such as X10 Y-2.5")]
    Empty,
    #[error("`{0}` is not an axis and a position (such as X10), a feed (F200) or G53")]
    Syntax(String),
    #[error("the machine has no {axis} axis (axes {machine})")]
    NoAxis { axis: Axis, machine: AxisSet },
    #[error("{0} is given twice")]
    Twice(String),
    #[error("{axis}{work} is outside the soft limits: work {lo}..{hi} (machine {min}..{max})")]
    SoftLimit {
        axis: Axis,
        work: String,
        lo: String,
        hi: String,
        min: String,
        max: String,
    },
    #[error("{axis}{value} is outside the soft limits: machine {min}..{max}")]
    MachineLimit {
        axis: Axis,
        value: String,
        min: String,
        max: String,
    },
    #[error("F{feed} is faster than {axis} may run: at most F{max} ({per_second} per second)")]
    TooFast {
        feed: String,
        axis: Axis,
        max: String,
        per_second: String,
    },
    #[error("F{feed} is slower than one step per second of {axis}: at least F{min}")]
    TooSlow {
        feed: String,
        axis: Axis,
        min: String,
    },
}

/// Parse `X10,Y-2.5`, `x=10 z=0 F200`, `G53 X10Y-2.5`: an axis letter, an
/// optional `=`, a decimal number; `F` and a speed in units per minute;
/// `G53`; items separated by commas or blanks, or not at all.
pub fn parse(text: &str, settings: &JogSettings) -> Result<Target, TargetError> {
    let machine = settings.axis_set();
    let mut target = Target::plain(Vec::new());
    for word in items(text) {
        if word.eq_ignore_ascii_case("G53") {
            if target.machine {
                return Err(TargetError::Twice("G53".into()));
            }
            target.machine = true;
            continue;
        }
        let mut chars = word.chars();
        let first = chars.next();
        let rest = chars.as_str();
        let number = rest.strip_prefix('=').unwrap_or(rest);
        let value = || -> Result<f64, TargetError> {
            number
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| TargetError::Syntax(word.clone()))
        };
        if first.is_some_and(|c| c.eq_ignore_ascii_case(&'F')) {
            if target.feed.is_some() {
                return Err(TargetError::Twice("F".into()));
            }
            target.feed = Some(value()?);
            continue;
        }
        let axis = first
            .and_then(Axis::from_letter)
            .ok_or_else(|| TargetError::Syntax(word.clone()))?;
        let value = value()?;
        if !machine.contains(axis) {
            return Err(TargetError::NoAxis { axis, machine });
        }
        if target.units.iter().any(|(a, _)| *a == axis) {
            return Err(TargetError::Twice(axis.to_string()));
        }
        target.units.push((axis, value));
    }
    if target.units.is_empty() {
        return Err(TargetError::Empty);
    }
    target.units.sort_by_key(|(a, _)| a.index());
    Ok(target)
}

/// The items of a target line: split at blanks and commas, before every
/// axis letter, and before an `F` or `G` followed by a number (not at `e`:
/// `X1e3` is a number; nor in `Xinf`, which is refused whole).
fn items(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut current = String::new();
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        let separator = c.is_whitespace() || c == ',';
        let number_follows = chars
            .peek()
            .is_some_and(|n| n.is_ascii_digit() || matches!(n, '.' | '-' | '+' | '='));
        let starts = Axis::from_letter(c).is_some()
            || (matches!(c, 'F' | 'f' | 'G' | 'g') && number_follows);
        if (separator || starts) && !current.is_empty() {
            out.push(std::mem::take(&mut current));
        }
        if !separator {
            current.push(c);
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

fn amount(v: f64) -> String {
    super::super::position::format_amount(v)
}

/// A checked move: the request, and what it was typed in, for messages.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    pub request: Request,
    pub frame: Frame,
    /// The path speed, units per second.
    pub speed: f64,
}

/// The move to `target`, typed in `frame` (a typed `G53` makes it machine
/// coordinates), work coordinates counted from the active system of
/// `offsets`; at the typed feed or else at `speed` units per second. The
/// soft limits and speeds are checked here so the prompt says at once what
/// is wrong; the driver checks again (it knows the position then).
pub fn request(
    target: &Target,
    frame: Frame,
    settings: &JogSettings,
    offsets: &WorkOffsets,
    speed: f64,
) -> Result<Planned, TargetError> {
    let frame = if target.machine {
        Frame::Machine
    } else {
        frame
    };
    let mut steps = PerAxis::new();
    let mut pairs = Vec::new();
    let mut axes = Vec::new();
    for (axis, typed) in &target.units {
        let Some(a) = settings.axis(*axis) else {
            return Err(TargetError::NoAxis {
                axis: *axis,
                machine: settings.axis_set(),
            });
        };
        let zero_steps = match frame {
            Frame::Machine => 0,
            Frame::Work => offsets.active_zero(*axis),
        };
        let zero = zero_steps as f64 / a.steps_per_unit;
        let machine_units = typed + zero;
        // A hair of tolerance, so a limit typed exactly is not refused for
        // the rounding of its steps.
        let eps = 0.5 / a.steps_per_unit;
        if machine_units < a.min - eps || machine_units > a.max + eps {
            return Err(match frame {
                Frame::Work => TargetError::SoftLimit {
                    axis: *axis,
                    work: amount(*typed),
                    lo: amount(a.min - zero),
                    hi: amount(a.max - zero),
                    min: amount(a.min),
                    max: amount(a.max),
                },
                Frame::Machine => TargetError::MachineLimit {
                    axis: *axis,
                    value: amount(*typed),
                    min: amount(a.min),
                    max: amount(a.max),
                },
            });
        }
        steps.set(*axis, a.to_steps(*typed).saturating_add(zero_steps));
        // The direction does not matter for the speed of each axis.
        pairs.push((*axis, Dir::Plus));
        axes.push(a);
    }
    let speed = match target.feed {
        Some(feed) => feed_speed(feed, &axes)?,
        None => speed,
    };
    Ok(Planned {
        request: Request::MoveTo {
            target: steps,
            frame: Frame::Machine,
            speed_hz: settings.speeds_hz(&pairs, speed),
        },
        frame,
        speed,
    })
}

/// A typed feed (units per minute) as a path speed in units per second:
/// no faster than the slowest axis it moves may run, no slower than one
/// step per second of any of them.
fn feed_speed(feed: f64, axes: &[&crate::jog::JogAxis]) -> Result<f64, TargetError> {
    let per_second = feed / 60.0;
    for a in axes {
        if per_second > a.max_speed + 1e-9 {
            return Err(TargetError::TooFast {
                feed: amount(feed),
                axis: a.axis,
                max: amount(a.max_speed * 60.0),
                per_second: amount(a.max_speed),
            });
        }
        if per_second * a.steps_per_unit < 1.0 {
            return Err(TargetError::TooSlow {
                feed: amount(feed),
                axis: a.axis,
                min: amount(60.0 / a.steps_per_unit),
            });
        }
    }
    Ok(per_second)
}

/// The move to the work zero of every axis.
pub fn zero_target(settings: &JogSettings) -> Target {
    Target::plain(settings.axes.iter().map(|a| (a.axis, 0.0)).collect())
}

/// `X10 Y-2.5` for messages.
pub fn describe(target: &Target) -> String {
    target
        .units
        .iter()
        .map(|(a, v)| format!("{a}{}", amount(*v)))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn settings() -> JogSettings {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        JogSettings::from_profile(&profile)
    }

    #[test]
    fn targets_parse_in_any_spelling() {
        let s = settings();
        for text in [
            "X10 Y-2.5",
            "x=10, y=-2.5",
            " y-2.5,x10 ",
            "X10Y-2.5",
            "x10,y=-2.5",
        ] {
            assert_eq!(
                parse(text, &s),
                Ok(Target::plain(vec![(Axis::X, 10.0), (Axis::Y, -2.5)])),
                "{text}"
            );
        }
        assert_eq!(parse("", &s), Err(TargetError::Empty));
        assert_eq!(parse("X", &s), Err(TargetError::Syntax("X".into())));
        assert_eq!(parse("Q5", &s), Err(TargetError::Syntax("Q5".into())));
        assert_eq!(parse("X1=2", &s), Err(TargetError::Syntax("X1=2".into())));
        assert_eq!(parse("Xinf", &s), Err(TargetError::Syntax("Xinf".into())));
        assert_eq!(parse("X1 X2", &s), Err(TargetError::Twice("X".into())));
        assert_eq!(parse("X1 F2 F3", &s), Err(TargetError::Twice("F".into())));
        assert_eq!(
            parse("G53 g53 X1", &s),
            Err(TargetError::Twice("G53".into()))
        );
        assert_eq!(parse("G54 X1", &s), Err(TargetError::Syntax("G54".into())));
        assert_eq!(parse("F200", &s), Err(TargetError::Empty));
        assert_eq!(
            parse("X1e1", &s).map(|t| t.units),
            Ok(vec![(Axis::X, 10.0)])
        );
        let t = parse("g53x10Y5F200", &s).expect("parses");
        assert_eq!(t.units, vec![(Axis::X, 10.0), (Axis::Y, 5.0)]);
        assert_eq!((t.feed, t.machine), (Some(200.0), true));
        assert!(matches!(
            parse("A5", &s),
            Err(TargetError::NoAxis { axis: Axis::A, .. })
        ));
    }

    proptest::proptest! {
        /// Whatever is typed: an answer, never a panic; an accepted target
        /// names each of the machine's axes at most once, with a finite value.
        #[test]
        fn any_typed_line_is_parsed_or_refused(text in "[xyzaXYZA0-9=,.+\\-e ]{0,24}|\\PC{0,24}") {
            let s = settings();
            if let Ok(t) = parse(&text, &s) {
                proptest::prop_assert!(!t.units.is_empty());
                for (i, (axis, v)) in t.units.iter().enumerate() {
                    proptest::prop_assert!(v.is_finite());
                    proptest::prop_assert!(s.axis_set().contains(*axis));
                    proptest::prop_assert!(t.units.iter().skip(i + 1).all(|(a, _)| a != axis));
                }
                let _ = request(&t, Frame::Work, &s, &WorkOffsets::default(), 2.0);
            }
        }
    }

    /// Work zero (G54) at X = 100 mm (40000 steps): X may go from -100 to
    /// 200 in work coordinates, 0 to 300 in machine coordinates; the move
    /// goes out in machine steps.
    fn offsets() -> WorkOffsets {
        let mut t = WorkOffsets::default();
        t.set(crate::offsets::System::G54, Axis::X, 40_000);
        t
    }

    fn go(text: &str, frame: Frame) -> Result<Planned, String> {
        let s = settings();
        parse(text, &s)
            .and_then(|t| request(&t, frame, &s, &offsets(), 2.0))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn soft_limits_count_from_the_work_zero() {
        let Ok(Planned {
            request:
                Request::MoveTo {
                    target,
                    frame,
                    speed_hz,
                },
            frame: typed,
            speed,
        }) = go("X-100", Frame::Work)
        else {
            panic!()
        };
        assert_eq!(target.get(Axis::X), Some(0));
        assert_eq!((frame, typed, speed), (Frame::Machine, Frame::Work, 2.0));
        assert_eq!(speed_hz.get(Axis::X), Some(800.0));
        assert_eq!(
            go("X201", Frame::Work).map(|_| ()),
            Err("X201 is outside the soft limits: work -100..200 (machine 0..300)".into())
        );
    }

    #[test]
    fn machine_coordinates_by_tab_or_g53() {
        for (text, frame) in [("X250", Frame::Machine), ("G53 X250", Frame::Work)] {
            let Ok(p) = go(text, frame) else {
                panic!("{text}")
            };
            assert_eq!(p.frame, Frame::Machine);
            let Request::MoveTo { target, .. } = p.request else {
                panic!()
            };
            assert_eq!(target.get(Axis::X), Some(100_000), "{text}");
        }
        assert_eq!(
            go("G53 X301", Frame::Work).map(|_| ()),
            Err("X301 is outside the soft limits: machine 0..300".into())
        );
    }

    #[test]
    fn a_typed_feed_is_units_per_minute_within_the_axes_speeds() {
        // F120 = 2 mm/s = 800 Hz at 400 steps/mm.
        let Ok(p) = go("X10 F120", Frame::Work) else {
            panic!()
        };
        let Request::MoveTo { speed_hz, .. } = &p.request else {
            panic!()
        };
        assert_eq!((p.speed, speed_hz.get(Axis::X)), (2.0, Some(800.0)));
        // The default profile: X at most 25 mm/s (F1500), Z 15 mm/s (F900).
        assert!(go("X10 F1500", Frame::Work).is_ok());
        assert_eq!(
            go("X10 Z5 F1000", Frame::Work).map(|_| ()),
            Err("F1000 is faster than Z may run: at most F900 (15 per second)".into())
        );
        assert_eq!(
            go("X10 F0.1", Frame::Work).map(|_| ()),
            Err("F0.1 is slower than one step per second of X: at least F0.15".into())
        );
        assert!(go("X10 F-5", Frame::Work).is_err());
    }
}
