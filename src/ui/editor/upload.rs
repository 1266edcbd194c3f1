//! The editor's view of an upload (`Request::Upload`, `UploadEvent`): its
//! progress with lines per second and time left, and, when the controller
//! refuses a line, that line marked with what the code means. The source
//! line of every uploaded command is remembered when the upload starts, so
//! an error for command N lands on the line that was sent as command N.

use std::time::Duration;

use crate::device::api::UploadEvent;
use crate::program::Language;

use super::buffer::Change;

#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    Idle,
    /// Handed to the device task; it has not started yet.
    Requested,
    Running {
        done: usize,
        total: usize,
        lines_per_second: f64,
    },
    Finished {
        total: usize,
        elapsed: Duration,
    },
    /// The controller refused command `command` (0-based, as uploaded).
    Failed {
        command: usize,
        code: String,
        meaning: String,
    },
    Aborted {
        done: usize,
        reason: String,
    },
}

/// A line the controller refused, with why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mark {
    pub line: usize,
    pub message: String,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Upload {
    pub phase: Phase,
    /// Source line of each uploaded command, as when the upload started.
    lines_of: Vec<usize>,
    /// The buffer state that was uploaded.
    pub state: Option<u64>,
    pub mark: Option<Mark>,
    /// The last upload found a program in the way (`@0i` answered `G`): the
    /// next answer about the stored program should offer to erase it.
    pub offer_erase: bool,
    /// The editor started the running upload (not someone else's events).
    pub ours: bool,
    /// The language uploaded: what a failed upload leaves in the controller
    /// differs (isel: an invalid program; EMCU: nothing, the job is dropped).
    language: Option<Language>,
}

impl Default for Upload {
    fn default() -> Self {
        Upload {
            phase: Phase::Idle,
            lines_of: Vec::new(),
            state: None,
            mark: None,
            offer_erase: false,
            ours: false,
            language: None,
        }
    }
}

/// What the operator should be told about an upload event.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Report {
    pub danger: bool,
    pub text: String,
}

impl Upload {
    /// An upload of `language` commands whose source lines are `lines_of`
    /// was sent.
    pub fn start(&mut self, language: Language, lines_of: Vec<usize>, state: u64) {
        self.language = Some(language);
        self.phase = Phase::Requested;
        self.lines_of = lines_of;
        self.state = Some(state);
        self.mark = None;
        self.offer_erase = false;
        self.ours = true;
    }

    /// Sent or running: the text must stay as it is being sent.
    pub fn busy(&self) -> bool {
        matches!(self.phase, Phase::Requested | Phase::Running { .. })
    }

    /// The source line of uploaded command `command`: the appended `9` (one
    /// past the commands) is put on the last command's line.
    pub fn line_of(&self, command: usize) -> Option<usize> {
        self.lines_of
            .get(command)
            .or_else(|| self.lines_of.last())
            .copied()
    }

    /// Take an event from the device task.
    pub fn event(&mut self, event: &UploadEvent) -> Option<Report> {
        match event {
            UploadEvent::Started { total } => {
                self.phase = Phase::Running {
                    done: 0,
                    total: *total,
                    lines_per_second: 0.0,
                };
                None
            }
            UploadEvent::Progress {
                done,
                total,
                lines_per_second,
            } => {
                self.phase = Phase::Running {
                    done: *done,
                    total: *total,
                    lines_per_second: *lines_per_second,
                };
                None
            }
            UploadEvent::Finished { total, elapsed } => {
                self.phase = Phase::Finished {
                    total: *total,
                    elapsed: *elapsed,
                };
                Some(Report {
                    danger: false,
                    text: format!(
                        "upload finished: {total} commands stored in {:.1} s",
                        elapsed.as_secs_f64()
                    ),
                })
            }
            UploadEvent::Failed { line, fault } => {
                let meaning = format!("`{}`: {}", fault.code, fault.meaning);
                let at = if self.ours { self.line_of(*line) } else { None };
                self.mark = at.map(|l| Mark {
                    line: l,
                    message: format!("the controller answered {meaning}"),
                });
                self.phase = Phase::Failed {
                    command: *line,
                    code: fault.code.clone(),
                    meaning: fault.meaning.clone(),
                };
                let place = match at {
                    Some(l) => format!("command {} (line {})", line + 1, l + 1),
                    None => format!("command {}", line + 1),
                };
                let after = match self.language {
                    // The driver ends the transfer with a bare 0x01, which
                    // discards the job (`docs/protocols.md`, EMCU).
                    Some(Language::Emcu) => format!(
                        "the interface discarded the job and stores nothing (it took {line} \
                         command{}); change the job, then upload again",
                        if *line == 1 { "" } else { "s" }
                    ),
                    Some(Language::Isel) | None => "the stored program is invalid: fix the line, \
                         then upload again (it offers to erase first)"
                        .to_string(),
                };
                Some(Report {
                    danger: true,
                    text: format!(
                        "upload failed at {place}: the controller answered {meaning}; {after}"
                    ),
                })
            }
            UploadEvent::Aborted { done, reason, .. } => {
                // Nothing stored and nothing sent: `@0i` found a program.
                self.offer_erase = *done == 0 && self.ours;
                self.phase = Phase::Aborted {
                    done: *done,
                    reason: reason.clone(),
                };
                Some(Report {
                    danger: true,
                    text: format!("upload stopped after {done} commands: {reason}"),
                })
            }
        }
    }

    /// Seconds left at the current rate.
    pub fn time_left(&self) -> Option<f64> {
        match self.phase {
            Phase::Running {
                done,
                total,
                lines_per_second,
            } if lines_per_second > 0.0 => {
                Some(total.saturating_sub(done) as f64 / lines_per_second)
            }
            _ => None,
        }
    }

    /// Lines moved or were replaced: the mark follows its line, and goes
    /// when the line is edited (the operator is fixing it).
    pub fn changed(&mut self, change: Change) {
        if let Some(mark) = &mut self.mark {
            match change.map_line(mark.line) {
                Some(line) => mark.line = line,
                None => self.mark = None,
            }
        }
        for line in &mut self.lines_of {
            *line = change.map_line(*line).unwrap_or(change.at);
        }
    }

    /// Forget a finished upload's outcome (a new program was opened).
    pub fn clear(&mut self) {
        if !self.busy() {
            *self = Upload::default();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::{ControllerFault, Recovery};

    fn fault(code: &str) -> ControllerFault {
        ControllerFault {
            command: "m1,2".into(),
            code: code.into(),
            meaning: "wrong number of parameters".into(),
            recovery: Recovery::None,
        }
    }

    #[test]
    fn a_refused_command_marks_the_line_it_was_sent_from() {
        let mut u = Upload::default();
        // Commands 0, 1, 2 come from lines 1, 3, 4 (comments between).
        u.start(Language::Isel, vec![1, 3, 4], 7);
        assert!(u.busy());
        u.event(&UploadEvent::Started { total: 3 });
        u.event(&UploadEvent::Progress {
            done: 1,
            total: 3,
            lines_per_second: 2.0,
        });
        assert_eq!(u.time_left(), Some(1.0));
        let report = u
            .event(&UploadEvent::Failed {
                line: 1,
                fault: fault("7"),
            })
            .expect("said");
        assert!(report.danger);
        assert!(
            report.text.contains("command 2 (line 4)"),
            "{}",
            report.text
        );
        assert_eq!(u.mark.as_ref().map(|m| m.line), Some(3));
        assert!(!u.busy());
        // A line inserted above moves the mark; editing the line removes it.
        u.changed(Change {
            at: 0,
            removed: 0,
            inserted: 1,
        });
        assert_eq!(u.mark.as_ref().map(|m| m.line), Some(4));
        u.changed(Change {
            at: 4,
            removed: 1,
            inserted: 1,
        });
        assert_eq!(u.mark, None);
    }

    #[test]
    fn a_job_the_emcu_has_no_room_for_is_marked_and_said_to_be_gone() {
        let mut u = Upload::default();
        u.start(Language::Emcu, vec![1, 2, 4], 3);
        u.event(&UploadEvent::Started { total: 3 });
        let report = u
            .event(&UploadEvent::Failed {
                line: 2,
                fault: ControllerFault {
                    command: "W50".into(),
                    code: "0x03".into(),
                    meaning: "memory full".into(),
                    recovery: Recovery::None,
                },
            })
            .expect("said");
        assert!(
            report.text.contains("command 3 (line 5)"),
            "{}",
            report.text
        );
        assert!(
            report.text.contains("`0x03`: memory full"),
            "{}",
            report.text
        );
        assert!(
            report
                .text
                .contains("discarded the job and stores nothing (it took 2 commands)"),
            "{}",
            report.text
        );
        let mark = u.mark.as_ref().expect("marked");
        assert_eq!(mark.line, 4);
        assert!(mark.message.contains("memory full"), "{}", mark.message);
    }

    #[test]
    fn the_appended_end_is_put_on_the_last_command() {
        let mut u = Upload::default();
        u.start(Language::Isel, vec![0, 2], 1);
        assert_eq!(u.line_of(2), Some(2));
        assert_eq!(u.line_of(1), Some(2));
    }

    #[test]
    fn a_program_in_the_way_offers_an_erase() {
        let mut u = Upload::default();
        u.start(Language::Isel, vec![0], 1);
        u.event(&UploadEvent::Started { total: 1 });
        u.event(&UploadEvent::Aborted {
            done: 0,
            reason: "a program is already stored".into(),
            link_lost: false,
        });
        assert!(u.offer_erase);
        let mut theirs = Upload::default();
        theirs.event(&UploadEvent::Aborted {
            done: 0,
            reason: "x".into(),
            link_lost: false,
        });
        assert!(!theirs.offer_erase, "only for the editor's own upload");
    }
}
