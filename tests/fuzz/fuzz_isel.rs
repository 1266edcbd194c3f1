//! isel @-format: reply decoder (every kind of reply) and the controller's side (request framer, DNC and CNC line parsers).

use crate::fuzz_checks;
use crate::fuzz_inputs;

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
