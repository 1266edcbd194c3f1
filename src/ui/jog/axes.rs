//! The choice of an axis for a reference run or a work zero of one axis
//! (or of all): a popup that takes a letter; choosing is the confirmation.

use crate::axis::{Axis, AxisSet};
use crate::device::api::Request;

use super::super::keymap::Action;

/// What the chosen axes are for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    /// A reference run (isel `@0R`, EMCU `$H`, EMP `26`).
    Home,
    /// The work zero at the current position (isel `@0n`).
    Zero,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisChoice {
    pub purpose: Purpose,
    /// The machine's axes.
    pub axes: AxisSet,
}

impl AxisChoice {
    pub fn title(&self) -> &'static str {
        match self.purpose {
            Purpose::Home => "Reference run",
            Purpose::Zero => "Work zero",
        }
    }

    pub fn question(&self) -> String {
        let letters: Vec<String> = self
            .axes
            .iter()
            .map(|a| a.letter().to_ascii_lowercase().to_string())
            .collect();
        match self.purpose {
            Purpose::Home => format!(
                "Which axis moves to its reference switch? {} for one axis, Enter for all \
                 ({}). Keep clear of the machine.",
                letters.join(" "),
                self.axes
            ),
            Purpose::Zero => format!(
                "Which axis gets its work zero at the current position? {} for one axis, \
                 Enter for all ({}).",
                letters.join(" "),
                self.axes
            ),
        }
    }

    /// The axes an action of the popup names: `None` for an axis the
    /// machine does not have (or another action).
    pub fn chosen(&self, action: Action) -> Option<AxisSet> {
        let axis = match action {
            Action::AxisAll => return Some(self.axes),
            Action::AxisX => Axis::X,
            Action::AxisY => Axis::Y,
            Action::AxisZ => Axis::Z,
            Action::AxisA => Axis::A,
            _ => return None,
        };
        self.axes.contains(axis).then(|| AxisSet::EMPTY.with(axis))
    }

    pub fn request(&self, axes: AxisSet) -> Request {
        match self.purpose {
            Purpose::Home => Request::Home { axes },
            Purpose::Zero => Request::SetZero { axes },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_machines_axes_can_be_chosen() {
        let c = AxisChoice {
            purpose: Purpose::Home,
            axes: AxisSet::XYZ,
        };
        assert_eq!(c.chosen(Action::AxisAll), Some(AxisSet::XYZ));
        assert_eq!(c.chosen(Action::AxisY), Some(AxisSet::EMPTY.with(Axis::Y)));
        assert_eq!(c.chosen(Action::AxisA), None);
        assert_eq!(c.chosen(Action::Cancel), None);
        assert_eq!(
            c.request(AxisSet::EMPTY.with(Axis::Z)),
            Request::Home {
                axes: AxisSet::EMPTY.with(Axis::Z)
            }
        );
        assert!(c.question().contains("x y z"), "{}", c.question());
    }
}
