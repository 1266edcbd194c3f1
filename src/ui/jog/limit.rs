//! The jog off a limit switch from the console (`L`, `docs/jogging.md`,
//! "Jog off a limit switch"): which switch reads active (the last I/O
//! snapshot, as the profile's `[io]` wires it), the question the operator
//! confirms, the run shown on the keypad's status line, and what follows
//! its end (a reference run is asked for once the axis is off the switch).
//!
//! The UI only asks: the driver checks the switch and the direction again
//! against its own reading and does the moving (`Request::LimitJog`).

use std::time::Instant;

use crate::axis::Axis;
use crate::device::api::{ActiveLimit, Dir, Event, JogEnd, JogId, Request};
use crate::jog::Motion;
use crate::proto::Protocol;
use crate::ui::position::format_amount;

use super::super::setup::Setup;
use crate::jog::{Gate, JogSettings};

/// Limit jogs are numbered apart from the keypad's jogs (`jog::Jogger`
/// counts from 1), so an end is never taken for the other's.
const IDS: u64 = 1 << 63;

/// A jog off a limit switch the console asked for and has not seen end.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitRun {
    pub id: JogId,
    /// The switch it leaves.
    pub limit: ActiveLimit,
    pub since: Instant,
    /// The device task has reported it running.
    pub seen: bool,
    /// Seen running, then the machine at rest: its end was missed (it
    /// comes before the rest); not shown as running any more.
    pub idle: bool,
}

/// What the keypad keeps for the jog off a limit switch.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LimitState {
    /// The limit switches that read active in the last I/O snapshot.
    pub active: Vec<ActiveLimit>,
    pub run: Option<LimitRun>,
    next: u64,
}

/// What `L` asks: a title, the question, and the request a yes sends.
#[derive(Debug, Clone, PartialEq)]
pub struct Question {
    pub title: String,
    pub question: String,
    pub request: Request,
}

fn unit(setup: &Setup, axis: Axis) -> &'static str {
    setup.axis(axis).map_or("units", |p| p.unit.symbol())
}

fn dir_text(axis: Axis, dir: Dir) -> String {
    format!("{axis}{}", dir.symbol())
}

/// The switch `L` would leave: the first axis with one switch active; or
/// why there is none.
fn candidate(active: &[ActiveLimit]) -> Result<(ActiveLimit, Vec<ActiveLimit>), String> {
    let single = |l: &&ActiveLimit| active.iter().filter(|o| o.axis == l.axis).count() == 1;
    let mut singles = active.iter().filter(single).cloned();
    match singles.next() {
        Some(first) => Ok((first, singles.collect())),
        None => match active.first() {
            Some(both) => Err(format!(
                "both limit switches of {} read active: which end it stands at is unknown; \
                 check the switches and the profile's [io] wiring",
                both.axis
            )),
            None => {
                Err("no limit switch reads active (ports as last read): nothing to jog off".into())
            }
        },
    }
}

/// `L`: the question to confirm, or why not (for the message line).
pub fn ask(
    state: &mut LimitState,
    settings: &JogSettings,
    gate: &Gate,
    setup: &Setup,
) -> Result<Question, String> {
    if setup.protocol == Protocol::Emcu {
        return Err(
            "jog off limit: the EMCU reports no limit switches jogterm could read (docs/jogging.md)"
                .into(),
        );
    }
    gate.check(Motion::OffLimit)
        .map_err(|reason| format!("jog off limit refused: {reason}"))?;
    let (limit, others) = candidate(&state.active)?;
    let u = unit(setup, limit.axis);
    let speed = settings.axis(limit.axis).map_or(settings.limit_speed, |a| {
        settings.limit_speed.min(a.max_speed)
    });
    let mut question = format!(
        "{axis} stands in its {side} limit switch {name} ({address}). It moves slowly in {dir} \
         ({speed} {u}/s) until the switch releases, at most {distance} {u}; nothing but that \
         switch is overridden. Then a reference run. Keep clear of the machine. Jog {axis} \
         off the switch?",
        axis = limit.axis,
        side = limit.side,
        name = limit.name,
        address = limit.address,
        dir = dir_text(limit.axis, limit.away()),
        speed = format_amount(speed),
        distance = format_amount(settings.limit_distance),
    );
    if !others.is_empty() {
        let list: Vec<String> = others
            .iter()
            .map(|o| format!("{} {}", o.axis, o.side))
            .collect();
        question.push_str(&format!(
            " ({} also read active: L again afterwards.)",
            list.join(", ")
        ));
    }
    state.next += 1;
    let id = JogId(IDS | state.next);
    Ok(Question {
        title: format!("Jog {} off its limit switch", limit.axis),
        question,
        request: Request::LimitJog {
            id,
            axis: limit.axis,
            dir: limit.away(),
        },
    })
}

impl LimitState {
    /// The request went out: show it running.
    pub fn issued(&mut self, request: &Request, now: Instant) {
        let Request::LimitJog { id, axis, dir } = request else {
            return;
        };
        let limit = self
            .active
            .iter()
            .find(|l| l.axis == *axis && l.away() == *dir)
            .cloned();
        if let Some(limit) = limit {
            self.run = Some(LimitRun {
                id: *id,
                limit,
                since: now,
                seen: false,
                idle: false,
            });
        }
    }

    /// A device event: the switches read, the run seen going and ending.
    pub fn device_event(&mut self, event: &Event) {
        match event {
            Event::Io(snapshot) => self.active = snapshot.active_limits(),
            Event::State(state) => {
                if let Some(run) = self.run.as_mut() {
                    if state.activity != crate::device::api::Activity::Idle {
                        run.seen = true;
                    } else if run.seen {
                        run.idle = true;
                    }
                }
            }
            _ => {}
        }
    }

    /// Jog `id` ended: its run, when it was the jog off a limit switch.
    pub fn ended(&mut self, id: JogId) -> Option<LimitRun> {
        self.run.take_if(|r| r.id == id)
    }
}

/// What the console does when the jog off a limit switch has ended.
#[derive(Debug, Clone, PartialEq)]
pub enum AfterEnd {
    /// Off the switch: ask for the reference run.
    Reference,
    /// Say this (the driver's notice has the details).
    Say { danger: bool, text: String },
}

pub fn after(run: &LimitRun, end: &JogEnd) -> AfterEnd {
    let axis = run.limit.axis;
    let say = |danger: bool, text: String| AfterEnd::Say { danger, text };
    match end {
        JogEnd::OffLimit => AfterEnd::Reference,
        JogEnd::StillOnLimit => say(
            true,
            format!(
                "jog off limit: {} still reads active: {axis} stopped (see the console)",
                run.limit.name
            ),
        ),
        JogEnd::Stopped | JogEnd::Released | JogEnd::DeadMan => {
            say(false, format!("jog of {axis} off its limit switch stopped"))
        }
        JogEnd::SoftLimit => say(false, format!("jog of {axis} off its limit switch ended")),
        JogEnd::Refused(reason) => say(true, format!("jog off limit refused: {reason}")),
        JogEnd::Fault(f) => say(
            true,
            format!(
                "jog off limit ended: {}",
                crate::ui::messages::fault_text(f)
            ),
        ),
        JogEnd::LinkLost => say(true, "jog off limit ended: link lost".into()),
    }
}

/// The keypad's status line while it runs.
pub fn status(state: &LimitState, s: &JogSettings, setup: &Setup) -> Option<String> {
    let run = state.run.as_ref().filter(|r| !r.idle)?;
    let axis = run.limit.axis;
    let u = unit(setup, axis);
    // The speed is in the question and Space on the key line: the panel
    // is narrow.
    Some(format!(
        "off {}: {} at most {} {u}",
        run.limit.name,
        dir_text(axis, run.limit.away()),
        format_amount(s.limit_distance),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wiring::Side;

    fn limit(axis: Axis, side: Side) -> ActiveLimit {
        ActiveLimit {
            axis,
            side,
            name: format!("limit {axis}"),
            address: "in3.0".into(),
        }
    }

    #[test]
    fn the_first_axis_with_one_switch_is_the_candidate() {
        assert!(candidate(&[]).is_err());
        let both = [limit(Axis::X, Side::Min), limit(Axis::X, Side::Max)];
        let e = candidate(&both).err().unwrap_or_default();
        assert!(e.contains("both limit switches of X"), "{e}");
        let mixed = [
            limit(Axis::X, Side::Min),
            limit(Axis::X, Side::Max),
            limit(Axis::Z, Side::Max),
            limit(Axis::A, Side::Min),
        ];
        let (first, others) = candidate(&mixed).expect("Z");
        assert_eq!((first.axis, first.side), (Axis::Z, Side::Max));
        assert_eq!(others.len(), 1);
    }
}
