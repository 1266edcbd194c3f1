//! `jogterm check FILE`: lint an isel CNC program or an EMCU job for a
//! machine profile and print compiler-style diagnostics
//! (`docs/programs.md`).
//!
//! stdout: one `file:line:col: error|warning: message` per diagnostic, sorted
//! by position; stderr: one summary line. Exit 0 without errors, 1 with
//! errors, 2 on bad usage, an unreadable file or a broken profile.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use crate::axis::AxisSet;
use crate::config::{self, ConfigDirs, Profile};
use crate::program::{Diagnostic, Fix, Language, LintConfig, Program, Severity, lint};
use crate::proto::Protocol;

/// Arguments of `jogterm check`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// The program: `.isel`/`.cnc` for isel CNC programs, `.emcu`/`.job` for
    /// EMCU jobs.
    pub file: PathBuf,
    /// The language, when the extension does not say (default: from the
    /// extension, else the profile's protocol).
    #[arg(long, value_enum)]
    pub protocol: Option<Language>,
    /// Axes the controller is initialised with: 1 = X, 2 = XY, 3 = XYZ,
    /// 4 = XYZA (isel only). Default: the profile's axes.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=4))]
    pub axes: Option<u8>,
    /// Machine profile (name or path) whose axes, soft limits and speeds
    /// apply. Default: `default`.
    #[arg(long)]
    pub profile: Option<String>,
}

/// Exit codes.
const PROBLEMS: u8 = 1;
const USAGE: u8 = 2;

/// Run with the process' stdout and stderr.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let stdout = std::io::stdout();
    let stderr = std::io::stderr();
    run_to(
        &args,
        &ConfigDirs::from_env(),
        &mut stdout.lock(),
        &mut stderr.lock(),
    )
}

/// Run, writing diagnostics to `out` and the summary and errors to `err`.
pub fn run_to(
    args: &Args,
    dirs: &ConfigDirs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let profile_name = args.profile.as_deref().unwrap_or("default");
    let profile = match config::load_profile(profile_name, dirs) {
        Ok(p) => p,
        Err(e) => {
            writeln!(err, "{e}")?;
            return Ok(ExitCode::from(USAGE));
        }
    };
    let language = match language(args, &profile) {
        Ok(l) => l,
        Err(message) => {
            writeln!(err, "jogterm check: {message}")?;
            return Ok(ExitCode::from(USAGE));
        }
    };
    let setup = match setup(args, &profile, profile_name, language) {
        Ok(s) => s,
        Err(message) => {
            writeln!(err, "jogterm check: {message}")?;
            return Ok(ExitCode::from(USAGE));
        }
    };
    let bytes = match std::fs::read(&args.file) {
        Ok(b) => b,
        Err(e) => {
            writeln!(
                err,
                "jogterm check: cannot read {}: {e}",
                args.file.display()
            )?;
            return Ok(ExitCode::from(USAGE));
        }
    };
    let text = String::from_utf8_lossy(&bytes);
    let program = Program::parse(language, &text);
    let diagnostics = lint(&program, &setup.config);
    let name = args.file.display().to_string();
    let mut text_out = String::new();
    for d in &diagnostics {
        text_out.push_str(&render(&name, &program, d));
        text_out.push('\n');
    }
    out.write_all(text_out.as_bytes())?;
    out.flush()?;
    let errors = diagnostics
        .iter()
        .filter(|d| d.severity == Severity::Error)
        .count();
    let warnings = diagnostics.len() - errors;
    writeln!(
        err,
        "{name}: {}, {} in {} ({language}, axes {}, {})",
        plural(errors, "error"),
        plural(warnings, "warning"),
        plural(program.command_count(), "command"),
        setup.config.axes,
        setup.limits
    )?;
    Ok(if errors > 0 {
        ExitCode::from(PROBLEMS)
    } else {
        ExitCode::SUCCESS
    })
}

/// `--protocol`, else the extension, else the profile's protocol.
fn language(args: &Args, profile: &Profile) -> Result<Language, String> {
    if let Some(l) = args.protocol.or_else(|| Language::from_path(&args.file)) {
        return Ok(l);
    }
    match profile.connection.protocol {
        Protocol::Isel => Ok(Language::Isel),
        Protocol::Emcu => Ok(Language::Emcu),
        Protocol::Emp => Err(format!(
            "{}: the extension names no program language (.isel, .cnc, .emcu, .job) and the \
             profile's EMP drives store no programs: give --protocol isel or --protocol emcu",
            args.file.display()
        )),
    }
}

struct Setup {
    config: LintConfig,
    /// For the summary: where the soft limits come from.
    limits: String,
}

/// The lint configuration: the profile's machine when it speaks the file's
/// language, `--axes` over its axes.
fn setup(
    args: &Args,
    profile: &Profile,
    profile_name: &str,
    language: Language,
) -> Result<Setup, String> {
    let speaks = matches!(
        (profile.connection.protocol, language),
        (Protocol::Isel, Language::Isel) | (Protocol::Emcu, Language::Emcu)
    );
    let (mut config, limits) = if speaks {
        (
            LintConfig::from_profile(profile),
            format!("soft limits of profile `{profile_name}`"),
        )
    } else {
        let note = if args.profile.is_some() {
            format!(
                "no soft limits: profile `{profile_name}` is for {} controllers",
                profile.connection.protocol
            )
        } else {
            "no soft limits".to_string()
        };
        (LintConfig::new(AxisSet::XYZ), note)
    };
    if let Some(n) = args.axes {
        if !(1..=4).contains(&n) {
            return Err(format!("--axes {n}: the axes are 1 (X) to 4 (XYZA)"));
        }
        if language == Language::Emcu && n > 3 {
            return Err(format!("--axes {n}: EMCU drives 3 axes at most (X, Y, Z)"));
        }
        config.axes = AxisSet::from_mask((1u8 << n) - 1);
    }
    Ok(Setup { config, limits })
}

/// `file:line:col: severity: message [fix: …]`, line and column from 1.
fn render(name: &str, program: &Program, d: &Diagnostic) -> String {
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
