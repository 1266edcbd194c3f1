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

/// Issue 37 (13): an infinite soft limit is named as what it is, at its
/// own key, not as "min < max".
#[test]
fn an_infinite_soft_limit_is_refused_at_its_key() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/inf.toml"),
        "[axes.X]\nmax = 100.0\nmin = -inf\n",
    )
    .unwrap();
    let err = load_profile("inf", &dirs).unwrap_err();
    assert_eq!(err.line, Some(3), "{err}");
    assert!(err.message.contains("finite"), "{err}");
    assert!(!err.message.contains("min < max"), "{err}");
}

/// Issue 37 (13): a user profile whose `base` is its own name, with no
/// shipped profile of that name, says so at its `base` line; before, it
/// said "no profile named `selfbase` (known: …, selfbase)".
#[test]
fn a_base_naming_its_own_file_says_so() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/selfbase.toml"),
        "# loops\nbase = \"selfbase\"\n",
    )
    .unwrap();
    let err = load_profile("selfbase", &dirs).unwrap_err();
    assert_eq!(err.line, Some(2), "{err}");
    assert!(err.message.contains("names this file itself"), "{err}");
    assert!(!err.message.contains("known:"), "{err}");
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

#[test]
fn every_problem_of_a_profile_is_reported_with_its_place() {
    let (dir, dirs) = user_dir();
    let path = dir.path().join("profiles/many.toml");
    // Two fields serde refuses, two checks of the whole, one bad [io]
    // entry: all five, in the order of the lines, each file:line:col.
    fs::write(
        &path,
        "name = \"many\"\n\
         [axes.X]\n\
         steps_per_unit = \"fast\"\n\
         [jog]\n\
         speeed = 3\n\
         step = 9\n\
         [axes.Z]\n\
         min = 10.0\n\
         max = 5.0\n\
         [io.\"in9.0\"]\n\
         wired = true\n",
    )
    .unwrap();
    let err = load_profile("many", &dirs).unwrap_err();
    let each = err.each();
    let lines: Vec<Option<usize>> = each.iter().map(|e| e.line).collect();
    assert_eq!(
        lines,
        [Some(3), Some(5), Some(6), Some(9), Some(10)],
        "{err}"
    );
    assert!(each.iter().all(|e| e.origin == Origin::File(path.clone())));
    assert!(each.iter().all(|e| e.column.is_some()), "{err}");
    let text = err.to_string();
    assert_eq!(text.lines().count(), 5, "{text}");
    for needle in [
        "expected f64",
        "speeed",
        "outside `steps`",
        "min < max",
        "in9.0",
    ] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
    assert!(text.lines().all(|l| l.contains("many.toml:")), "{text}");
}

#[test]
fn io_entries_patch_the_wiring_and_bad_ones_are_placed() {
    use crate::wiring::{LimitSwitch, Role, Side};
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/wired.toml"),
        "[io.\"in0.3\"]\nname = \"tool setter\"\nrole = \"probe\"\n\
         [io.\"in3.1\"]\nside = \"-\"\n",
    )
    .unwrap();
    let p = load_profile("wired", &dirs).unwrap();
    let wiring = p.wiring().expect("wiring");
    let probe = wiring.bit("in0.3").expect("bit");
    assert_eq!(
        (probe.name.as_str(), probe.role),
        ("tool setter", Role::Probe)
    );
    assert_eq!(
        wiring.bit("in3.1").map(|b| b.role),
        Some(Role::Limit(LimitSwitch {
            axis: Axis::X,
            side: Side::Min
        }))
    );
    fs::write(
        dir.path().join("profiles/badio.toml"),
        "[io.\"in0.3\"]\nrole = \"limit\"\n[io.\"in1.0\"]\nactive = \"sideways\"\n\
         [sim]\nvariants = [\"hood-unwired\", \"bogus\"]\n",
    )
    .unwrap();
    let err = load_profile("badio", &dirs).unwrap_err();
    let text = err.to_string();
    assert_eq!(text.lines().count(), 3, "{text}");
    assert!(text.contains("badio.toml:2:"), "{text}");
    assert!(text.contains("`axis`"), "{text}");
    assert!(text.contains("badio.toml:4:"), "{text}");
    assert!(text.contains("sideways"), "{text}");
    assert!(text.contains("unknown simulator variant `bogus`"), "{text}");
    // A variant of another family is refused where it is written.
    fs::write(
        dir.path().join("profiles/emcuhood.toml"),
        "base = \"emcu\"\n[sim]\nvariants = [\"hood-unwired\"]\n",
    )
    .unwrap();
    let err = load_profile("emcuhood", &dirs).unwrap_err();
    assert!(
        err.message.contains("emcu simulator has no variant"),
        "{err}"
    );
    assert_eq!(err.line, Some(3), "{err}");
}

#[test]
fn the_rewired_example_profile_says_what_its_machine_has() {
    use crate::wiring::{LimitSwitch, Role, Side};
    let p = load_profile("isel-rewired", &ConfigDirs::builtin_only()).unwrap();
    assert_eq!(p.connection.protocol, Protocol::Isel);
    let w = p.wiring().expect("wiring");
    let probe = w.bit("in0.3").expect("tool setter");
    assert_eq!(
        (probe.name.as_str(), probe.role),
        ("tool setter", Role::Probe)
    );
    assert!(
        probe.is_active(false) && !probe.is_active(true),
        "normally closed"
    );
    assert!(w.bit("in2.1").expect("power").interlocks());
    for hood in ["in2.5", "in2.6"] {
        assert!(!w.bit(hood).expect(hood).wired, "{hood}");
    }
    assert_eq!(w.bit("in2.7").map(|b| b.role), Some(Role::Unused));
    let y: Vec<(String, LimitSwitch)> = w
        .limit_switches()
        .filter(|(_, l)| l.axis == Axis::Y)
        .map(|(b, l)| (b.name.clone(), l))
        .collect();
    assert_eq!(
        y,
        [
            (
                "Y end".to_string(),
                LimitSwitch {
                    axis: Axis::Y,
                    side: Side::Max
                }
            ),
            (
                "Y home".to_string(),
                LimitSwitch {
                    axis: Axis::Y,
                    side: Side::Min
                }
            ),
        ]
    );
    assert_eq!(w.bit("out0.1").map(|b| b.name.as_str()), Some("coolant"));
    assert_eq!(
        w.bit("out0.1").map(|b| b.role),
        Some(crate::wiring::Role::Coolant)
    );
}

#[test]
fn macros_are_checked_at_load_and_a_bad_line_names_file_line_and_column() {
    let (dir, dirs) = user_dir();
    let file = dir.path().join("profiles/mill.toml");
    fs::write(
        &file,
        "name = \"mill\"\n\
         [macros.park]\n\
         description = \"Z up, then to the park position\"\n\
         lines = [\"@0P\", \"@0M 0,900,0,900,8000,900,0,900\"]\n\
         [macros.probe]\n\
         confirm = false\n\
         lines = [\n  \"@0b1\",\n]\n",
    )
    .unwrap();
    let p = load_profile("mill", &dirs).unwrap();
    let macros = p.macros().unwrap();
    assert_eq!(macros.len(), 2);
    assert_eq!(macros[0].name, "park");
    assert!(macros[0].moves && macros[0].confirm);
    assert!(!macros[1].moves && !macros[1].confirm);

    // Line 8 is the second line of `lines`; `@0M` with XYZ takes four
    // pairs, and the column is that of the place the parser names.
    fs::write(
        &file,
        "name = \"mill\"\n\
         [macros.park]\n\
         lines = [\n  \"@0P\",\n  \"@0M 0,900\",\n]\n\
         [macros.bad]\n\
         lines = [\"@0Q\"]\n",
    )
    .unwrap();
    let err = load_profile("mill", &dirs).unwrap_err();
    let all = err.each();
    assert_eq!(all.len(), 2, "{err}");
    let text = err.to_string();
    let bad = all.iter().find(|e| e.message.contains("`bad`")).unwrap();
    assert_eq!((bad.line, bad.column), (Some(8), Some(13)), "{text}");
    assert!(bad.message.contains("isel command expected"), "{text}");
    let park = all.iter().find(|e| e.message.contains("`park`")).unwrap();
    assert_eq!(park.line, Some(5), "{text}");
    assert!(park.column.unwrap() > 3, "{text}");
    assert!(park.message.contains("line 2"), "{text}");
    assert!(text.contains("mill.toml:5:"), "{text}");

    // A macro for another family's syntax is refused too.
    fs::write(
        &file,
        "name = \"mill\"\n[connection]\nprotocol = \"emcu\"\nport = \"sim\"\n\
         [macros.x]\nlines = [\"@0P\"]\n",
    )
    .unwrap();
    let err = load_profile("mill", &dirs).unwrap_err();
    assert_eq!(err.line, Some(6), "{err}");
    assert!(err.message.contains("emcu command expected"), "{err}");
}

/// The reply margin no manual states is the profile's (`docs/profiles.md`):
/// 100 ms when absent, and a margin outside 20 ms to 5 s is refused at its
/// line. That every family's driver takes it is
/// `device::common::settings::tests::every_family_takes_the_profiles_reply_margin`.
#[test]
fn the_reply_margin_is_the_profiles_and_checked() {
    use std::time::Duration;
    let (dir, dirs) = user_dir();
    let default = load_profile("default", &dirs).unwrap();
    assert_eq!(
        default.connection.reply_margin(),
        Duration::from_millis(100)
    );
    fs::write(
        dir.path().join("profiles/slow.toml"),
        "[connection]\nreply_margin_ms = 350\n",
    )
    .unwrap();
    let slow = load_profile("slow", &dirs).unwrap();
    assert_eq!(slow.connection.reply_margin(), Duration::from_millis(350));
    fs::write(
        dir.path().join("profiles/hasty.toml"),
        "# too short for any host\n[connection]\nreply_margin_ms = 5\n",
    )
    .unwrap();
    let err = load_profile("hasty", &dirs).unwrap_err();
    assert_eq!(err.line, Some(3), "{err}");
    assert!(err.message.contains("expected 20 to 5000 ms"), "{err}");
}

#[test]
fn the_plunge_feed_has_a_default_and_a_bad_one_is_refused_at_its_line() {
    let (dir, dirs) = user_dir();
    let default = load_profile("default", &dirs).unwrap();
    assert_eq!(
        default.gcode.plunge_feed,
        crate::config::profile::DEFAULT_PLUNGE_FEED
    );
    fs::write(
        dir.path().join("profiles/still.toml"),
        "[gcode]\nreference_first = false\nplunge_feed = 0\n",
    )
    .unwrap();
    let err = load_profile("still", &dirs).unwrap_err();
    assert_eq!(err.line, Some(3), "{err}");
    assert!(err.message.contains("must be a positive feed"), "{err}");
}

/// Issue 37: how long a session that only reads waits for an isel that
/// answers nothing is the profile's (600 s when absent, 1 s to a day), and
/// a baud rate no line runs at is refused at its line.
#[test]
fn the_busy_wait_and_the_baud_rate_are_checked_at_their_lines() {
    use std::time::Duration;
    let (dir, dirs) = user_dir();
    let default = load_profile("default", &dirs).unwrap();
    assert_eq!(default.isel.busy_wait(), Duration::from_secs(600));
    fs::write(
        dir.path().join("profiles/patient.toml"),
        "[isel]\nbusy_wait_s = 7200\n",
    )
    .unwrap();
    let patient = load_profile("patient", &dirs).unwrap();
    assert_eq!(patient.isel.busy_wait(), Duration::from_secs(7200));
    for (name, text, line, expected) in [
        (
            "never",
            "\n[isel]\nbusy_wait_s = 0\n",
            3,
            "expected 1 to 86400 s",
        ),
        (
            "still",
            "[connection]\nbaud = 0\n",
            2,
            "expected 300 to 4000000 baud",
        ),
        (
            "fast",
            "[connection]\nbaud = 5000000\n",
            2,
            "expected 300 to 4000000 baud",
        ),
    ] {
        fs::write(dir.path().join(format!("profiles/{name}.toml")), text).unwrap();
        let err = load_profile(name, &dirs).unwrap_err();
        assert_eq!(err.line, Some(line), "{name}: {err}");
        assert!(err.message.contains(expected), "{name}: {err}");
    }
    fs::write(
        dir.path().join("profiles/slow.toml"),
        "[connection]\nbaud = 300\n",
    )
    .unwrap();
    assert_eq!(
        load_profile("slow", &dirs).unwrap().connection.line().baud,
        300
    );
}

/// Issue 37 (13): a profile with several errors reports every one, each at
/// its line, also when `machine.axes` is one of them; before, a broken
/// axis list was the only error reported.
#[test]
fn every_error_of_a_profile_is_reported_at_its_line() {
    let (dir, dirs) = user_dir();
    fs::write(
        dir.path().join("profiles/several.toml"),
        "[machine]\naxes = \"XQ\"\n[axes.X]\nmin = 10.0\nmax = 5.0\n[jog]\nmax_overrun = -1.0\n",
    )
    .unwrap();
    let text = load_profile("several", &dirs).unwrap_err().to_string();
    for (line, what) in [
        (2, "`Q` is not an axis"),
        (5, "min < max"),
        (7, "positive distance"),
    ] {
        assert!(
            text.lines()
                .any(|l| l.contains(&format!("several.toml:{line}:")) && l.contains(what)),
            "{what} at line {line}:\n{text}"
        );
    }
}
