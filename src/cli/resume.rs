//! `jogterm run`'s offer to resume (`docs/gcode.md`, "Resume"): before a
//! G-code job runs, the job log is asked whether the newest run of the same
//! content broke off (a crash, a fault, a lost line) after a known line.
//!
//! What happens then is the operator's choice, never guessed: on a terminal
//! jogterm asks (restart from that line, or from the start); `--resume`
//! takes the offer and `--from-start` declines it. `--yes` alone chooses
//! neither: it would either cut the part again from its first line or
//! start in its middle without anyone having said so, so the run is
//! refused with the two commands that say it.

use std::io::IsTerminal;
use std::path::Path;

use super::out;
use super::run::RunArgs;
use crate::joblog::{self, resume::Offer};

/// What the run does after the log was asked.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// As asked: no offer, declined, or `--from-line` given.
    AsAsked,
    /// Restart from `line`; the last run's work offset, which this run's
    /// must be.
    Resume { line: u32, offset: String },
    /// Not started (said already): the exit status.
    Refused(u8),
}

/// Ask the log about `file` (content `hash`) and the operator as `args`
/// say.
pub fn decide(args: &RunArgs, hash: Option<&str>) -> Decision {
    if args.from_line.is_some() {
        return Decision::AsAsked;
    }
    let folded = match (joblog::file::dir(), hash) {
        (Some(dir), Some(_)) => joblog::file::read(&dir),
        _ => joblog::Folded::default(),
    };
    let offer = joblog::resume::offer(&folded, hash.unwrap_or_default());
    if let Some(said) = joblog::resume::said(&offer) {
        out::say(format_args!("jogterm run: {said}"));
    }
    let file = args.file.display();
    match offer {
        Offer::Nothing | Offer::NoLine { .. } if args.resume => {
            out::say(format_args!(
                "jogterm run: --resume: the job log has no run of {file} (same content) that broke \
                 off after a known line; nothing was sent"
            ));
            Decision::Refused(1)
        }
        Offer::Nothing | Offer::NoLine { .. } => Decision::AsAsked,
        Offer::Resume { run, line } => {
            let resume = Decision::Resume {
                line,
                offset: run.start.offset.clone(),
            };
            if args.resume {
                out::say(format_args!(
                    "jogterm run: --resume: restarting from line {line}"
                ));
                return resume;
            }
            if args.from_start {
                out::say("jogterm run: --from-start: the whole job, from its first line");
                return Decision::AsAsked;
            }
            if args.yes {
                out::say(refusal(&args.file, line));
                return Decision::Refused(1);
            }
            match asked(line) {
                Some(true) => resume,
                // No terminal: the start's confirmation refuses next,
                // with what to give.
                Some(false) | None => Decision::AsAsked,
            }
        }
    }
}

/// Why `--yes` alone does not start, and the two commands that would.
pub fn refusal(file: &Path, line: u32) -> String {
    let file = file.display();
    format!(
        "jogterm run: not started, nothing was sent: after a run that broke off,\n\
         --yes alone chooses neither a restart nor the whole job again (with this run's\n\
         other options):\n  \
         restart from line {line}: jogterm run {file} --from-line {line} --yes (or --resume)\n  \
         the whole job: jogterm run {file} --from-start --yes"
    )
}

/// On a terminal: restart from `line`? `None` without a terminal.
fn asked(line: u32) -> Option<bool> {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return None;
    }
    out::say_raw(format_args!(
        "restart from line {line} (retract, above its start, descend), instead of the whole \
         job? [y/N] "
    ));
    let mut answer = String::new();
    if stdin.read_line(&mut answer).is_err() {
        return Some(false);
    }
    Some(matches!(answer.trim(), "y" | "Y" | "yes" | "YES" | "Yes"))
}

/// A resumed run's work offset must be the one the broken-off run cut
/// with: else the restart would cut elsewhere. `Err`: what to say.
pub fn same_offset(expected: &str, now: &str) -> Result<(), String> {
    if expected == now {
        return Ok(());
    }
    Err(format!(
        "jogterm run: not restarted, nothing was sent: the run that broke off cut with work \
         offset {expected}, this one would with {now}; set the zero back (or give --work-zero) \
         and resume, or choose with --from-line"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_refusal_names_both_commands() {
        let text = refusal(Path::new("part.nc"), 120);
        assert!(
            text.contains("jogterm run part.nc --from-line 120 --yes"),
            "{text}"
        );
        assert!(
            text.contains("jogterm run part.nc --from-start --yes"),
            "{text}"
        );
        // Within 80 columns but for the file's name.
        assert!(
            text.replace("part.nc", "")
                .lines()
                .all(|l| l.chars().count() <= 80),
            "{text}"
        );
    }

    #[test]
    fn a_resume_needs_the_same_offset() {
        assert_eq!(same_offset("G54 X1.000", "G54 X1.000"), Ok(()));
        assert!(same_offset("G54 X1.000", "G54 X2.000").is_err());
    }
}
