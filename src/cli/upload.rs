//! `jogterm upload FILE`: check a program, store it in the controller
//! (isel `@0i` … `9`, manual 2.2.13 and chapter 3) with its progress on
//! stderr, and optionally start it (`@0S`, manual 2.2.23).
//!
//! The program is linted for the machine profile first; an error is bad
//! usage and nothing is sent. A controller error at command N is reported
//! at the file line that holds command N (comments and blank lines are never
//! sent, so N is not the line number).

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;

use super::GlobalArgs;
use super::check::render;
use super::session::{self, EXIT_LINK, EXIT_USAGE, Linked, Polling, Session, StartError};
use crate::device::api::{
    Activity, ControllerFault, Event, LinkState, PerAxis, Refusal, Request, UploadEvent,
};
use crate::program::store;
use crate::program::{Language, LintConfig, Program, Severity, lint};
use crate::proto::Protocol;

pub const LONG_ABOUT: &str = "\
Check an isel CNC program, store it in the controller's program memory and, with --start,
run it.

The program is checked for the machine profile first, as `jogterm check` does; with an error
nothing is sent. Comments and blank lines are not sent; every command goes out in its
canonical spelling, one at a time, each answered by the controller before the next. Progress
(commands, lines per second, time left) goes to stderr.

If the controller holds a program already (it answers `@0i` with `G`), --erase erases it
first (`@0k`); without it the upload stops and says so. A controller error at command N is
reported as FILE:LINE for the line that holds command N; the partial program the controller
then holds is invalid and has to be erased (upload again with --erase).

With --start the stored program is started (`@0S`) and followed until it ends; the final
position is printed. Ctrl-C, a hang-up or SIGTERM stop the machine first.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 stored (and run); 1 the controller answered an error or refused for its
state, or interrupted (Ctrl-C, SIGTERM, a hang-up: the machine is stopped first); 2 bad
usage (an error in the program, an unreadable file, an unknown option); 3 link failure.

Examples:
  jogterm upload drill.isel --port /dev/ttyUSB0 --protocol isel
  jogterm upload drill.isel --port /tmp/isel --erase --start
  jogterm --sim isel upload examples/programs/drill-pattern.isel --start";

/// Options of `jogterm upload`.
#[derive(Debug, Args)]
pub struct UploadArgs {
    /// The program (.isel or .cnc)
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Erase a program the controller holds already (`@0k`) instead of stopping
    #[arg(long)]
    pub erase: bool,
    /// Start the program once it is stored and wait until it ends
    #[arg(long)]
    pub start: bool,
    /// Baud rate, instead of the profile's (isel: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
}

/// The program as it goes out: the commands and the file line of each.
struct Prepared {
    name: String,
    lines: Vec<String>,
    program: Program,
}

/// The file, checked; `Err` is the message for bad usage (printed already
/// when it is a list of diagnostics).
fn prepare(args: &UploadArgs, config: &LintConfig) -> Result<Prepared, String> {
    let name = args.file.display().to_string();
    if let Some(other) = Language::from_path(&args.file).filter(|l| *l != Language::Isel) {
        return Err(format!(
            "{name}: an {other} program by its extension; jogterm uploads isel programs so far"
        ));
    }
    let loaded = store::load(&args.file)
        .map_err(|e| e.to_string())?
        .ok_or_else(|| format!("{name}: no such file"))?;
    if loaded.lossy {
        return Err(format!(
            "{name}: bytes that are not UTF-8 (the controller takes ASCII)"
        ));
    }
    let program = Program::parse(Language::Isel, &loaded.text);
    let diagnostics = lint(&program, config);
    let errors: Vec<_> = diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .collect();
    if !errors.is_empty() {
        for d in &errors {
            eprintln!("{}", render(&name, &program, d));
        }
        return Err(format!(
            "{name}: {} error{} to fix first; nothing was sent",
            errors.len(),
            if errors.len() == 1 { "" } else { "s" }
        ));
    }
    let lines = program
        .upload_lines()
        .map_err(|(span, e)| format!("{name}:{}: {}", span.line + 1, e.message))?;
    if lines.is_empty() {
        return Err(format!("{name}: the program has no commands"));
    }
    Ok(Prepared {
        name,
        lines,
        program,
    })
}

pub fn run(global: &GlobalArgs, args: &UploadArgs) -> anyhow::Result<ExitCode> {
    let usage = |m: String| {
        eprintln!("jogterm upload: {m}");
        Ok(ExitCode::from(EXIT_USAGE))
    };
    let profile = match session::resolve(global, args.baud) {
        Ok(p) => p,
        Err(StartError::Usage(m)) => return usage(m),
        Err(StartError::Failed(e)) => return Err(e),
    };
    // The command's checks, initialise-and-retry and `--erase` are the isel
    // controller's (manual 3.1); an EMCU job goes up from the console's
    // editor (F5), EMP drives store no programs.
    if profile.connection.protocol != Protocol::Isel {
        return usage(format!(
            "jogterm upload stores isel CNC programs; for an {} controller use the console's editor (jogterm --program FILE, F5 uploads an EMCU job)",
            profile.connection.protocol
        ));
    }
    let prepared = match prepare(args, &LintConfig::from_profile(&profile)) {
        Ok(p) => p,
        Err(m) => return usage(m),
    };
    let runtime = session::runtime()?;
    runtime.block_on(async {
        let session = match session::start(global, profile, Polling::OFF) {
            Ok(s) => s,
            Err(StartError::Usage(m)) => return usage(m),
            Err(StartError::Failed(e)) => return Err(e),
        };
        Ok(upload_and_run(session, &prepared, args).await)
    })
}

async fn upload_and_run(mut session: Session, prepared: &Prepared, args: &UploadArgs) -> ExitCode {
    let stopper = session.handle.clone();
    let code = tokio::select! {
        code = steps(&mut session, prepared, args) => code,
        () = session::interrupted() => {
            let _ = stopper.stop().written().await;
            session::say_interrupted("upload");
            1
        }
    };
    session.close().await;
    ExitCode::from(code)
}

/// How a step ended when it did not succeed: the exit status, said already.
type Status = Result<(), u8>;

async fn steps(session: &mut Session, prepared: &Prepared, args: &UploadArgs) -> u8 {
    let result = async {
        if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
            eprintln!("jogterm upload: link failure: {reason}");
            return Err(EXIT_LINK);
        }
        upload(session, prepared, args.erase).await?;
        if args.start {
            start(session).await?;
        }
        Ok(())
    }
    .await;
    match result {
        Ok(()) => 0,
        Err(code) => code,
    }
}

/// The exit status for a refusal, said on stderr.
fn refused(what: &str, reason: &Refusal) -> u8 {
    eprintln!("jogterm upload: {what} refused: {reason}");
    match reason {
        Refusal::Invalid { .. } => EXIT_USAGE,
        Refusal::NotConnected => EXIT_LINK,
        _ => 1,
    }
}

fn lost(reason: &str) -> u8 {
    eprintln!("jogterm upload: link failure: {reason}");
    EXIT_LINK
}

async fn next(session: &mut Session) -> Result<Event, u8> {
    session
        .events
        .recv()
        .await
        .ok_or_else(|| lost("the device task ended"))
}

async fn upload(session: &mut Session, prepared: &Prepared, erase: bool) -> Status {
    let mut initialised = false;
    let mut progress = Progress::new(prepared.lines.len());
    loop {
        let request = Request::Upload {
            lines: prepared.lines.clone(),
            erase_first: erase,
        };
        if session.handle.request(request).is_err() {
            return Err(lost("the device task ended"));
        }
        loop {
            match next(session).await? {
                // A controller not yet told its axes is initialised once
                // (the profile's axes, `@0<n>`), then the upload retried.
                Event::Refused {
                    reason: Refusal::NotInitialised,
                    ..
                } if !initialised => {
                    initialised = true;
                    initialise(session).await?;
                    break;
                }
                Event::Refused { reason, .. } => return Err(refused("the upload", &reason)),
                Event::Upload(event) => match event {
                    UploadEvent::Started { .. } => progress.show(0, 0.0),
                    UploadEvent::Progress {
                        done,
                        lines_per_second,
                        ..
                    } => progress.show(done, lines_per_second),
                    UploadEvent::Finished { total, elapsed } => {
                        progress.end();
                        let secs = elapsed.as_secs_f64();
                        eprintln!(
                            "{}: {total} commands stored in {secs:.1} s ({:.1} lines/s)",
                            prepared.name,
                            if secs > 0.0 { total as f64 / secs } else { 0.0 }
                        );
                        return Ok(());
                    }
                    UploadEvent::Failed { line, fault } => {
                        progress.end();
                        eprintln!("{}", failure(prepared, line, &fault));
                        return Err(1);
                    }
                    UploadEvent::Aborted { done, reason } => {
                        progress.end();
                        eprintln!(
                            "jogterm upload: the upload stopped after {done} commands: {reason}"
                        );
                        return Err(1);
                    }
                },
                Event::Link(LinkState::Lost { reason }) => {
                    progress.end();
                    return Err(lost(&reason));
                }
                _ => {}
            }
        }
    }
}

/// `FILE:LINE: the controller refused command N `…`: code meaning; advice`.
fn failure(prepared: &Prepared, index: usize, fault: &ControllerFault) -> String {
    let place = match prepared.program.line_of(index) {
        Some(line) => format!("{}:{}", prepared.name, line + 1),
        // The `9` the driver appends to a program that lacks one.
        None => format!("{} (the closing 9)", prepared.name),
    };
    format!(
        "{place}: the controller refused command {} `{}`: {} {}; the partial program it holds \
         is invalid (upload again with --erase)",
        index + 1,
        fault.command,
        fault.code,
        fault.meaning,
    )
}

/// `Initialise`, and wait until the controller has its axes.
async fn initialise(session: &mut Session) -> Status {
    if session.handle.request(Request::Initialise).is_err() {
        return Err(lost("the device task ended"));
    }
    loop {
        match next(session).await? {
            Event::State(s) if !s.initialised.is_empty() && s.activity == Activity::Idle => {
                return Ok(());
            }
            Event::Refused { reason, .. } => return Err(refused("initialising", &reason)),
            Event::Fault(f) => {
                eprintln!(
                    "jogterm upload: initialising failed: `{}` answered {}: {}",
                    f.command, f.code, f.meaning
                );
                return Err(1);
            }
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
}

/// `RunProgram`, followed until the machine is idle again.
async fn start(session: &mut Session) -> Status {
    if session.handle.request(Request::RunProgram).is_err() {
        return Err(lost("the device task ended"));
    }
    eprintln!("running the program (Ctrl-C stops the machine)");
    let mut running = false;
    let mut fault: Option<ControllerFault> = None;
    let mut position: Option<PerAxis<i64>> = None;
    loop {
        match next(session).await? {
            Event::State(s) if s.activity == Activity::RunningProgram => running = true,
            Event::State(s) if running && s.activity == Activity::Idle => break,
            Event::Position(p) => position = Some(p.steps),
            Event::Fault(f) => fault = Some(f),
            Event::Refused { reason, .. } => return Err(refused("starting the program", &reason)),
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
    // The position read at the end comes with or just after the idle state.
    let settle = tokio::time::Instant::now() + Duration::from_millis(300);
    while let Ok(Some(event)) = tokio::time::timeout_at(settle, session.events.recv()).await {
        match event {
            Event::Position(p) => position = Some(p.steps),
            Event::Fault(f) => fault = Some(f),
            // Idle because the link went, not because the program ended.
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
    if let Some(f) = fault {
        eprintln!(
            "jogterm upload: the program ended with `{}`: {}",
            f.code, f.meaning
        );
        return Err(1);
    }
    let at = position.map_or_else(
        || "unknown".to_string(),
        |p| {
            p.iter()
                .map(|(axis, v)| format!("{axis} {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        },
    );
    eprintln!("the program ended; position (steps): {at}");
    Ok(())
}

/// The progress line on stderr: rewritten in place on a terminal, else a
/// line a second.
struct Progress {
    total: usize,
    terminal: bool,
    last: Option<Instant>,
    shown: bool,
}

impl Progress {
    fn new(total: usize) -> Progress {
        Progress {
            total,
            terminal: std::io::stderr().is_terminal(),
            last: None,
            shown: false,
        }
    }

    fn show(&mut self, done: usize, rate: f64) {
        let now = Instant::now();
        let every = if self.terminal {
            Duration::ZERO
        } else {
            Duration::from_secs(1)
        };
        if self.last.is_some_and(|t| now < t + every) && done < self.total {
            return;
        }
        self.last = Some(now);
        let text = progress_text(done, self.total, rate);
        let mut err = std::io::stderr().lock();
        let _ = if self.terminal {
            write!(err, "\r\x1b[2K{text}")
        } else {
            writeln!(err, "{text}")
        };
        let _ = err.flush();
        self.shown = true;
    }

    fn end(&mut self) {
        if self.terminal && self.shown {
            eprintln!();
        }
        self.shown = false;
    }
}

/// `upload 120/1000 (12 %), 55.3 lines/s, 16 s left`.
pub fn progress_text(done: usize, total: usize, rate: f64) -> String {
    let percent = (done * 100).checked_div(total).unwrap_or(100);
    let left = if rate > 0.0 && done < total {
        format!(", {:.0} s left", (total - done) as f64 / rate)
    } else {
        String::new()
    };
    format!("upload {done}/{total} ({percent} %), {rate:.1} lines/s{left}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_says_rate_and_time_left() {
        assert_eq!(
            progress_text(120, 1000, 55.0),
            "upload 120/1000 (12 %), 55.0 lines/s, 16 s left"
        );
        assert_eq!(
            progress_text(1000, 1000, 55.0),
            "upload 1000/1000 (100 %), 55.0 lines/s"
        );
        assert_eq!(progress_text(0, 10, 0.0), "upload 0/10 (0 %), 0.0 lines/s");
    }

    #[test]
    fn a_failure_names_the_file_line_of_the_command() {
        let text = "; head\n\n7 7\n; between\nm8000,8000\n9\n";
        let program = Program::parse(Language::Isel, text);
        let prepared = Prepared {
            name: "p.isel".into(),
            lines: program.upload_lines().expect("lines"),
            program,
        };
        let fault = ControllerFault {
            command: "m8000,8000".into(),
            code: "3".into(),
            meaning: "invalid number".into(),
            recovery: crate::device::api::Recovery::None,
        };
        let said = failure(&prepared, 1, &fault);
        assert!(said.starts_with("p.isel:5: the controller refused command 2 `m8000,8000`"));
        assert!(failure(&prepared, 7, &fault).starts_with("p.isel (the closing 9)"));
    }
}
