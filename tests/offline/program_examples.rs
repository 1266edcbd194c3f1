//! The example programs in `examples/programs` are clean for the machine
//! profiles they are written for, and end where their comments say.

use std::path::Path;

use jogterm::axis::AxisSet;
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::program::{Language, LintConfig, PathEnd, Program, SegmentKind, Start, lint, path};

fn example(name: &str) -> Program {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/programs")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
    let language = Language::from_path(&path).unwrap_or_else(|| panic!("{name}: extension"));
    Program::parse(language, &text)
}

fn config(profile: &str) -> LintConfig {
    let profile = load_profile(profile, &ConfigDirs::builtin_only()).expect("shipped profile");
    LintConfig::from_profile(&profile)
}

#[test]
fn every_example_is_clean_for_its_profile() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/programs");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("examples/programs") {
        let name = entry
            .expect("entry")
            .file_name()
            .to_string_lossy()
            .into_owned();
        let program = example(&name);
        let profile = match program.language() {
            Language::Isel => "default",
            Language::Emcu => "emcu",
        };
        let diagnostics = lint(&program, &config(profile));
        assert_eq!(diagnostics, vec![], "{name}");
        seen += 1;
    }
    assert!(seen >= 4);
}

#[test]
fn the_examples_end_where_they_say() {
    let xyz = Start::at_zero(AxisSet::XYZ);
    let drill = path(&example("drill-pattern.isel"), &xyz);
    assert_eq!(drill.finish, PathEnd::End { line: 17 });
    assert_eq!(drill.end, [0, 0, 24000, 0]);
    // 12 holes: each a plunge and a lift.
    let plunges = drill
        .segments
        .iter()
        .filter(|s| s.to[2] == 16000 && s.from[2] == 24000)
        .count();
    assert_eq!(plunges, 12);
    let circle = path(&example("circle.isel"), &xyz);
    let arc_end = circle
        .segments
        .iter()
        .find(|s| matches!(s.kind, SegmentKind::Arc(_)))
        .map(|s| s.to);
    // The arc ends where the absolute move after it goes, which then has
    // nothing left to do.
    assert_eq!(arc_end, Some([4000, 3718, 8000, 0]));
    assert!(matches!(
        circle.segments.last().map(|s| &s.kind),
        Some(SegmentKind::Arc(_))
    ));
    assert_eq!(circle.end, [4000, 3718, 8000, 0]);
    let probe = path(&example("probe.isel"), &xyz);
    // The path assumes the probe never closes and the branch is not taken.
    assert_eq!(probe.end, [20000, 20000, 4000, 0]);
    let job = path(&example("pick-and-place.job"), &xyz);
    assert_eq!(job.end, [0, 0, 8000, 0]);
    assert_eq!(job.finish, PathEnd::Finished);
}
