//! `jogterm upload FILE`: check a program, store it in the controller with
//! its progress on stderr, and optionally start it. isel: `@0i` … `9`
//! (manual 2.2.13, chapter 3), started with `@0S` (2.2.23). EMCU: a ROM job,
//! `@F` … 0x01 (manual 1.5.17, decision 2), started with `@J` (1.5.18). Both
//! go through the device task's `Upload` and `RunProgram`, as the console's
//! editor does.
//!
//! The program is linted for the machine profile first; an error is bad
//! usage and nothing is sent. A controller error at command N is reported
//! at the file line that holds command N (comments and blank lines are never
//! sent, so N is not the line number).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Args;

use super::GlobalArgs;
use super::check::render;
use super::out;
use super::session::{self, EXIT_LINK, EXIT_USAGE, Linked, Session, StartError};
use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    Activity, ControllerFault, Event, LinkState, MachineState, PerAxis, PositionSource, Refusal,
    Request, UploadEvent,
};
use crate::program::store;
use crate::program::{Language, LintConfig, Program, Severity, lint};
use crate::proto::Protocol;

pub const LONG_ABOUT: &str = "\
Check an isel CNC program or an EMCU job, store it in the controller and, with --start, run
it.

The program is checked for the machine profile first, as `jogterm check` does; with an error
nothing is sent. Comments and blank lines are not sent; every command goes out in its
canonical spelling, one at a time, each answered by the controller before the next. Progress
(commands, lines per second, time left) goes to stderr.

isel: if the controller holds a program already (it answers `@0i` with `G`), --erase erases
it first (`@0k`); without it the upload stops and says so. EMCU: the job goes into the ROM
job store (`@F` … 0x01), which replaces a stored job in any case (--erase changes nothing).

A controller error at command N (isel: its error code; EMCU: 0x03, memory full) is reported
as FILE:LINE for the line that holds command N. An isel controller then holds an invalid
program that has to be erased (upload again with --erase); an EMCU interface has discarded
the job.

With --start the stored program is started (isel `@0S`, EMCU `@J`) and followed until it
ends; the final position is printed. A controller whose ramp or axes jogterm has not set up
yet in this session is initialised first. On axes that are not referenced the program starts
only when its first commands reference them (isel `7`, EMCU `$H`; settings may come before);
otherwise the refusal names the command that references them. Ctrl-C, a hang-up or SIGTERM
stop the machine first. EMP drives store no programs.";

pub const AFTER_LONG_HELP: &str = "\
Progress and messages on a stderr that is closed or hung up are dropped: the upload (and the
run) goes on to its end, and the exit status says how it ended.

Exit status: 0 stored (and run); 1 the controller answered an error or refused for its
state, or interrupted (Ctrl-C, SIGTERM, a hang-up: the machine is stopped first); 2 bad
usage (an error in the program, an unreadable file, an unknown option, an EMP drive); 3 link
failure.

Examples:
  jogterm upload drill.isel --port /dev/ttyUSB0 --protocol isel
  jogterm upload drill.isel --port /tmp/isel --erase --start
  jogterm upload pallet.emcu --port /dev/ttyUSB1 --protocol emcu --start
  jogterm --sim isel upload examples/programs/drill-pattern.isel --start";

/// Options of `jogterm upload`.
#[derive(Debug, Args)]
pub struct UploadArgs {
    /// The program (isel: .isel or .cnc; EMCU: .emcu)
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// isel: erase a program the controller holds already (`@0k`) instead of
    /// stopping. EMCU: `@F` replaces a stored job anyway
    #[arg(long)]
    pub erase: bool,
    /// Start the program once it is stored and wait until it ends
    #[arg(long)]
    pub start: bool,
    /// Baud rate, instead of the profile's (isel and EMCU: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// The file is G-code (also known by its extension: .nc .ngc .gcode .tap .gc): it is
    /// imported as `jogterm import` does and its controller program uploaded
    #[arg(long)]
    pub gcode: bool,
    /// G-code: the active work offset's zero in machine units (`X50 Y50 Z60`), instead of
    /// the console's stored one
    #[arg(long, value_name = "POS")]
    pub work_zero: Option<String>,
    /// G-code: follow a probed surface, every Z shifted by the height map's surface under
    /// it (as `jogterm import --height-map`)
    #[arg(long, value_name = "MAP")]
    pub height_map: Option<PathBuf>,
    /// G-code bigger than the controller's memory: store and run it in parts, each cut
    /// where the tool stands retracted at the job's safe height (needs --start; isel)
    #[arg(long, requires = "start")]
    pub chunked: bool,
    /// G-code: run it as a DNC stream instead of storing it, each command sent when the
    /// one before has ended (isel; every move stops before the next: a stream leaves marks
    /// at the part where stored programs do not)
    #[arg(long, conflicts_with_all = ["chunked", "start", "erase"])]
    pub stream: bool,
}

impl UploadArgs {
    pub fn is_gcode(&self) -> bool {
        self.gcode || crate::gcode::is_gcode_path(&self.file)
    }
}

/// The program as it goes out: the commands and the file line of each.
pub(super) struct Prepared {
    name: String,
    lines: Vec<String>,
    program: Program,
    /// A program converted from G-code: its commands' G-code lines.
    gcode: Option<crate::gcode::output::Program>,
}

impl Prepared {
    fn language(&self) -> Language {
        self.program.language()
    }

    pub(super) fn name(&self) -> &str {
        &self.name
    }

    pub(super) fn program(&self) -> &Program {
        &self.program
    }

    /// Where a converted job stops for the operator, to say before it
    /// starts.
    pub(super) fn pauses(&self) -> Vec<String> {
        self.gcode
            .iter()
            .flat_map(|program| {
                program.pauses.iter().map(|(origin, what)| {
                    format!(
                        "{}:{}:{}: the program pauses here: {what}",
                        self.name, origin.line, origin.col
                    )
                })
            })
            .collect()
    }

    /// The G-code line of its first command (a converted job's part):
    /// where a restart picks the job up again.
    pub(super) fn first_gcode_line(&self) -> Option<u32> {
        self.gcode
            .as_ref()
            .and_then(|g| {
                g.lines
                    .iter()
                    .find(|l| !l.command.is_empty() && l.origin.is_some())
            })
            .and_then(|l| l.origin)
            .map(|o| o.line)
    }

    /// The last G-code line of a converted job (or part): once it has run
    /// to its end, so has the line (`cli::log`).
    pub(super) fn last_gcode_line(&self) -> Option<u32> {
        self.gcode
            .as_ref()
            .and_then(|g| g.lines.iter().rev().find_map(|l| l.origin))
            .map(|o| o.line)
    }

    pub(super) fn place(&self) -> super::run::stream::Place<'_> {
        super::run::stream::Place {
            name: &self.name,
            gcode: self.gcode.as_ref(),
            total: self
                .gcode
                .as_ref()
                .map_or(self.lines.len(), |g| g.lines.len()),
            estimate_s: None,
            log: None,
            ways: None,
        }
    }
}

/// The file, checked as a program of `language`; `Err` is the message for
/// bad usage (printed already when it is a list of diagnostics).
pub(super) fn prepare(
    global: &GlobalArgs,
    file: &Path,
    profile: &crate::config::profile::Profile,
    language: Language,
    config: &LintConfig,
) -> Result<Prepared, String> {
    let name = file.display().to_string();
    if let Some(other) = Language::from_path(file).filter(|l| *l != language) {
        return Err(format!(
            "{name}: an {other} program by its extension, but the controller is {} (it takes {language} programs)",
            language.protocol()
        ));
    }
    let loaded = store::load(file)
        .map_err(|e| e.to_string())?
        .ok_or_else(|| format!("{name}: no such file"))?;
    if loaded.lossy {
        return Err(format!(
            "{name}: bytes that are not UTF-8 (the controller takes ASCII)"
        ));
    }
    if let Some(stale) = super::import::stale_offset(global, profile, &loaded.text) {
        return Err(format!("{name}: {stale}; nothing was sent"));
    }
    checked(name, &loaded.text, language, config, None)
}

/// Program text (of a file, or converted from G-code), checked.
fn checked(
    name: String,
    text: &str,
    language: Language,
    config: &LintConfig,
    gcode: Option<crate::gcode::output::Program>,
) -> Result<Prepared, String> {
    let program = Program::parse(language, text);
    let diagnostics = lint(&program, config);
    let errors: Vec<_> = diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .collect();
    if !errors.is_empty() {
        for d in &errors {
            out::say(render(&name, &program, d));
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
    if let Some(converted) = &gcode {
        made_by_the_converter(&name, &lines, converted, language)?;
    }
    Ok(Prepared {
        name,
        lines,
        program,
        gcode,
    })
}

/// The lines to send of a program converted from G-code are the
/// converter's commands, one for one: the text they were checked in holds
/// no line that came from elsewhere (a name with a line break in it, issue
/// 37). Each command is one line of one command.
fn made_by_the_converter(
    name: &str,
    lines: &[String],
    converted: &crate::gcode::output::Program,
    language: Language,
) -> Result<(), String> {
    let commands = converted.lines.iter().filter(|l| !l.command.is_empty());
    let mut sent = lines.iter();
    for (k, line) in commands.enumerate() {
        let alone = Program::parse(language, &line.command);
        let canonical = match alone.upload_lines() {
            Ok(c) if c.len() == 1 && alone.lines().len() == 1 => c.into_iter().next(),
            _ => None,
        };
        if canonical.is_none() || canonical.as_ref() != sent.next() {
            return Err(format!(
                "{name}: command {} of the converted program is not the converter's `{}`: nothing was sent",
                k + 1,
                line.command.escape_debug()
            ));
        }
    }
    if let Some(extra) = sent.next() {
        return Err(format!(
            "{name}: the converted program holds `{extra}`, which the converter did not make: nothing was sent"
        ));
    }
    Ok(())
}

/// A G-code file imported for the profile, its warnings said; the job to
/// run: the whole file, or its restart from a line.
pub(super) struct Imported {
    pub import: crate::gcode::Import,
    pub restart: Option<crate::gcode::Restart>,
    /// The file as the operator named it, for `FILE:LINE` messages.
    pub name: String,
    /// The header's file name of the converted program.
    pub header: String,
}

/// Import `file` for the profile (the console's work offset, or
/// `work_zero`), and restart it from `from_line` when given; on failure
/// the exit status and what to say (the diagnostics included).
pub(super) fn import_gcode(
    global: &GlobalArgs,
    file: &Path,
    work_zero: Option<&str>,
    height_map: Option<&Path>,
    from_line: Option<u32>,
    profile: &crate::config::profile::Profile,
    command: &str,
) -> Result<Imported, (u8, String)> {
    let target = crate::gcode::Target::of(profile.connection.protocol)
        .map_err(|why| (EXIT_USAGE, format!("jogterm {command}: {why}")))?;
    let dirs = crate::config::ConfigDirs::from_env();
    let name = file.display().to_string();
    let header = crate::gcode::import::header_name(file);
    let mut err = Vec::new();
    let placement = super::import::Placement {
        work_zero,
        height_map,
    };
    let imported =
        super::import::read_and_import(global, &dirs, profile, file, target, placement, &mut err);
    let said = |err: &[u8]| String::from_utf8_lossy(err).trim_end().to_owned();
    let (import, text, offsets) = match imported {
        Ok(i) => i,
        Err(code) => return Err((code, said(&err))),
    };
    let restart = match from_line {
        Some(line) => {
            match crate::gcode::restart(&text, &header, profile, &offsets, &import, line) {
                Ok(r) => Some(r),
                Err(e) => {
                    super::restart::refused(&name, line, &e, &mut err);
                    return Err((1, said(&err)));
                }
            }
        }
        None => None,
    };
    let report = said(&err);
    if !report.is_empty() {
        out::say(&report);
    }
    for w in &import.warnings {
        out::say(crate::gcode::render(&name, w));
    }
    if let Some(m) = &import.height_map {
        out::say(super::import::height_map_text(m).trim());
    }
    if let Some(t) = &import.tool {
        out::say(crate::gcode::waits::tool_text(Some(t)));
    }
    Ok(Imported {
        import,
        restart,
        name,
        header,
    })
}

impl Imported {
    /// The converted job that runs: the restart's, or the whole file's.
    pub(super) fn program(&self) -> &crate::gcode::output::Program {
        self.restart
            .as_ref()
            .map_or(&self.import.program, |r| &r.program)
    }

    /// Its motion time, as estimated.
    pub(super) fn motion_s(&self) -> f64 {
        self.restart
            .as_ref()
            .map_or(self.import.summary.estimated_s, |r| r.estimated_s)
    }

    /// A converted program (the whole job, a part, a restart), checked as
    /// the controller's program.
    pub(super) fn checked(
        &self,
        program: crate::gcode::output::Program,
        language: Language,
        config: &LintConfig,
        command: &str,
    ) -> Result<Prepared, (u8, String)> {
        let text = program.text(&self.header);
        checked(self.name.clone(), &text, language, config, Some(program))
            .map_err(|m| (EXIT_USAGE, format!("jogterm {command}: {m}")))
    }

    /// The job cut into parts that fit, each checked; why it cannot be.
    pub(super) fn in_parts(
        &self,
        language: Language,
        config: &LintConfig,
        profile: &crate::config::profile::Profile,
        command: &str,
    ) -> Result<Vec<Prepared>, (u8, String)> {
        let program = self.program();
        let parts = program
            .parts(program.capacity)
            .map_err(|why| (1, format!("{}: {why}; nothing was sent", self.name)))?;
        say_parts(program, self.motion_s(), &parts, profile);
        (0..parts.len())
            .map(|k| self.checked(program.part(&parts, k), language, config, command))
            .collect()
    }
}

/// A G-code file, imported for the profile and checked as its program;
/// on failure the exit status and what to say (the diagnostics included).
fn prepare_gcode(
    global: &GlobalArgs,
    args: &UploadArgs,
    profile: &crate::config::profile::Profile,
    language: Language,
    config: &LintConfig,
) -> Result<Vec<Prepared>, (u8, String)> {
    let imported = import_gcode(
        global,
        &args.file,
        args.work_zero.as_deref(),
        args.height_map.as_deref(),
        None,
        profile,
        "upload",
    )?;
    let program = &imported.import.program;
    if args.stream && language == Language::Isel {
        let config = super::run::streamed(config);
        return Ok(vec![imported.checked(
            program.clone(),
            language,
            &config,
            "upload",
        )?]);
    }
    if program.fits() {
        return Ok(vec![imported.checked(
            program.clone(),
            language,
            config,
            "upload",
        )?]);
    }
    if !args.chunked || language != Language::Isel {
        // The ways `jogterm run` lists: parts only where the job can be cut.
        let ways = crate::gcode::ways::Ways::of(
            program,
            imported.motion_s(),
            &crate::gcode::ways::Costs::of(profile, language),
        );
        let how = ways.advice();
        return Err((
            1,
            format!(
                "{}: the converted program has {} commands and the controller stores {}: nothing was sent ({how})",
                imported.name, program.commands, program.capacity
            ),
        ));
    }
    imported.in_parts(language, config, profile, "upload")
}

/// What running in parts costs, before it starts (`gcode::ways`): motion
/// from the estimate; the erases (`@0k`, about 2 s, manual 2.2.17) and the
/// uploads of the parts after the first, while the tool stands retracted.
fn say_parts(
    program: &crate::gcode::output::Program,
    motion_s: f64,
    parts: &[crate::gcode::output::Part],
    profile: &crate::config::profile::Profile,
) {
    out::say(format_args!(
        "{} commands, the controller stores {}: storing and running it in {} parts, each cut where the tool stands retracted at the job's safe height",
        program.commands,
        program.capacity,
        parts.len()
    ));
    let language = Language::of_protocol(profile.connection.protocol).unwrap_or(Language::Isel);
    let costs = crate::gcode::ways::Costs::of(profile, language);
    let ways = crate::gcode::ways::Ways::of(program, motion_s, &costs);
    if let Ok(chunked) = ways.chunked {
        out::say(format_args!(
            "estimated: {} in all, motion {}; the tool waits {} retracted while parts are erased and stored at {:.0} baud, never in the part",
            crate::gcode::ways::duration(chunked.total_s),
            crate::gcode::ways::duration(chunked.motion_s),
            crate::gcode::ways::duration(chunked.retracted_s),
            costs.baud
        ));
    }
}

/// The profile of `jogterm <command>` (which stores or runs programs) and
/// its program language; else how the command ends, said already.
pub(super) fn program_profile(
    global: &GlobalArgs,
    baud: Option<u32>,
    command: &str,
) -> Result<(crate::config::profile::Profile, Language), anyhow::Result<ExitCode>> {
    let usage = |m: String| {
        out::say(format_args!("jogterm {command}: {m}"));
        Err(Ok(ExitCode::from(EXIT_USAGE)))
    };
    let profile = match session::resolve(global, baud) {
        Ok(p) => p,
        Err(StartError::Usage(m)) => return usage(m),
        Err(StartError::Failed(e)) => return Err(Err(e)),
    };
    match Language::of_protocol(profile.connection.protocol) {
        Some(language) => Ok((profile, language)),
        None => usage(format!(
            "{} drives store no programs: jogterm {command} takes isel CNC programs and EMCU jobs",
            profile.connection.protocol
        )),
    }
}

pub fn run(global: &GlobalArgs, args: &UploadArgs) -> anyhow::Result<ExitCode> {
    let usage = |m: String| {
        out::say(format_args!("jogterm upload: {m}"));
        Ok(ExitCode::from(EXIT_USAGE))
    };
    let (profile, language) = match program_profile(global, args.baud, "upload") {
        Ok(p) => p,
        Err(exit) => return exit,
    };
    let config = LintConfig::from_profile(&profile);
    let prepared = if args.is_gcode() {
        // G-code that does not import is the file's fault, exit 1 as for
        // `jogterm import`; an unreadable file is 2.
        match prepare_gcode(global, args, &profile, language, &config) {
            Ok(p) => p,
            Err((code, m)) => {
                out::say(m);
                return Ok(ExitCode::from(code));
            }
        }
    } else if args.chunked || args.stream {
        return usage(
            "--chunked and --stream run G-code; a controller program is stored whole".into(),
        );
    } else if args.work_zero.is_some() || args.height_map.is_some() {
        // A controller program's coordinates are the controller's own: an
        // offset or a surface accepted here would be one the job never sees.
        let option = if args.work_zero.is_some() {
            "--work-zero places"
        } else {
            "--height-map shifts"
        };
        return usage(format!(
            "{option} G-code; a controller program runs in the controller's own coordinates \
             and is stored as it is"
        ));
    } else {
        match prepare(global, &args.file, &profile, language, &config) {
            Ok(p) => vec![p],
            Err(m) => return usage(m),
        }
    };
    let remedy = Remedy::of(&profile);
    session::moving(global, profile, "upload", async |session| {
        upload_and_run(session, &prepared, args, &remedy).await
    })
}

async fn upload_and_run(
    mut session: Session,
    prepared: &[Prepared],
    args: &UploadArgs,
    remedy: &Remedy,
) -> ExitCode {
    let stopper = session.handle.clone();
    let code = tokio::select! {
        code = steps(&mut session, prepared, args, remedy) => code,
        () = session::interrupted() => {
            let _ = stopper.stop().written().await;
            session::say_interrupted("upload", session::Moves::Yes);
            1
        }
    };
    if args.start || args.stream {
        let outputs = job_outputs(prepared);
        if let Some(ended) = super::run::outputs::ended_by(code) {
            super::run::outputs::after_end(&mut session, &outputs, ended, "upload", remedy).await;
        }
    }
    session.close().await;
    ExitCode::from(code)
}

/// The outputs the job's parts switch on, each once.
pub(super) fn job_outputs(parts: &[Prepared]) -> Vec<crate::program::outputs::JobOutput> {
    let mut all: Vec<crate::program::outputs::JobOutput> = Vec::new();
    for part in parts {
        for o in crate::program::outputs::switched_on(&part.program) {
            if !all.iter().any(|a| a.id == o.id) {
                all.push(o);
            }
        }
    }
    all
}

/// How a step ended when it did not succeed: the exit status, said already.
pub(super) type Status = Result<(), u8>;

/// Each part stored and (with --start) run in turn: one part unless a
/// G-code job runs `--chunked`, when every part but the last ends with the
/// tool retracted at the safe height, so that it stands clear of the part
/// while the next is erased and stored.
async fn steps(
    session: &mut Session,
    prepared: &[Prepared],
    args: &UploadArgs,
    remedy: &Remedy,
) -> u8 {
    let result = async {
        if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
            out::say(format_args!("jogterm upload: link failure: {reason}"));
            return Err(EXIT_LINK);
        }
        if args.stream {
            let part = prepared.first().ok_or(EXIT_USAGE)?;
            return stream(session, part, remedy).await;
        }
        for (k, part) in prepared.iter().enumerate() {
            if prepared.len() > 1 {
                out::say(format_args!("part {}/{}", k + 1, prepared.len()));
            }
            // A part after the first replaces the one that just ran.
            upload(session, part, args.erase || k > 0, remedy).await?;
            if args.start {
                for pause in part.pauses() {
                    out::say(pause);
                }
                start(session, remedy).await?;
            }
        }
        Ok(())
    }
    .await;
    match result {
        Ok(()) => 0,
        Err(code) => code,
    }
}

/// How the operator references axes from the command line: the refusal of
/// a start on axes not referenced names this, not the console's key.
pub(super) struct Remedy {
    /// `jogterm send --port P --protocol F`, or `jogterm --sim F send`.
    pub(super) send: String,
    protocol: Protocol,
    pub(super) isel_device: u8,
    /// The machine's axes: also what a G-code stream's DNC moves carry.
    pub(super) axes: AxisSet,
    /// The command whose messages these are (`jogterm <command>: …`).
    pub(super) command: &'static str,
}

impl Remedy {
    pub(super) fn of(profile: &crate::config::Profile) -> Remedy {
        Remedy::of_command(profile, "upload")
    }

    /// The same for another command that sets up a controller this way
    /// (`run`, `probe`).
    pub(super) fn of_command(profile: &crate::config::Profile, command: &'static str) -> Remedy {
        let protocol = profile.connection.protocol;
        let send = if profile.connection.is_simulator() {
            format!("jogterm --sim {protocol} send")
        } else {
            format!(
                "jogterm send --port {} --protocol {protocol}",
                profile.connection.port
            )
        };
        Remedy {
            send,
            protocol,
            isel_device: profile.isel.device,
            axes: profile.axis_set(),
            command,
        }
    }

    /// The command line that references `axes` (isel: `@0R<mask>`, A on its
    /// own, manual 2.2.22; EMCU: `$H` Z, Y, X first, run at once).
    pub(super) fn reference(&self, axes: AxisSet) -> String {
        match self.protocol {
            Protocol::Emcu => {
                let order: String = [Axis::Z, Axis::Y, Axis::X]
                    .into_iter()
                    .filter(|a| axes.contains(*a))
                    .map(|a| a.to_string())
                    .collect();
                format!("{} '$H{order}\\x01'", self.send)
            }
            Protocol::Isel | Protocol::Emp => {
                let d = self.isel_device;
                let linear = axes.mask() & 0b0111;
                let mut lines = Vec::new();
                if linear != 0 {
                    lines.push(format!("@{d}R{linear}"));
                }
                if axes.contains(Axis::A) {
                    lines.push(format!("@{d}R8"));
                }
                format!("{} {}", self.send, lines.join(" "))
            }
        }
    }
}

/// The job as a DNC stream (`run::stream`), without the operator's keys:
/// `jogterm run` has them. The controller is set up first, as a stored run
/// finds it (axes, ramps).
async fn stream(session: &mut Session, prepared: &Prepared, remedy: &Remedy) -> Status {
    initialise(session, remedy).await?;
    let commands = prepared
        .gcode
        .as_ref()
        .map_or(prepared.lines.len(), |g| g.commands);
    out::say(format_args!(
        "streaming {commands} commands (Ctrl-C stops the machine)"
    ));
    super::run::stream::run(
        session,
        &prepared.program,
        &prepared.place(),
        (remedy.isel_device, remedy.axes),
        super::run::stream::FACTOR_MAX,
        &mut super::run::keys::Keys::none(),
    )
    .await
}

/// The exit status for a refusal, said on stderr.
pub(super) fn refused(what: &str, reason: &Refusal, remedy: &Remedy) -> u8 {
    refused_in(remedy.command, what, reason, remedy)
}

/// [`refused`], said as `jogterm <command>: …`.
pub(super) fn refused_in(command: &str, what: &str, reason: &Refusal, remedy: &Remedy) -> u8 {
    match reason {
        // `(h)` is the console's key: the command line names its own way.
        Refusal::NotReferenced { axes } => out::say(format_args!(
            "jogterm {command}: {what} refused: axes {axes} not referenced: reference them \
             first ({})",
            remedy.reference(*axes)
        )),
        _ => out::say(format_args!("jogterm {command}: {what} refused: {reason}")),
    }
    match reason {
        Refusal::Invalid { .. } => EXIT_USAGE,
        Refusal::NotConnected => EXIT_LINK,
        _ => 1,
    }
}

fn lost(reason: &str) -> u8 {
    out::say(format_args!("jogterm upload: link failure: {reason}"));
    EXIT_LINK
}

async fn next(session: &mut Session) -> Result<Event, u8> {
    // Through `next_event`: the session's activity stays current, which
    // the job's outputs wait on after a stop (`run::outputs`).
    session
        .next_event()
        .await
        .ok_or_else(|| lost("the device task ended"))
}

pub(super) async fn upload(
    session: &mut Session,
    prepared: &Prepared,
    erase: bool,
    remedy: &Remedy,
) -> Status {
    let mut initialised = false;
    let mut progress = Progress::new(prepared.lines.len());
    // The activity the device task last reported: the upload may go on
    // after its last line (EMCU reads `@X`), and a start before then would
    // be refused as busy.
    let mut activity = Activity::Idle;
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
                // A controller the driver says is not initialised (isel: its
                // axes, `@0<n>`) is initialised once, then the upload retried.
                Event::Refused {
                    reason: Refusal::NotInitialised,
                    ..
                } if !initialised => {
                    initialised = true;
                    initialise(session, remedy).await?;
                    break;
                }
                Event::Refused { reason, .. } => {
                    return Err(refused("the upload", &reason, remedy));
                }
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
                        out::say(format_args!(
                            "{}: {total} commands stored in {secs:.1} s ({:.1} lines/s)",
                            prepared.name,
                            if secs > 0.0 { total as f64 / secs } else { 0.0 }
                        ));
                        if activity != Activity::Idle {
                            idle(session).await?;
                        }
                        return Ok(());
                    }
                    UploadEvent::Failed { line, fault } => {
                        progress.end();
                        out::say(failure(prepared, line, &fault));
                        return Err(1);
                    }
                    UploadEvent::Aborted {
                        done,
                        reason,
                        link_lost,
                    } => {
                        progress.end();
                        out::say(format_args!(
                            "jogterm upload: the upload stopped after {done} commands: {reason}"
                        ));
                        // A lost link is a link failure (exit 3), whatever
                        // the upload was doing when it went.
                        return Err(if link_lost { EXIT_LINK } else { 1 });
                    }
                },
                Event::Link(LinkState::Lost { reason }) => {
                    progress.end();
                    return Err(lost(&reason));
                }
                Event::State(s) => activity = s.activity,
                _ => {}
            }
        }
    }
}

/// Wait until the device task reports the machine idle.
async fn idle(session: &mut Session) -> Status {
    loop {
        match next(session).await? {
            Event::State(s) if s.activity == Activity::Idle => return Ok(()),
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
}

/// `FILE:LINE: the controller refused command N `…`: code meaning; what
/// it holds now`.
fn failure(prepared: &Prepared, index: usize, fault: &ControllerFault) -> String {
    let place = match (&prepared.gcode, prepared.program.line_of(index)) {
        // Converted from G-code: the G-code line, never a line of the
        // converted text, which is no file the operator has.
        (Some(gcode), _) => match gcode.origin_of_command(index) {
            Some(o) => format!("{}:{}:{}", prepared.name, o.line, o.col),
            None => format!(
                "{} (a command the conversion adds, from no G-code line)",
                prepared.name
            ),
        },
        (None, Some(line)) => format!("{}:{}", prepared.name, line + 1),
        // The `9` the driver appends to a program that lacks one.
        (None, None) => match prepared.language() {
            Language::Isel => format!("{} (the closing 9)", prepared.name),
            Language::Emcu => format!("{} (after its last command)", prepared.name),
        },
    };
    let full = match prepared.language() {
        Language::Isel => {
            fault.code == crate::proto::isel::ReplyCode::MemoryFull.char().to_string()
        }
        Language::Emcu => fault.code == crate::device::emcu::MEMORY_FULL_CODE,
    };
    // Memory full: the same upload fails the same way, with or without
    // --erase (issue 37); what fits is a shorter program, or the job run
    // in parts or streamed once the profile says how much the controller
    // holds.
    let advice = if full {
        let how = if prepared.gcode.is_some() {
            format!(
                "set the profile's `[gcode] memory = {index}` (what this controller holds), \
                 and `jogterm run FILE` runs the job in parts or streamed"
            )
        } else {
            format!(
                "shorten it or split it into programs of at most {index} commands, or stream \
                 it (`jogterm run FILE --stream`); `[gcode] memory = {index}` in the profile \
                 lets `jogterm check` say so before an upload"
            )
        };
        format!(
            "the program does not fit: the controller stored {index} of its {} commands, and \
             uploading it again fails the same way: {how}; ",
            prepared.lines.len()
        )
    } else {
        String::new()
    };
    let after = match prepared.language() {
        Language::Isel if full => "the partial program it holds is invalid (the next upload \
             of a program that fits erases it: --erase)"
            .to_string(),
        Language::Isel => {
            "the partial program it holds is invalid (upload again with --erase)".to_string()
        }
        // The driver ends the transfer with a bare 0x01, which discards the
        // job (`docs/protocols.md`, EMCU).
        Language::Emcu => format!(
            "the interface discarded the job, nothing is stored (the job has {} commands, \
             the controller took {index})",
            prepared.lines.len()
        ),
    };
    format!(
        "{place}: the controller refused command {} `{}`: {} {}; {advice}{after}",
        index + 1,
        fault.command,
        fault.code,
        fault.meaning,
    )
}

/// `Initialise`, and wait until the controller has its axes.
pub(super) async fn initialise(session: &mut Session, remedy: &Remedy) -> Status {
    initialise_reading(session, remedy).await.map(drop)
}

/// What [`initialise_reading`] saw: the state that said the controller has
/// its axes, and the last position measured on the way (`None`: none was).
pub(super) struct Initialised {
    pub(super) state: MachineState,
    pub(super) measured: Option<PerAxis<i64>>,
}

/// [`initialise`], keeping the state and the measured positions seen on the
/// way. Once only in a session: an `Initialise` that changes nothing (the
/// controller has its axes already) sends no state, and this would wait
/// for one for ever.
pub(super) async fn initialise_reading(
    session: &mut Session,
    remedy: &Remedy,
) -> Result<Initialised, u8> {
    if session.handle.request(Request::Initialise).is_err() {
        return Err(lost("the device task ended"));
    }
    let mut measured = None;
    loop {
        match next(session).await? {
            Event::State(s) if !s.initialised.is_empty() && s.activity == Activity::Idle => {
                return Ok(Initialised { state: s, measured });
            }
            Event::Position(p) if p.source == PositionSource::Measured => {
                measured = Some(p.steps);
            }
            Event::Refused { reason, .. } => return Err(refused("initialising", &reason, remedy)),
            Event::Fault(f) => {
                out::say(format_args!(
                    "jogterm {}: initialising failed: `{}` answered {}: {}",
                    remedy.command, f.command, f.code, f.meaning
                ));
                return Err(1);
            }
            Event::Link(LinkState::Lost { reason }) => {
                out::say(format_args!(
                    "jogterm {}: link failure: {reason}",
                    remedy.command
                ));
                return Err(EXIT_LINK);
            }
            _ => {}
        }
    }
}

/// How long the set-up's last state and position may take to arrive after
/// the state that says the axes are set ([`initialise_settled`]).
const SETTLE: Duration = Duration::from_millis(500);

/// [`initialise_reading`], then whatever state and measured position
/// follow within a moment: the state that says the axes are set can come
/// before the reference probe and the position read that end the set-up.
/// The axes stand throughout (the session stopped them at connect), so an
/// earlier measured position is where they still are.
pub(super) async fn initialise_settled(
    session: &mut Session,
    remedy: &Remedy,
) -> Result<Initialised, u8> {
    let mut set = initialise_reading(session, remedy).await?;
    let settle = tokio::time::Instant::now() + SETTLE;
    loop {
        match tokio::time::timeout_at(settle, session.next_event()).await {
            Ok(Some(Event::Position(p))) if p.source == PositionSource::Measured => {
                set.measured = Some(p.steps);
                return Ok(set);
            }
            Ok(Some(Event::State(s))) => set.state = s,
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => {
                out::say(format_args!(
                    "jogterm {}: link failure: {reason}",
                    remedy.command
                ));
                return Err(EXIT_LINK);
            }
            Ok(Some(_)) => {}
            Ok(None) => {
                out::say(format_args!(
                    "jogterm {}: link failure: the device task ended",
                    remedy.command
                ));
                return Err(EXIT_LINK);
            }
            Err(_) => return Ok(set),
        }
    }
}

/// `RunProgram`, followed until the machine is idle again.
pub(super) async fn start(session: &mut Session, remedy: &Remedy) -> Status {
    let mut initialised = false;
    let mut running = false;
    let mut fault: Option<ControllerFault> = None;
    let mut position: Option<PerAxis<i64>> = None;
    'request: loop {
        if session.handle.request(Request::RunProgram).is_err() {
            return Err(lost("the device task ended"));
        }
        loop {
            match next(session).await? {
                // A session that has not set the controller up (EMCU: `#S`
                // and `#R` cannot be read back, `docs/protocols.md`)
                // initialises it once, then starts again.
                Event::Refused {
                    reason: Refusal::NotInitialised,
                    ..
                } if !initialised && !running => {
                    initialised = true;
                    initialise(session, remedy).await?;
                    continue 'request;
                }
                Event::State(s) if s.activity == Activity::RunningProgram => {
                    if !running {
                        out::say("running the program (Ctrl-C stops the machine)");
                    }
                    running = true;
                }
                Event::State(s) if running && s.activity == Activity::Idle => break 'request,
                Event::Position(p) => position = Some(p.steps),
                Event::Fault(f) => fault = Some(f),
                Event::Refused { reason, .. } => {
                    return Err(refused("starting the program", &reason, remedy));
                }
                Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
                _ => {}
            }
        }
    }
    // The position read at the end comes with or just after the idle state:
    // it is awaited (300 ms at most), not the whole time, which a job in
    // parts would spend standing before each next part.
    let settle = tokio::time::Instant::now() + Duration::from_millis(300);
    let mut read_at_end = false;
    while !read_at_end
        && let Ok(Some(event)) = tokio::time::timeout_at(settle, session.next_event()).await
    {
        match event {
            Event::Position(p) => {
                position = Some(p.steps);
                read_at_end = true;
            }
            Event::Fault(f) => fault = Some(f),
            // Idle because the link went, not because the program ended.
            Event::Link(LinkState::Lost { reason }) => return Err(lost(&reason)),
            _ => {}
        }
    }
    if let Some(f) = fault {
        out::say(format_args!(
            "jogterm upload: the program ended with `{}`: {}",
            f.code, f.meaning
        ));
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
    out::say(format_args!("the program ended; position (steps): {at}"));
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
        // A closed stderr never aborts the upload: the lines keep going out
        // and the exit status says how it ended.
        if self.terminal {
            out::say_raw(format_args!("\r\x1b[2K{text}"));
        } else {
            out::say(text);
        }
        self.shown = true;
    }

    fn end(&mut self) {
        if self.terminal && self.shown {
            out::say("");
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
    fn the_remedy_for_axes_not_referenced_is_a_command_line() {
        let remedy = |protocol, port: &str| Remedy {
            send: format!("jogterm send --port {port} --protocol {protocol}"),
            protocol,
            isel_device: 0,
            axes: AxisSet::XYZ,
            command: "upload",
        };
        let isel = remedy(Protocol::Isel, "/tmp/isel");
        assert_eq!(
            isel.reference(AxisSet::XYZ),
            "jogterm send --port /tmp/isel --protocol isel @0R7"
        );
        assert_eq!(
            isel.reference(AxisSet::from_mask(0b1010)),
            "jogterm send --port /tmp/isel --protocol isel @0R2 @0R8"
        );
        assert_eq!(
            remedy(Protocol::Emcu, "/tmp/emcu").reference(AxisSet::XYZ),
            "jogterm send --port /tmp/emcu --protocol emcu '$HZYX\\x01'"
        );
    }

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
            gcode: None,
        };
        let fault = ControllerFault {
            command: "m8000,8000".into(),
            code: "3".into(),
            meaning: "invalid number".into(),
            recovery: crate::device::api::Recovery::None,
        };
        let said = failure(&prepared, 1, &fault);
        assert!(said.starts_with("p.isel:5: the controller refused command 2 `m8000,8000`"));
        assert!(said.ends_with("(upload again with --erase)"), "{said}");
        assert!(failure(&prepared, 7, &fault).starts_with("p.isel (the closing 9)"));
    }

    #[test]
    fn a_failure_of_a_converted_program_names_the_gcode_line_or_none() {
        use crate::gcode::Origin;
        let mut gcode = crate::gcode::output::Program::default();
        gcode.comment("jogterm-gcode file=part.nc");
        gcode.command("77", None);
        gcode.command("m8000,8000", Some(Origin { line: 57, col: 3 }));
        gcode.command("9", Some(Origin { line: 60, col: 1 }));
        let text = gcode.text("part.nc");
        let program = Program::parse(Language::Isel, &text);
        let prepared = Prepared {
            name: "part.nc".into(),
            lines: program.upload_lines().expect("lines"),
            program,
            gcode: Some(gcode),
        };
        let fault = ControllerFault {
            command: "m8000,8000".into(),
            code: "3".into(),
            meaning: "invalid number".into(),
            recovery: crate::device::api::Recovery::None,
        };
        let said = failure(&prepared, 1, &fault);
        assert!(
            said.starts_with("part.nc:57:3: the controller refused command 2"),
            "{said}"
        );
        // The reference run the conversion puts first has no G-code line:
        // not a line of the converted text either.
        let said = failure(&prepared, 0, &fault);
        assert!(
            said.starts_with("part.nc (a command the conversion adds, from no G-code line)"),
            "{said}"
        );
    }

    #[test]
    fn an_emcu_failure_names_the_line_and_says_the_job_is_gone() {
        let text = "; pallet\n$HZYX\n\nL1,X100\nL1,X200\n";
        let program = Program::parse(Language::Emcu, text);
        let prepared = Prepared {
            name: "p.emcu".into(),
            lines: program.upload_lines().expect("lines"),
            program,
            gcode: None,
        };
        let fault = ControllerFault {
            command: "L1,X200".into(),
            code: "0x03".into(),
            meaning: "memory full".into(),
            recovery: crate::device::api::Recovery::None,
        };
        let said = failure(&prepared, 2, &fault);
        assert!(
            said.starts_with(
                "p.emcu:5: the controller refused command 3 `L1,X200`: 0x03 memory full"
            ),
            "{said}"
        );
        assert!(said.contains("discarded the job"), "{said}");
        assert!(
            said.contains("(the job has 3 commands, the controller took 2)"),
            "{said}"
        );
    }
}
