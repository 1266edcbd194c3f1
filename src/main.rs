//! The `jogterm` binary: parse the command line (bad usage exits 2) and run
//! it; any failure is one message on stderr and exit status 1.

// Output goes through `cli::out`, which does not panic on a closed stdout
// or stderr.
#![deny(clippy::print_stdout, clippy::print_stderr)]

use std::process::ExitCode;

use clap::Parser;
use jogterm::cli::{self, Cli, out};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli::run(cli) {
        Ok(code) => code,
        Err(e) => {
            // Not `eprintln!`, which panics when stderr is gone (a terminal
            // that hung up under the console, docs/field-notes.md
            // "Order on hang-up") and turns status 1 into a panic's 101.
            out::say(format_args!("jogterm: {e:#}"));
            ExitCode::FAILURE
        }
    }
}
