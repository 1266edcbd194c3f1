//! The command line: `jogterm [global options] [command]`.
//!
//! One clap root for everything jogterm does. The global options belong to
//! the root and may be given before or after the command; each command
//! uses the ones that mean something to it and says so in its help. Without
//! a command jogterm runs the console (`tui`); the commands are `sim`,
//! `send`, `poll`, `watch`, `commission`, `check`, `import`, `arc`, `upload`,
//! `run`, `probe`, `log` and `ports`.
//!
//! Exit codes: 0 ok, 1 failure (a message on stderr), 2 bad usage (clap, and
//! the console's configuration errors); `send`, `poll`, `watch`,
//! `commission` and `upload` add 3 for a link failure.

pub mod arc;
pub mod check;
pub mod commission;
pub mod emp;
pub mod frame;
pub mod import;
mod lines;
pub mod log;
pub mod out;
pub mod poll;
pub mod ports;
pub mod probe;
pub mod profile;
mod restart;
mod resume;
pub mod run;
pub mod send;
mod session;
pub mod sim;
pub mod tui;
pub mod upload;
pub mod watch;

use std::fs::OpenOptions;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;

use anyhow::Context as _;
use clap::{Args, Parser, Subcommand};

use crate::proto::Protocol;

/// `--protocol` and `--sim` take a family by name. The protocol crate knows
/// no command line, so the CLI lists the names and their help here.
fn family_parser() -> impl clap::builder::TypedValueParser<Value = Protocol> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser as _};
    PossibleValuesParser::new(Protocol::ALL.map(|family| {
        PossibleValue::new(family.name()).help(match family {
            Protocol::Isel => "isel @-format: iMC-M, iMC-MP, iMC-S8",
            Protocol::Emcu => "EMCU interface on SMC3000 stepper cards",
            Protocol::Emp => "Easy Motion Protocol: MSR DRS-500-ECS servo drives",
        })
    }))
    .try_map(|name| name.parse::<Protocol>())
}

const ABOUT: &str = "Keyboard-only console for isel, EMCU and EMP serial motion controllers";

const LONG_ABOUT: &str = "\
jogterm drives stepper and servo machines through serial motion controllers of three
families: isel @-format (iMC-M, iMC-MP, iMC-S8), EMCU (SMC3000 interface) and EMP
(MSR DRS-500-ECS). Built-in simulators of the controllers let it run without hardware.

The controller is reached on a serial device (--port /dev/serial/by-id/…, see `jogterm
ports`) or on a serial port server such as ser2net (--port tcp://HOST:PORT raw, or
rfc2217://HOST:PORT, which also sets the remote port's baud rate; docs/network.md).

Machine profiles (--profile) say how to reach the controller and describe the machine:
axes, steps per unit, soft limits, jog settings. A name is looked up as
$JOGTERM_CONFIG_DIR/profiles/NAME.toml (default ~/.config/jogterm/profiles), then among the
shipped profiles (default, isel, emcu, emp); a value with a `/` or ending in `.toml` is a
path. Without --profile the shipped `default` profile is used: the isel simulator.";

const AFTER_LONG_HELP: &str = "\
Exit status: 0 ok, 1 failure (the reason on stderr), 2 bad usage, 3 link failure
(send, poll, watch, commission, upload).

Examples:
  jogterm sim --protocol isel --pty            serve the isel simulator on a new pty
  jogterm sim --pty --link /tmp/isel           the same, reachable as /tmp/isel
  jogterm sim --pty --profile mymachine        simulate the machine of a profile
  jogterm sim --tcp 127.0.0.1:0                serve it like a serial port server (prints tcp://…)
  jogterm ports                                the serial ports here, by-id names, who has them
  jogterm --profile isel --port tcp://pi.local:2000        a controller behind ser2net (raw)
  jogterm send --port rfc2217://pi.local:2001 '@0P'        … behind ser2net telnet(rfc2217)
  jogterm send --port /tmp/isel '@07' '@0P'    send commands, print the replies
  jogterm poll --port /tmp/isel --count 5      read the position five times
  jogterm watch --port /tmp/isel --json        print every change of an input
  jogterm commission --port /tmp/isel          walk every input, write the report
  jogterm check drill.isel                     check a CNC program for the default machine
  jogterm import part.nc -o part.isel          G-code from CAM: check it, convert it to a program
  jogterm arc --radius 200 --start 135 --end 225 --ccw --speed 1500
  jogterm upload drill.isel --port /tmp/isel --erase --start
  jogterm --program drill.isel                 the console, with the program in its editor";

/// `jogterm`: the global options and the command.
#[derive(Debug, Parser)]
#[command(
    name = "jogterm",
    version,
    about = ABOUT,
    long_about = LONG_ABOUT,
    after_long_help = AFTER_LONG_HELP
)]
pub struct Cli {
    #[command(flatten)]
    pub global: GlobalArgs,
    /// Open this isel program or EMCU job in the console's program editor (the console
    /// only; unsaved edits of earlier sessions are offered back in any case)
    #[arg(long, value_name = "FILE")]
    pub program: Option<PathBuf>,
    /// With a G-code --program: follow a probed surface, every Z shifted by the height
    /// map's surface under it (as `jogterm import --height-map`)
    #[arg(long, value_name = "MAP", requires = "program")]
    pub height_map: Option<PathBuf>,
    /// The console's active work offset's zero for this session, in machine coordinates
    /// ('X50 Y50 Z60', as `jogterm run --work-zero`); saved only when an offset is set
    #[arg(long, value_name = "ZERO")]
    pub work_zero: Option<String>,
    #[command(subcommand)]
    pub command: Option<CliCommand>,
}

/// Options every command accepts.
#[derive(Debug, Clone, Default, Args)]
pub struct GlobalArgs {
    /// Machine profile: a name (user profile, else shipped: default, isel, emcu, emp) or a
    /// path to a .toml file [default: default]
    #[arg(long, global = true, value_name = "NAME")]
    pub profile: Option<String>,
    /// The controller's port, instead of the profile's connection.port: a serial device
    /// (best its /dev/serial/by-id name, `jogterm ports`), tcp://HOST:PORT (a serial port
    /// server in raw mode, ser2net `accepter: tcp,PORT`) or rfc2217://HOST:PORT (ser2net
    /// `telnet(rfc2217)`: also sets the remote baud rate). The console and the talking
    /// commands; `sim` serves a port and refuses it
    #[arg(long, global = true, value_name = "PORT")]
    pub port: Option<String>,
    /// Controller family, instead of the profile's connection.protocol
    #[arg(long, global = true, value_name = "FAMILY", value_parser = family_parser())]
    pub protocol: Option<Protocol>,
    /// Use the built-in simulator of this family instead of a port (for `sim`: the
    /// family to serve, like --protocol)
    #[arg(long, global = true, value_name = "FAMILY", value_parser = family_parser())]
    pub sim: Option<Protocol>,
    /// Colour theme of the console: a name (user theme, else shipped: dark, light,
    /// mono16) or a path (used by the console only)
    #[arg(long, global = true, value_name = "NAME")]
    pub theme: Option<String>,
    /// Append a log of what jogterm does to FILE (never to the terminal); `send` and
    /// `poll` add every byte on the line to it (UTC time, >> sent, << received)
    #[arg(long, global = true, value_name = "FILE")]
    pub log: Option<PathBuf>,
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum CliCommand {
    /// Serve a built-in controller simulator on a new pseudo-terminal or a TCP port
    #[command(long_about = sim::LONG_ABOUT, after_long_help = sim::AFTER_LONG_HELP)]
    Sim(sim::SimArgs),
    /// Send commands to the controller one by one and print the replies decoded
    #[command(long_about = send::LONG_ABOUT, after_long_help = send::AFTER_LONG_HELP)]
    Send(send::SendArgs),
    /// Read the position (and ports) repeatedly, one line per sample
    #[command(long_about = poll::LONG_ABOUT, after_long_help = poll::AFTER_LONG_HELP)]
    Poll(poll::PollArgs),
    /// Read every input as fast as the line allows, one line per change
    #[command(long_about = watch::LONG_ABOUT, after_long_help = watch::AFTER_LONG_HELP)]
    Watch(watch::WatchArgs),
    /// Walk through every wired input (and output), write a commissioning report
    #[command(long_about = commission::LONG_ABOUT, after_long_help = commission::AFTER_LONG_HELP)]
    Commission(commission::CommissionArgs),
    /// Check an isel CNC program or an EMCU job for a machine profile
    #[command(long_about = check::LONG_ABOUT, after_long_help = check::AFTER_LONG_HELP)]
    Check(check::CheckArgs),
    /// Import G-code from CAM: check it against the machine, convert it into the controller's program
    #[command(long_about = import::LONG_ABOUT, after_long_help = import::AFTER_LONG_HELP)]
    Import(import::ImportArgs),
    /// Print the isel commands of a circular arc or a helix
    #[command(long_about = arc::LONG_ABOUT, after_long_help = arc::AFTER_LONG_HELP)]
    Arc(arc::ArcArgs),
    /// Store a program in the controller (checked first), with progress; --start runs it
    #[command(long_about = upload::LONG_ABOUT, after_long_help = upload::AFTER_LONG_HELP)]
    Upload(upload::UploadArgs),
    /// Run a job (G-code or a program): stored when it fits, else in parts or as a stream
    #[command(long_about = run::LONG_ABOUT, after_long_help = run::AFTER_LONG_HELP)]
    Run(run::RunArgs),
    /// Probe with the probe input: touch off Z, find an edge; sets the work offset
    #[command(long_about = probe::LONG_ABOUT, after_long_help = probe::AFTER_LONG_HELP)]
    Probe(probe::ProbeArgs),
    /// List the runs of the job log: file, way, last line, time taken, how each ended
    #[command(long_about = log::LONG_ABOUT, after_long_help = log::AFTER_LONG_HELP)]
    Log(log::LogArgs),
    /// Trace the rectangle of a G-code job's extents at its safe height, at the jog speed
    #[command(long_about = frame::LONG_ABOUT, after_long_help = frame::AFTER_LONG_HELP)]
    Frame(frame::FrameArgs),
    /// List the serial ports of this machine: by-id names, USB vendor and product, in use
    #[command(long_about = ports::LONG_ABOUT, after_long_help = ports::AFTER_LONG_HELP)]
    Ports(ports::PortsArgs),
}

/// Run what the command line asks for.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    if let Some(path) = &cli.global.log {
        start_log(path)?;
    }
    if cli.program.is_some() && cli.command.is_some() {
        out::say("jogterm: error: --program belongs to the console, not to a command");
        return Ok(ExitCode::from(2));
    }
    if cli.work_zero.is_some() && cli.command.is_some() {
        out::say(
            "jogterm: error: --work-zero before the command belongs to the console; give it after the command (jogterm run FILE --work-zero …)",
        );
        return Ok(ExitCode::from(2));
    }
    match &cli.command {
        Some(CliCommand::Sim(args)) => {
            sim::run(&cli.global, args)?;
            Ok(ExitCode::SUCCESS)
        }
        Some(CliCommand::Send(args)) => send::run(&cli.global, args),
        Some(CliCommand::Poll(args)) => poll::run(&cli.global, args),
        Some(CliCommand::Watch(args)) => watch::run(&cli.global, args),
        Some(CliCommand::Commission(args)) => commission::run(&cli.global, args),
        Some(CliCommand::Check(args)) => check::run(&cli.global, args),
        Some(CliCommand::Arc(args)) => arc::run(args),
        Some(CliCommand::Import(args)) => import::run(&cli.global, args),
        Some(CliCommand::Upload(args)) => upload::run(&cli.global, args),
        Some(CliCommand::Run(args)) => run::run(&cli.global, args),
        Some(CliCommand::Log(args)) => log::run(args),
        Some(CliCommand::Ports(args)) => ports::run(args),
        Some(CliCommand::Probe(args)) => probe::run(&cli.global, args),
        Some(CliCommand::Frame(args)) => frame::run(&cli.global, args),
        None => tui::run(
            &cli.global,
            tui::Opening {
                program: cli.program.as_deref(),
                height_map: cli.height_map.as_deref(),
                work_zero: cli.work_zero.as_deref(),
            },
        ),
    }
}

/// Log to `path` (appending); nothing is ever logged to the terminal.
fn start_log(path: &PathBuf) -> anyhow::Result<()> {
    let file = OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("cannot open the log file {}", path.display()))?;
    tracing_subscriber::fmt()
        .with_writer(Mutex::new(file))
        .with_ansi(false)
        .try_init()
        .map_err(|e| anyhow::anyhow!("cannot start logging: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn global_options_go_before_or_after_the_command() {
        let cli = Cli::try_parse_from([
            "jogterm",
            "--profile",
            "mine",
            "sim",
            "--pty",
            "--protocol",
            "isel",
            "--link",
            "/tmp/x",
        ])
        .expect("parses");
        assert_eq!(cli.global.profile.as_deref(), Some("mine"));
        assert_eq!(cli.global.protocol, Some(Protocol::Isel));
        let Some(CliCommand::Sim(args)) = cli.command else {
            panic!("sim");
        };
        assert!(args.pty);
        assert_eq!(args.link, Some(PathBuf::from("/tmp/x")));
    }

    #[test]
    fn bad_usage_is_refused() {
        for bad in [
            &["jogterm", "sim"][..],
            &["jogterm", "sim", "--pty", "--protocol", "modbus"],
            &["jogterm", "frobnicate"],
            &["jogterm", "check"],
            &["jogterm", "check", "a.isel", "--axes", "5"],
            &[
                "jogterm", "arc", "--radius", "1", "--start", "0", "--end", "9", "--speed", "1",
            ],
        ] {
            let err = Cli::try_parse_from(bad).expect_err("refused");
            assert_eq!(err.exit_code(), 2, "{bad:?}");
        }
        assert!(Cli::try_parse_from(["jogterm"]).is_ok());
    }

    #[test]
    fn check_takes_the_global_profile_and_protocol_on_either_side() {
        let cli = Cli::try_parse_from([
            "jogterm",
            "--profile",
            "mill",
            "check",
            "a.txt",
            "--protocol",
            "emcu",
            "--axes",
            "2",
        ])
        .expect("parses");
        assert_eq!(cli.global.profile.as_deref(), Some("mill"));
        assert_eq!(cli.global.protocol, Some(Protocol::Emcu));
        let Some(CliCommand::Check(args)) = cli.command else {
            panic!("check");
        };
        assert_eq!((args.file, args.axes), (PathBuf::from("a.txt"), Some(2)));
    }
}
