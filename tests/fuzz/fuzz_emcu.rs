//! EMCU: reply decoder and the interface's side (command framer and parser).

use crate::fuzz_checks;
use crate::fuzz_inputs;

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
