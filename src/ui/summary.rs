//! The machine's state in one word and what to do about it, for the status
//! bar and the message line. The order is the order of urgency: no link
//! beats everything (the state is unknown), an emergency stop beats a limit
//! switch, and so on down to "ready".

use crate::device::api::{Activity, LinkState, Recovery};

use super::model::Model;

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    Ok,
    Warning,
    Danger,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Summary {
    pub severity: Severity,
    /// One or two words, upper case: `READY`, `E-STOP`.
    pub word: &'static str,
    /// What it means and the recovery it needs, in words.
    pub detail: Option<String>,
}

impl Summary {
    fn new(severity: Severity, word: &'static str, detail: Option<String>) -> Self {
        Self {
            severity,
            word,
            detail,
        }
    }
}

pub fn summarise(model: &Model) -> Summary {
    use Severity::*;
    let unknown = "motion state unknown".to_string();
    match &model.link {
        LinkState::Connecting => {
            return Summary::new(
                Warning,
                "UNKNOWN",
                Some(format!("connecting to the controller; {unknown}")),
            );
        }
        LinkState::Lost { reason } => {
            return Summary::new(
                Danger,
                "UNKNOWN",
                Some(format!(
                    "link lost: {reason}; {unknown} until the controller is read again"
                )),
            );
        }
        LinkState::Reconnecting { attempt, retry_in } => {
            return Summary::new(
                Danger,
                "UNKNOWN",
                Some(format!(
                    "link lost, reconnecting: attempt {attempt}, next in {:.1} s; {unknown}",
                    retry_in.as_secs_f64()
                )),
            );
        }
        LinkState::Closed => return Summary::new(Warning, "CLOSED", None),
        LinkState::Connected => {}
    }
    let m = &model.machine;
    if !m.link_up {
        return Summary::new(
            Warning,
            "READING",
            Some("reading the controller's state".into()),
        );
    }
    if m.estop {
        return Summary::new(
            Danger,
            "E-STOP",
            Some(Recovery::ClearEmergencyStop.instruction().to_string()),
        );
    }
    if m.limit {
        // The jog off a limit switch (`ui::jog::limit`) is the way out,
        // where the family does it.
        let key = model
            .keymap
            .key_for(
                super::keymap::Mode::Main,
                super::keymap::Action::JogOffLimit,
            )
            .filter(|_| model.setup.protocol != crate::proto::Protocol::Emcu);
        let detail = match key {
            Some(key) => format!(
                "a limit switch is active: initialise (i), jog off it ({key}), reference (h)"
            ),
            None => format!(
                "a limit switch is active: {}",
                Recovery::ReinitialiseAndReference.instruction()
            ),
        };
        return Summary::new(Danger, "LIMIT", Some(detail));
    }
    if let Some(f) = &m.fault {
        return Summary::new(Danger, "ERROR", Some(super::messages::fault_text(f)));
    }
    let word = match m.activity {
        Activity::Idle => None,
        Activity::Jogging => Some("JOGGING"),
        Activity::Stepping => Some("STEPPING"),
        Activity::Moving => Some("MOVING"),
        Activity::Homing => Some("HOMING"),
        Activity::Probing => Some("PROBING"),
        Activity::RunningProgram => Some("RUNNING"),
        Activity::Uploading => Some("UPLOADING"),
        Activity::Stopping => Some("STOPPING"),
    };
    if let Some(word) = word {
        return Summary::new(Warning, word, Some("Space stops all motion".into()));
    }
    if m.initialised.is_empty() {
        return Summary::new(
            Warning,
            "NOT INIT",
            Some("controller not initialised: initialise (i)".into()),
        );
    }
    let unreferenced: crate::axis::AxisSet = m
        .initialised
        .iter()
        .filter(|a| !m.referenced.contains(*a))
        .collect();
    if !unreferenced.is_empty() && !m.test_mode {
        return Summary::new(
            Warning,
            "NOT REF",
            Some(format!(
                "axes {unreferenced} not referenced: {}",
                Recovery::Reference.instruction()
            )),
        );
    }
    if m.test_mode {
        return Summary::new(
            Warning,
            "TEST MODE",
            Some("test mode: moves ignore the reference and the limit switches".into()),
        );
    }
    Summary::new(Ok, "READY", None)
}
