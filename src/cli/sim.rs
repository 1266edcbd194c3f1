//! `jogterm sim`: serve a built-in controller simulator on a new
//! pseudo-terminal or a TCP port (`sim::shell::run_simulator_with`) until
//! stdin or stdout closes.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::{Context as _, bail};
use clap::{ArgGroup, Args};

use super::out::WatchedStdout;
use super::{GlobalArgs, profile};
use crate::config::{ConfigDirs, SimVariant};
use crate::sim::registry;
use crate::sim::shell::{PtyOptions, Serve, run_simulator_with};
use crate::sim::timescale::TimeScale;

pub const LONG_ABOUT: &str = "\
Serve a built-in controller simulator on a new pseudo-terminal or a TCP port.

With --pty the first line on stdout is the path to open (the --link path if given, else
the pseudo-terminal's /dev/pts/N). Open it like a serial port; the simulator paces the line
at the controller's baud rate (isel 19200). Clients may close it and open it again.

With --tcp ADDR:PORT it serves like a serial port server in raw mode (ser2net's `accepter:
tcp,PORT`): the first line is the URL to give --port (tcp://127.0.0.1:PORT; port 0 picks a
free one); one client at a time, a second one is told `Port already in use` and closed.

The simulated machine is the one the profile describes (axes, soft limits, [sim]
limit_margin and start_position), and the controller the one its [sim] variants and
--variant describe: the range of real controllers (docs/simulator.md, Variants). The
family is --protocol (or --sim), else the profile's connection.protocol; without
--profile, --sim/--protocol pick the shipped profile of that family (isel, emcu, emp).

--probe-surface SURFACE puts a work piece under the probe, in machine steps, Z+ up: Z0[,GX,GY]
the material below the plane z = Z0 + GX*x + GY*y; block:X0,X1,Y0,Y1,TOP a block X0..X1,
Y0..Y1 up to TOP (corners and edges to probe from outside); bore:CX,CY,R,TOP stock up to TOP
with a bore of radius R around CX, CY (a centre to probe from inside). The probe input reads
touched while the tip stands inside the material: isel in1.5, changing at the step the carriage
enters or leaves it, so a @0Z ends there and ramps down past it from its speed (at or below the
start-stop frequency it stops on it); EMP the drive input the profile's [io] gives role probe.
The EMCU's input E1 cannot be read: refused there. `show` prints the surface.

--time-scale S runs the simulated machine S times faster than the wall clock (0.01 to
1000; 1, the default, is real time): motion, the modelled wire, erase times, reply delays
and timed controls alike. It is for tests of logic (where a move ends, what went over the
wire); a client's deadlines and position estimates are made for the real machine, so
timing is only the controller's at 1 (docs/simulator.md, Time scale).

Lines on stdin operate the machine and inject faults; each accepted line prints `ok` (or
its output), errors go to stderr. The simulator ends when stdin closes, on `quit`, when
the reader of its stdout goes away (status 0, as for the others), or when it is killed.";

pub const AFTER_LONG_HELP: &str = "\
Control language (one command per line, docs/simulator.md):
  set <input> on|off|open|closed|1|0   set an input (closed = 1 = healthy, open = 0)
  press <input>                        press and release a button (start, stop)
  fault drop-byte [<index>|middle]     leave one byte out of the next message
  fault corrupt-byte [<index>|middle]  flip bit 7 of one byte of the next message
  fault withhold                       do not send the next message
  fault garbage <text>|hex:<hex>       send these bytes now, unasked
  fault delay <ms>                     send the next message <ms> later
  fault stream <bytes>                 instead of the next message, <bytes> of U unbroken
  fault close [<reopen-after-ms>]      close the line (a pty may reopen)
  fault stall                          the next long action stays busy, unmoving (EMP)
  show                                 device state, line, counters
  show received                        the bytes the simulator received (readable)
  show received times                  each read of them, with its time (s since 1970)
  help                                 commands and the device's inputs
  quit                                 end the simulator

isel inputs: limit-x1 limit-x2 limit-y1 limit-y2 limit-z1 limit-z2 limit-a1 limit-a2
  (on = the switch is held active), estop1 estop2 (closed/open), overtemp, power-ok,
  hood (closed/open), key-switch (on = setup mode), probe (not with --probe-surface),
  start, stop (press),
  in0.0 … in0.7 (user inputs)";

/// Options of `jogterm sim`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("serve").required(true).args(["pty", "tcp"])))]
pub struct SimArgs {
    /// Serve on a new pseudo-terminal
    #[arg(long)]
    pub pty: bool,
    /// Serve on a TCP port, raw, like a serial port server (ADDR:PORT; port 0 picks a
    /// free one, printed as tcp://ADDR:PORT)
    #[arg(long, value_name = "ADDR:PORT", conflicts_with_all = ["pty", "link"])]
    pub tcp: Option<SocketAddr>,
    /// Keep a symbolic link at PATH that points at the pseudo-terminal
    #[arg(long, value_name = "PATH", requires = "pty")]
    pub link: Option<PathBuf>,
    /// Model a controller that differs from the default (repeatable, added to the
    /// profile's [sim] variants): hood-unwired, no-port2, work-positions (isel),
    /// memory=<commands> (isel, EMCU), emp-rejects-0a-before-on (EMP),
    /// probe-surface=<z0>[,<gx>,<gy>], =block:…, =bore:… (isel, EMP)
    #[arg(long = "variant", value_name = "NAME[=N]")]
    pub variants: Vec<SimVariant>,
    /// A work piece under the probe, in machine steps (Z+ up): Z0[,GX,GY] the material
    /// below the plane z = Z0 + GX*x + GY*y, block:X0,X1,Y0,Y1,TOP a block up to TOP,
    /// bore:CX,CY,R,TOP stock up to TOP with a bore of radius R; the probe input reads
    /// touched while the tip stands inside the material. The variant probe-surface=…
    /// of the same text; it replaces one the profile sets (isel, EMP; docs/simulator.md,
    /// Probe surface)
    #[arg(
        long,
        value_name = "Z0[,GX,GY]|block:X0,X1,Y0,Y1,TOP|bore:CX,CY,R,TOP",
        value_parser = probe_surface
    )]
    pub probe_surface: Option<SimVariant>,
    /// Run the simulated machine S times faster than the wall clock (motion, wire,
    /// delays alike; 1 = real time): for tests of logic, not of timing
    #[arg(long, value_name = "S", default_value_t = TimeScale::REAL)]
    pub time_scale: TimeScale,
}

/// `--probe-surface SURFACE`: the variant `probe-surface=` of the same
/// text, so both are parsed and checked alike.
fn probe_surface(text: &str) -> Result<SimVariant, String> {
    format!("probe-surface={text}").parse()
}

/// Run `jogterm sim` until stdin closes.
pub fn run(global: &GlobalArgs, args: &SimArgs) -> anyhow::Result<()> {
    if let Some(port) = &global.port {
        bail!(
            "--port {port}: `jogterm sim` serves a new pseudo-terminal or TCP port instead \
             of opening a port; use --link PATH for a fixed path, --tcp ADDR:PORT for a \
             network one"
        );
    }
    let mut profile = profile::resolve(global, &ConfigDirs::from_env())?;
    let protocol = profile::family(&profile);
    if let Some(v) = args.variants.iter().find(|v| !v.applies_to(protocol)) {
        let why = v
            .info()
            .elsewhere
            .map(|why| format!(": {why}"))
            .unwrap_or_default();
        bail!("--variant {v}: the {protocol} simulator has no such variant{why}");
    }
    profile.sim.variants.extend(args.variants.iter().copied());
    if let Some(surface) = args.probe_surface {
        if let Some(why) = surface.refusal(protocol) {
            bail!("--probe-surface: {why}");
        }
        // The option is the operator's word for this run: it replaces the
        // profile's surface rather than stacking a second one.
        profile
            .sim
            .variants
            .retain(|v| !matches!(v, SimVariant::ProbeSurface(_)));
        profile.sim.variants.push(surface);
    }
    let device = registry::build(protocol, &profile)?;
    let surface = profile
        .sim
        .variants
        .iter()
        .rev()
        .find_map(|v| match v {
            SimVariant::ProbeSurface(s) => Some(s.to_string()),
            _ => None,
        })
        .unwrap_or_else(|| "none".into());
    tracing::info!(
        %protocol,
        profile = %profile.name,
        time_scale = %args.time_scale,
        probe_surface = %surface,
        "simulator starting"
    );
    let mut stdout = WatchedStdout::new();
    let serve = match args.tcp {
        Some(addr) => Serve::Tcp(addr),
        None => Serve::Pty(PtyOptions {
            link: args.link.clone(),
        }),
    };
    let result = run_simulator_with(
        device,
        serve,
        args.time_scale,
        std::io::stdin().lock(),
        &mut stdout,
        &mut std::io::stderr(),
    );
    match result {
        // Nobody reads the answers any more (`| head -1` took the path):
        // the simulator ends as when its stdin closes. It has shut down
        // its line already.
        Err(e) if stdout.reader_gone() => {
            tracing::info!(%protocol, "simulator ended: {e}");
            Ok(())
        }
        Err(e) => Err(e).with_context(|| format!("the {protocol} simulator failed")),
        Ok(()) => {
            tracing::info!(%protocol, "simulator ended");
            Ok(())
        }
    }
}
