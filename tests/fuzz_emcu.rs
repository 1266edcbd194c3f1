//! EMCU: reply decoder and the interface's side (command framer and parser).
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
    fn reply_decoder(data in fuzz_inputs::inputs("emcu_reply")) {
        fuzz_checks::emcu::reply(&data);
    }

    #[test]
    fn command_side(data in fuzz_inputs::inputs("emcu_command")) {
        fuzz_checks::emcu::command(&data);
    }
}

#[test]
fn every_emcu_reply_seed_passes() {
    for seed in fuzz_inputs::seeds("emcu_reply") {
        fuzz_checks::emcu::reply(&seed);
    }
}

#[test]
fn every_emcu_command_seed_passes() {
    for seed in fuzz_inputs::seeds("emcu_command") {
        fuzz_checks::emcu::command(&seed);
    }
}
