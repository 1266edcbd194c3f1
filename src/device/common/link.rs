//! A reply that does not come within its deadline means the line or the
//! controller is gone: the driver reports a fault that asks to check the
//! link, then `Event::Link(Lost)`, which the device task treats like a
//! vanished port (`docs/device.md`, "Link supervision").

use std::time::Duration;

use crate::device::api::{ControllerFault, Event, LinkState, Recovery};

use super::sink::Sink;

/// No reply to `command` after `waited`: the fault and the loss, in that
/// order. Returns the reason given to the loss.
pub fn no_reply(command: &str, waited: Duration, sink: &mut impl Sink) -> String {
    sink.emit(Event::Fault(ControllerFault {
        command: command.to_owned(),
        code: "timeout".to_owned(),
        meaning: format!(
            "No reply within {} ms: the controller or the line is gone.",
            waited.as_millis()
        ),
        recovery: Recovery::CheckLink,
    }));
    let reason = format!("no reply to {command} within {} ms", waited.as_millis());
    sink.emit(Event::Link(LinkState::Lost {
        reason: reason.clone(),
    }));
    reason
}

/// A reply that could not be read, or answered something else: the outcome
/// of `command` is unknown, the line is in doubt, not the machine.
pub fn unreadable(command: &str, what: &str) -> ControllerFault {
    ControllerFault {
        command: command.to_owned(),
        code: what.to_owned(),
        meaning: "The reply could not be read: the outcome of the command is unknown.".to_owned(),
        recovery: Recovery::CheckLink,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    #[test]
    fn a_missing_reply_is_a_fault_then_a_loss() {
        let mut events = VecDeque::new();
        let reason = no_reply("@LX", Duration::from_millis(520), &mut events);
        assert_eq!(reason, "no reply to @LX within 520 ms");
        assert!(matches!(
            events.pop_front(),
            Some(Event::Fault(f)) if f.code == "timeout" && f.recovery == Recovery::CheckLink
        ));
        assert!(matches!(
            events.pop_front(),
            Some(Event::Link(LinkState::Lost { .. }))
        ));
        assert_eq!(unreadable("@X", "garbled").recovery, Recovery::CheckLink);
    }
}
