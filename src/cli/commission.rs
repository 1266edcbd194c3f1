//! `jogterm commission`: the switch walk-test (`device::inputs::walk`) on a
//! terminal. It asks on stderr, reads the operator's answers on stdin,
//! watches the inputs as fast as the line allows, and writes the
//! commissioning report as Markdown and JSON.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime};

use anyhow::Context as _;
use clap::Args;

use super::GlobalArgs;
use super::out;
use super::session::{self, EXIT_LINK, EXIT_USAGE, Polling, Session};
use crate::device::api::{Event, LinkState, Recovery};
use crate::device::inputs::channels;
use crate::device::inputs::report::{self, Meta};
use crate::device::inputs::walk::{Do, STEP_TIME, WalkTest, outputs_of};
use crate::device::log::utc_timestamp;

pub const LONG_ABOUT: &str = "\
Walk through every wired input of the machine profile (its `[io]` wiring), one at a time, and
check that it is wired as the profile says: the command asks for the input (`[2/18] limit X1
(in3.0): trip the switch, then free it now`), watches every input as fast as the line allows (as `jogterm watch`
does), and reports what it saw:
  ok                 the input went to its active level and back;
  inverted           it toggles, but is active at the other level (a normally-closed
                     switch where the profile expects normally open, or the reverse);
  other input moved  another input changed instead: a swapped or mislabelled wire;
  not seen           nothing changed within the step's time (--step-s);
  skipped            the operator pressed Enter.
The E-stop circuits are one step: press the emergency stop and release it; each circuit's
opening and closing is timed, and the skew between the circuits is measured.

With --outputs every output follows, each switched only after the operator answered y (and
switched back after the answer whether it did what it should); inputs that follow an output
(the isel spindle feedback) are noted.

It moves no axis. Answers on stdin: Enter skips the step, q ends the walk-test (the rest is
listed as skipped), y/n answer the output questions. A closed stdin means no more answers:
the steps then end when their input has been seen or their time is up.

At the end it writes the commissioning report: BASE.md (for a person) and BASE.json (for a
tool), with the machine, the profile, the date, and every input with its result, its active
level and the times it was seen (t: seconds since the link came up).";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 every input walked toggled as the profile says; 1 something needs looking into
(a finding in the report), the walk-test was ended early or interrupted, or the report could
not be written; 2 bad usage; 3 link failure (the report so far is written).

Examples:
  jogterm commission --port /dev/ttyUSB0 --protocol isel --report mill-2026-11
  jogterm commission --port /tmp/isel --outputs --step-s 30";

/// Options of `jogterm commission`.
#[derive(Debug, Args)]
pub struct CommissionArgs {
    /// Baud rate, instead of the profile's (isel: 19200)
    #[arg(long, value_name = "N")]
    pub baud: Option<u32>,
    /// Write the report to BASE.md and BASE.json [default: commissioning-<UTC date and time>]
    #[arg(long, value_name = "BASE")]
    pub report: Option<PathBuf>,
    /// After the inputs, switch every output (each only after a yes)
    #[arg(long)]
    pub outputs: bool,
    /// Seconds a step waits for its input before it counts as not seen
    #[arg(long, value_name = "S", default_value_t = STEP_TIME.as_secs())]
    pub step_s: u64,
    /// EMP: the drives on the link (`11`, `11,21`), for the axes X, Y, Z, A
    #[arg(long, value_name = "DS")]
    pub drive: Vec<String>,
}

/// How long to wait for the first reading of every input.
const FIRST_READING: Duration = Duration::from_secs(5);

pub fn run(global: &GlobalArgs, args: &CommissionArgs) -> anyhow::Result<ExitCode> {
    let profile = match session::command_profile("commission", global, args.baud, &args.drive) {
        Ok(p) => p,
        Err(ended) => return ended,
    };
    if args.step_s == 0 {
        out::say("jogterm commission: --step-s must be at least 1");
        return Ok(ExitCode::from(EXIT_USAGE));
    }
    let started = SystemTime::now();
    let base = args.report.clone().unwrap_or_else(|| {
        let stamp: String = utc_timestamp(started)
            .chars()
            .take(19)
            .filter(|c| c.is_ascii_digit() || *c == 'T')
            .collect();
        PathBuf::from(format!("commissioning-{stamp}Z"))
    });
    let meta = Meta {
        machine: profile.name.clone(),
        description: profile.description.clone(),
        profile: chosen_profile(global),
        protocol: profile.connection.protocol.to_string(),
        port: profile.connection.port.clone(),
        baud: profile.connection.line().baud,
        date: utc_timestamp(started),
        read_every: None,
    };
    let runtime = session::runtime()?;
    runtime.block_on(async {
        let channels = channels::shared(&profile);
        let session = match session::command_session(
            "commission",
            global,
            profile,
            Polling::INPUTS,
            session::Moves::No,
        )
        .await
        {
            Ok(s) => s,
            Err(ended) => return ended,
        };
        let step = Duration::from_secs(args.step_s);
        Ok(commission(session, args, &channels, step, meta, &base).await)
    })
}

/// The profile as `cli::profile::resolve` chose it: `--profile`, else the
/// `default` one when it is of the family asked for (or none was), else the
/// shipped profile named after the family.
fn chosen_profile(global: &GlobalArgs) -> String {
    if let Some(name) = &global.profile {
        return name.clone();
    }
    let Some(family) = global.protocol.or(global.sim) else {
        return "default".to_owned();
    };
    let default = crate::config::load_profile("default", &crate::config::ConfigDirs::from_env());
    match default {
        Ok(p) if p.connection.protocol == family => "default".to_owned(),
        _ => family.name().to_owned(),
    }
}

async fn commission(
    mut session: Session,
    args: &CommissionArgs,
    channels: &[std::sync::Arc<crate::device::api::InputChannel>],
    step: Duration,
    mut meta: Meta,
    base: &Path,
) -> ExitCode {
    let inputs = session.handle.inputs().clone();
    // Every input group read (at least twice), so every input's resting
    // level is known before its step; the outputs from the same snapshot.
    let deadline = tokio::time::Instant::now() + FIRST_READING;
    let snapshot = loop {
        match tokio::time::timeout_at(deadline, session.next_event()).await {
            Ok(Some(Event::Io(io))) if inputs.read(|r| r.sampling()).is_some() => break io,
            Ok(Some(Event::Link(LinkState::Lost { reason }))) => {
                out::say(format_args!("jogterm commission: link failure: {reason}"));
                session.close().await;
                return ExitCode::from(EXIT_LINK);
            }
            Ok(Some(Event::Notice(text))) => out::say(format_args!("jogterm commission: {text}")),
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => {
                out::say(format_args!(
                    "jogterm commission: no input was read within {} s: is the controller \
                     connected and switched on?",
                    FIRST_READING.as_secs()
                ));
                session.close().await;
                return ExitCode::from(1);
            }
        }
    };
    let outputs = if args.outputs {
        outputs_of(&snapshot)
    } else {
        Vec::new()
    };
    let mut walk = WalkTest::new(channels, outputs).with_step_time(step);
    walk.observe(&snapshot);
    if walk.steps() == 0 {
        out::say(
            "jogterm commission: the profile names no input an operator can move (and no output was asked for)",
        );
    }
    out::say(format_args!(
        "jogterm commission: {} steps; Enter skips a step, q ends; nothing moves",
        walk.steps()
    ));
    let mut answers = super::lines::stdin_lines();
    let mut answers_open = true;
    let interrupted = session::interrupted();
    tokio::pin!(interrupted);
    let mut pending = walk.start(Instant::now());
    let mut code = 0u8;
    // An output switched back must be on the wire before the port closes.
    let mut requested = false;
    loop {
        let mut finished = false;
        for d in std::mem::take(&mut pending) {
            match d {
                Do::Say(text) => out::say(format_args!("walk: {text}")),
                Do::Request(r) => {
                    requested = true;
                    if let Err(e) = session.handle.request(r) {
                        pending.extend(walk.refused(&e.to_string(), Instant::now()));
                    }
                }
                Do::Finished => finished = true,
            }
        }
        if !pending.is_empty() {
            continue;
        }
        if finished {
            break;
        }
        let deadline = walk.deadline();
        let timer = async {
            match deadline {
                Some(t) => tokio::time::sleep_until(t.into()).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            _ = &mut interrupted => {
                // What ending asks (an output back off) still goes out.
                for d in walk.end(Instant::now()) {
                    if let Do::Request(r) = d {
                        requested |= session.handle.request(r).is_ok();
                    }
                }
                session::say_interrupted("commission", session::Moves::No);
                code = 1;
                break;
            }
            line = answers.recv(), if answers_open => match line.flatten() {
                Some(line) => pending = walk.answer(&line, Instant::now()),
                None => {
                    answers_open = false;
                    out::say("jogterm commission: stdin closed: steps end when seen or when their time is up");
                }
            },
            () = timer => pending = walk.timed_out(Instant::now()),
            event = session.next_event() => match event {
                Some(Event::Io(io)) => walk.observe(&io),
                Some(Event::Input(change)) => pending = walk.input(&change, Instant::now()),
                Some(Event::Refused { request, reason }) if request.starts_with("output") => {
                    pending = walk.refused(&reason.to_string(), Instant::now());
                }
                Some(Event::Link(LinkState::Lost { reason })) => {
                    out::say(format_args!(
                        "jogterm commission: link failure: {reason}; {}",
                        Recovery::CheckLink.instruction()
                    ));
                    walk.end(Instant::now());
                    code = EXIT_LINK;
                    break;
                }
                None => {
                    walk.end(Instant::now());
                    code = EXIT_LINK;
                    break;
                }
                Some(Event::Notice(text)) => out::say(format_args!("jogterm commission: {text}")),
                Some(_) => {}
            },
        }
    }
    if requested && code != EXIT_LINK {
        carried_out(&mut session).await;
    }
    meta.read_every = inputs.read(|r| r.sampling()).map(|s| s.longest);
    let findings = report::findings(&walk);
    match write_report(base, &meta, &walk) {
        Ok((md, json)) => out::say(format_args!(
            "jogterm commission: report written to {} and {}",
            md.display(),
            json.display()
        )),
        Err(e) => {
            out::say(format_args!("jogterm commission: {e:#}"));
            code = code.max(1);
        }
    }
    if findings.is_empty() {
        out::say("jogterm commission: no findings");
    } else {
        out::say(format_args!(
            "jogterm commission: {} finding(s):",
            findings.len()
        ));
        for f in &findings {
            out::say(format_args!("  {f}"));
        }
        code = code.max(1);
    }
    if walk.ended_early {
        code = code.max(1);
    }
    session.close().await;
    ExitCode::from(code)
}

/// Wait until the requests given have been carried out (at most 2 s). The
/// driver sends a request between two polls, so of the port reports that
/// follow it (`Event::Io`: one at the end of each poll cycle, one after an
/// output is written) at most one, the cycle under way, comes before it is
/// done: the second comes after. Closing before would lose a request still
/// queued: an output switched on for its check and not yet off again.
async fn carried_out(session: &mut Session) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    let mut cycles = 0;
    while cycles < 2 {
        match tokio::time::timeout_at(deadline, session.next_event()).await {
            Ok(Some(Event::Io(_))) => cycles += 1,
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => {
                out::say(
                    "jogterm commission: the last output request was not confirmed on the wire; check the outputs",
                );
                return;
            }
        }
    }
}

fn with_extension(base: &Path, ext: &str) -> PathBuf {
    let mut name = base.as_os_str().to_owned();
    name.push(format!(".{ext}"));
    PathBuf::from(name)
}

fn write_report(base: &Path, meta: &Meta, walk: &WalkTest) -> anyhow::Result<(PathBuf, PathBuf)> {
    let md = with_extension(base, "md");
    let json = with_extension(base, "json");
    std::fs::write(&md, report::markdown(meta, walk))
        .with_context(|| format!("cannot write the report {}", md.display()))?;
    let text = serde_json::to_string_pretty(&report::json(meta, walk))
        .context("cannot write the report as JSON")?;
    std::fs::write(&json, text + "\n")
        .with_context(|| format!("cannot write the report {}", json.display()))?;
    Ok((md, json))
}
