//! Simulators fed arbitrary bytes through the shell's engine.
//!
//! Proptest engine of the fuzz suite (`docs/fuzzing.md`): inputs from
//! `tests/fuzz_inputs`, properties from `tests/fuzz_checks` (the same ones the
//! cargo-fuzz targets in `fuzz/` check). `JOGTERM_FUZZ_CASES` sets the number
//! of cases.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod fuzz_checks;
mod fuzz_inputs;

use proptest::prelude::*;

proptest! {
    #![proptest_config(fuzz_inputs::config())]

    #[test]
    fn simulators(data in fuzz_inputs::inputs("sim")) {
        fuzz_checks::sim::drive(&data);
    }
}

#[test]
fn every_sim_seed_passes() {
    for seed in fuzz_inputs::seeds("sim") {
        fuzz_checks::sim::drive(&seed);
    }
}
