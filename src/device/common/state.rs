//! Telling the clients when the machine state changed: `Event::State` with
//! the whole state, only when it differs from the last one sent.

use crate::device::api::{Event, MachineState};

use super::sink::Sink;

#[derive(Debug, Clone, Default, PartialEq)]
pub struct StateReport {
    last: Option<MachineState>,
}

impl StateReport {
    /// Send `state` if it differs from what the clients last saw.
    pub fn publish(&mut self, state: &MachineState, sink: &mut impl Sink) {
        if self.last.as_ref() != Some(state) {
            self.last = Some(state.clone());
            sink.emit(Event::State(state.clone()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    #[test]
    fn only_changes_are_sent() {
        let mut report = StateReport::default();
        let mut events = VecDeque::new();
        let mut state = MachineState::default();
        report.publish(&state, &mut events);
        report.publish(&state, &mut events);
        state.link_up = true;
        report.publish(&state, &mut events);
        assert_eq!(events.len(), 2);
    }
}
