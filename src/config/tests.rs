//! Loading, layering and error placement of profiles and themes.

use std::fs;

use super::*;
use crate::axis::{Axis, AxisSet};
use crate::proto::Protocol;

fn user_dir() -> (tempfile::TempDir, ConfigDirs) {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir_all(dir.path().join("profiles")).unwrap();
    fs::create_dir_all(dir.path().join("themes")).unwrap();
    let dirs = ConfigDirs {
        user: Some(dir.path().to_path_buf()),
    };
    (dir, dirs)
}

#[test]
fn every_shipped_profile_and_theme_loads() {
    let dirs = ConfigDirs::builtin_only();
    for (name, _) in BUILTIN_PROFILES {
        load_profile(name, &dirs).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    for (name, _) in BUILTIN_THEMES {
        load_theme(name, &dirs).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn default_profile_is_the_isel_simulator() {
    let p = load_profile("default", &ConfigDirs::builtin_only()).unwrap();
    assert_eq!(p.connection.protocol, Protocol::Isel);
    assert!(p.connection.is_simulator());
    assert_eq!(p.axis_set(), AxisSet::XYZ);
    assert_eq!(p.connection.line().baud, 19200);
}

#[test]
fn emp_example_has_one_axis_on_drive_11() {
    let p = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
    assert_eq!(p.axis_set(), AxisSet::EMPTY.with(Axis::X));
    assert_eq!(p.axes[&Axis::X].drive.as_deref(), Some("11"));
    // Patched fields come from the file, the rest from the base axis.
    assert_eq!(p.axes[&Axis::X].steps_per_unit, 11200.0);
    assert_eq!(p.axes[&Axis::X].min, 0.0);
    assert_eq!(p.connection.line().baud, 38400);
}

#[test]
fn user_profile_patches_field_by_field() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/mill.toml"),
        "name = \"mill\"\n[axes.X]\nmax = 123.0\n[jog]\nspeed = 0\n",
    )
    .unwrap();
    let p = load_profile("mill", &dirs).unwrap();
    assert_eq!(p.name, "mill");
    assert_eq!(p.axes[&Axis::X].max, 123.0);
    assert_eq!(p.axes[&Axis::X].steps_per_unit, 400.0);
    assert_eq!(p.jog.speed, 0);
    assert_eq!(p.jog.steps.len(), 4);
}

#[test]
fn a_user_file_may_patch_the_shipped_one_of_the_same_name() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("themes/dark.toml"),
        "[styles]\nlit = { fg = \"magenta\" }\n",
    )
    .unwrap();
    let t = load_theme("dark", &dirs).unwrap();
    assert_eq!(t.name, "dark");
    assert_eq!(
        t.styles.lit.fg.map(|c| c.0),
        Some(ratatui::style::Color::Magenta)
    );
}

#[test]
fn base_chains_resolve_and_loops_are_refused() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/a.toml"),
        "base = \"emcu\"\nname = \"a\"\n",
    )
    .unwrap();
    let p = load_profile("a", &dirs).unwrap();
    assert_eq!(p.connection.protocol, Protocol::Emcu);
    fs::write(dir.path().join("profiles/b.toml"), "base = \"c\"\n").unwrap();
    fs::write(dir.path().join("profiles/c.toml"), "base = \"b\"\n").unwrap();
    let err = load_profile("b", &dirs).unwrap_err();
    assert!(err.message.contains("loops"), "{err}");
}

#[test]
fn wrong_type_names_file_line_and_expectation() {
    let (dir, dirs) = user_dir();
    let path = dir.path().join("profiles/bad.toml");
    fs::write(
        &path,
        "name = \"bad\"\n\n[axes.Y]\nsteps_per_unit = \"fast\"\n",
    )
    .unwrap();
    let err = load_profile("bad", &dirs).unwrap_err();
    assert_eq!(err.origin, Origin::File(path));
    assert_eq!(err.line, Some(4), "{err}");
    assert!(err.message.contains("expected f64"), "{err}");
    assert!(err.to_string().contains("bad.toml:4:"), "{err}");
}

#[test]
fn unknown_field_is_an_error_on_its_line() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/typo.toml"),
        "[jog]\nsteps = [1.0]\nspeeed = 3\n",
    )
    .unwrap();
    let err = load_profile("typo", &dirs).unwrap_err();
    assert_eq!(err.line, Some(3), "{err}");
    assert!(err.message.contains("speeed"), "{err}");
}

#[test]
fn semantic_errors_point_at_the_offending_key() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/limits.toml"),
        "# soft limits swapped\n[axes.Z]\nmin = 10.0\nmax = 5.0\n",
    )
    .unwrap();
    let err = load_profile("limits", &dirs).unwrap_err();
    assert_eq!(err.line, Some(4), "{err}");
    assert!(err.message.contains("min < max"), "{err}");
}

#[test]
fn isel_refuses_axis_combinations_it_cannot_drive() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/xz.toml"),
        "[machine]\naxes = \"XZ\"\n",
    )
    .unwrap();
    let err = load_profile("xz", &dirs).unwrap_err();
    assert_eq!(err.line, Some(2));
    assert!(err.message.contains("XYZ"), "{err}");
}

#[test]
fn emp_axes_need_distinct_drive_addresses() {
    let (dir, dirs) = user_dir();
    let text = "base = \"emp\"\n[machine]\naxes = \"XY\"\n[axes.Y]\ndrive = \"11\"\n";
    fs::write(dir.path().join("profiles/two.toml"), text).unwrap();
    let err = load_profile("two", &dirs).unwrap_err();
    assert!(err.message.contains("already axis X"), "{err}");
    assert_eq!(err.line, Some(5));
}

#[test]
fn syntax_error_and_missing_file_and_unknown_name() {
    let (dir, dirs) = user_dir();
    fs::write(dir.path().join("themes/broken.toml"), "[styles\n").unwrap();
    let err = load_theme("broken", &dirs).unwrap_err();
    assert_eq!(err.line, Some(1));
    let err = load_profile("/nonexistent/x.toml", &dirs).unwrap_err();
    assert!(err.message.contains("cannot read"), "{err}");
    let err = load_profile("nope", &dirs).unwrap_err();
    assert!(
        err.message.contains("known: default, isel, emcu, emp"),
        "{err}"
    );
}

#[test]
fn bad_colour_says_what_a_colour_is() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("themes/c.toml"),
        "[styles]\nok = { fg = \"greenish\" }\n",
    )
    .unwrap();
    let err = load_theme("c", &dirs).unwrap_err();
    assert_eq!(err.line, Some(2), "{err}");
    assert!(err.message.contains("not a colour"), "{err}");
}
