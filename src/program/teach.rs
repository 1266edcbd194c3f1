//! Teach-in: program lines from where the machine stands (`docs/editor.md`,
//! "Teach-in"). Pure: the position, work zero and speed come in, checked
//! command lines in the program's language go out. The editor asks for them
//! (`ui::editor`); it builds no command text of its own.
//!
//! - isel (manual 3.2.16, 3.2.2): an absolute move `m` to the position in
//!   work coordinates (the virtual zero of `@0n` in force when taught,
//!   `docs/protocols.md` isel: `m` targets count from it), or a relative
//!   move `0` by the distance from the previously taught point. One
//!   steps,speed pair per axis of the controller's configuration; with three
//!   axes four pairs (x, y, z1, z2), the last one 0 (`docs/decisions.md`
//!   isel 5).
//! - EMCU (manual 1.5.10, 1.5.6): `L<slot>,X…,Y…,Z…` (upper case absolute,
//!   in machine coordinates from the reference point, `docs/protocols.md`
//!   EMCU: jogterm's work zero is the console's own and no part of a job;
//!   lower case relative) with the end-speed slot [`EMCU_TEACH_SLOT`], whose
//!   speed `#E<slot>,<hz>` is set before the move when the job does not
//!   already run it at that speed, and set back after it for a later move of
//!   the job that relied on the old one.
//! - Dwell: isel `5` in tenths of a second (3.2.6), EMCU `W` in ms (1.5.16).
//! - Output: isel `p<port>,<bit>,<value>` (3.2.20), EMCU `A<n>,<0|1>` (1.5.15).
//!
//! Every line is checked with the protocol core's own parser (and for isel
//! the axis configuration) before it is offered.

use thiserror::Error;

use super::path::covering_config;
use super::{Command, Language, Program};
use crate::axis::Axis;
use crate::config::profile::AxisProfile;
use crate::device::api::{MachineState, PerAxis};
use crate::proto::emcu;
use crate::proto::isel::{AxisConfig, CncCommand, validate_cnc};

/// The EMCU end-speed slot taught moves use (jogterm's own moves use the
/// profile's `emcu.move_slot`, 9 by default).
pub const EMCU_TEACH_SLOT: u8 = 8;

/// isel step frequencies (`docs/decisions.md` isel 13).
const ISEL_HZ: (f64, f64) = (1.0, 40_000.0);
/// EMCU `#E` speeds (manual 1.5.6).
const EMCU_HZ: (f64, f64) = (emcu::Speed::MIN as f64, emcu::Speed::MAX as f64);
/// isel position counters are 24 bit (`docs/decisions.md` isel 2).
const ISEL_STEPS: (i64, i64) = (-8_388_608, 8_388_607);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// To the position, in work coordinates.
    Absolute,
    /// From the previously taught point to the position.
    Relative,
}

#[derive(Debug, Clone, PartialEq, Error)]
pub enum TeachError {
    #[error("the position of {0} is not known yet: wait for the controller to report it")]
    NoPosition(Axis),
    #[error(
        "the work zero of {0} is not known: set it (z) or reference the axes (h) before teaching absolute moves"
    )]
    ZeroUnknown(Axis),
    #[error(
        "{0} is not referenced: reference the axes (h) before teaching absolute moves (EMCU targets count from the reference point)"
    )]
    Unreferenced(Axis),
    #[error("no point taught yet: teach an absolute move (t) first, relative moves follow it")]
    NothingTaught,
    #[error("{axis}: {value} steps is beyond what the controller counts ({min}..{max})")]
    OutOfRange {
        axis: Axis,
        value: i64,
        min: i64,
        max: i64,
    },
    #[error("{0}")]
    Invalid(String),
}

/// What the machine is, for teaching: the program's language and the axes
/// of the profile in X, Y, Z, A order.
#[derive(Debug, Clone, Copy)]
pub struct Machine<'a> {
    pub language: Language,
    pub axes: &'a [(Axis, AxisProfile)],
}

impl Machine<'_> {
    fn isel_config(&self) -> AxisConfig {
        covering_config(self.axes.iter().map(|(a, _)| *a).collect())
    }

    fn profile(&self, axis: Axis) -> Option<&AxisProfile> {
        self.axes.iter().find(|(a, _)| *a == axis).map(|(_, p)| p)
    }

    /// The step frequency of `axis` at `units_per_second`, capped by the
    /// profile's highest speed of the axis and the controller's range.
    fn hz(&self, axis: Axis, units_per_second: f64) -> u32 {
        let (min, max) = match self.language {
            Language::Isel => ISEL_HZ,
            Language::Emcu => EMCU_HZ,
        };
        let Some(p) = self.profile(axis) else {
            return min as u32;
        };
        let wanted = p.speed_hz(units_per_second.min(p.max_speed));
        let hz = if wanted.is_finite() {
            wanted.round()
        } else {
            min
        };
        hz.clamp(min, max) as u32
    }
}

/// Where the EMCU teach slot's speed stands around the insertion point of a
/// job (EMCU jobs run from top to bottom, manual 1.5).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SlotContext {
    /// The slot's speed set by the last `#E` before the insertion point.
    pub before: Option<u16>,
    /// A move of the slot follows the insertion point before any `#E` of it
    /// sets a new speed: it relies on `before`.
    pub used_after: bool,
}

impl SlotContext {
    /// Read the context of inserting before line `at` of `program`.
    pub fn of(program: &Program, at: usize) -> SlotContext {
        let mut ctx = SlotContext::default();
        let mut after_set = false;
        for (line, s) in program.statements() {
            let Ok(Command::Emcu(c)) = &s.command else {
                continue;
            };
            match c {
                emcu::Command::EndSpeed { slot, speed }
                    if slot.get() == u16::from(EMCU_TEACH_SLOT) =>
                {
                    if line < at {
                        ctx.before = Some(speed.get());
                    } else {
                        after_set = true;
                    }
                }
                emcu::Command::Move(mv)
                    if line >= at
                        && !after_set
                        && mv.slot().get() == u16::from(EMCU_TEACH_SLOT) =>
                {
                    ctx.used_after = true;
                }
                _ => {}
            }
        }
        ctx
    }
}

/// Where taught lines go in `program` when the cursor is on line `cursor`:
/// after the cursor's line, but never after the program's end `9` (they
/// would be refused as commands after the end).
pub fn insertion_point(program: &Program, cursor: usize) -> usize {
    let at = cursor + 1;
    let end = program.statements().find_map(|(line, s)| {
        matches!(&s.command, Ok(Command::Isel(CncCommand::End))).then_some(line)
    });
    end.map_or(at, |e| at.min(e))
}

/// A number as the operator types it into a form (a decimal comma is a
/// point); `what` names it in the error.
pub fn number(text: &str, what: &str) -> Result<f64, String> {
    text.trim()
        .replace(',', ".")
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("the {what} is no number: `{}`", text.trim()))
}

/// Taught lines and the point they leave the machine at.
#[derive(Debug, Clone, PartialEq)]
pub struct Taught {
    pub lines: Vec<String>,
    /// Machine steps: the next relative move starts here.
    pub point: PerAxis<i64>,
}

/// Check a line with the core's parser (and the isel axis configuration);
/// the canonical spelling, or why it cannot be stored.
pub fn checked_line(machine: &Machine, line: &str) -> Result<String, String> {
    match machine.language {
        Language::Isel => validate_cnc(line, machine.isel_config())
            .map(|p| p.value.to_string())
            .map_err(|r| format!("`{line}`: {}", r.message)),
        Language::Emcu => emcu::parse_line(line)
            .map_err(|e| format!("`{line}`: {}", e.kind))
            .and_then(|c| {
                if c.is_storable() {
                    Ok(c.to_string())
                } else {
                    Err(format!("`{line}` is a master command and cannot be stored"))
                }
            }),
    }
}

fn in_range(axis: Axis, value: i64, (min, max): (i64, i64)) -> Result<i64, TeachError> {
    if (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(TeachError::OutOfRange {
            axis,
            value,
            min,
            max,
        })
    }
}

/// Where the absolute targets of a stored program count from, machine steps
/// per axis (an axis left out has none known yet):
/// - isel `m` from the virtual zero of `@0n` in force (manual 2.2.19), which
///   the driver tracks as its work zero (back at 0 after a reference run);
/// - EMCU `L` from the reference point (manual 1.5.10): 0 on every
///   referenced axis. jogterm's EMCU work zero (`z`) is the console's own
///   offset for its go-to moves and the position display; a job never sees
///   it (`docs/protocols.md` EMCU), so teaching must not subtract it.
pub fn absolute_origin(language: Language, machine: &MachineState) -> PerAxis<i64> {
    match language {
        Language::Isel => machine.work_zero,
        Language::Emcu => machine
            .referenced
            .iter()
            .fold(PerAxis::new(), |origin, axis| origin.with(axis, 0)),
    }
}

/// A taught move to `position` (machine steps) at `units_per_second`.
/// `origin` is where absolute targets count from ([`absolute_origin`]),
/// `previous` the point taught before (relative moves), `slot` the EMCU slot
/// context.
pub fn taught_move(
    machine: &Machine,
    kind: MoveKind,
    position: &PerAxis<i64>,
    origin: &PerAxis<i64>,
    previous: Option<&PerAxis<i64>>,
    units_per_second: f64,
    slot: SlotContext,
) -> Result<Taught, TeachError> {
    let mut values: Vec<(Axis, i64)> = Vec::new();
    for (axis, _) in machine.axes {
        let here = position.get(*axis).ok_or(TeachError::NoPosition(*axis))?;
        let value = match kind {
            MoveKind::Absolute => {
                let unknown = match machine.language {
                    Language::Isel => TeachError::ZeroUnknown(*axis),
                    Language::Emcu => TeachError::Unreferenced(*axis),
                };
                here - origin.get(*axis).ok_or(unknown)?
            }
            MoveKind::Relative => {
                let from = previous.ok_or(TeachError::NothingTaught)?;
                here - from.get(*axis).ok_or(TeachError::NothingTaught)?
            }
        };
        values.push((*axis, value));
    }
    let lines = match machine.language {
        Language::Isel => vec![isel_move(machine, kind, &values, units_per_second)?],
        Language::Emcu => emcu_move(machine, kind, &values, units_per_second, slot)?,
    };
    let mut checked = Vec::with_capacity(lines.len());
    for line in &lines {
        checked.push(checked_line(machine, line).map_err(TeachError::Invalid)?);
    }
    Ok(Taught {
        lines: checked,
        point: *position,
    })
}

fn isel_move(
    machine: &Machine,
    kind: MoveKind,
    values: &[(Axis, i64)],
    units_per_second: f64,
) -> Result<String, TeachError> {
    let value = |axis: Axis| -> Result<(i64, u32), TeachError> {
        let steps = values
            .iter()
            .find(|(a, _)| *a == axis)
            .map_or(0, |(_, v)| *v);
        Ok((
            in_range(axis, steps, ISEL_STEPS)?,
            machine.hz(axis, units_per_second),
        ))
    };
    let config = machine.isel_config();
    let mut pairs = Vec::with_capacity(4);
    for axis in config.axes().iter() {
        pairs.push(value(axis)?);
    }
    if config == AxisConfig::XYZ {
        // x, y, z1, z2: the second Z leg is 0 for both `0` and `m` (isel 5).
        let z_speed = pairs.last().map_or(1, |(_, hz)| *hz);
        pairs.push((0, z_speed));
    }
    let code = match kind {
        MoveKind::Absolute => CncCommand::MoveAbsolute(Vec::new()).code(),
        MoveKind::Relative => CncCommand::MoveRelative(Vec::new()).code(),
    };
    let params: Vec<String> = pairs.iter().map(|(s, hz)| format!("{s},{hz}")).collect();
    Ok(format!("{code}{}", params.join(",")))
}

fn emcu_move(
    machine: &Machine,
    kind: MoveKind,
    values: &[(Axis, i64)],
    units_per_second: f64,
    slot: SlotContext,
) -> Result<Vec<String>, TeachError> {
    let mut targets = Vec::new();
    let mut speed = None;
    for (axis, v) in values {
        if *axis == Axis::A {
            continue;
        }
        let v = in_range(
            *axis,
            *v,
            (i64::from(emcu::Steps::MIN), i64::from(emcu::Steps::MAX)),
        )?;
        // The slot's speed is the path speed; the first axis sets it.
        speed.get_or_insert(machine.hz(*axis, units_per_second));
        let letter = match kind {
            MoveKind::Absolute => axis.letter(),
            MoveKind::Relative => axis.letter().to_ascii_lowercase(),
        };
        targets.push(format!("{letter}{v}"));
    }
    let speed = speed.unwrap_or(1);
    let mut lines = Vec::new();
    let changes = slot.before != u16::try_from(speed).ok();
    if changes {
        lines.push(format!("#E{EMCU_TEACH_SLOT},{speed}"));
    }
    lines.push(format!("L{EMCU_TEACH_SLOT},{}", targets.join(",")));
    if let (true, true, Some(old)) = (changes, slot.used_after, slot.before) {
        lines.push(format!("#E{EMCU_TEACH_SLOT},{old}"));
    }
    Ok(lines)
}

/// A dwell of `seconds`: isel `5` in tenths (rounded), EMCU `W` in ms.
pub fn dwell(machine: &Machine, seconds: f64) -> Result<String, String> {
    if !seconds.is_finite() || seconds < 0.0 {
        return Err(format!("a dwell is a time in seconds, not {seconds}"));
    }
    let line = match machine.language {
        Language::Isel => format!("5{}", (seconds * 10.0).round() as u64),
        Language::Emcu => format!("W{}", (seconds * 1000.0).round() as u64),
    };
    checked_line(machine, &line)
}

/// Setting an output: isel port, bit (0-7, or 128 for the whole byte) and
/// value; EMCU output (1-2, the bit is ignored) and 0/1.
pub fn output(machine: &Machine, port: u32, bit: u32, value: u32) -> Result<String, String> {
    let line = match machine.language {
        Language::Isel => format!("p{port},{bit},{value}"),
        Language::Emcu => format!("A{port},{value}"),
    };
    checked_line(machine, &line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::profile::Unit;

    fn axis(spu: f64, max_speed: f64) -> AxisProfile {
        AxisProfile {
            steps_per_unit: spu,
            unit: Unit::Mm,
            min: 0.0,
            max: 300.0,
            max_speed,
            drive: None,
        }
    }

    fn xyz() -> Vec<(Axis, AxisProfile)> {
        vec![
            (Axis::X, axis(400.0, 25.0)),
            (Axis::Y, axis(400.0, 25.0)),
            (Axis::Z, axis(400.0, 15.0)),
        ]
    }

    fn at(x: i64, y: i64, z: i64) -> PerAxis<i64> {
        PerAxis::new()
            .with(Axis::X, x)
            .with(Axis::Y, y)
            .with(Axis::Z, z)
    }

    #[test]
    fn isel_absolute_moves_count_from_the_work_zero_with_four_pairs_on_three_axes() {
        let axes = xyz();
        let m = Machine {
            language: Language::Isel,
            axes: &axes,
        };
        let taught = taught_move(
            &m,
            MoveKind::Absolute,
            &at(4000, 2000, -400),
            &at(1000, 0, 0),
            None,
            10.0,
            SlotContext::default(),
        )
        .expect("taught");
        // 10 mm/s = 4000 Hz; Z is capped at its 15 mm/s = 6000 Hz only above.
        assert_eq!(taught.lines, ["m3000,4000,2000,4000,-400,4000,0,4000"]);
        assert_eq!(taught.point, at(4000, 2000, -400));
        let fast = taught_move(
            &m,
            MoveKind::Absolute,
            &at(0, 0, 0),
            &at(0, 0, 0),
            None,
            20.0,
            SlotContext::default(),
        )
        .expect("taught");
        assert_eq!(
            fast.lines,
            ["m0,8000,0,8000,0,6000,0,6000"],
            "Z capped at its highest speed"
        );
    }

    #[test]
    fn isel_relative_moves_start_at_the_point_taught_before() {
        let axes: Vec<_> = xyz().into_iter().take(2).collect();
        let m = Machine {
            language: Language::Isel,
            axes: &axes,
        };
        let here = PerAxis::new().with(Axis::X, 500).with(Axis::Y, 100);
        let before = PerAxis::new().with(Axis::X, 800).with(Axis::Y, 100);
        let taught = taught_move(
            &m,
            MoveKind::Relative,
            &here,
            &PerAxis::new(),
            Some(&before),
            1.0,
            SlotContext::default(),
        )
        .expect("taught");
        assert_eq!(taught.lines, ["0-300,400,0,400"]);
        assert_eq!(
            taught_move(
                &m,
                MoveKind::Relative,
                &here,
                &PerAxis::new(),
                None,
                1.0,
                SlotContext::default()
            ),
            Err(TeachError::NothingTaught)
        );
        assert_eq!(
            taught_move(
                &m,
                MoveKind::Absolute,
                &here,
                &PerAxis::new(),
                None,
                1.0,
                SlotContext::default()
            ),
            Err(TeachError::ZeroUnknown(Axis::X))
        );
        assert_eq!(
            taught_move(
                &m,
                MoveKind::Absolute,
                &PerAxis::new(),
                &here,
                None,
                1.0,
                SlotContext::default()
            ),
            Err(TeachError::NoPosition(Axis::X))
        );
        let far = PerAxis::new().with(Axis::X, 9_000_000).with(Axis::Y, 0);
        assert!(matches!(
            taught_move(
                &m,
                MoveKind::Absolute,
                &far,
                &PerAxis::new().with(Axis::X, 0).with(Axis::Y, 0),
                None,
                1.0,
                SlotContext::default()
            ),
            Err(TeachError::OutOfRange { axis: Axis::X, .. })
        ));
    }

    #[test]
    fn emcu_moves_set_the_slot_speed_only_when_it_changes_and_restore_it() {
        let axes = xyz();
        let m = Machine {
            language: Language::Emcu,
            axes: &axes,
        };
        let taught = |slot| {
            taught_move(
                &m,
                MoveKind::Absolute,
                &at(100, 200, 300),
                &at(0, 0, 0),
                None,
                2.0,
                slot,
            )
            .expect("taught")
            .lines
        };
        assert_eq!(
            taught(SlotContext::default()),
            ["#E8,800", "L8,X100,Y200,Z300"]
        );
        let same = SlotContext {
            before: Some(800),
            used_after: true,
        };
        assert_eq!(taught(same), ["L8,X100,Y200,Z300"]);
        let other = SlotContext {
            before: Some(500),
            used_after: true,
        };
        assert_eq!(taught(other), ["#E8,800", "L8,X100,Y200,Z300", "#E8,500"]);
        let rel = taught_move(
            &m,
            MoveKind::Relative,
            &at(100, 200, 300),
            &PerAxis::new(),
            Some(&at(0, 200, 0)),
            2.0,
            same,
        )
        .expect("taught");
        assert_eq!(rel.lines, ["L8,x100,y0,z300"]);
    }

    /// Issue 20, finding 3: after `g X5`, `z` and a jog of 0.75 mm, `t`
    /// taught the work position (`X150`), and right after `h` it said the
    /// work zero was not known. EMCU `L` targets are machine coordinates.
    #[test]
    fn emcu_absolute_moves_are_taught_in_machine_coordinates_whatever_the_work_zero() {
        let axes = xyz();
        let m = Machine {
            language: Language::Emcu,
            axes: &axes,
        };
        let mut state = MachineState {
            referenced: crate::axis::AxisSet::XYZ,
            ..MachineState::default()
        };
        // `z` at machine X 5 mm (400 steps/mm in `xyz`), then 0.75 mm on.
        state.work_zero = at(2000, 0, 0);
        let here = at(2300, 0, 0);
        let taught = |state: &MachineState| {
            taught_move(
                &m,
                MoveKind::Absolute,
                &here,
                &absolute_origin(Language::Emcu, state),
                None,
                2.0,
                SlotContext {
                    before: Some(800),
                    used_after: false,
                },
            )
        };
        assert_eq!(taught(&state).expect("taught").lines, ["L8,X2300,Y0,Z0"]);
        // Right after a reference run, no work zero set: the same.
        state.work_zero = PerAxis::new();
        assert_eq!(taught(&state).expect("taught").lines, ["L8,X2300,Y0,Z0"]);
        // Unreferenced, a machine position means nothing yet.
        state.referenced = crate::axis::AxisSet::EMPTY;
        assert_eq!(taught(&state), Err(TeachError::Unreferenced(Axis::X)));
        // isel `m` counts from the virtual zero of `@0n`.
        state.work_zero = at(2000, 0, 0);
        assert_eq!(
            absolute_origin(Language::Isel, &state),
            state.work_zero,
            "isel keeps the driver's virtual zero"
        );
    }

    #[test]
    fn the_slot_context_follows_the_job_from_top_to_bottom() {
        let job = Program::parse(Language::Emcu, "#E8,500\nL8,X1\n#E8,700\nL8,X2\n#E8,900\n");
        assert_eq!(
            SlotContext::of(&job, 0),
            SlotContext {
                before: None,
                used_after: false
            }
        );
        assert_eq!(
            SlotContext::of(&job, 1),
            SlotContext {
                before: Some(500),
                used_after: true
            }
        );
        assert_eq!(
            SlotContext::of(&job, 2),
            SlotContext {
                before: Some(500),
                used_after: false
            }
        );
        assert_eq!(
            SlotContext::of(&job, 4),
            SlotContext {
                before: Some(700),
                used_after: false
            }
        );
    }

    #[test]
    fn dwells_and_outputs_are_checked_by_the_core() {
        let axes = xyz();
        let isel = Machine {
            language: Language::Isel,
            axes: &axes,
        };
        assert_eq!(dwell(&isel, 1.25), Ok("513".into()));
        assert!(dwell(&isel, 7000.0).is_err(), "beyond 65535 tenths");
        assert!(dwell(&isel, -1.0).is_err());
        assert_eq!(output(&isel, 0, 3, 1), Ok("p0,3,1".into()));
        assert!(output(&isel, 0, 9, 1).is_err());
        let emcu = Machine {
            language: Language::Emcu,
            axes: &axes,
        };
        assert_eq!(dwell(&emcu, 0.5), Ok("W500".into()));
        assert_eq!(output(&emcu, 2, 0, 1), Ok("A2,1".into()));
        assert!(output(&emcu, 3, 0, 1).is_err());
    }
}
