//! Configuration loader: profile and theme files.

use crate::fuzz_checks;
use crate::fuzz_inputs;

use proptest::prelude::*;

proptest! {
    #![proptest_config(fuzz_inputs::config())]

    #[test]
    fn config(data in fuzz_inputs::inputs("config")) {
        fuzz_checks::config::config(&data);
    }
}

#[test]
fn every_config_seed_passes() {
    for seed in fuzz_inputs::seeds("config") {
        fuzz_checks::config::config(&seed);
    }
}

// Found while writing the config target.

/// A profile named by a path that never ends (`/dev/zero` reads as an
/// endless run of NUL characters, which is valid UTF-8) was read whole, so
/// jogterm filled memory before it could report anything.
#[test]
fn a_file_that_never_ends_is_refused_after_a_bounded_read() {
    use jogterm::config::{ConfigDirs, MAX_FILE_BYTES, load_profile, load_theme};
    let dir = tempfile::tempdir().expect("temp dir");
    let patch = dir.path().join("zero.toml");
    std::fs::write(&patch, "base = \"/dev/zero\"\n").expect("write");
    let dirs = ConfigDirs::builtin_only();
    let limit = format!("larger than {} KiB", MAX_FILE_BYTES / 1024);
    let results = [
        load_profile("/dev/zero", &dirs).map(|_| ()),
        load_profile(&patch.to_string_lossy(), &dirs).map(|_| ()),
        load_theme("/dev/zero", &dirs).map(|_| ()),
    ];
    for result in results {
        let err = result.expect_err("/dev/zero is no configuration");
        assert!(err.to_string().contains(&limit), "{err}");
    }
}
