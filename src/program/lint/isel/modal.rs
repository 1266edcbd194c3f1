//! The controller's modal state along the jumps of an isel program: the
//! circle direction (`f`, manual 3.2.12) and plane (`e`, 3.2.11) each circle
//! runs with.

use crate::proto::isel::{AxisConfig, CncCommand, Plane};

use crate::program::flow::{self, Flow};
use crate::program::lint::{Diagnostic, Rule};
use crate::program::model::Statement;
use crate::program::source::Span;

/// The modal state of the controller when a command runs, over every way
/// that reaches it: whether an `f` has surely set the circle direction
/// (manual 3.2.12), and the planes (`e`, manual 3.2.11; XY at the start) it
/// may be in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Modal {
    direction_set: bool,
    /// Bit `Plane::value()` for each plane possible.
    plane_bits: u8,
}

impl Modal {
    pub(super) fn has(self, plane: Plane) -> bool {
        self.plane_bits & (1 << plane.value()) != 0
    }

    fn join(self, other: Modal) -> Modal {
        Modal {
            direction_set: self.direction_set && other.direction_set,
            plane_bits: self.plane_bits | other.plane_bits,
        }
    }
}

/// A forward data-flow over the jumps: `None` for commands no way reaches.
pub(super) fn modal_states(commands: &[Option<&CncCommand>], flows: &[Flow]) -> Vec<Option<Modal>> {
    let len = flows.len();
    let mut states: Vec<Option<Modal>> = vec![None; len];
    let Some(first) = states.first_mut() else {
        return states;
    };
    *first = Some(Modal {
        direction_set: false,
        plane_bits: 1 << Plane::XY.value(),
    });
    let mut work = vec![0usize];
    while let Some(i) = work.pop() {
        let Some(mut after) = states.get(i).copied().flatten() else {
            continue;
        };
        match commands.get(i).copied().flatten() {
            Some(CncCommand::SetCircleDirection(_)) => after.direction_set = true,
            Some(CncCommand::SetPlane(p)) => after.plane_bits = 1 << p.value(),
            _ => {}
        }
        let Some(f) = flows.get(i) else {
            continue;
        };
        for next in flow::successors(*f, i, len).into_iter().flatten() {
            let Some(slot) = states.get_mut(next) else {
                continue;
            };
            let new = slot.map_or(after, |old| old.join(after));
            if *slot != Some(new) {
                *slot = Some(new);
                work.push(next);
            }
        }
    }
    states
}

/// A circle or helix: its direction set before it (manual 3.2.12: "Die
/// Richtung für die Kreisinterpolation ist prinzipiell vor jeder
/// Kreisbewegung zu programmieren"), and the axes of every plane it may run
/// in initialised (the controller answers `3` when it runs it otherwise).
pub(super) fn circle_state(
    line: usize,
    statement: &Statement,
    command: &CncCommand,
    axes: AxisConfig,
    modal: Modal,
    out: &mut Vec<Diagnostic>,
) {
    let span = Span::new(line, statement.code.clone());
    let letter = command.code();
    if !modal.direction_set {
        out.push(Diagnostic::warning(
            Rule::CircleDirection,
            span,
            format!(
                "no `f` sets the circle direction before this `{letter}` (on some way here): \
                 it runs in whatever direction was set last; write `f0` (CW) or `f-1` (CCW) \
                 before it (manual 3.2.12)"
            ),
        ));
    }
    for plane in Plane::ALL.into_iter().filter(|p| modal.has(*p)) {
        let (a1, a2) = plane.axes();
        let mut needed = vec![a1, a2];
        if letter == 'w' {
            needed.push(plane.third_axis());
        }
        if let Some(missing) = needed.into_iter().find(|a| !axes.axes().contains(*a)) {
            out.push(Diagnostic::error(
                Rule::Axis,
                span,
                format!(
                    "this `{letter}` runs in the {plane:?} plane (manual 3.2.11), which needs \
                     axis {missing}; the controller has {axes} and answers `3` when it gets here"
                ),
            ));
        }
    }
}
