//! A long job converted on two threads is the program one thread makes,
//! line for line: wherever the cut falls, whatever stands before it (an
//! arc in another plane, one made as a line, a pause, a retract).

use proptest::prelude::*;

use super::{SPLIT_MIN_OPS, convert_ops_from, cut_of};
use crate::config::profile::Profile;
use crate::config::{ConfigDirs, load_profile};
use crate::gcode::output::Header;
use crate::gcode::profile::setup_of;
use crate::gcode::{Options, Toolpath, interpret};
use crate::offsets::WorkOffsets;

fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("the default profile")
}

fn toolpath(text: &str, profile: &Profile) -> Toolpath {
    let setup = setup_of(profile, &WorkOffsets::default()).expect("the default profile's setup");
    interpret(text, &setup).expect("the test's G-code interprets")
}

/// The program of `path` made on one thread and made cut in two (however
/// short): both, for comparison.
fn both_ways(
    path: &Toolpath,
    profile: &Profile,
) -> [Result<super::Program, Vec<crate::gcode::Diagnostic>>; 2] {
    let header = Header {
        file: "split.nc".into(),
        profile: profile.name.clone(),
        system: "G54".into(),
        zero: Default::default(),
    };
    let options = Options::default();
    [usize::MAX, 0].map(|split_min| {
        convert_ops_from(
            || path.ops.iter(),
            profile,
            &header,
            &options,
            split_min,
            None,
        )
    })
}

/// Lines of the kinds a CAM job holds, in mm within the default
/// machine's travel.
fn line() -> impl Strategy<Value = String> {
    let mm = || 1.0..60.0f64;
    prop_oneof![
        4 => (mm(), mm()).prop_map(|(x, y)| format!("G1 X{x:.3} Y{y:.3} F600")),
        // Collinear runs the output merges.
        2 => (mm(), 0..4u32).prop_map(|(x, n)| {
            (0..=n).map(|k| format!("G1 X{:.3} Y10 F600", x + f64::from(k) * 0.5)).collect::<Vec<_>>().join("\n")
        }),
        2 => (0.5..20.0f64).prop_map(|z| format!("G0 Z{z:.3}")),
        1 => (mm(), mm()).prop_map(|(x, y)| format!("G0 X{x:.3} Y{y:.3}")),
        2 => (1.0..8.0f64, any::<bool>()).prop_map(|(r, cw)| {
            let g = if cw { 2 } else { 3 };
            format!("G1 X30 Y30 F600\nG17 G{g} X{:.3} Y30 I{r:.3} J0 F400", 30.0 + 2.0 * r)
        }),
        1 => (1.0..8.0f64).prop_map(|r| format!("G1 X30 Z5 F600\nG18 G2 X{:.3} Z5 I{r:.3} K0 F400\nG17", 30.0 + 2.0 * r)),
        1 => (1.0..8.0f64).prop_map(|r| format!("G1 Y30 Z5 F600\nG19 G3 Y{:.3} Z5 J{r:.3} K0 F400\nG17", 30.0 + 2.0 * r)),
        // An arc shorter than a step: made as a line, no plane set.
        1 => Just("G1 X30 Z5 F600\nG18 G2 X30.0001 Z5 I0.00005 K0 F400\nG17".to_owned()),
        1 => Just("G4 P0.5".to_owned()),
        1 => Just("M3\nM5".to_owned()),
        1 => Just("S12000".to_owned()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn a_job_cut_in_two_converts_as_on_one_thread(lines in prop::collection::vec(line(), 1..40)) {
        let profile = profile();
        let text = format!("G21 G90 G17\nG0 X30 Y30 Z10\n{}\nG0 Z20\nM30\n", lines.join("\n"));
        let path = toolpath(&text, &profile);
        let [one, two] = both_ways(&path, &profile);
        prop_assert_eq!(one, two);
    }
}

/// The cut's guess of the plane is wrong here: the last arc before it is
/// in XZ but made as a line (shorter than a step), so the writer still
/// stands in XY, and the XZ arc after the cut needs its `e`. The second
/// part is converted again from where the first ended.
#[test]
fn a_wrong_guess_of_the_plane_converts_the_second_part_again() {
    let profile = profile();
    let mut text = String::from("G21 G90 G17\nG0 X30 Y30 Z10\n");
    for _ in 0..20 {
        text.push_str("G2 X40 Y30 I5 J0 F400\nG3 X30 Y30 I-5 J0\n");
    }
    text.push_str("G18 G2 X30.0001 Z10 I0.00005 K0\nG0 Z12\nG0 X30 Z10\nG2 X40 Z10 I5 K0\nM30\n");
    let path = toolpath(&text, &profile);
    let cut = cut_of(&|| path.ops.iter(), 0.0).expect("a rapid to cut at");
    assert_eq!(cut.plane, Some(crate::gcode::Plane::Zx));
    let [one, two] = both_ways(&path, &profile);
    let program = one.clone().expect("the job converts");
    assert!(
        program
            .lines
            .iter()
            .filter(|l| l.command.starts_with('e'))
            .count()
            >= 1,
        "the XZ arc after the cut sets its plane"
    );
    assert_eq!(one, two);
}

/// A job long enough is cut, and its program is one thread's.
#[test]
fn a_long_job_is_cut_and_converts_as_on_one_thread() {
    let profile = profile();
    let mut text = String::from("G21 G90 G17\nG0 X30 Y30 Z10\n");
    let mut k = 0usize;
    while k < SPLIT_MIN_OPS + 1000 {
        let a = 30.0 + (k % 40) as f64 * 0.25;
        text.push_str(&format!(
            "G1 X{a:.3} Y30 F600\nG2 X{:.3} Y30 I1 J0\nG0 Z{}\nG1 Z5\n",
            a + 2.0,
            10 + k % 3,
        ));
        k += 4;
    }
    text.push_str("M30\n");
    let path = toolpath(&text, &profile);
    assert!(path.ops.len() >= SPLIT_MIN_OPS);
    assert!(cut_of(&|| path.ops.iter(), 0.0).is_some());
    let [one, two] = both_ways(&path, &profile);
    assert!(one.is_ok());
    assert_eq!(one, two);
}
