//! `jogterm probe`: touch off Z, find an edge (`docs/probing.md`).
//!
//! Each probe is the device's `Request::Probe` (two passes on the
//! profile's probe input, then back to where it started); this command
//! sets up the controller, sends it, follows it (Space, Ctrl-C, a hang-up
//! stop it like any move) and turns the touched point into the work
//! offset, saved where the console keeps it (`s` saves the same file).

use std::process::ExitCode;

use clap::{Args, Subcommand, ValueEnum};
use serde_json::json;

mod grid;
pub(in crate::cli) mod operator;
mod shapes;
pub(in crate::cli) mod tool;

use operator::Operator;

use super::session::{self, EXIT_USAGE, Session};
use super::upload::{Remedy, initialise_reading, refused_in};
use super::{GlobalArgs, out, profile};
use crate::axis::Axis;
use crate::config::{ConfigDirs, Profile};
use crate::device::api::{Dir, PerAxis, ProbeEnd};
use crate::offsets::store::{OffsetsFile, profile_key, save};
use crate::offsets::{Identity, System};
use crate::probing;

pub const LONG_ABOUT: &str = "\
Probe with the profile's probe input (the [io] input with role `probe`; isel in1.5): a fast
pass toward the surface, a slow back-off until the input releases, a slow second pass from
which the controller stops within a step, then back to where the probe started.

  z      Z down from where the tool stands; the work offset's Z is set so that work Z 0 is
         the touched surface minus the plate (probe.plate, --plate)
  edge   X or Y toward a face (x+ moves toward larger X); the work offset's X or Y is set so
         that the face is 0, half the tip (probe.tip) beyond the touched centre

Refused before anything moves: axes not referenced, the probe input touched already, a travel
(probe.travel) that leaves the soft limits, an E-stop or controller error. Space stops a probe
like any move; nothing resumes after a stop or a lost link.";

pub const AFTER_LONG_HELP: &str = "\
Examples:
  jogterm probe z --plate 1.5
  jogterm probe z --offset G55 --json
  jogterm probe edge x+";

#[derive(Debug, Args)]
pub struct ProbeArgs {
    #[command(subcommand)]
    pub what: What,
}

#[derive(Debug, Subcommand)]
pub enum What {
    /// Touch off Z: work Z 0 is the touched surface minus the plate
    Z(ZArgs),
    /// Find a face along X or Y: the work offset's X or Y is set to it
    Edge(EdgeArgs),
    /// Find the corner of two faces (X then Y): the work offset's X and Y are set to it
    Corner(shapes::CornerArgs),
    /// Find the centre of a bore (X+ X-, then Y+ Y-): the work offset's X and Y are set to it
    Center(shapes::CenterArgs),
    /// Probe a grid of points: a height map for --height-map
    Grid(grid::GridArgs),
    /// Measure the tool on the fixed sensor (probe.tool_sensor): its length against the reference tool
    Tool(tool::ToolArgs),
}

#[derive(Debug, Args)]
pub struct Common {
    /// The work offset to set (G54-G59); default: the active one
    #[arg(long, value_name = "G54..G59")]
    pub offset: Option<String>,
    /// Print the result as JSON
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct ZArgs {
    /// Thickness of the touch plate, units (default: probe.plate)
    #[arg(long, value_name = "MM")]
    pub plate: Option<f64>,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Debug, Args)]
pub struct EdgeArgs {
    /// The direction the probe moves toward the face
    #[arg(value_enum)]
    pub side: Side,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Side {
    #[value(name = "x-")]
    XMinus,
    #[value(name = "x+")]
    XPlus,
    #[value(name = "y-")]
    YMinus,
    #[value(name = "y+")]
    YPlus,
}

impl Side {
    fn axis_dir(self) -> (Axis, Dir) {
        match self {
            Side::XMinus => (Axis::X, Dir::Minus),
            Side::XPlus => (Axis::X, Dir::Plus),
            Side::YMinus => (Axis::Y, Dir::Minus),
            Side::YPlus => (Axis::Y, Dir::Plus),
        }
    }
}

/// What one probe is for.
struct Job {
    axis: Axis,
    toward: Dir,
    system: Option<System>,
    json: bool,
    /// Where work 0 lies from the touched centre, units along the axis.
    zero_from_touch: f64,
}

pub fn run(global: &GlobalArgs, args: &ProbeArgs) -> anyhow::Result<ExitCode> {
    let dirs = ConfigDirs::from_env();
    let (profile, file) = match profile::resolve_with_sources(global, &dirs) {
        Ok((p, sources)) => {
            let key = profile_key(&sources);
            let file = OffsetsFile::from_env(Identity::of(&key, &p));
            (p, file)
        }
        Err(e) => return Ok(usage(&format!("{e:#}"))),
    };
    match &args.what {
        What::Tool(t) => return tool::run(global, profile, file, t),
        What::Grid(g) => return grid::run(global, profile, file, g),
        What::Corner(c) => return xy(global, profile, file, &c.common, Some(c.corner)),
        What::Center(c) => return xy(global, profile, file, &c.common, None),
        What::Z(_) | What::Edge(_) => {}
    }
    let job = match job(&profile, &args.what) {
        Ok(j) => j,
        Err(m) => return Ok(usage(&m)),
    };
    let probe = match probing::probe_move(&profile, job.axis, job.toward) {
        Ok(p) => p,
        Err(m) => return Ok(usage(&m)),
    };
    let remedy = Remedy::of_command(&profile, "probe");
    let for_session = profile.clone();
    session::moving(global, for_session, "probe", async |mut session| {
        let end = set_up(&mut session, &remedy).await;
        let end = match end {
            Ok((mut operator, _)) => operator.probe(&mut session, probe).await,
            Err(code) => Err(code),
        };
        session.close().await;
        match end {
            Ok(end) => finish(&profile, file.as_ref(), &job, &end, &remedy),
            Err(code) => ExitCode::from(code),
        }
    })
}

/// A corner (`Some`) or a bore: X and Y of the work offset.
fn xy(
    global: &GlobalArgs,
    profile: Profile,
    file: Option<OffsetsFile>,
    common: &Common,
    corner: Option<shapes::Corner>,
) -> anyhow::Result<ExitCode> {
    let system = match parse_system(common) {
        Ok(s) => s,
        Err(m) => return Ok(usage(&m)),
    };
    let remedy = Remedy::of_command(&profile, "probe");
    let for_session = profile.clone();
    session::moving(global, for_session, "probe", async |mut session| {
        let mut diameters = None;
        let result = match set_up(&mut session, &remedy).await {
            Err(code) => Err(shapes::Failed::Status(code)),
            Ok((mut operator, at)) => match corner {
                Some(c) => {
                    shapes::corner(&mut operator, &mut session, &profile, at, c, &remedy).await
                }
                None => shapes::center(&mut operator, &mut session, &profile, &remedy)
                    .await
                    .map(|(centre, d)| {
                        diameters = Some(d);
                        centre
                    }),
            },
        };
        session.close().await;
        shapes::finish(
            &profile,
            file.as_ref(),
            common,
            system,
            result,
            diameters,
            &remedy,
        )
    })
}

fn parse_system(common: &Common) -> Result<Option<System>, String> {
    common
        .offset
        .as_deref()
        .map(|name| {
            System::from_name(name).ok_or_else(|| format!("--offset {name}: expected G54 to G59"))
        })
        .transpose()
}

/// The controller set up (initialised, its position read) and the
/// operator's stops watched from now on.
async fn set_up(
    session: &mut Session,
    remedy: &Remedy,
) -> Result<(Operator, Option<PerAxis<i64>>), u8> {
    let set = initialise_reading(session, remedy).await?;
    Ok((Operator::new(set.measured), set.measured))
}

fn usage(message: &str) -> ExitCode {
    out::say(format_args!("jogterm probe: {message}"));
    ExitCode::from(EXIT_USAGE)
}

fn job(profile: &Profile, what: &What) -> Result<Job, String> {
    let (common, axis, toward, zero_from_touch) = match what {
        What::Z(z) => {
            let plate = z.plate.unwrap_or(profile.probe.plate);
            if !(plate.is_finite() && plate >= 0.0) {
                return Err(format!(
                    "--plate {plate}: expected a thickness of 0 or more"
                ));
            }
            (&z.common, Axis::Z, Dir::Minus, -plate)
        }
        What::Edge(e) => {
            let (axis, toward) = e.side.axis_dir();
            let half = probing::edge(0.0, toward, profile.probe.tip);
            (&e.common, axis, toward, half)
        }
        What::Tool(_) | What::Corner(_) | What::Center(_) | What::Grid(_) => {
            return Err("not a probe of one axis".into());
        }
    };
    let system = parse_system(common)?;
    Ok(Job {
        axis,
        toward,
        system,
        json: common.json,
        zero_from_touch,
    })
}

/// The touched point into the work offset, saved, and said.
fn finish(
    profile: &Profile,
    file: Option<&OffsetsFile>,
    job: &Job,
    end: &ProbeEnd,
    remedy: &Remedy,
) -> ExitCode {
    let what = format!("the probe of {}{}", job.axis, job.toward.symbol());
    let Some(at) = probing::touched(end) else {
        return not_touched(profile, &what, job.axis, end, remedy);
    };
    let touched = at.get(job.axis).unwrap_or(0);
    let zero_units = probing::units(profile, job.axis, touched) + job.zero_from_touch;
    let (system, saved) = set_zeros(profile, file, job.system, &[(job.axis, zero_units)]);
    if job.json {
        let mut zero_mm = serde_json::Map::new();
        zero_mm.insert(job.axis.to_string().to_lowercase(), json!(zero_units));
        print_line(&json!({
            "touched_machine_mm": machine_units(profile, at),
            "work_offset": system.to_string(),
            "zero_machine_mm": zero_mm,
            "saved": saved.as_ref().ok(),
        }));
    } else {
        out::say(format_args!("{}", end_text(profile, &what, job.axis, end)));
        out::say(format_args!(
            "{system} {} zero set to {zero_units:.4} (machine)",
            job.axis
        ));
    }
    if job.axis == Axis::Z
        && let Some(path) = file.and_then(tool::table_path)
        && let Ok(mut tools) = tool::load(&path)
    {
        // The tool in the spindle set work Z: the next one measured on the
        // sensor is the reference (`docs/probing.md`, "Tool length").
        tools.touched_off();
        if let Err(why) = tool::save(&path, &tools) {
            out::say(format_args!(
                "jogterm probe: the tool table was not saved: {why}"
            ));
        }
    }
    saved_status(&saved)
}

/// The work zeros (machine units per axis) set in `system` (default: the
/// active one) and saved where the console keeps them; which system, and
/// where it was saved or why not.
fn set_zeros(
    profile: &Profile,
    file: Option<&OffsetsFile>,
    system: Option<System>,
    zeros: &[(Axis, f64)],
) -> (System, Result<String, String>) {
    let startup = file.map(OffsetsFile::load);
    let mut table = startup
        .as_ref()
        .map(|s| s.offsets.clone())
        .unwrap_or_default();
    let system = system.unwrap_or(table.active());
    for (axis, units) in zeros {
        table.set(system, *axis, probing::steps(profile, *axis, *units));
    }
    let saved = match file {
        Some(f) => {
            let refused = startup.as_ref().is_some_and(|s| s.refused);
            save(&f.job(&table, refused)).map(|p| p.display().to_string())
        }
        None => Err("there is no state directory (set JOGTERM_STATE_DIR)".to_owned()),
    };
    (system, saved)
}

/// The exit status after the offsets were set: 1 when they were not saved.
fn saved_status(saved: &Result<String, String>) -> ExitCode {
    match saved {
        Ok(_) => ExitCode::SUCCESS,
        Err(why) => {
            out::say(format_args!(
                "jogterm probe: the work offset was not saved: {why}"
            ));
            ExitCode::from(1)
        }
    }
}

/// A probe that did not touch, said; its exit status (2 for a refusal
/// of what was asked, 1 otherwise, as `upload` counts them).
fn not_touched(
    profile: &Profile,
    what: &str,
    axis: Axis,
    end: &ProbeEnd,
    remedy: &Remedy,
) -> ExitCode {
    if let ProbeEnd::Refused(reason) = end {
        return ExitCode::from(refused_in("probe", what, reason, remedy));
    }
    out::say(format_args!(
        "jogterm probe: {}",
        end_text(profile, what, axis, end)
    ));
    ExitCode::from(1)
}

fn end_text(profile: &Profile, what: &str, axis: Axis, end: &ProbeEnd) -> String {
    match profile.axis(axis) {
        Some(a) => probing::end_text(what, (axis, a), end),
        None => format!("{what}: the machine has no {axis} axis"),
    }
}

/// One line on stdout; a reader gone away changes nothing about the
/// outcome (the offset is saved either way).
fn print_line(value: &serde_json::Value) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stdout().lock(), "{value}");
}

/// `{"x": …, "y": …, "z": …}`: every axis of a position, machine units.
fn machine_units(profile: &Profile, at: &PerAxis<i64>) -> serde_json::Value {
    let map: serde_json::Map<String, serde_json::Value> = at
        .iter()
        .map(|(axis, steps)| {
            (
                axis.to_string().to_lowercase(),
                json!(probing::units(profile, axis, steps)),
            )
        })
        .collect();
    serde_json::Value::Object(map)
}
