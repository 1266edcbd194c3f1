//! Probing as an operator asks for it (`docs/probing.md`), sans-IO: the
//! probe move of the profile's `[probe]` table in steps, what a touched
//! point means for a work offset (Z touch-off, edges, bores), and the words
//! for how a probe ended. The console and `jogterm probe` both use it; the
//! probing move itself is the device's (`Request::Probe`,
//! `device::common::probe`).

use crate::axis::Axis;
use crate::config::Profile;
use crate::config::probe::ProbeProfile;
use crate::config::profile::AxisProfile;
use crate::device::api::{Dir, PerAxis, ProbeEnd, ProbeMove};

/// The probe move along `axis` toward smaller (`Dir::Minus`) or larger
/// machine units, from the profile: travel and speeds in steps (the speeds
/// at most the axis's `max_speed`).
pub fn probe_move(profile: &Profile, axis: Axis, toward: Dir) -> Result<ProbeMove, String> {
    let a = profile
        .axis(axis)
        .ok_or_else(|| format!("the machine has no {axis} axis"))?;
    Ok(probe_move_of(a, &profile.probe, axis, toward))
}

/// The same for an axis and a `[probe]` table at hand.
pub fn probe_move_of(a: &AxisProfile, p: &ProbeProfile, axis: Axis, toward: Dir) -> ProbeMove {
    let spu = a.steps_per_unit;
    // Steps count the other way where steps_per_unit is negative.
    let dir = if spu < 0.0 { toward.reverse() } else { toward };
    let hz = |speed: f64| speed.min(a.max_speed) * spu.abs();
    ProbeMove {
        axis,
        dir,
        travel: (p.travel * spu).abs().round() as i64,
        fast_hz: hz(p.fast_speed),
        slow_hz: hz(p.slow_speed),
    }
}

/// Machine units of `steps` on `axis`.
pub fn units(profile: &Profile, axis: Axis, steps: i64) -> f64 {
    profile.axis(axis).map_or(0.0, |a| a.to_units(steps))
}

/// Machine steps of `units` on `axis`.
pub fn steps(profile: &Profile, axis: Axis, units: f64) -> i64 {
    profile.axis(axis).map_or(0, |a| a.to_steps(units))
}

/// Machine steps of a point in machine units, `(axis, units)` each; an axis
/// the profile does not have is left out.
pub fn steps_of(profile: &Profile, units: impl IntoIterator<Item = (Axis, f64)>) -> PerAxis<i64> {
    let mut out = PerAxis::new();
    for (axis, v) in units {
        if let Some(a) = profile.axis(axis) {
            out.set(axis, a.to_steps(v));
        }
    }
    out
}

/// The work zero of Z (machine steps) from a touched Z: the surface minus
/// the plate the tool touched on.
pub fn touch_off_zero(z: &AxisProfile, touched_z: i64, plate: f64) -> i64 {
    z.to_steps(z.to_units(touched_z) - plate)
}

/// One go-to on the way to the tool sensor or back: the target (machine
/// steps) and each moving axis' speed (Hz).
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    pub target: PerAxis<i64>,
    pub speed_hz: PerAxis<f64>,
}

/// From `here` to `to` (machine steps) as a tool travels near the work and
/// the sensor: Z up alone first, to the higher of the two, then X and Y
/// over, then Z down; each axis at its `max_speed`. Only the axes `to`
/// names move; a leg that would move nothing is left out. `jogterm run`
/// and the console both go to the sensor and back this way.
pub fn up_over_down(profile: &Profile, here: &PerAxis<i64>, to: &PerAxis<i64>) -> Vec<Leg> {
    let rapid = |axis: Axis| {
        profile
            .axis(axis)
            .map_or(0.0, |a| a.speed_hz(a.max_speed).abs())
    };
    let mut legs = Vec::new();
    let mut at = *here;
    let mut go = |target: PerAxis<i64>, legs: &mut Vec<Leg>| {
        let mut speed_hz = PerAxis::new();
        let mut moves = false;
        for (axis, steps) in target.iter() {
            speed_hz.set(axis, rapid(axis));
            moves |= at.get(axis) != Some(steps);
            at.set(axis, steps);
        }
        if moves {
            legs.push(Leg { target, speed_hz });
        }
    };
    let here_z = here.get(Axis::Z);
    let to_z = to.get(Axis::Z).or(here_z);
    if let (Some(from), Some(end)) = (here_z, to_z) {
        go(PerAxis::new().with(Axis::Z, from.max(end)), &mut legs);
    }
    let mut over = PerAxis::new();
    for (axis, steps) in to.iter().filter(|(axis, _)| *axis != Axis::Z) {
        over.set(axis, steps);
    }
    if !over.axes().is_empty() {
        go(over, &mut legs);
    }
    if let Some(end) = to_z {
        go(PerAxis::new().with(Axis::Z, end), &mut legs);
    }
    legs
}

/// Where the face lies (machine units) that a probe moving `toward` along
/// its axis touched with its centre at `touched` units: half the tip
/// further on.
pub fn edge(touched: f64, toward: Dir, tip: f64) -> f64 {
    touched + toward.sign() as f64 * tip / 2.0
}

/// The touched point of a probe that touched.
pub fn touched(end: &ProbeEnd) -> Option<&PerAxis<i64>> {
    match end {
        ProbeEnd::Touched { at, .. } => Some(at),
        _ => None,
    }
}

/// How a probe ended, in words (`what`: "the probe of Z-"; `axis`: its
/// axis as the profile describes it).
pub fn end_text(what: &str, axis: (Axis, &AxisProfile), end: &ProbeEnd) -> String {
    let (axis, a) = axis;
    match end {
        ProbeEnd::Touched { at, fast_stop } => {
            let z = at.get(axis).unwrap_or(0);
            format!(
                "{what} touched at {axis} {:.4} {unit} (the fast pass stopped {:.4} past it)",
                a.to_units(z),
                a.to_units(fast_stop - z).abs(),
                unit = a.unit.symbol(),
            )
        }
        ProbeEnd::NoTrip { travel } => format!(
            "{what} found no surface within its travel ({:.3} {}): it went back to where it \
             started",
            a.to_units(*travel).abs(),
            a.unit.symbol()
        ),
        ProbeEnd::Stopped => format!("{what} was stopped; nothing resumes"),
        ProbeEnd::Refused(why) => format!("{what} was refused: {why}"),
        ProbeEnd::Fault(f) => format!("{what} ended with an error: {}", f.meaning),
        ProbeEnd::LinkLost => format!("{what} ended: the link was lost; nothing resumes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn isel() -> Profile {
        load_profile("default", &ConfigDirs::builtin_only()).expect("profile")
    }

    #[test]
    fn the_probe_move_is_the_profiles_table_in_steps() {
        let p = probe_move(&isel(), Axis::Z, Dir::Minus).expect("Z");
        // 10 mm at 400 steps/mm; 5 and 0.5 mm/s.
        assert_eq!(p.travel, 4000);
        assert_eq!(p.dir, Dir::Minus);
        assert_eq!(p.fast_hz, 2000.0);
        assert_eq!(p.slow_hz, 200.0);
        assert!(probe_move(&isel(), Axis::A, Dir::Minus).is_err());
    }

    #[test]
    fn the_work_zero_is_the_surface_minus_the_plate() {
        // Touched at 30 mm on a 1.5 mm plate: work Z 0 at 28.5 mm.
        let profile = isel();
        let z = profile.axis(Axis::Z).expect("Z");
        assert_eq!(touch_off_zero(z, 12_000, 1.5), 11_400);
        assert_eq!(touch_off_zero(z, 12_000, 0.0), 12_000);
    }

    #[test]
    fn the_way_to_the_sensor_goes_up_alone_over_and_down() {
        let profile = isel();
        let at = |x: i64, y: i64, z: i64| {
            PerAxis::new()
                .with(Axis::X, x)
                .with(Axis::Y, y)
                .with(Axis::Z, z)
        };
        let targets =
            |legs: Vec<Leg>| -> Vec<PerAxis<i64>> { legs.into_iter().map(|l| l.target).collect() };
        // From below the sensor point: up to it, over, nothing down.
        let legs = up_over_down(&profile, &at(100, 100, 1000), &at(10_000, 0, 11_000));
        assert_eq!(
            targets(legs.clone()),
            vec![
                PerAxis::new().with(Axis::Z, 11_000),
                PerAxis::new().with(Axis::X, 10_000).with(Axis::Y, 0),
            ]
        );
        // Each moving axis at its max_speed (isel: 400 steps/mm).
        let z = profile.axis(Axis::Z).expect("Z");
        assert_eq!(
            legs[0].speed_hz.get(Axis::Z),
            Some(z.speed_hz(z.max_speed).abs())
        );
        // From above it: over, then down; no leg up.
        assert_eq!(
            targets(up_over_down(
                &profile,
                &at(0, 0, 16_000),
                &at(10_000, 0, 11_000)
            )),
            vec![
                PerAxis::new().with(Axis::X, 10_000).with(Axis::Y, 0),
                PerAxis::new().with(Axis::Z, 11_000),
            ]
        );
        // Standing there already: nothing.
        assert!(up_over_down(&profile, &at(1, 2, 3), &at(1, 2, 3)).is_empty());
    }

    #[test]
    fn an_edge_lies_half_the_tip_beyond_the_touch() {
        assert_eq!(edge(10.0, Dir::Plus, 3.0), 11.5);
        assert_eq!(edge(10.0, Dir::Minus, 3.0), 8.5);
    }
}
