//! isel @-format: reply decoder (every kind of reply) and the controller's side (request framer, DNC and CNC line parsers).
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
    fn reply_decoder(data in fuzz_inputs::inputs("isel_reply")) {
        fuzz_checks::isel::reply(&data);
    }

    #[test]
    fn request_side(data in fuzz_inputs::inputs("isel_request")) {
        fuzz_checks::isel::request(&data);
    }
}

#[test]
fn every_isel_reply_seed_passes() {
    for seed in fuzz_inputs::seeds("isel_reply") {
        fuzz_checks::isel::reply(&seed);
    }
}

#[test]
fn every_isel_request_seed_passes() {
    for seed in fuzz_inputs::seeds("isel_request") {
        fuzz_checks::isel::request(&seed);
    }
}
