//! The fault-injection harness (`docs/faults.md`), shared by the fault
//! suite (`faults.rs`, with its own runner, `faults_runner.rs`) and the
//! end-to-end tests that drive the console: the real console in a pty
//! ([`console`]) and what the controller received split into commands
//! ([`wire`]). The simulator process is [`crate::sim_process`].

pub mod console;
pub mod wire;
