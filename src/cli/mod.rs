//! Command-line commands, each a clap `Args` struct and a `run` function.

pub mod arc;
pub mod check;
