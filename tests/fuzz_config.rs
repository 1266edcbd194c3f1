//! Configuration loader: profile and theme files.
//!
//! Proptest engine of the fuzz suite (`docs/fuzzing.md`): inputs from
//! `tests/fuzz_inputs`, properties from `tests/fuzz_checks` (the same ones the
//! cargo-fuzz targets in `fuzz/` check). `JOGTERM_FUZZ_CASES` sets the number
//! of cases.

mod fuzz_checks;
mod fuzz_inputs;

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
