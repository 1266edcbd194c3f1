//! `jogterm probe tool`: the tool measured on the fixed sensor
//! (`probe.tool_sensor`, `docs/probing.md`, "Tool length"). Z goes up to
//! the safe height first (the sensor point's Z, or higher where the tool
//! stands higher), then X and Y to the sensor, Z down to the point above
//! it, and the probe from there; the tool table in the state directory
//! keeps where it touched and its offset against the reference tool.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use serde_json::json;

use super::{GlobalArgs, Operator, end_text, not_touched, out, print_line, set_up, usage};
use crate::axis::Axis;
use crate::cli::session;
use crate::cli::upload::Remedy;
use crate::config::Profile;
use crate::device::api::{Dir, PerAxis};
use crate::offsets::store::OffsetsFile;
use crate::offsets::tools::ToolTable;
use crate::probing;

#[derive(Debug, Args)]
pub struct ToolArgs {
    /// The tool's name, as the job's `T` words name it
    #[arg(long, default_value = "T1", value_name = "TN")]
    pub tool: String,
    /// Print the result as JSON
    #[arg(long)]
    pub json: bool,
}

pub use crate::offsets::tools::{load, save, table_path};

pub fn run(
    global: &GlobalArgs,
    profile: Profile,
    offsets: Option<OffsetsFile>,
    args: &ToolArgs,
) -> anyhow::Result<ExitCode> {
    let sensor = match profile.probe.tool_sensor_point() {
        Some(Ok(p)) => p,
        Some(Err(why)) => return Ok(usage(&format!("probe.tool_sensor: {why}"))),
        None => {
            return Ok(usage(
                "the profile has no tool sensor: set probe.tool_sensor to the machine \
                 coordinates of the point above it (\"X10 Y250 Z70\")",
            ));
        }
    };
    let Some(path) = offsets.as_ref().and_then(table_path) else {
        return Ok(usage(
            "there is no state directory to keep the tool table in (set JOGTERM_STATE_DIR)",
        ));
    };
    let mut table = match load(&path) {
        Ok(t) => t,
        Err(why) => return Ok(usage(&why)),
    };
    if let Err(m) = probing::probe_move(&profile, Axis::Z, Dir::Minus) {
        return Ok(usage(&m));
    }
    let remedy = Remedy::of_command(&profile, "probe");
    let for_session = profile.clone();
    session::moving(global, for_session, "probe", async |mut session| {
        let measured = async {
            let (mut operator, at) = set_up(&mut session, &remedy).await?;
            measure(&mut operator, &mut session, &profile, &sensor, at, &remedy).await
        }
        .await;
        session.close().await;
        let end = match measured {
            Ok(end) => end,
            Err(code) => return ExitCode::from(code),
        };
        let what = format!("the measure of {}", args.tool);
        let Some(at) = probing::touched(&end) else {
            return not_touched(&profile, &what, Axis::Z, &end, &remedy);
        };
        let z = probing::units(&profile, Axis::Z, at.get(Axis::Z).unwrap_or(0));
        let offset = table.measured(&args.tool, z);
        if let Err(why) = save(&path, &table) {
            out::say(format_args!(
                "jogterm probe: the tool table was not saved: {why}"
            ));
            return ExitCode::from(1);
        }
        if args.json {
            print_line(&json!({
                "tool": args.tool,
                "length_mm": z,
                "offset_mm": offset,
                "reference": table.reference,
            }));
        } else {
            out::say(end_text(&profile, &what, Axis::Z, &end));
            out::say(format_args!(
                "{}: offset {offset:+.4} against the reference tool {}",
                args.tool,
                table.reference.as_deref().unwrap_or("-")
            ));
        }
        ExitCode::SUCCESS
    })
}

/// The tool in the spindle measured: to the sensor ([`to_sensor`]) and
/// the probe from there, which ends where it started, above the sensor.
pub(in crate::cli) async fn measure(
    operator: &mut Operator,
    session: &mut session::Session,
    profile: &Profile,
    sensor: &PerAxis<f64>,
    at: Option<PerAxis<i64>>,
    remedy: &Remedy,
) -> Result<crate::device::api::ProbeEnd, u8> {
    let probe = match probing::probe_move(profile, Axis::Z, Dir::Minus) {
        Ok(p) => p,
        Err(m) => return Err(usage_code(&m)),
    };
    to_sensor(operator, session, profile, sensor, at, remedy).await?;
    operator.probe(session, probe).await
}

fn usage_code(message: &str) -> u8 {
    out::say(format_args!("jogterm probe: {message}"));
    session::EXIT_USAGE
}

/// The tool table of the session `global` opens for `profile`: where it
/// is kept (`None`: no state directory) and what it holds.
pub(in crate::cli) fn table_of(
    global: &GlobalArgs,
    profile: &Profile,
) -> Option<(PathBuf, Result<ToolTable, String>)> {
    let dirs = crate::config::ConfigDirs::from_env();
    let (_, sources) = crate::cli::profile::resolve_with_sources(global, &dirs).ok()?;
    let key = crate::offsets::store::profile_key(&sources);
    let file = OffsetsFile::from_env(crate::offsets::Identity::of(&key, profile))?;
    let path = table_path(&file)?;
    let table = load(&path);
    Some((path, table))
}

/// The tool in the spindle and its length offset, as the tool table keeps
/// them: every Z of a job shifts by it (`docs/probing.md`, "Tool length").
pub(in crate::cli) fn active_offset(
    global: &GlobalArgs,
    profile: &Profile,
) -> Option<crate::gcode::waits::ToolOffset> {
    let (_, table) = table_of(global, profile)?;
    let (tool, offset_mm) = table.ok()?.active_offset()?;
    Some(crate::gcode::waits::ToolOffset { tool, offset_mm })
}

/// Up to the safe height, over to the sensor, down to the point above it
/// (`probing::up_over_down`).
async fn to_sensor(
    operator: &mut Operator,
    session: &mut session::Session,
    profile: &Profile,
    sensor: &PerAxis<f64>,
    at: Option<PerAxis<i64>>,
    remedy: &Remedy,
) -> Result<(), u8> {
    let to = probing::steps_of(profile, sensor.iter());
    let here = at.unwrap_or_default();
    for leg in probing::up_over_down(profile, &here, &to) {
        operator
            .move_to(session, leg.target, leg.speed_hz, remedy)
            .await?;
    }
    Ok(())
}
