//! Reply deadlines from physics. The isel controller answers a command only
//! when it is done (manual 2.1, 2.2.2), so how long to wait depends on what
//! the command does:
//! - a query or setting: its bytes at the baud rate plus a small margin for
//!   the controller and the host's scheduling;
//! - a move: the duration of its trapezoid (`motion::Motion`) plus a quarter
//!   and a second, since the controller's ramp is modelled, not known;
//! - a reference run: the travel of every named axis at the reference speed,
//!   one axis after the other (manual 2.2.22: Z, Y, X, A);
//! - `@0k`: about 2 s (manual 2.2.17);
//! - a program run (`@0S`): no deadline, a stored program may wait for ever
//!   (CNC `2`, `5`, manual 3.2.4, 3.2.6).
//!
//! A reply that does not come within its deadline means the link is dead
//! (`docs/device.md`).

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::common::deadline as common_deadline;
use crate::proto::isel::{CncCommand, Command, Expect, InitCommand};

use super::settings::IselSettings;

/// Erasing the program memory takes about 2 s (manual 2.2.17).
pub const ERASE: Duration = Duration::from_secs(4);
/// Writing the flash: `9` ends a stored program and saves status data
/// (manual 3.2.9), `@0IW`/`@0IL`/`@0IX` (manual 4.2.17-4.2.19).
pub const FLASH: Duration = Duration::from_secs(3);
/// Freeing an axis from its switch (`@0F`, manual 2.2.9): a short, slow move
/// of unknown length.
pub const CLEAR_SWITCH: Duration = Duration::from_secs(15);

pub use crate::device::common::deadline::{exchange, motion};

/// How long a reference run of `mask` may take at `speed_hz`: each axis may
/// have to cross its whole travel and a half again (it may start beyond a
/// soft limit and overshoots its switch), then clear the switch slowly
/// (`common::deadline::reference`).
pub fn reference(settings: &IselSettings, mask: AxisSet, speed_hz: u32) -> Duration {
    let widest = settings
        .axes
        .iter()
        .map(|(_, l)| l.span())
        .max()
        .unwrap_or(0);
    let spans = mask
        .iter()
        .map(|axis| settings.limits(axis).map_or(widest, |l| l.span()));
    common_deadline::reference(spans, f64::from(speed_hz))
}

/// The deadline for a DNC command that is no move planned by the driver
/// (those pass their own), or `None` for a program run.
pub fn for_command(
    command: &Command,
    expect: Expect,
    wire_len: usize,
    settings: &IselSettings,
    reference_hz: u32,
) -> Option<Duration> {
    let margin = settings.timing.reply_margin;
    let query = exchange(settings.line, margin, wire_len, expect.max_len());
    Some(match command {
        Command::Start => return None,
        Command::EraseProgram => ERASE,
        Command::Init(
            InitCommand::WriteToFlash | InitCommand::LoadFromFlash | InitCommand::RestoreDefaults,
        ) => FLASH,
        Command::Reference(mask) => reference(settings, *mask, reference_hz),
        Command::ClearLimitSwitch(_) => CLEAR_SWITCH,
        Command::Circle(c) => arc(c.arc_length, c.speed),
        Command::Helix(h) => arc(h.circle.arc_length, h.circle.speed),
        Command::MoveUntilPort(m) => {
            let longest = m.steps.iter().map(|s| s.unsigned_abs()).max().unwrap_or(0);
            motion(Duration::from_secs_f64(
                f64::from(longest) / f64::from(m.speed.max(1)),
            ))
        }
        _ => query,
    })
}

/// A stored CNC line: parsed and written to the flash (manual 3.2.1).
pub fn stored_line(command: &CncCommand, settings: &IselSettings, wire_len: usize) -> Duration {
    match command {
        CncCommand::End => FLASH,
        _ => {
            exchange(settings.line, settings.timing.reply_margin, wire_len, 1)
                + Duration::from_millis(400)
        }
    }
}

/// Circles and helices run at constant path speed (manual 2.2.28): `B`
/// steps at `V` Hz.
fn arc(arc_length: u32, speed: u32) -> Duration {
    motion(Duration::from_secs_f64(
        f64::from(arc_length) / f64::from(speed.max(1)),
    ))
}

/// A reference run's axes in the order the controller runs them (manual
/// 2.2.22); A only on its own (`docs/decisions.md` isel 3).
pub fn reference_masks(axes: AxisSet) -> Vec<AxisSet> {
    let planar: AxisSet = axes.iter().filter(|a| *a != Axis::A).collect();
    let mut out = Vec::new();
    if !planar.is_empty() {
        out.push(planar);
    }
    if axes.contains(Axis::A) {
        out.push(AxisSet::EMPTY.with(Axis::A));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::wire::LineSettings;

    fn settings() -> IselSettings {
        let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
        IselSettings::from_profile(&profile).expect("settings")
    }

    #[test]
    fn a_position_query_waits_for_its_bytes_and_the_margin() {
        let s = settings();
        let d = for_command(
            &Command::ReadPosition,
            Expect::Positions { with_a: false },
            4,
            &s,
            4000,
        );
        assert_eq!(
            d,
            Some(LineSettings::new(19200).transfer_time(23) + s.timing.reply_margin)
        );
    }

    #[test]
    fn a_program_run_has_no_deadline_and_erase_takes_seconds() {
        let s = settings();
        assert_eq!(
            for_command(&Command::Start, Expect::ProgramRun, 4, &s, 4000),
            None
        );
        assert_eq!(
            for_command(&Command::EraseProgram, Expect::Handshake, 4, &s, 4000),
            Some(ERASE)
        );
    }

    #[test]
    fn a_reference_run_covers_each_axis_travel_in_turn() {
        let s = settings();
        // X: 120000 steps * 1.5 / 4000 Hz = 45 s, plus 1 s to clear the switch.
        let x = reference(&s, AxisSet::EMPTY.with(Axis::X), 4000);
        assert_eq!(x, motion(Duration::from_secs(46)) + Duration::from_secs(1));
        let xyz = reference(&s, AxisSet::XYZ, 4000);
        assert!(xyz > x);
    }

    #[test]
    fn a_is_referenced_on_its_own() {
        assert_eq!(
            reference_masks(AxisSet::XYZA),
            vec![AxisSet::XYZ, AxisSet::from_mask(8)]
        );
        assert_eq!(
            reference_masks(AxisSet::from_mask(8)),
            vec![AxisSet::from_mask(8)]
        );
        assert!(reference_masks(AxisSet::EMPTY).is_empty());
    }
}
