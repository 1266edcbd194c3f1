//! `jogterm probe grid`: a height map of the surface (`docs/probing.md`,
//! "Height map"). Every point of the grid (work coordinates, the active or
//! named offset) is probed with the same two-pass probe as a Z touch-off,
//! from the height the tool stands at when the command starts (the
//! clearance: the probe goes back up to it after each point, and X and Y
//! move there). The map keeps where, when and for which work offset it
//! was probed (`jogterm_gcode::heightmap`, written with the same type that
//! `--height-map` reads).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{SystemTime, UNIX_EPOCH};

use clap::Args;
use serde_json::json;

use super::{Common, not_touched, out, parse_system, print_line, set_up, usage};
use crate::axis::Axis;
use crate::cli::session::{self, Session};
use crate::cli::upload::Remedy;
use crate::config::Profile;
use crate::device::api::{Dir, PerAxis};
use crate::gcode::heightmap::{Area, Grid, HeightMap};
use crate::gcode::toolpath::Point;
use crate::offsets::store::OffsetsFile;
use crate::probing;

#[derive(Debug, Args)]
pub struct GridArgs {
    /// The area, work coordinates: 'X0 Y0 X100 Y80' (two corners)
    #[arg(
        long,
        value_name = "'X0 Y0 X100 Y80'",
        required_unless_present = "of",
        conflicts_with = "of"
    )]
    pub area: Option<String>,
    /// The area of a G-code job: its extents in X and Y, work coordinates
    #[arg(long, value_name = "FILE")]
    pub of: Option<PathBuf>,
    /// The distance between grid points, mm
    #[arg(long, value_name = "MM")]
    pub spacing: f64,
    /// Write the map to FILE (for --height-map)
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub common: Common,
}

/// `'X0 Y0 X100 Y80'`: two X and two Y values, any order of corners.
pub fn parse_area(text: &str) -> Result<Area, String> {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for word in text.split_whitespace() {
        let (letter, number) = word.split_at(word.chars().next().map_or(0, char::len_utf8));
        let value: f64 = number
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("--area: `{word}`: expected X or Y and a number"))?;
        match letter {
            "X" | "x" => xs.push(value),
            "Y" | "y" => ys.push(value),
            _ => return Err(format!("--area: `{word}`: expected X or Y and a number")),
        }
    }
    match (xs.as_slice(), ys.as_slice()) {
        ([a, b], [c, d]) if a != b && c != d => Ok(Area {
            x0: a.min(*b),
            y0: c.min(*d),
            x1: a.max(*b),
            y1: c.max(*d),
        }),
        _ => Err(format!(
            "--area {text:?}: expected two corners of different X and Y, 'X0 Y0 X100 Y80'"
        )),
    }
}

pub fn run(
    global: &super::GlobalArgs,
    profile: Profile,
    file: Option<OffsetsFile>,
    args: &GridArgs,
) -> anyhow::Result<ExitCode> {
    if args.output.is_none() && !args.common.json {
        return Ok(usage(
            "say where the map goes: -o map.json (and/or --json for the points)",
        ));
    }
    let offsets = file
        .as_ref()
        .map(OffsetsFile::load)
        .map(|s| s.offsets)
        .unwrap_or_default();
    let area = match (&args.area, &args.of) {
        (Some(text), _) => parse_area(text),
        (None, Some(job)) => job_area(&profile, &offsets, job),
        (None, None) => Err("--area or --of FILE says where to probe".to_owned()),
    };
    let area = match area {
        Ok(a) => a,
        Err(m) => return Ok(usage(&m)),
    };
    let grid = match Grid::new(area, args.spacing) {
        Ok(g) => g,
        Err(errors) => {
            let text: Vec<String> = errors.iter().map(ToString::to_string).collect();
            return Ok(usage(&text.join("; ")));
        }
    };
    let system = match parse_system(&args.common) {
        Ok(s) => s.unwrap_or(offsets.active()),
        Err(m) => return Ok(usage(&m)),
    };
    let zero_mm = |axis: Axis| probing::units(&profile, axis, offsets.zero(system, axis));
    let zero = Point {
        x: zero_mm(Axis::X),
        y: zero_mm(Axis::Y),
        z: zero_mm(Axis::Z),
    };
    // Every point within the soft limits before anything moves.
    let machine: Vec<(f64, f64)> = grid
        .points()
        .map(|(x, y)| (zero.x + x, zero.y + y))
        .collect();
    for &(x, y) in &machine {
        for (axis, v) in [(Axis::X, x), (Axis::Y, y)] {
            if let Some(a) = profile.axis(axis)
                && !(a.min..=a.max).contains(&v)
            {
                return Ok(usage(&format!(
                    "the grid point at machine {axis} {v:.3} lies outside the soft limits \
                     ({} to {}); nothing moved",
                    a.min, a.max
                )));
            }
        }
    }
    let probe = match probing::probe_move(&profile, Axis::Z, Dir::Minus) {
        Ok(p) => p,
        Err(m) => return Ok(usage(&m)),
    };
    let remedy = Remedy::of_command(&profile, "probe");
    let for_session = profile.clone();
    session::moving(global, for_session, "probe", async |mut session| {
        let probed = probe_points(&mut session, &profile, &machine, probe, &remedy).await;
        session.close().await;
        let zs = match probed {
            Ok(zs) => zs,
            Err(code) => return code,
        };
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs() as i64);
        let map = match HeightMap::new(now, &profile.name, system, zero, area, args.spacing, &zs) {
            Ok(m) => m,
            Err(errors) => {
                let text: Vec<String> = errors.iter().map(ToString::to_string).collect();
                out::say(format_args!("jogterm probe: {}", text.join("; ")));
                return ExitCode::from(1);
            }
        };
        if let Some(path) = &args.output {
            let written = serde_json::to_string_pretty(&map)
                .map_err(|e| e.to_string())
                .and_then(|text| {
                    crate::program::store::save(path, &text, None).map_err(|e| e.to_string())
                });
            if let Err(why) = written {
                out::say(format_args!(
                    "jogterm probe: the map was not written: {why}"
                ));
                return ExitCode::from(1);
            }
        }
        let (lo, hi) = zs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
                (lo.min(*z), hi.max(*z))
            });
        if args.common.json {
            print_line(&json!({ "points": map.points }));
        } else {
            out::say(format_args!(
                "{} points probed for {system}: the surface from machine Z {lo:.4} to {hi:.4}",
                zs.len()
            ));
        }
        if let Some(path) = &args.output {
            out::say(format_args!("height map written to {}", path.display()));
        }
        ExitCode::SUCCESS
    })
}

/// The X/Y extents of the G-code job in `path` (work coordinates of the
/// offsets in force), as its interpretation gives them. Not checked
/// against the soft limits: a job whose Z zero is not set yet (the usual
/// order: the map first, then the touch-off) is still a job with an area.
fn job_area(
    profile: &Profile,
    offsets: &crate::offsets::WorkOffsets,
    path: &std::path::Path,
) -> Result<Area, String> {
    use crate::gcode::profile::{machine_of, setup_of};
    let name = path.display().to_string();
    let bytes = crate::cli::import::read_bounded(path, crate::gcode::MAX_FILE_BYTES)
        .map_err(|e| format!("--of {name}: {e}"))?;
    let text = String::from_utf8_lossy(&bytes);
    let target = crate::gcode::Target::of(profile.connection.protocol)?;
    let setup = setup_of(profile, offsets).map_err(|errors| {
        let first = errors
            .first()
            .map_or_else(String::new, |e| format!("{}: {}", e.key, e.message));
        format!("--of {name}: profile: {first}")
    })?;
    let toolpath = crate::gcode::interpret(&text, &setup).map_err(|d| {
        let first = d.first().map_or_else(String::new, |d| {
            format!("{name}:{}:{}: {}", d.origin.line, d.origin.col, d.message)
        });
        format!("--of: the job does not read: {first}")
    })?;
    let e = crate::gcode::check::summarise(&toolpath, &machine_of(profile, target)).extents;
    if !(e.max.x > e.min.x && e.max.y > e.min.y) {
        return Err(format!("--of {name}: the job covers no area in X and Y"));
    }
    Ok(Area {
        x0: e.min.x,
        y0: e.min.y,
        x1: e.max.x,
        y1: e.max.y,
    })
}

/// Each point in turn: X and Y there (at the height the tool stands), the
/// probe down and back up. The surface's machine Z per point, mm.
async fn probe_points(
    session: &mut Session,
    profile: &Profile,
    machine: &[(f64, f64)],
    probe: crate::device::api::ProbeMove,
    remedy: &Remedy,
) -> Result<Vec<f64>, ExitCode> {
    let (mut operator, _) = set_up(session, remedy).await.map_err(ExitCode::from)?;
    let rapid = |axis: Axis| {
        profile
            .axis(axis)
            .map_or(0.0, |a| a.speed_hz(a.max_speed).abs())
    };
    let mut zs = Vec::with_capacity(machine.len());
    for (i, &(x, y)) in machine.iter().enumerate() {
        let target = PerAxis::new()
            .with(Axis::X, probing::steps(profile, Axis::X, x))
            .with(Axis::Y, probing::steps(profile, Axis::Y, y));
        let hz = PerAxis::new()
            .with(Axis::X, rapid(Axis::X))
            .with(Axis::Y, rapid(Axis::Y));
        operator
            .move_to(session, target, hz, remedy)
            .await
            .map_err(ExitCode::from)?;
        let end = operator
            .probe(session, probe)
            .await
            .map_err(ExitCode::from)?;
        let what = format!(
            "the probe of point {} of {} (X {x:.3} Y {y:.3})",
            i + 1,
            machine.len()
        );
        match probing::touched(&end).and_then(|at| at.get(Axis::Z)) {
            Some(z) => zs.push(probing::units(profile, Axis::Z, z)),
            None => return Err(not_touched(profile, &what, Axis::Z, &end, remedy)),
        }
    }
    Ok(zs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_area_is_two_corners() {
        let a = parse_area("X100 Y80 X0 Y0").expect("area");
        assert_eq!((a.x0, a.y0, a.x1, a.y1), (0.0, 0.0, 100.0, 80.0));
        assert!(parse_area("X0 Y0 X0 Y10").is_err());
        assert!(parse_area("X0 Y0 X10").is_err());
        assert!(parse_area("X0 Z0 X10 Y10").is_err());
        assert!(parse_area("Xa Y0 X10 Y10").is_err());
    }
}
