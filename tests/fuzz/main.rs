//! The proptest fuzz suites (`docs/fuzzing.md`), one module per target:
//! inputs from [`fuzz_inputs`], properties from [`fuzz_checks`] (the same
//! ones the cargo-fuzz targets in `fuzz/` check). `JOGTERM_FUZZ_CASES` sets
//! the number of cases; `.ci/run`'s fuzz round runs this crate alone with
//! many of them (`cargo test --test fuzz`).
//!
//! One test crate: each crate links the whole of jogterm, so the suites
//! share one binary (docs/architecture.md, "Tests").

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod fuzz_checks;
mod fuzz_inputs;

mod fuzz_config;
mod fuzz_emcu;
mod fuzz_emp;
mod fuzz_isel;
mod fuzz_program;
mod fuzz_sim;
