//! Tests in real time: the real `jogterm` binary in a pseudo-terminal or
//! with its standard streams (the console, `send`, `poll`, `upload`,
//! `watch`, `sim`), ser2net in between, and in-process device tasks,
//! transports and simulators over sockets and ptys against the wall clock.
//! Each test waits for what it expects with a bound, never for a fixed time.
//! Tests that measure a timing promise take [`timing::SERIAL`] while they
//! measure and so never run beside each other; the rest, ptys included, run
//! beside each other, five at a time (`.cargo/config.toml` sets libtest's
//! threads: most of these wait on the simulators' real time, not on the
//! CPU). Tests of logic that wait for real motion to end run the simulator
//! faster (`SimProcess::options(..).time_scale(..)`; `docs/testing.md`,
//! "The time scale", says which and why). `docs/testing.md` has the figures.
//!
//! One test crate: each crate links the whole of jogterm, so these share one
//! binary (docs/architecture.md, "Tests"). The fault-injection suite
//! (`faults.rs`) is a second crate in this directory with its own runner
//! (`harness = false` in Cargo.toml); it declares the support modules it uses
//! itself.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod console_big_jobs_e2e;
mod console_pty;
mod device_support;
mod faults_support;
mod jog_support;
mod ser2net_support;
mod sim_process;
mod sim_shell_support;
mod stops_support;
mod timing;
mod ui_pty;

mod checkout_e2e;
mod circle_e2e;
mod cli_arc;
mod cli_check;
mod cli_closed_output;
mod cli_commission;
mod cli_messages;
mod cli_probe_surface;
mod cli_send_poll;
mod cli_send_poll_emcu;
mod cli_send_poll_emp;
mod cli_sim_isel;
mod cli_upload;
mod cli_watch;
mod cli_wiring;
mod console_gcode_e2e;
mod console_toolchange_e2e;
mod device_emcu;
mod device_emp;
mod device_reconnect;
mod device_task;
mod editor_e2e;
mod eta_e2e;
mod frame_e2e;
mod gcode_e2e;
mod gcode_input_e2e;
mod gcode_restart_e2e;
mod heightmap_e2e;
mod job_outputs_e2e;
mod joblog_e2e;
mod jog_terminal;
mod jog_wire;
mod limit_jog_e2e;
mod macros_e2e;
mod network;
mod network_transport;
mod offsets_e2e;
mod port_identity;
mod probe_console_e2e;
mod probe_e2e;
mod quiet_sessions;
mod read_sessions;
mod run_e2e;
mod sim_shell_faults;
mod sim_shell_pty;
mod sim_shell_timing;
mod sim_start_e2e;
mod sim_time_scale;
mod stops_cli;
mod stops_console;
mod toolchange_e2e;
mod transport_reader;
mod transport_sim_rate;
mod transport_writer;
mod ui_e2e;
mod ui_terminal;
mod workflow_variants;
