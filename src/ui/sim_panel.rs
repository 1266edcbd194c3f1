//! The simulator panel's state: the built-in simulator's inputs (limit
//! switches, E-stop circuits, buttons; names from the device model) and the
//! level each stands at: as the simulator reported it at start, then as
//! jogterm last set it. An input the simulator gives no level for (a
//! test double, an input changed from the simulator's stdin is not seen)
//! shows as unknown until it is set here.

use crate::sim::InputControl;
use crate::sim::start_key::StartKey;

use super::keymap::Action;
use super::msg::Effect;
use super::outcome::Outcome;
use super::traffic_log::NoteLevel;

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimInput {
    pub name: String,
    /// The level last set from this panel (`true` = reads 1: on / closed).
    pub level: Option<bool>,
    /// A change has been sent and not yet confirmed by the simulator.
    pub pending: bool,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimPanel {
    pub inputs: Vec<SimInput>,
    pub selected: usize,
    /// The input wired as the machine's start key, pressed by its own key
    /// whichever input is selected; or why there is none.
    pub start_key: Result<StartKey, String>,
}

impl SimPanel {
    pub fn new(inputs: &[(String, Option<bool>)]) -> Self {
        SimPanel {
            inputs: inputs
                .iter()
                .map(|(name, level)| SimInput {
                    name: name.clone(),
                    level: *level,
                    pending: false,
                })
                .collect(),
            selected: 0,
            start_key: Err("the profile wires no start key".into()),
        }
    }

    pub fn with_start_key(self, start_key: Result<StartKey, String>) -> Self {
        SimPanel { start_key, ..self }
    }

    /// The control that presses the start key (what a job's pause waits
    /// for), whichever input is selected.
    pub fn press_start_key(&mut self) -> Result<InputControl, String> {
        let key = self.start_key.as_ref().map_err(Clone::clone)?;
        if let Some(input) = self.inputs.iter_mut().find(|i| i.name == key.input) {
            input.pending = true;
        }
        Ok(key.press())
    }

    pub fn selected(&self) -> Option<&SimInput> {
        self.inputs.get(self.selected)
    }

    pub fn step(&mut self, delta: isize) {
        let len = self.inputs.len() as isize;
        if len > 0 {
            self.selected = (self.selected as isize + delta).rem_euclid(len) as usize;
        }
    }

    /// The control that sets the selected input to `level`.
    pub fn set_selected(&mut self, level: bool) -> Option<InputControl> {
        let input = self.inputs.get_mut(self.selected)?;
        input.pending = true;
        Some(InputControl::Set {
            name: input.name.clone(),
            level,
        })
    }

    /// The control that flips the selected input; one whose level is not
    /// known needs a level set here first.
    pub fn toggle_selected(&mut self) -> Result<InputControl, String> {
        let input = self
            .inputs
            .get(self.selected)
            .ok_or_else(|| "the simulator has no inputs".to_string())?;
        let level = input.level.ok_or_else(|| {
            format!(
                "{}: level not known yet; set it on/closed (1) or off/open (0) first",
                input.name
            )
        })?;
        self.set_selected(!level)
            .ok_or_else(|| "the simulator has no inputs".to_string())
    }

    pub fn press_selected(&mut self) -> Option<InputControl> {
        let input = self.inputs.get_mut(self.selected)?;
        input.pending = true;
        Some(InputControl::Press {
            name: input.name.clone(),
        })
    }

    /// The simulator answered a control.
    pub fn done(&mut self, control: &InputControl, ok: bool) {
        let name = control.name();
        if let Some(input) = self.inputs.iter_mut().find(|i| i.name == name) {
            input.pending = false;
            if let (true, InputControl::Set { level, .. }) = (ok, control) {
                input.level = Some(*level);
            }
        }
    }
}

impl SimPanel {
    /// The simulator panel as a component: a key of the focused panel.
    pub fn update(&mut self, action: Action) -> Outcome {
        let control = match action {
            Action::SelectPrev | Action::SelectNext => {
                self.step(if action == Action::SelectNext { 1 } else { -1 });
                None
            }
            Action::SimOn => self.set_selected(true),
            Action::SimOff => self.set_selected(false),
            Action::SimPress => self.press_selected(),
            Action::SimStart => match self.press_start_key() {
                Ok(c) => Some(c),
                Err(why) => return Outcome::note(NoteLevel::Warning, why),
            },
            Action::SimToggle => match self.toggle_selected() {
                Ok(c) => Some(c),
                Err(why) => return Outcome::note(NoteLevel::Warning, why),
            },
            _ => None,
        };
        Outcome::effects(control.map(Effect::Simulator).into_iter().collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_reported_at_start_can_be_flipped_at_once() {
        let mut p = SimPanel::new(&[("estop1".to_string(), Some(true))]);
        assert_eq!(
            p.toggle_selected(),
            Ok(InputControl::Set {
                name: "estop1".into(),
                level: false
            })
        );
        assert!(p.inputs[0].pending);
    }

    #[test]
    fn levels_are_known_only_once_the_simulator_took_them() {
        let mut p = SimPanel::new(&[("limit-x1".to_string(), None), ("stop".to_string(), None)]);
        assert!(p.toggle_selected().unwrap_err().contains("not known"));
        let c = p.set_selected(true).expect("control");
        assert_eq!(
            c,
            InputControl::Set {
                name: "limit-x1".into(),
                level: true
            }
        );
        assert_eq!(p.inputs[0].level, None);
        p.done(&c, true);
        assert_eq!(p.inputs[0].level, Some(true));
        let off = p.toggle_selected().expect("control");
        assert_eq!(
            off,
            InputControl::Set {
                name: "limit-x1".into(),
                level: false
            }
        );
        p.done(&off, false);
        assert_eq!(
            p.inputs[0].level,
            Some(true),
            "a refused change changes nothing"
        );
        p.step(-1);
        assert_eq!(
            p.press_selected(),
            Some(InputControl::Press {
                name: "stop".into()
            })
        );
    }

    #[test]
    fn the_start_key_is_pressed_whichever_input_is_selected() {
        let mut p = SimPanel::new(&[
            ("estop1".to_string(), Some(true)),
            ("start".to_string(), None),
        ]);
        assert!(p.press_start_key().unwrap_err().contains("no start key"));
        let mut p = p.with_start_key(Ok(StartKey {
            input: "start".into(),
            name: "start key".into(),
        }));
        assert_eq!(p.selected, 0);
        assert_eq!(
            p.press_start_key(),
            Ok(InputControl::Press {
                name: "start".into()
            })
        );
        assert!(p.inputs[1].pending && !p.inputs[0].pending);
    }
}
