//! What buffered commands leave behind once they have run (manual 1.5.5 to
//! 1.5.19): the start speed and ramp (jogterm's moves rely on the profile's),
//! the move slot's end speed, the outputs, the E1 link, references. Applied
//! when a batch or a job jogterm knows has run; when the commands are not
//! known (a job stored by someone else), all of it counts as unknown.

use crate::axis::AxisSet;
use crate::device::common::Sink;
use crate::proto::emcu::Command;

use super::context::Context;

/// `commands` have run; `completed` when the run ended normally with the
/// position known (reference runs count only then).
pub fn apply(cx: &mut Context, commands: &[Command], completed: bool) {
    for command in commands {
        match command {
            Command::StartSpeed(s) if *s != cx.settings.start_speed => unset_ramp(cx),
            Command::Ramp(r) if *r != cx.settings.ramp => unset_ramp(cx),
            Command::EndSpeed { slot, speed } if *slot == cx.settings.move_slot => {
                cx.slot_hz = Some(speed.get());
            }
            Command::SetOutput { output, on } => {
                if let Some(cell) = cx
                    .outputs
                    .get_mut(usize::from(output.get().saturating_sub(1)))
                {
                    *cell = Some(*on);
                }
            }
            Command::LinkE1(on) => cx.e1_link = Some(*on),
            Command::Reference(order) if completed => cx.referenced(order.set()),
            Command::Reference(_) => cx.state.referenced = AxisSet::EMPTY,
            _ => {}
        }
    }
}

/// What the unknown commands may have set is unknown.
pub fn unknown(cx: &mut Context) {
    cx.slot_hz = None;
    cx.outputs = [None; 2];
    cx.e1_link = None;
    if cx.ready() {
        unset_ramp(cx);
    }
}

fn unset_ramp(cx: &mut Context) {
    if cx.ready() {
        cx.set_ramp(false);
        cx.notice("start speed or ramp differ from the profile now: initialise (i) before moving");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};
    use crate::device::emcu::EmcuSettings;

    fn cx() -> Context {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        let mut cx = Context::new(EmcuSettings::from_profile(&profile).expect("settings"));
        cx.set_ramp(true);
        cx
    }

    fn commands(text: &[&str]) -> Vec<Command> {
        text.iter().map(|t| t.parse().expect("command")).collect()
    }

    #[test]
    fn settings_outputs_and_references_are_followed() {
        let mut cx = cx();
        apply(
            &mut cx,
            &commands(&["#S200", "#E9,700", "#E1,100", "A2,1", "&V1", "$HZX"]),
            true,
        );
        assert!(cx.ready());
        assert_eq!(cx.slot_hz, Some(700));
        assert_eq!(cx.outputs, [None, Some(true)]);
        assert_eq!(cx.e1_link, Some(true));
        assert_eq!(cx.state.referenced, AxisSet::from_mask(0b101));
        apply(&mut cx, &commands(&["#R100"]), true);
        assert!(!cx.ready());
    }

    #[test]
    fn an_unknown_job_leaves_nothing_known() {
        let mut cx = cx();
        cx.slot_hz = Some(5);
        unknown(&mut cx);
        assert_eq!(cx.slot_hz, None);
        assert!(!cx.ready());
    }
}
