//! `jogterm check FILE`: lint an isel CNC program or an EMCU job for a
//! machine profile and print compiler-style diagnostics
//! (`docs/programs.md`, "Command line").
//!
//! stdout: one `file:line:col: error|warning: message` per diagnostic, sorted
//! by position; stderr: one summary line. Exit 0 without errors, 1 with
//! errors, 2 on bad usage, an unreadable file or a profile that cannot be
//! used.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::out::closed_is_ok;
use super::{GlobalArgs, profile};
use crate::axis::AxisSet;
use crate::config::ConfigDirs;
use crate::program::{Diagnostic, Fix, Language, LintConfig, Program, Severity, lint};

pub const LONG_ABOUT: &str = "\
Check an isel CNC program or an EMCU job before it is stored in a controller.

Prints one line per problem on stdout, sorted by position, in the form
file:line:col: error|warning: message, and a summary on stderr. Errors are what the
controller would refuse or what would go wrong while the program runs (a move beyond a
soft limit of the machine profile); warnings are what is allowed but probably not meant.

The language is --protocol (isel or emcu), else the file's extension (.isel and .cnc:
isel; .emcu and .job: EMCU), else the profile's family. The machine is the profile's:
--profile, else the shipped profile of the file's family (`default` for isel). Its axes,
soft limits and highest speeds apply; --axes sets the axes instead. The start position is
unknown: an axis' moves are checked against the soft limits from its first reference run
or absolute move on (docs/programs.md).";

pub const AFTER_LONG_HELP: &str = "\
Exit status: 0 no errors (warnings allowed), 1 errors (or stdout failed other than by its
reader going away), 2 bad usage, an unreadable file or a profile that cannot be used. A
reader that takes only the first lines (`| head -1`) changes neither the summary nor the
status; a failure to write stderr is ignored.

Examples:
  jogterm check drill.isel                  check for the default machine
  jogterm check --profile mymill drill.cnc  check for a machine of your own
  jogterm check --axes 2 table.isel         an XY controller
  jogterm check --protocol emcu job.txt     an EMCU job in a .txt file";

/// Options of `jogterm check`.
#[derive(Debug, Clone, Args)]
pub struct CheckArgs {
    /// The program: .isel/.cnc for isel CNC programs, .emcu/.job for EMCU jobs
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Axes the controller is initialised with: 1 = X, 2 = XY, 3 = XYZ, 4 = XYZA (EMCU: at
    /// most 3) [default: the profile's axes]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=4))]
    pub axes: Option<u8>,
    /// The file is G-code from CAM (also known by its extension: .nc .ngc .gcode .tap .gc):
    /// it is checked as `jogterm import` checks it, against the profile's machine
    #[arg(long)]
    pub gcode: bool,
    /// G-code: the active work offset's zero in machine units (`X50 Y50 Z60`), instead of
    /// the console's stored one
    #[arg(long, value_name = "POS")]
    pub work_zero: Option<String>,
}

/// Exit codes.
const PROBLEMS: u8 = 1;
const USAGE: u8 = 2;

/// Run with the process' stdout and stderr and the user's configuration.
pub fn run(global: &GlobalArgs, args: &CheckArgs) -> anyhow::Result<ExitCode> {
    let stdout = std::io::stdout();
    let stderr = std::io::stderr();
    run_to(
        global,
        args,
        &ConfigDirs::from_env(),
        &mut stdout.lock(),
        &mut stderr.lock(),
    )
}

/// Run, writing diagnostics to `out` and the summary and errors to `err`.
pub fn run_to(
    global: &GlobalArgs,
    args: &CheckArgs,
    dirs: &ConfigDirs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    if args.gcode || crate::gcode::is_gcode_path(&args.file) {
        return check_gcode(global, args, dirs, out, err);
    }
    let (language, config, machine) = match setup(global, args, dirs) {
        Ok(s) => s,
        Err(message) => {
            let _ = writeln!(err, "jogterm check: {message}");
            return Ok(ExitCode::from(USAGE));
        }
    };
    let bytes = match super::import::read_bounded(&args.file, crate::program::store::MAX_FILE_BYTES)
    {
        Ok(b) => b,
        Err(e) => {
            let _ = writeln!(
                err,
                "jogterm check: cannot read {}: {e}",
                args.file.display()
            );
            return Ok(ExitCode::from(USAGE));
        }
    };
    let text = String::from_utf8_lossy(&bytes);
    let program = Program::parse(language, &text);
    let diagnostics = lint(&program, &config);
    let name = args.file.display().to_string();
    let mut report = String::new();
    for d in &diagnostics {
        report.push_str(&render(&name, &program, d));
        report.push('\n');
    }
    // A reader that takes only the first lines (`| head -1`) leaves the
    // verdict as it is; any other failure to write is one.
    closed_is_ok(out.write_all(report.as_bytes()).and_then(|()| out.flush()))?;
    let errors = diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .count();
    let warnings = diagnostics.len() - errors;
    let _ = writeln!(
        err,
        "{name}: {}, {} in {} ({language}, axes {}, soft limits of `{machine}`)",
        plural(errors, "error"),
        plural(warnings, "warning"),
        plural(program.command_count(), "command"),
        config.axes,
    );
    Ok(if errors > 0 {
        ExitCode::from(PROBLEMS)
    } else {
        ExitCode::SUCCESS
    })
}

/// A G-code file: imported for the profile (the same check as `jogterm
/// import`, soft limits through the work offset included), every
/// diagnostic at FILE:LINE:COL on `out`, the verdict on `err`.
fn check_gcode(
    global: &GlobalArgs,
    args: &CheckArgs,
    dirs: &ConfigDirs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let name = args.file.display().to_string();
    let profile = match profile::resolve(global, dirs) {
        Ok(p) => p,
        Err(e) => {
            let _ = writeln!(err, "jogterm check: {name}: {e:#}");
            return Ok(ExitCode::from(USAGE));
        }
    };
    let target = match crate::gcode::Target::of(profile::family(&profile)) {
        Ok(t) => t,
        Err(why) => {
            let _ = writeln!(err, "jogterm check: {name}: {why}");
            return Ok(ExitCode::from(USAGE));
        }
    };
    let mut diagnostics = Vec::new();
    let imported = super::import::convert(
        global,
        dirs,
        &profile,
        &args.file,
        target,
        super::import::Placement {
            work_zero: args.work_zero.as_deref(),
            height_map: None,
        },
        &mut diagnostics,
    );
    let mut report = String::from_utf8_lossy(&diagnostics).into_owned();
    match imported {
        Ok(imported) => {
            for w in &imported.warnings {
                report.push_str(&crate::gcode::render(&name, w));
                report.push('\n');
            }
            closed_is_ok(out.write_all(report.as_bytes()).and_then(|()| out.flush()))?;
            let fits = if imported.program.fits() {
                "fits the controller's memory"
            } else {
                "does NOT fit the controller's memory"
            };
            let _ = writeln!(
                err,
                "{name}: 0 errors, {} in {} of G-code for `{}`: {} program of {}, {fits}",
                plural(imported.warnings.len(), "warning"),
                plural(imported.toolpath.lines as usize, "line"),
                profile.name,
                imported.target.name(),
                plural(imported.program.commands, "command"),
            );
            Ok(ExitCode::SUCCESS)
        }
        Err(code) => {
            closed_is_ok(out.write_all(report.as_bytes()).and_then(|()| out.flush()))?;
            Ok(ExitCode::from(code))
        }
    }
}

/// The language, the lint configuration and the profile's name, or why
/// there are none. The family is `--protocol`/`--sim`, else the extension's;
/// the profile is resolved for it like for every command
/// ([`profile::resolve`]), so it always describes a machine of the file's
/// family.
fn setup(
    global: &GlobalArgs,
    args: &CheckArgs,
    dirs: &ConfigDirs,
) -> Result<(Language, LintConfig, String), String> {
    let named = global.protocol.or(global.sim);
    let from_extension = Language::from_path(&args.file);
    let mut resolving = global.clone();
    if named.is_none() {
        resolving.protocol = from_extension.map(Language::protocol);
    }
    let profile = profile::resolve(&resolving, dirs).map_err(|e| {
        let by = match (named, from_extension) {
            (None, Some(l)) => format!(" (an {l} program by its extension)"),
            _ => String::new(),
        };
        format!("{}{by}: {e:#}", args.file.display())
    })?;
    let family = profile::family(&profile);
    let language = Language::of_protocol(family).ok_or_else(|| {
        format!(
            "{}: EMP drives store no programs; the file's extension (.isel, .cnc, .emcu, \
             .job) or --protocol isel|emcu says which language it is",
            args.file.display()
        )
    })?;
    let mut config = LintConfig::from_profile(&profile);
    if let Some(n) = args.axes {
        if !(1..=4).contains(&n) {
            return Err(format!("--axes {n}: the axes are 1 (X) to 4 (XYZA)"));
        }
        if language == Language::Emcu && n > 3 {
            return Err(format!("--axes {n}: EMCU drives 3 axes at most (X, Y, Z)"));
        }
        config.axes = AxisSet::from_mask((1u8 << n) - 1);
    }
    Ok((language, config, profile.name))
}

/// `file:line:col: severity: message [fix: …]`, line and column from 1.
pub(super) fn render(name: &str, program: &Program, d: &Diagnostic) -> String {
    let line_text = program.line(d.span.line).map_or("", |l| l.text());
    let fix = d
        .fix
        .as_ref()
        .map(|f| format!(" [fix: {}]", describe_fix(f)))
        .unwrap_or_default();
    format!(
        "{name}:{}:{}: {}: {}{fix}",
        d.span.line + 1,
        d.span.column(line_text),
        d.severity,
        d.message
    )
}

fn describe_fix(fix: &Fix) -> String {
    match fix.replacement.strip_prefix('\n') {
        Some(line) => format!("add a line `{line}`"),
        None if fix.span.start == fix.span.end => format!("insert `{}`", fix.replacement),
        None => format!("write `{}`", fix.replacement),
    }
}

fn plural(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}
