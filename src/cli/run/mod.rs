//! `jogterm run FILE`: run a job on the machine from start to end, the way
//! that costs least at the part (issue 27, `docs/gcode.md` "Jobs bigger
//! than the memory"): stored and started when it fits the controller's
//! memory, else in parts cut where the tool stands retracted, or as a DNC
//! stream. The estimate of every way is said before the start, and the
//! operator confirms it; during the run the keys of [`keys`] pause, resume,
//! change the speed of a stream and stop.

pub mod keys;
pub(super) mod outputs;
pub mod retract;
pub mod sim_start;
pub mod stream;
mod waits;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;

use super::GlobalArgs;
use super::out;
use super::session::{self, EXIT_LINK, EXIT_USAGE, Linked, Session};
use super::upload::{self, Prepared, Remedy, Status};
use crate::gcode::ways::{Costs, Way, Ways};
use crate::program::{Language, LintConfig};
use keys::{Key, Keys};

pub const LONG_ABOUT: &str = "\
Run a job: G-code from CAM (imported as `jogterm import` does) or a controller program.

A job that fits the controller's memory is stored and started. A G-code job that does not is
run one of two ways, chosen before the start and shown with the estimate of each:

  chunked  cut into parts that fit, each cut only where the tool stands retracted at the
           job's safe height; each part is stored, run and replaced in turn (isel: the erase
           takes about 2 s). The tool waits above the part, never in it.
  stream   every command sent as a DNC command when the one before has ended. The
           controllers buffer no motion: the axes stop between every two commands, in the
           material, for at least the command's wire time.

jogterm takes the way that leaves the tool standing least in the part, then the faster one;
--stream or --chunked choose yourself. The estimates are floors: motion at the programmed
feeds without ramps, the wire at the line's baud rate.

Before the start jogterm asks for a confirmation on the terminal (--yes skips it; without a
terminal --yes is needed). While it runs, from the terminal:

  Space, s, q   stop the machine (the full stop; nothing resumes)
  p             pause: a stream halts its move without losing steps (isel 0xFD, resumed with
                @0S; EMCU @B, the rest sent again); a job in parts pauses before its next
                part, with the tool retracted
  r, Enter      resume after a pause
  + and -       the speed of the moves not yet sent, 10 % to 100 % of the program's (streams)

--from-line N restarts a G-code job at line N, after a broken tool or a power cut: the
confirmation lists the modal state the skipped lines leave (units, plane, offset, feed, spindle,
coolant) and the entry, which runs first: retract Z alone to the job's safe height from wherever
the tool stands (jogterm reads where, before the program; with Z not referenced only the
program's reference run can take it out, and without one nothing starts), the program's
reference run when the profile has one, go above the line's start, switch the spindle and
outputs as the skipped lines left them, descend at the file's last plunge feed (else
gcode.plunge_feed); then
the job from line N on, by the way chosen for what is left (`jogterm import --from-line N`
shows the same without moving anything).

Every run is written to the job log (`jogterm log`). After a run of the same file (same
content) that broke off (killed, crashed, the power went, a fault, a lost line), the next run
offers to restart from the last line that ran to its end, as --from-line would: on a terminal
it asks; --resume takes the offer, --from-start runs the whole job, and --yes alone chooses
neither: it refuses, nothing sent, and names both commands.

Ctrl-C, SIGTERM and a hang-up stop the machine, as a lost link or a controller error ends the
run; nothing resumes after a reconnect.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 the job ran to its end; 1 stopped, refused, a controller error, or not
confirmed; 2 bad usage (an unreadable file, a program with errors, no terminal to confirm on
without --yes); 3 link failure.

Examples:
  jogterm run part.nc --port /dev/ttyUSB0 --protocol isel
  jogterm run part.nc --port /dev/ttyUSB0 --protocol isel --stream --speed 80
  jogterm run part.nc --port /dev/ttyUSB0 --protocol isel --from-line 1200
  jogterm --sim isel run examples/gcode/fusion-grbl.nc --work-zero \"X50 Y50 Z60\" --yes";

/// Options of `jogterm run`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// The job: G-code (.nc .ngc .gcode .tap .gc, or --gcode), an isel program (.isel .cnc)
    /// or an EMCU job (.emcu)
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Run it as a DNC stream, even when it would fit or could run in parts
    #[arg(long, conflicts_with = "chunked")]
    pub stream: bool,
    /// Store and run it in parts cut where the tool stands retracted (G-code, isel)
    #[arg(long)]
    pub chunked: bool,
    /// The speed of a stream's moves, in percent of the program's (10 to 100)
    #[arg(long, value_name = "PERCENT", default_value_t = 100,
          value_parser = clap::value_parser!(u32).range(10..=100))]
    pub speed: u32,
    /// Start without asking
    #[arg(long, short = 'y')]
    pub yes: bool,
    /// isel: erase a program the controller holds already (`@0k`) before storing
    #[arg(long)]
    pub erase: bool,
    /// The file is G-code whatever its extension
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
    /// Baud rate, instead of the profile's
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// G-code: restart from this line (after a broken tool, a power cut): retract Z alone
    /// to the safe height, go above the line's start, apply the skipped lines' modal state,
    /// descend at the plunge feed, then run from the line on
    #[arg(long, value_name = "LINE")]
    pub from_line: Option<u32>,
    /// G-code: restart from the last line the job log has of this file's last run, which broke
    /// off (a crash, a fault, a lost line), as --from-line would
    #[arg(long, conflicts_with_all = ["from_line", "from_start"])]
    pub resume: bool,
    /// G-code: run the whole job even though its last run broke off (with --yes, which alone
    /// does not choose)
    #[arg(long, conflicts_with = "from_line")]
    pub from_start: bool,
    /// On the built-in simulator: press its start key (what M0, M1 and tool changes wait
    /// for) every SECONDS while the job runs, or once per line on stdin (`stdin`)
    #[arg(long, value_name = "SECONDS|stdin", value_parser = sim_start::parse)]
    pub sim_start_key: Option<sim_start::SimStart>,
    /// Print each wait (tool change, pause), what ends it and each tool measured as a JSON
    /// line on stdout
    #[arg(long)]
    pub json: bool,
}

/// What runs: the prepared program(s) and the way.
struct Job {
    parts: Vec<Prepared>,
    way: Way,
    /// The way's estimate, for the time left early in a stream.
    estimate_s: Option<f64>,
    /// The ways of a G-code job: the model of the live ETA.
    ways: Option<Ways>,
    /// A restart's first step, before the program: Z up alone.
    retract: Option<retract::Retract>,
    /// G-code: the work offset and its zero, for the job log.
    offset: String,
    /// Tool changes and pauses, run host-driven between the job's pieces.
    waits: Option<waits::Waited>,
}

pub fn run(global: &GlobalArgs, args: &RunArgs) -> anyhow::Result<ExitCode> {
    let usage = |m: String| {
        out::say(format_args!("jogterm run: {m}"));
        Ok(ExitCode::from(EXIT_USAGE))
    };
    let (profile, language) = match upload::program_profile(global, args.baud, "run") {
        Ok(p) => p,
        Err(exit) => return exit,
    };
    let config = LintConfig::from_profile(&profile);
    let is_gcode = args.gcode || crate::gcode::is_gcode_path(&args.file);
    // The job log: the offer to resume a run that broke off (G-code only).
    let hash = super::log::hash_of(&args.file);
    let resumed;
    let mut expected_offset = None;
    let args = match is_gcode.then(|| super::resume::decide(args, hash.as_deref())) {
        Some(super::resume::Decision::Refused(code)) => return Ok(ExitCode::from(code)),
        Some(super::resume::Decision::Resume { line, offset }) => {
            expected_offset = Some(offset);
            resumed = RunArgs {
                from_line: Some(line),
                ..args.clone()
            };
            &resumed
        }
        _ => args,
    };
    let job = if is_gcode {
        match gcode_job(global, args, &profile, language, &config) {
            Ok(job) => job,
            Err((code, m)) => {
                if !m.is_empty() {
                    out::say(m);
                }
                return Ok(ExitCode::from(code));
            }
        }
    } else if args.from_line.is_some() {
        return usage(
            "--from-line restarts G-code, whose lines it knows; a controller program runs whole"
                .into(),
        );
    } else if args.height_map.is_some() {
        // A map followed only where jogterm makes the moves.
        return usage(
            "--height-map shifts G-code onto a surface; a controller program runs in the \
             controller's own coordinates as it is"
                .into(),
        );
    } else if args.chunked {
        return usage(
            "--chunked runs G-code, cut where its tool stands retracted; a controller program \
             is stored whole or streamed"
                .into(),
        );
    } else {
        let config = if args.stream {
            streamed(&config)
        } else {
            config
        };
        match upload::prepare(global, &args.file, &profile, language, &config) {
            Ok(p) => Job {
                parts: vec![p],
                way: if args.stream {
                    Way::Stream
                } else {
                    Way::Stored
                },
                estimate_s: None,
                ways: None,
                retract: None,
                offset: String::new(),
                waits: None,
            },
            Err(m) => return usage(m),
        }
    };
    if let Some(Err(m)) = expected_offset.map(|e| super::resume::same_offset(&e, &job.offset)) {
        out::say(m);
        return Ok(ExitCode::from(1));
    }
    match &job.waits {
        Some(w) => w.said_before().iter().for_each(out::say),
        None => job
            .parts
            .iter()
            .flat_map(Prepared::pauses)
            .for_each(out::say),
    }
    if !args.yes {
        match confirmed(job.way) {
            Ok(true) => {}
            Ok(false) => {
                out::say("jogterm run: not started; nothing was sent");
                return Ok(ExitCode::from(1));
            }
            Err(m) => return usage(m),
        }
    }
    let presses = match sim_start_key(args, &profile) {
        Ok(p) => p,
        Err(m) => return usage(m),
    };
    let remedy = Remedy::of_command(&profile, "run");
    let info = super::log::RunInfo {
        file: &args.file,
        hash: hash.unwrap_or_default(),
        profile: &profile,
        offset: job.offset.clone(),
        way: job.way,
        estimate_s: job.estimate_s,
        from_line: args.from_line,
    };
    let logged = super::log::Logged::begin(&info);
    session::moving(global, profile, "run", async |session| {
        run_job(session, &job, args, &remedy, logged, presses).await
    })
}

/// `--sim-start-key`, checked: on the built-in simulator only, with a start
/// key it can press, `stdin` only from a pipe (a terminal's keys are the
/// run's).
fn sim_start_key(
    args: &RunArgs,
    profile: &crate::config::profile::Profile,
) -> Result<Option<(sim_start::SimStart, crate::sim::start_key::StartKey)>, String> {
    let Some(when) = args.sim_start_key else {
        return Ok(None);
    };
    if !profile.connection.is_simulator() {
        return Err("--sim-start-key presses the built-in simulator's start key: use --sim".into());
    }
    if when == sim_start::SimStart::Stdin && std::io::stdin().is_terminal() {
        return Err(
            "--sim-start-key stdin reads lines from a pipe; on a terminal give seconds".into(),
        );
    }
    let key = crate::sim::start_key::StartKey::of(profile)
        .map_err(|why| format!("--sim-start-key: {why}"))?;
    Ok(Some((when, key)))
}

/// The G-code job imported, its ways estimated and said, the way taken.
fn gcode_job(
    global: &GlobalArgs,
    args: &RunArgs,
    profile: &crate::config::profile::Profile,
    language: Language,
    config: &LintConfig,
) -> Result<Job, (u8, String)> {
    let imported = upload::import_gcode(
        global,
        &args.file,
        args.work_zero.as_deref(),
        args.height_map.as_deref(),
        args.from_line,
        profile,
        "run",
    )?;
    if let Some(r) = &imported.restart {
        out::say_raw(super::restart::text(
            &imported.name,
            profile,
            &imported.import,
            r,
            None,
            true,
        ));
    }
    let program = imported.program();
    let ways = Ways::of(program, imported.motion_s(), &Costs::of(profile, language));
    out::say(format_args!(
        "{}: {} commands, the controller stores {}",
        imported.name, program.commands, program.capacity
    ));
    let asked = if args.stream {
        Some(Way::Stream)
    } else if args.chunked {
        Some(Way::Chunked)
    } else {
        None
    };
    let ways = Ways {
        chosen: asked.unwrap_or(ways.chosen),
        ..ways
    };
    for line in ways.describe() {
        out::say(format_args!("  {line}"));
    }
    if let Some(line) = calibrated(profile, &ways) {
        out::say(format_args!("  {line}"));
    }
    if let (Some(Way::Chunked), Err(why)) = (asked, &ways.chunked) {
        return Err((
            1,
            format!("{}: --chunked: {why}; nothing was sent", imported.name),
        ));
    }
    let parts = match ways.chosen {
        Way::Stored => vec![imported.checked(program.clone(), language, config, "run")?],
        Way::Stream => {
            vec![imported.checked(program.clone(), language, &streamed(config), "run")?]
        }
        Way::Chunked => imported.in_parts(language, config, profile, "run")?,
    };
    let retract = imported
        .restart
        .as_ref()
        .and_then(|r| retract::Retract::of(r, profile));
    Ok(Job {
        parts,
        way: ways.chosen,
        estimate_s: ways.estimate(ways.chosen).map(|e| e.total_s),
        ways: Some(ways.clone()),
        retract,
        offset: super::log::offset_of(&imported.import.summary),
        waits: waits::Waited::of(imported, profile, language, config, global)?,
    })
}

/// The chosen way's estimate beside what the last whole runs of this
/// profile and way took (`joblog::calibrate`); nothing without a log or
/// with too few runs.
fn calibrated(profile: &crate::config::Profile, ways: &Ways) -> Option<String> {
    let estimate = ways.estimate(ways.chosen)?.total_s;
    let folded = crate::joblog::file::read(&crate::joblog::file::dir()?);
    let way = ways.chosen.to_string();
    crate::joblog::calibrate::of(&folded, &profile.name, &way)
        .map(|c| c.describe(estimate, &profile.name, &way))
}

/// The lint of a program that is streamed: it is stored nowhere, so the
/// controller's memory is no limit.
pub fn streamed(config: &LintConfig) -> LintConfig {
    LintConfig {
        capacity: Some(usize::MAX),
        ..config.clone()
    }
}

/// Asks on the terminal; `Err` when there is none to ask on.
fn confirmed(way: Way) -> Result<bool, String> {
    let stdin = std::io::stdin();
    if !stdin.is_terminal() {
        return Err(
            "no terminal to confirm the start on: give --yes to start without asking".into(),
        );
    }
    out::say(keys::HELP);
    out::say_raw(format_args!("start the job ({way})? [y/N] "));
    let mut answer = String::new();
    if stdin.read_line(&mut answer).is_err() {
        return Ok(false);
    }
    Ok(matches!(answer.trim(), "y" | "Y" | "yes" | "YES" | "Yes"))
}

async fn run_job(
    mut session: Session,
    job: &Job,
    args: &RunArgs,
    remedy: &Remedy,
    logged: super::log::Logged,
    presses: Option<(sim_start::SimStart, crate::sim::start_key::StartKey)>,
) -> ExitCode {
    let stopper = session.handle.clone();
    let mut keys = Keys::from_stdin();
    let mut interrupted = false;
    let presses = presses.and_then(|(when, key)| {
        session
            .simulator()
            .map(|control| sim_start::Presses::start(when, control, key))
    });
    let code = tokio::select! {
        code = steps(&mut session, job, args, remedy, &mut keys, &logged) => code,
        () = session::interrupted() => {
            let _ = stopper.stop().written().await;
            session::say_interrupted("run", session::Moves::Yes);
            interrupted = true;
            1
        }
    };
    logged.end(code, interrupted || keys.stopped);
    drop(keys);
    drop(presses);
    if let Some(ended) = outputs::ended_by(code) {
        let on = upload::job_outputs(&job.parts);
        outputs::after_end(&mut session, &on, ended, "run", remedy).await;
    }
    session.close().await;
    ExitCode::from(code)
}

async fn steps(
    session: &mut Session,
    job: &Job,
    args: &RunArgs,
    remedy: &Remedy,
    keys: &mut Keys,
    logged: &super::log::Logged,
) -> u8 {
    let result = async {
        if let Linked::Failed(reason) = session.linked(Duration::from_secs(10)).await {
            out::say(format_args!("jogterm run: link failure: {reason}"));
            return Err(EXIT_LINK);
        }
        // A restart's retract sets the controller up itself, once for the
        // run (`retract::retract`); a stream needs it set up as a stored
        // run finds it.
        if let Some(to) = job.retract {
            retract::retract(session, to, remedy, keys).await?;
        } else if job.way == Way::Stream {
            upload::initialise(session, remedy).await?;
        }
        if let Some(w) = &job.waits {
            return waits::run(session, w, job.way, args, remedy, keys, logged).await;
        }
        if job.way == Way::Stream {
            let part = job.parts.first().ok_or(EXIT_USAGE)?;
            out::say(format_args!(
                "streaming {} (speed {} %)",
                part.name(),
                args.speed
            ));
            let place = stream::Place {
                estimate_s: job.estimate_s,
                log: Some(logged),
                ways: job.ways.as_ref(),
                ..part.place()
            };
            return stream::run(
                session,
                part.program(),
                &place,
                (remedy.isel_device, remedy.axes),
                args.speed,
                keys,
            )
            .await;
        }
        let mut pause_next = false;
        let mut eta = parts_eta(job);
        for (k, part) in job.parts.iter().enumerate() {
            if job.parts.len() > 1 {
                let left = eta
                    .as_ref()
                    .and_then(|e| e.left_s(k, 0.0))
                    .map(|s| format!(", about {} left", crate::gcode::ways::duration(s)))
                    .unwrap_or_default();
                out::say(format_args!("part {}/{}{left}", k + 1, job.parts.len()));
            }
            if pause_next {
                out::say(
                    "paused before the next part, the tool retracted, the spindle and the job's outputs \
                     still on (r resumes, Space stops)",
                );
                wait_resume(session, keys).await?;
                pause_next = false;
            }
            let began = std::time::Instant::now();
            let ran = match upload::upload(session, part, args.erase || k > 0, remedy).await {
                Ok(()) => stored_run(session, remedy, keys, &mut pause_next).await,
                Err(code) => Err(code),
            };
            if ran == Err(EXIT_LINK) && job.parts.len() > 1 {
                out::say(lost_in_part(job, k, args));
            }
            ran?;
            if let Some(e) = eta.as_mut() {
                e.part_done(k, began.elapsed().as_secs_f64());
            }
            if let Some(line) = part.last_gcode_line() {
                logged.line(line);
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

/// The model's time left of a G-code job run in parts, part by part
/// (`gcode::eta::PartsEta`); none for a program, or where the parts are
/// not the ones the model cut.
fn parts_eta(job: &Job) -> Option<crate::gcode::eta::PartsEta> {
    let ways = job.ways.as_ref().filter(|_| job.way == Way::Chunked)?;
    (ways.part_s.len() == job.parts.len())
        .then(|| crate::gcode::eta::PartsEta::new(ways.part_s.clone()))
}

/// Where a job in parts goes on after the link was lost in part `k`: the
/// parts before it have run to their end, each ending retracted; of part
/// `k` nothing is known (a stored program is not read while it runs), so
/// the restart takes it again from its first G-code line.
fn lost_in_part(job: &Job, k: usize, args: &RunArgs) -> String {
    let n = job.parts.len();
    let line = job.parts.get(k).and_then(Prepared::first_gcode_line);
    let file = args.file.display();
    match line {
        // The first part of a whole job: nothing to skip.
        Some(_) if k == 0 && args.from_line.is_none() => format!(
            "jogterm run: the link was lost in part 1/{n}: no part has run to its end; run the job again from its start"
        ),
        Some(line) => format!(
            "jogterm run: the link was lost in part {}/{n}, which begins at G-code line {line}{}; to go on, restart from that line: jogterm run {file} --from-line {line}",
            k + 1,
            if k > 0 {
                format!(" (parts 1-{k} ran to their end, the tool retracted after each)")
            } else {
                String::new()
            }
        ),
        None => format!(
            "jogterm run: the link was lost in part {}/{n}, which has no G-code line",
            k + 1
        ),
    }
}

/// The stored program started and followed to its end, the keys obeyed: a
/// stop stops it; a pause is taken before the next part.
async fn stored_run(
    session: &mut Session,
    remedy: &Remedy,
    keys: &mut Keys,
    pause_next: &mut bool,
) -> Status {
    let stopper = session.handle.clone();
    let run = upload::start(session, remedy);
    tokio::pin!(run);
    loop {
        tokio::select! {
            result = &mut run => return result,
            key = keys.next() => match key {
                Key::Stop | Key::Gone => {
                    let _ = stopper.stop().written().await;
                    out::say("jogterm run: stopped; nothing resumes");
                    return Err(1);
                }
                Key::Pause => {
                    *pause_next = true;
                    out::say(
                        "the job pauses after this part, with the tool retracted; \
                         the spindle and the job's outputs stay on",
                    );
                }
                Key::Resume => *pause_next = false,
                Key::Faster | Key::Slower => out::say(
                    "a stored program runs at its programmed speeds: the speed factor is for streams",
                ),
            },
        }
    }
}

/// Between parts, paused: the tool stands retracted.
async fn wait_resume(session: &mut Session, keys: &mut Keys) -> Status {
    loop {
        match keys.next().await {
            Key::Resume => return Ok(()),
            Key::Stop | Key::Gone => {
                let _ = session.handle.stop().written().await;
                out::say("jogterm run: stopped while paused; nothing resumes");
                return Err(1);
            }
            _ => {}
        }
    }
}
