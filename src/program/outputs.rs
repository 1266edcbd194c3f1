//! The outputs a job switches on (isel `p`, EMCU `A<n>`), for what happens
//! to them when the job ends early (issue 37): a stop, a controller error or
//! a lost line would otherwise leave the spindle running with nothing said.
//! The CLI (`jogterm run`, `upload --start`) and the console switch off the
//! ones [`JobOutput::left`] allows once the axes stand, and say the rest.
//!
//! Only the spindle port and the EMCU's outputs are switched off: outputs
//! cannot be read back, so a bit of a byte-wide port (isel port 0, the
//! user outputs) cannot be cleared without guessing the port's other bits,
//! which the program may have changed (port 100 holds the brake and the
//! power stage's enable). Those are listed with the reason and left on.
//! The other on/off ports (hood, motor currents, current reduction, brake)
//! are the machine's, not the job's, and are not listed.

use crate::device::api::OutputId;
use crate::proto::emcu;
use crate::proto::isel::CncCommand;
use crate::proto::isel::ports::{OutputPort, PortBits};
use crate::wiring::isel_output_address;

use super::{Command, Program};

/// An output a job switches on somewhere.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JobOutput {
    /// For `Request::SetOutput`.
    pub id: OutputId,
    /// `spindle (out2)`: the name the program's comment gives, and the
    /// profile address.
    pub label: String,
    /// `None` when it can be switched off on its own; else why it is left
    /// as it is.
    pub left: Option<String>,
}

/// The outputs `program` switches on, in the order of their first `on`,
/// each once. Every one counts, also those the program switches off again
/// later: a stop may come between.
pub fn switched_on(program: &Program) -> Vec<JobOutput> {
    let mut found: Vec<JobOutput> = Vec::new();
    for line in program.lines() {
        let Some(statement) = line.statement() else {
            continue;
        };
        let Ok(command) = &statement.command else {
            continue;
        };
        let comment = statement
            .comment
            .as_ref()
            .map(|c| line.slice(c.clone()).to_owned());
        let Some((id, address, left)) = output_on(command) else {
            continue;
        };
        if found.iter().any(|o| o.id == id) {
            continue;
        }
        let label = match comment.as_deref().and_then(name_of) {
            Some(name) => format!("{name} ({address})"),
            None => address,
        };
        found.push(JobOutput { id, label, left });
    }
    found
}

/// How a job ended before its end, for its outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// Stopped, a controller error: the link still stands, and the outputs
    /// are switched off once the axes stand.
    Early,
    /// The link is gone: nothing can be sent.
    LinkLost,
}

/// How long the axes may take to stand after a stop before the outputs
/// are left as they are (and said so): a stop ramps down within a second
/// or two on every family; ten seconds are a broken report, not a ramp.
pub const STAND_WITHIN: std::time::Duration = std::time::Duration::from_secs(10);

// The words the CLI and the console share, so that they say the same.

/// The link went: nothing can be switched off from here.
pub fn link_lost_text(outputs: &[JobOutput]) -> String {
    format!(
        "the link is lost: the job's outputs may still be on: {}; switch them off at the machine",
        labels(outputs)
    )
}

/// The axes did not report standing within [`STAND_WITHIN`].
pub fn not_standing_text(outputs: &[JobOutput]) -> String {
    format!(
        "the axes did not report standing: the job's outputs were left as they are: {}",
        labels(outputs)
    )
}

/// An output [`JobOutput::left`] keeps on, why, and `how` to switch it off.
pub fn left_on_text(output: &JobOutput, why: &str, how: &str) -> String {
    format!("{} left on: {why}; {how}", output.label)
}

/// An output whose switching off failed.
pub fn still_on_text(output: &JobOutput, why: &str) -> String {
    format!("{} may still be on: {why}", output.label)
}

/// The outputs switched off after the job ended early.
pub fn switched_off_text<'a>(off: impl IntoIterator<Item = &'a JobOutput>) -> String {
    format!("switched off once the axes stood: {}", labels(off))
}

/// What a pause does to the job's outputs: they stay as the job left
/// them (a spindle keeps turning above the part); `None` when the job
/// switches none on.
pub fn paused_text(outputs: &[JobOutput]) -> Option<String> {
    (!outputs.is_empty()).then(|| {
        format!(
            "the job's outputs stay on while it pauses: {}",
            labels(outputs)
        )
    })
}

/// `a, b and c` of the outputs' labels.
pub fn labels<'a>(outputs: impl IntoIterator<Item = &'a JobOutput>) -> String {
    let labels: Vec<&str> = outputs.into_iter().map(|o| o.label.as_str()).collect();
    match labels.split_last() {
        None => String::new(),
        Some((last, [])) => (*last).to_owned(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
    }
}

/// The output a command switches on: its id, address and why it is left
/// on after a stop (`None`: it is switched off).
fn output_on(command: &Command) -> Option<(OutputId, String, Option<String>)> {
    match command {
        Command::Isel(CncCommand::SetPort { port, bits, value }) if *value != 0 => {
            isel_output(*port, *bits)
        }
        Command::Emcu(emcu::Command::SetOutput { output, on: true }) => Some((
            OutputId {
                group: output.get(),
                bit: None,
            },
            format!("A{output}"),
            None,
        )),
        _ => None,
    }
}

fn isel_output(port: OutputPort, bits: PortBits) -> Option<(OutputId, String, Option<String>)> {
    let n = port.number();
    match (port, bits) {
        // Port 2 is the spindle's on/off alone (manual 2.2.4): `@0B2,0`
        // touches nothing else.
        (OutputPort::Spindle, _) => Some((
            OutputId {
                group: u16::from(n),
                bit: None,
            },
            isel_output_address(port, None),
            None,
        )),
        (OutputPort::User, PortBits::Bit(bit)) => Some((
            OutputId {
                group: u16::from(n),
                bit: Some(bit),
            },
            isel_output_address(port, Some(bit)),
            Some(format!(
                "the other bits of port {n} are unknown (outputs cannot be read back)"
            )),
        )),
        (OutputPort::User | OutputPort::Analog, _) => Some((
            OutputId {
                group: u16::from(n),
                bit: None,
            },
            isel_output_address(port, None),
            Some(format!(
                "port {n} is a whole byte of outputs, not all of them the job's"
            )),
        )),
        _ => None,
    }
}

/// `o.nc:2 spindle on` → `spindle`: the G-code import's note (`gcode::isel`)
/// after the file place; a hand-written comment as it stands, without `;`.
fn name_of(comment: &str) -> Option<&str> {
    let text = comment.trim_start_matches(';').trim();
    let text = text.strip_suffix(" on").unwrap_or(text);
    let text = match text.split_once(' ') {
        Some((place, rest)) if place.contains(':') => rest,
        _ => text,
    };
    let text = text.trim();
    (!text.is_empty()).then_some(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Language;

    fn on(language: Language, text: &str) -> Vec<(OutputId, String, bool)> {
        switched_on(&Program::parse(language, text))
            .into_iter()
            .map(|o| (o.id, o.label, o.left.is_none()))
            .collect()
    }

    fn id(group: u16, bit: Option<u8>) -> OutputId {
        OutputId { group, bit }
    }

    #[test]
    fn the_spindle_of_a_converted_job_is_switched_off() {
        let text = "p2,128,1 ; o.nc:2 spindle on\nm100,900\np2,128,0 ; o.nc:5 spindle off\n9\n";
        assert_eq!(
            on(Language::Isel, text),
            vec![(id(2, None), "spindle (out2)".into(), true)]
        );
    }

    #[test]
    fn a_user_output_bit_is_left_with_the_reason() {
        let out = switched_on(&Program::parse(
            Language::Isel,
            "p0,2,1 ; o.nc:3 coolant on\np0,2,1\np0,3,0\n9\n",
        ));
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].id, id(0, Some(2)));
        assert_eq!(out[0].label, "coolant (out0.2)");
        assert!(
            out[0]
                .left
                .as_deref()
                .is_some_and(|w| w.contains("other bits of port 0 are unknown")),
            "{out:?}"
        );
    }

    #[test]
    fn machine_ports_and_outputs_switched_off_are_not_the_jobs() {
        // Motor currents, brake and an output only ever switched off.
        assert_eq!(
            on(Language::Isel, "p3,128,1\np6,128,1\np2,128,0\n9\n"),
            vec![]
        );
    }

    #[test]
    fn emcu_outputs_are_switched_off() {
        assert_eq!(
            on(Language::Emcu, "A1,1\nA2,0\nA1,0\n"),
            vec![(id(1, None), "A1".into(), true)]
        );
    }

    #[test]
    fn labels_read_as_a_list() {
        let o = |l: &str| JobOutput {
            id: id(0, None),
            label: l.into(),
            left: None,
        };
        assert_eq!(labels(&[]), "");
        assert_eq!(labels(&[o("a")]), "a");
        assert_eq!(labels(&[o("a"), o("b"), o("c")]), "a, b and c");
    }
}
