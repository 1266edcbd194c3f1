//! `jogterm arc`: the isel commands of a circular arc or helix (manual 2.3,
//! `docs/decisions.md` isel 12): the lines of [`ArcSteps`], which the
//! editor's circle helper inserts too (`program::circle`).
//!
//! stdout: the direction command and the arc command, one per line, as DNC
//! frames (`@0f-1`, `@0y…`/`@0w…`) or with `--cnc` as stored program lines
//! (`f-1`, `y…`/`w…`). stderr: where the arc ends. Exit 0, or 2 with a
//! message when the arguments describe no arc (radius 0, speed out of range,
//! an arc shorter than a step …).

use std::io::Write;
use std::process::ExitCode;

use super::out::closed_is_ok;
use crate::program::circle::ArcSteps;
use crate::proto::isel::{CircleDirection, CncCommand, Command, DeviceNumber, Frame, arc_end};

pub const LONG_ABOUT: &str = "\
Print the isel commands of a circular arc or a helix (manual 2.3).

Computes the direction command `f` and the arc command `y` (with --helix-steps the helix
`w`) for an arc of --radius steps from --start to --end degrees (counter-clockwise from
axis 1 of the plane; equal angles make a full circle) in the given direction at --speed Hz
path speed. Prints them one per line as DNC commands (`@0f-1`) or, with --cnc, as lines of a
stored program (`f-1`). stderr says where the arc ends relative to its start.";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 ok (also when the reader of stdout goes away early, `| head -1`), 1 stdout
failed otherwise, 2 bad usage or values that describe no arc (radius 0, a speed outside
1-40000 Hz, an arc shorter than one step). A failure to write stderr is ignored.

Example (manual 2.3.6):
  jogterm arc --radius 200 --start 135 --end 225 --ccw --speed 1500
  @0f-1
  @0y400,1500,119,-141,141,-1,-1";

/// Options of `jogterm arc`.
#[derive(Debug, Clone, clap::Args)]
#[command(group = clap::ArgGroup::new("direction").required(true).args(["cw", "ccw"]))]
pub struct ArcArgs {
    /// Radius in steps
    #[arg(long, value_name = "R")]
    pub radius: u32,
    /// Start angle in degrees, counter-clockwise from axis 1 of the plane
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub start: f64,
    /// End angle in degrees; equal to the start for a full circle
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub end: f64,
    /// Clockwise
    #[arg(long)]
    pub cw: bool,
    /// Counter-clockwise
    #[arg(long)]
    pub ccw: bool,
    /// Path speed in Hz (1-40000)
    #[arg(long, value_name = "V")]
    pub speed: u32,
    /// A helix: steps of the plane's third axis over the arc (`w` instead of `y`)
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub helix_steps: Option<i32>,
    /// Print stored program lines (`f…`, `y…`) instead of DNC commands
    #[arg(long)]
    pub cnc: bool,
    /// Device number of the DNC commands
    #[arg(long, value_name = "D", default_value_t = 0, value_parser = clap::value_parser!(u8).range(0..=9))]
    pub device: u8,
}

/// Run with the process' stdout and stderr.
pub fn run(args: &ArcArgs) -> anyhow::Result<ExitCode> {
    let stdout = std::io::stdout();
    let stderr = std::io::stderr();
    run_to(args, &mut stdout.lock(), &mut stderr.lock())
}

/// Run, writing the commands to `out` and messages to `err`.
pub fn run_to(
    args: &ArcArgs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let direction = if args.ccw {
        CircleDirection::Ccw
    } else {
        CircleDirection::Cw
    };
    let arc = ArcSteps {
        radius: args.radius,
        start: args.start,
        end: args.end,
        direction,
        speed: args.speed,
        helix: args.helix_steps,
    };
    let lines: [CncCommand; 2] = match arc.lines() {
        Ok(lines) => lines,
        Err(e) => {
            let _ = writeln!(err, "jogterm arc: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    let Some(device) = DeviceNumber::new(args.device) else {
        let _ = writeln!(
            err,
            "jogterm arc: the device number is 0-9, got {}",
            args.device
        );
        return Ok(ExitCode::from(2));
    };
    let mut text = String::new();
    for line in &lines {
        let command = if args.cnc {
            line.to_string()
        } else {
            match line.as_dnc() {
                Some(command) => dnc(device, command),
                None => line.to_string(),
            }
        };
        text.push_str(&command);
        text.push('\n');
    }
    // A reader that takes only the first line (`| head -1`) has what it
    // asked for; any other failure to write is one.
    closed_is_ok(out.write_all(text.as_bytes()).and_then(|()| out.flush()))?;
    let end = arc_end(args.radius, args.start, args.end);
    let mut note = format!(
        "the arc ends {},{} steps from its start",
        end.from_start.0, end.from_start.1
    );
    if let Some(s3) = args.helix_steps {
        note.push_str(&format!(" in the plane, {s3} along the third axis"));
    }
    let _ = writeln!(
        err,
        "{note}; the controller may end a step off it, so follow it with an absolute move \
         (manual 2.3.2)"
    );
    Ok(ExitCode::SUCCESS)
}

fn dnc(device: DeviceNumber, command: Command) -> String {
    Frame::new(device, command).to_string()
}
