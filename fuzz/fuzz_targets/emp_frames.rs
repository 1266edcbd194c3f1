//! cargo-fuzz target: EMP frame decoder, requests and replies decoded from the frames, the correlator.
//! The properties are in `tests/fuzz/fuzz_checks`, shared with the proptest
//! suites (`docs/fuzzing.md`).
#![no_main]

// One target checks one property of the shared set.
#[allow(dead_code)]
#[path = "../../tests/fuzz/fuzz_checks/mod.rs"]
mod fuzz_checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_checks::emp::frames(data));
