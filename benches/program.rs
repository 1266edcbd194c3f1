//! Program language timings: parse, lint, format, path of generated isel
//! programs, an incremental edit, and `jogterm check` (`run_to`: read the
//! file, parse, lint for the default profile, print) of a 100 000-line file.
//!
//! Run: `cargo bench --bench program` (optimised build), or
//! `cargo bench --bench program -- lint` for the rows whose name contains
//! `lint`. Prints a table of the median and the slowest wall time of several
//! runs and the median CPU time of the thread; the figures go into
//! `docs/performance.md`, "Programs".
//!
//! Hand-written, not on divan: its bars (`docs/performance.md`) are in the
//! thread's CPU time, which is what the code costs on this shared 2-core
//! VM; divan (and criterion without a custom measurement) time the wall
//! clock, which the other builds and tests on the machine inflate by about
//! half at a 100 ms run. The codec bench, whose runs are nanoseconds long
//! and so rarely interrupted, is on divan.

// A benchmark's setup that fails cannot measure anything: it stops with its
// message (Cargo.toml [lints] denies these in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;
use std::time::{Duration, Instant};

use jogterm::axis::AxisSet;
use jogterm::cli::{GlobalArgs, check};
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::program::{Language, LintConfig, Program, Start, format, lint, path};

/// A drilling-and-milling program of about `lines` lines for the default
/// profile (XYZ, soft limits 120000 / 80000 / 32000 steps): comments, moves
/// that come back to where they started, small loops, arcs, port commands.
fn program(lines: usize) -> String {
    let mut out = String::with_capacity(lines * 32);
    out.push_str("; generated benchmark program\n7 7\nj300\nJ100\nf-1\n");
    out.push_str("m40000,8000,40000,8000,24000,4000,0,4000\n");
    let mut n = 6;
    let mut k = 0usize;
    while n + 8 < lines {
        let dx = 100 + (k % 50) as i64 * 10;
        match k % 6 {
            0 => {
                out.push_str(&format!("; block {k}\n"));
                out.push_str(&format!("0 {dx},8000,0,8000,-800,2000,800,2000   ; hole\n"));
                out.push_str("3 2,-1\n");
                out.push_str(&format!("0 -{},8000,0,8000,0,2000,0,2000\n", 3 * dx));
                n += 4;
            }
            1 => {
                out.push_str("y400,1500,119,-141,141,-1,-1\n");
                out.push_str("m40000,8000,40000,8000,24000,4000,0,4000\n");
                n += 2;
            }
            2 => {
                out.push_str("p2,0,1\n\n");
                out.push_str(&format!("0 0,8000,{dx},8000,0,4000,0,4000\n"));
                out.push_str(&format!("0 0,8000,-{dx},8000,0,4000,0,4000\n"));
                out.push_str("p2,0,0\n");
                n += 5;
            }
            3 => {
                out.push_str("o0,0,1,2\n");
                out.push_str(&format!("0 {dx},8000,{dx},8000,0,4000,0,4000\n"));
                out.push_str(&format!(
                    "m40000,8000,40000,8000,24000,4000,0,4000 ; back {k}\n"
                ));
                n += 3;
            }
            4 => {
                out.push_str("# a comment line with some words in it\n5 2\n");
                n += 2;
            }
            _ => {
                out.push_str(&format!(
                    "M40000,8000,{},8000,24000,4000,0,4000\n",
                    40000 + dx
                ));
                out.push_str("m40000,8000,40000,8000,24000,4000,0,4000\n");
                n += 2;
            }
        }
        k += 1;
    }
    while n + 1 < lines {
        out.push_str("; padding\n");
        n += 1;
    }
    out.push_str("9\n");
    out
}

/// CPU time this thread has used: on a machine shared with other work the
/// wall time of a run includes time the scheduler gave to others.
fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    if ok {
        Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
    } else {
        Duration::ZERO
    }
}

/// Median and maximum wall time and median CPU time of `runs` runs of `f`.
fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, Duration, Duration) {
    let mut wall = Vec::with_capacity(runs);
    let mut cpu = Vec::with_capacity(runs);
    for _ in 0..runs {
        let (start, start_cpu) = (Instant::now(), thread_cpu());
        black_box(f());
        wall.push(start.elapsed());
        cpu.push(thread_cpu().saturating_sub(start_cpu));
    }
    wall.sort();
    cpu.sort();
    (wall[runs / 2], wall[runs - 1], cpu[runs / 2])
}

/// The rows to run: those whose name contains the first argument that is
/// not an option (`cargo bench` passes `--bench`).
fn wanted(what: &str) -> bool {
    std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .is_none_or(|filter| what.contains(&filter))
}

fn row<T>(what: &str, lines: usize, runs: usize, f: impl FnMut() -> T) {
    if !wanted(what) {
        return;
    }
    let (median, max, cpu) = time(runs, f);
    println!(
        "| {what:<48} | {lines:>7} | {:>9.2} | {:>9.2} | {:>9.2} |",
        median.as_secs_f64() * 1e3,
        max.as_secs_f64() * 1e3,
        cpu.as_secs_f64() * 1e3
    );
}

fn main() {
    let profile = match load_profile("default", &ConfigDirs::builtin_only()) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let config = LintConfig::from_profile(&profile);
    let mut editor = config.clone();
    editor.budget = 100_000;
    println!("| what | lines | median ms | max ms | cpu ms |");
    println!("| --- | ---: | ---: | ---: | ---: |");
    for lines in [10_000, 100_000] {
        let text = program(lines);
        let runs = if lines > 50_000 { 7 } else { 21 };
        let parsed = Program::parse(Language::Isel, &text);
        row("parse", lines, runs, || {
            Program::parse(Language::Isel, &text)
        });
        row("parse: the core's parse_cnc alone", lines, runs, || {
            text.lines()
                .filter(|l| !l.starts_with(';') && !l.starts_with('#') && !l.is_empty())
                .map(|l| {
                    jogterm::proto::isel::parse_cnc(l.split(';').next().unwrap_or(l).trim()).is_ok()
                })
                .filter(|ok| *ok)
                .count()
        });
        row(
            "lint (default profile: soft limits on)",
            lines,
            runs,
            || lint(&parsed, &config),
        );
        row("lint, no profile (no soft-limit run)", lines, runs, || {
            lint(&parsed, &LintConfig::new(AxisSet::XYZ))
        });
        row("lint, editor budget 100 000", lines, runs, || {
            lint(&parsed, &editor)
        });
        let mut edited = parsed.clone();
        row("edit one line (replace_lines)", lines, runs, || {
            edited.replace_lines(lines / 2..lines / 2 + 1, "0 5,900,0,900,0,900,0,900");
        });
        row("format", lines, runs, || format(&parsed));
        row("path", lines, runs, || {
            path(&parsed, &Start::at_zero(AxisSet::XYZ)).segments.len()
        });
        let dir = std::env::temp_dir().join(format!("jogterm-bench-{}", std::process::id()));
        if std::fs::create_dir_all(&dir).is_ok() {
            let file = dir.join(format!("bench-{lines}.isel"));
            if std::fs::write(&file, &text).is_ok() {
                let args = check::CheckArgs {
                    file: file.clone(),
                    axes: None,
                    gcode: false,
                    work_zero: None,
                };
                let global = GlobalArgs::default();
                let dirs = ConfigDirs::builtin_only();
                row(
                    "jogterm check (run_to: read, parse, lint, print)",
                    lines,
                    runs,
                    || {
                        let (mut out, mut err) = (Vec::new(), Vec::new());
                        let _ = check::run_to(&global, &args, &dirs, &mut out, &mut err);
                        out.len()
                    },
                );
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
        let diagnostics = lint(&parsed, &config);
        eprintln!(
            "{lines} lines: {} commands, {} diagnostics ({:?})",
            parsed.command_count(),
            diagnostics.len(),
            diagnostics
                .iter()
                .map(|d| d.rule.name())
                .collect::<std::collections::BTreeSet<_>>()
        );
    }
}
