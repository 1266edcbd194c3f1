//! Sequences of buffered commands: a ROM job upload (`@F`, manual 1.5.17,
//! decision 2) and a batch for the data memory that runs at its end (manual
//! 1.4.2, decision 1). Only buffered commands may be stored; the last one
//! ends with 0x01. Each line must be acknowledged before the next is sent
//! (manual 1.4.2), so a sequence is handed out line by line with the reply
//! each one expects.

use thiserror::Error;

use super::command::{Command, Terminator};
use super::exchange::Expect;

/// Commands the data memory holds by default (decision 1); the command that
/// fills it is acknowledged with 0x03 CR.
pub const DATA_MEMORY_CAPACITY: usize = 256;
/// Commands a ROM job may hold. The manual gives no size for the ROM store;
/// jogterm assumes the data memory's (`docs/protocols.md`, EMCU).
pub const JOB_CAPACITY: usize = DATA_MEMORY_CAPACITY;

/// Why a list of commands cannot be stored.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum JobError {
    #[error("a job needs at least one command: its last one ends the transfer with 0x01")]
    Empty,
    #[error(
        "command {} `{command}` is a master command: it runs at once and cannot be stored",
        .index + 1
    )]
    MasterCommand { index: usize, command: String },
    #[error("a job holds at most {max} commands, this one has {len}")]
    TooLong { len: usize, max: usize },
}

/// Every problem of a job, for an editor that shows them all.
pub fn job_problems(commands: &[Command]) -> Vec<JobError> {
    let mut problems = batch_problems(commands);
    if commands.len() > JOB_CAPACITY {
        problems.push(JobError::TooLong {
            len: commands.len(),
            max: JOB_CAPACITY,
        });
    }
    problems
}

fn batch_problems(commands: &[Command]) -> Vec<JobError> {
    if commands.is_empty() {
        return vec![JobError::Empty];
    }
    commands
        .iter()
        .enumerate()
        .filter(|(_, c)| !c.is_storable())
        .map(|(index, c)| JobError::MasterCommand {
            index,
            command: c.to_string(),
        })
        .collect()
}

/// One line of a sequence: the command, its bytes with terminator, and the
/// reply that acknowledges it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SequenceLine {
    pub command: Command,
    pub bytes: Vec<u8>,
}

impl SequenceLine {
    /// Only for commands already checked to be buffered (`batch_problems`),
    /// which may end with either terminator.
    fn new(command: &Command, end: Terminator) -> SequenceLine {
        let mut bytes = command.to_string().into_bytes();
        bytes.push(end.byte());
        SequenceLine {
            command: *command,
            bytes,
        }
    }

    pub fn expect(&self) -> Expect {
        self.command.expect()
    }
}

fn lines(commands: &[Command]) -> Vec<SequenceLine> {
    let last = commands.len().saturating_sub(1);
    commands
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let end = if i == last {
                Terminator::RunBuffer
            } else {
                Terminator::Cr
            };
            SequenceLine::new(c, end)
        })
        .collect()
}

/// A ROM job upload: `@F` CR, the commands ended by CR, the last by 0x01,
/// which ends the transfer without running anything (decision 2).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JobUpload {
    lines: Vec<SequenceLine>,
}

impl JobUpload {
    /// Checks the job (first problem reported) and lays out its lines.
    pub fn new(commands: &[Command]) -> Result<JobUpload, JobError> {
        if let Some(problem) = job_problems(commands).into_iter().next() {
            return Err(problem);
        }
        // `@F` is a master command ended by CR, which `new` writes as asked.
        let mut all = vec![SequenceLine::new(&Command::StoreJob, Terminator::Cr)];
        all.extend(lines(commands));
        Ok(JobUpload { lines: all })
    }

    /// The lines in sending order, `@F` first.
    pub fn lines(&self) -> &[SequenceLine] {
        &self.lines
    }

    /// Stored commands (the `@F` line not counted).
    pub fn len(&self) -> usize {
        self.lines.len().saturating_sub(1)
    }

    /// Never true: a job has at least one command.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The whole upload as one byte sequence (for a job file or a log; on the
    /// wire each line waits for its acknowledgement).
    pub fn to_bytes(&self) -> Vec<u8> {
        self.lines
            .iter()
            .flat_map(|l| l.bytes.iter().copied())
            .collect()
    }
}

/// A batch for the data memory: the commands ended by CR, the last by 0x01,
/// which starts the memory; 0x02 CR follows when it has run (decision 1).
/// Longer than [`DATA_MEMORY_CAPACITY`] is allowed: the command that fills
/// the memory is answered 0x03 CR, and the rest must wait for 0x02 CR.
pub fn run_batch(commands: &[Command]) -> Result<Vec<SequenceLine>, JobError> {
    match batch_problems(commands).into_iter().next() {
        Some(problem) => Err(problem),
        None => Ok(lines(commands)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn commands(text: &[&str]) -> Vec<Command> {
        text.iter().map(|t| t.parse().unwrap()).collect()
    }

    #[test]
    fn an_upload_starts_with_store_job_and_ends_with_run_buffer() {
        let job = JobUpload::new(&commands(&["#S150", "L1,x500,y1000", "W250"])).unwrap();
        assert_eq!(job.to_bytes(), b"@F\r#S150\rL1,x500,y1000\rW250\x01");
        assert_eq!(job.len(), 3);
        let expects: Vec<Expect> = job.lines().iter().map(SequenceLine::expect).collect();
        assert_eq!(
            expects,
            vec![
                Expect::Ack,
                Expect::AckOrMemoryFull,
                Expect::AckOrMemoryFull,
                Expect::AckOrMemoryFull
            ]
        );
    }

    #[test]
    fn a_single_command_job_ends_at_once() {
        let job = JobUpload::new(&commands(&["A1,1"])).unwrap();
        assert_eq!(job.to_bytes(), b"@F\rA1,1\x01");
    }

    #[test]
    fn master_commands_empty_and_oversized_jobs_are_refused() {
        assert_eq!(JobUpload::new(&[]), Err(JobError::Empty));
        let with_masters = commands(&["W1", "@X", "A1,0", "@S"]);
        assert_eq!(
            job_problems(&with_masters),
            vec![
                JobError::MasterCommand {
                    index: 1,
                    command: "@X".into()
                },
                JobError::MasterCommand {
                    index: 3,
                    command: "@S".into()
                }
            ]
        );
        assert_eq!(
            JobUpload::new(&with_masters)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Err("command 2 `@X` is a master command: it runs at once and cannot be stored".into())
        );
        let long = commands(&["W1"]).repeat(JOB_CAPACITY + 1);
        assert_eq!(
            JobUpload::new(&long),
            Err(JobError::TooLong {
                len: JOB_CAPACITY + 1,
                max: JOB_CAPACITY
            })
        );
        assert!(JobUpload::new(&long[..JOB_CAPACITY]).is_ok());
    }

    #[test]
    fn a_batch_runs_at_its_last_line() {
        let batch = run_batch(&commands(&["$HZXY", "L1,X0,Y0,Z0"])).unwrap();
        let bytes: Vec<&[u8]> = batch.iter().map(|l| l.bytes.as_slice()).collect();
        assert_eq!(bytes, vec![&b"$HZXY\r"[..], b"L1,X0,Y0,Z0\x01"]);
        assert_eq!(
            run_batch(&commands(&["@J"])).map(|_| ()),
            Err(JobError::MasterCommand {
                index: 0,
                command: "@J".into()
            })
        );
        assert!(run_batch(&commands(&["W1"]).repeat(DATA_MEMORY_CAPACITY + 10)).is_ok());
    }
}
