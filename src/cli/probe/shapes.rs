//! `jogterm probe corner` and `probe center`: several probes of X and Y
//! and the moves between them (`docs/probing.md`, "Corners and bores").
//!
//! A corner: the probe stands outside the corner at cutting depth, off
//! both faces by less than `probe.clearance`. For the X face it first
//! moves along Y by twice the clearance (beside the face, still off it in
//! X), probes X, and goes back; then the Y face the same way along X. A
//! bore: the probe stands inside, near the centre; X+ and X- give the
//! centre in X (the tip cancels out), it moves there, then Y+ and Y-.

use std::process::ExitCode;

use clap::{Args, ValueEnum};
use serde_json::json;

use super::{Common, Operator, not_touched, out, print_line, saved_status, set_zeros};
use crate::axis::Axis;
use crate::cli::session::Session;
use crate::cli::upload::Remedy;
use crate::config::Profile;
use crate::device::api::{Dir, PerAxis, ProbeEnd};
use crate::offsets::store::OffsetsFile;
use crate::probing;

#[derive(Debug, Args)]
pub struct CornerArgs {
    /// The directions the probe moves toward the two faces
    #[arg(value_enum)]
    pub corner: Corner,
    #[command(flatten)]
    pub common: Common,
}

#[derive(Debug, Args)]
pub struct CenterArgs {
    #[command(flatten)]
    pub common: Common,
}

/// Named by the directions the probe moves (`x+y+`: toward larger X and
/// Y, so it finds the corner at the stock's smallest X and Y).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Corner {
    #[value(name = "x+y+")]
    PlusPlus,
    #[value(name = "x-y+")]
    MinusPlus,
    #[value(name = "x+y-")]
    PlusMinus,
    #[value(name = "x-y-")]
    MinusMinus,
}

impl Corner {
    fn dirs(self) -> (Dir, Dir) {
        match self {
            Corner::PlusPlus => (Dir::Plus, Dir::Plus),
            Corner::MinusPlus => (Dir::Minus, Dir::Plus),
            Corner::PlusMinus => (Dir::Plus, Dir::Minus),
            Corner::MinusMinus => (Dir::Minus, Dir::Minus),
        }
    }
}

/// What went wrong, as the exit status; or the probe that did not touch.
pub enum Failed {
    Status(u8),
    NotTouched(String, Axis, ProbeEnd),
}

impl From<u8> for Failed {
    fn from(code: u8) -> Failed {
        Failed::Status(code)
    }
}

/// One probe along `axis` toward `dir`: the touched machine units.
async fn touch(
    operator: &mut Operator,
    session: &mut Session,
    profile: &Profile,
    axis: Axis,
    dir: Dir,
) -> Result<f64, Failed> {
    let probe = probing::probe_move(profile, axis, dir).map_err(|m| {
        out::say(format_args!("jogterm probe: {m}"));
        Failed::Status(2)
    })?;
    let end = operator.probe(session, probe).await?;
    match probing::touched(&end).and_then(|at| at.get(axis)) {
        Some(steps) => Ok(probing::units(profile, axis, steps)),
        None => Err(Failed::NotTouched(
            format!("the probe of {axis}{}", dir.symbol()),
            axis,
            end,
        )),
    }
}

/// A move of `axis` to machine `units` at its top speed.
async fn go(
    operator: &mut Operator,
    session: &mut Session,
    profile: &Profile,
    axis: Axis,
    units: f64,
    remedy: &Remedy,
) -> Result<(), Failed> {
    let target = PerAxis::new().with(axis, probing::steps(profile, axis, units));
    let hz = profile
        .axis(axis)
        .map_or(0.0, |a| a.speed_hz(a.max_speed).abs());
    operator
        .move_to(session, target, PerAxis::new().with(axis, hz), remedy)
        .await
        .map_err(Failed::Status)
}

/// Where the axes stand, machine units.
fn here(profile: &Profile, at: Option<PerAxis<i64>>, axis: Axis) -> Result<f64, Failed> {
    match at.and_then(|p| p.get(axis)) {
        Some(steps) => Ok(probing::units(profile, axis, steps)),
        None => {
            out::say(format_args!(
                "jogterm probe: the controller reported no position of {axis}"
            ));
            Err(Failed::Status(1))
        }
    }
}

/// The two faces of a corner: their X and Y, machine units.
pub async fn corner(
    operator: &mut Operator,
    session: &mut Session,
    profile: &Profile,
    at: Option<PerAxis<i64>>,
    corner: Corner,
    remedy: &Remedy,
) -> Result<(f64, f64), Failed> {
    let (dx, dy) = corner.dirs();
    let (x0, y0) = (here(profile, at, Axis::X)?, here(profile, at, Axis::Y)?);
    let aside = 2.0 * profile.probe.clearance;
    let tip = profile.probe.tip;
    go(
        operator,
        session,
        profile,
        Axis::Y,
        y0 + dy.sign() as f64 * aside,
        remedy,
    )
    .await?;
    let x = touch(operator, session, profile, Axis::X, dx).await?;
    go(operator, session, profile, Axis::Y, y0, remedy).await?;
    go(
        operator,
        session,
        profile,
        Axis::X,
        x0 + dx.sign() as f64 * aside,
        remedy,
    )
    .await?;
    let y = touch(operator, session, profile, Axis::Y, dy).await?;
    go(operator, session, profile, Axis::X, x0, remedy).await?;
    Ok((probing::edge(x, dx, tip), probing::edge(y, dy, tip)))
}

/// The centre of a bore and its diameters in X and Y, machine units.
pub async fn center(
    operator: &mut Operator,
    session: &mut Session,
    profile: &Profile,
    remedy: &Remedy,
) -> Result<((f64, f64), (f64, f64)), Failed> {
    let tip = profile.probe.tip;
    let mut centre = [0.0; 2];
    let mut diameter = [0.0; 2];
    for (i, axis) in [Axis::X, Axis::Y].into_iter().enumerate() {
        let plus = touch(operator, session, profile, axis, Dir::Plus).await?;
        let minus = touch(operator, session, profile, axis, Dir::Minus).await?;
        let mid = (plus + minus) / 2.0;
        go(operator, session, profile, axis, mid, remedy).await?;
        centre[i] = mid;
        diameter[i] = plus - minus + tip;
    }
    Ok(((centre[0], centre[1]), (diameter[0], diameter[1])))
}

/// Corners and bores set X and Y of the work offset; said and saved.
pub fn finish(
    profile: &Profile,
    file: Option<&OffsetsFile>,
    common: &Common,
    system: Option<crate::offsets::System>,
    result: Result<(f64, f64), Failed>,
    diameters: Option<(f64, f64)>,
    remedy: &Remedy,
) -> ExitCode {
    let (x, y) = match result {
        Ok(xy) => xy,
        Err(Failed::Status(code)) => return ExitCode::from(code),
        Err(Failed::NotTouched(what, axis, end)) => {
            return not_touched(profile, &what, axis, &end, remedy);
        }
    };
    let (system, saved) = set_zeros(profile, file, system, &[(Axis::X, x), (Axis::Y, y)]);
    if common.json {
        let mut value = json!({
            "work_offset": system.to_string(),
            "zero_machine_mm": {"x": x, "y": y},
            "saved": saved.as_ref().ok(),
        });
        if let (Some((dx, dy)), Some(map)) = (diameters, value.as_object_mut()) {
            map.insert("diameter_mm".into(), json!({"x": dx, "y": dy}));
        }
        print_line(&value);
    } else {
        if let Some((dx, dy)) = diameters {
            out::say(format_args!("bore diameter {dx:.4} in X, {dy:.4} in Y"));
        }
        out::say(format_args!(
            "{system} X Y zero set to {x:.4} {y:.4} (machine)"
        ));
    }
    saved_status(&saved)
}
