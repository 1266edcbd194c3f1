//! The `jogterm` binary: parse the command line (bad usage exits 2) and run
//! it; any failure is one message on stderr and exit status 1.

use std::process::ExitCode;

use clap::Parser;
use jogterm::cli::{self, Cli};

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli::run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("jogterm: {e:#}");
            ExitCode::FAILURE
        }
    }
}
