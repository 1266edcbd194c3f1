//! EMP: frame decoder, request and reply decoding, the correlator.

use crate::fuzz_checks;
use crate::fuzz_inputs;

use proptest::prelude::*;

proptest! {
    #![proptest_config(fuzz_inputs::config())]

    #[test]
    fn frames(data in fuzz_inputs::inputs("emp_frames")) {
        fuzz_checks::emp::frames(&data);
    }
}

#[test]
fn every_emp_frames_seed_passes() {
    for seed in fuzz_inputs::seeds("emp_frames") {
        fuzz_checks::emp::frames(&seed);
    }
}
