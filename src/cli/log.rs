//! `jogterm log`: the runs of the job log (`joblog`, `docs/gcode.md` "Job
//! log"), and the one handle `jogterm run` writes its run through
//! ([`Logged`]): started before the first byte of the job, told each G-code
//! line that ran to its end, ended with how the run ended.

use std::path::Path;
use std::process::ExitCode;

use clap::Args;
use serde_json::json;

use super::out::{self, StdoutError};
use super::session::EXIT_LINK;
use crate::joblog::{self, How, JobLog, Start};
use crate::program::store::Fingerprint;

pub const LONG_ABOUT: &str = "\
List the runs of the job log, newest last.

Every run of a job, by `jogterm run` or by the console, is written to the job log in the state
directory ($JOGTERM_STATE_DIR, else ~/.local/state/jogterm): the file and its content hash, the
profile, the port, the work offset, the way (stored, chunked, stream), when it started and
ended, the last G-code line that ran to its end, the estimated and the actual time, and how it
ended: done, stopped (by the operator), error (a fault), lost (the line to the controller), or
crash (no end: killed, crashed or the power went), or running (its process still runs).

A run that ended by a crash, a fault or a lost line is offered for a restart from its last
line the next time the same file is run (`jogterm run --help`, --resume).";

pub const AFTER_LONG_HELP: &str = "\
Columns: started (UTC), file, way, the last line that ran to its end, the time taken, the
estimate, how it ended. --json gives one object with every run's fields (\"resume_line\": the
line a restart would take up) and the notes on lines left out of the log.

Exit status: 0; 1 when there is no state directory.

Examples:
  jogterm log
  jogterm log -n 3
  jogterm log --json | jq '.runs[-1]'";

/// Options of `jogterm log`.
#[derive(Debug, Args)]
pub struct LogArgs {
    /// One JSON object: the runs and the notes
    #[arg(long)]
    pub json: bool,
    /// How many runs, the newest
    #[arg(short = 'n', long = "count", value_name = "N", default_value_t = 10)]
    pub count: usize,
}

pub fn run(args: &LogArgs) -> anyhow::Result<ExitCode> {
    let Some(dir) = joblog::file::dir() else {
        out::say("jogterm log: no state directory (no home directory, no $JOGTERM_STATE_DIR)");
        return Ok(ExitCode::from(1));
    };
    let folded = joblog::file::read(&dir);
    let from = folded.runs.len().saturating_sub(args.count);
    let runs = folded.runs.get(from..).unwrap_or_default();
    let text = if args.json {
        json!({
            "log": dir.join(joblog::file::FILE_NAME).display().to_string(),
            "runs": runs.iter().map(joblog::table::json).collect::<Vec<_>>(),
            "notes": folded.notes,
        })
        .to_string()
    } else {
        for note in &folded.notes {
            out::say(format_args!("jogterm log: {note}"));
        }
        joblog::table::table(&folded.runs, args.count).join("\n")
    };
    match out::line(text) {
        Ok(()) | Err(StdoutError::Closed) => Ok(ExitCode::SUCCESS),
        Err(e) => Err(e.into()),
    }
}

/// The content hash of a job's file, as the log keeps it; `None` when it
/// cannot be read (the run then says its own error).
pub fn hash_of(file: &Path) -> Option<String> {
    std::fs::read(file)
        .ok()
        .map(|bytes| Fingerprint::of(&bytes).to_string())
}

/// What a run of `jogterm run` is, for its start record.
pub struct RunInfo<'a> {
    pub file: &'a Path,
    pub hash: String,
    pub profile: &'a crate::config::profile::Profile,
    pub offset: String,
    pub way: crate::gcode::ways::Way,
    pub estimate_s: Option<f64>,
    pub from_line: Option<u32>,
}

/// A run's place in the job log, or a run without one (no state
/// directory, a log that cannot be written: said once, the run goes on).
pub struct Logged(Option<JobLog>);

impl Logged {
    pub fn begin(info: &RunInfo<'_>) -> Logged {
        let Some(dir) = joblog::file::dir() else {
            return Logged(None);
        };
        let at = joblog::file::now_utc();
        let file = std::path::absolute(info.file).unwrap_or_else(|_| info.file.to_path_buf());
        let start = Start {
            run: joblog::file::run_id(&at),
            at,
            file: file.display().to_string(),
            hash: info.hash.clone(),
            profile: info.profile.name.clone(),
            port: info.profile.connection.port.clone(),
            offset: info.offset.clone(),
            way: info.way.to_string(),
            estimate_s: info.estimate_s.map(joblog::record::seconds),
            from_line: info.from_line,
            by: "run".into(),
            pid: std::process::id(),
            boot: joblog::file::boot_id(),
        };
        match JobLog::start(&dir, &start) {
            Ok(log) => Logged(Some(log)),
            Err(e) => {
                out::say(format_args!(
                    "jogterm run: the job log in {} could not be written ({e}); the run goes on \
                     without it",
                    dir.display()
                ));
                Logged(None)
            }
        }
    }

    /// G-code line `line` ran to its end.
    pub fn line(&self, line: u32) {
        if let Some(log) = &self.0 {
            log.line(line);
        }
    }

    /// The run ended with exit status `code`; `stopped`: the operator
    /// stopped it (a stop key, Ctrl-C, a hang-up).
    pub fn end(self, code: u8, stopped: bool) {
        let how = match code {
            0 => How::Done,
            EXIT_LINK => How::Lost,
            _ if stopped => How::Stopped,
            _ => How::Error,
        };
        if let Some(note) = self.0.and_then(|log| log.end(how)) {
            out::say(format_args!("jogterm run: {note}"));
        }
    }
}

/// The work offset of an import and its zero in machine units, as the log
/// keeps it: `G54 X50.000 Y50.000 Z60.000 mm`.
pub fn offset_of(summary: &crate::gcode::check::Summary) -> String {
    let z = summary.zero;
    format!("{} X{:.3} Y{:.3} Z{:.3} mm", summary.system, z.x, z.y, z.z)
}
