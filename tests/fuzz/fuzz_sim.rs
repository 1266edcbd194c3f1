//! Simulators fed arbitrary bytes through the shell's engine.

use crate::fuzz_checks;
use crate::fuzz_inputs;

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
