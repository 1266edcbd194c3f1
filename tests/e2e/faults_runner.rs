//! The suite's own test runner (`harness = false`): runs the scenarios a few
//! at a time, each on its own thread with a panic caught, prints one line per
//! scenario and the totals:
//!
//! ```text
//! fault scenarios: 12 run, 12 passed (0 flaky), 15 faults survived, 200 inputs fuzzed
//! ```
//!
//! A scenario that fails runs once more, alone, to tell a flaky scenario
//! from a broken one; either way it has failed and the suite fails with it
//! (a scenario that passes only on a second attempt is a failure to fix,
//! not a pass).
//!
//! It takes the arguments `cargo test` hands every test binary: names to
//! filter by (substrings, or whole names with `--exact`), `--skip NAME`,
//! `--list`, `--test-threads N` (else `RUST_TEST_THREADS`, as libtest),
//! `--ignored` (runs nothing: no scenario is ignored); other libtest flags
//! are accepted and ignored.

use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

/// What a scenario counts as it goes.
#[derive(Debug, Default, Clone, Copy)]
pub struct Tally {
    /// Faults injected (each one the console had to survive).
    pub faults: u32,
    /// Random inputs fed in (fuzzed garbage bursts).
    pub fuzzed: u32,
}

impl Tally {
    pub fn fault(&mut self) {
        self.faults += 1;
    }
}

pub struct Scenario {
    pub name: &'static str,
    pub run: fn(&mut Tally),
}

/// Scenarios at once when neither `--test-threads` nor `RUST_TEST_THREADS`
/// (which `.cargo/config.toml` sets for `cargo test`, as libtest reads it)
/// says: each runs two processes with a few threads, and the suite must
/// stay well inside a minute on two cores.
const DEFAULT_PARALLEL: usize = 2;

/// The whole suite is stopped after this, whatever hangs.
const SUITE_LIMIT: Duration = Duration::from_secs(300);

struct Options {
    filters: Vec<String>,
    skip: Vec<String>,
    exact: bool,
    list: bool,
    /// `--ignored`: only ignored tests, and no scenario is ignored.
    only_ignored: bool,
    threads: usize,
}

fn options() -> Options {
    let mut o = Options {
        filters: Vec::new(),
        skip: Vec::new(),
        exact: false,
        list: false,
        only_ignored: false,
        threads: std::env::var("RUST_TEST_THREADS")
            .ok()
            .and_then(|n| n.parse::<usize>().ok())
            .map_or(DEFAULT_PARALLEL, |n| n.max(1)),
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--list" => o.list = true,
            "--exact" => o.exact = true,
            "--ignored" => o.only_ignored = true,
            "--skip" => o.skip.extend(args.next()),
            "--test-threads" => {
                if let Some(n) = args.next().and_then(|n| n.parse::<usize>().ok()) {
                    o.threads = n.max(1);
                }
            }
            // Flags with a value that this runner does not use.
            "--format" | "--color" | "--logfile" | "-Z" => {
                args.next();
            }
            a if a.starts_with("--test-threads=") => {
                if let Ok(n) = a["--test-threads=".len()..].parse::<usize>() {
                    o.threads = n.max(1);
                }
            }
            a if a.starts_with('-') => {}
            a => o.filters.push(a.to_string()),
        }
    }
    o
}

impl Options {
    fn selects(&self, name: &str) -> bool {
        let matches = |f: &String| {
            if self.exact {
                name == f
            } else {
                name.contains(f.as_str())
            }
        };
        !self.only_ignored
            && (self.filters.is_empty() || self.filters.iter().any(matches))
            && !self.skip.iter().any(|s| name.contains(s.as_str()))
    }
}

/// A scenario's name, its outcome (the tally, or why it failed), its time.
type Finished = (&'static str, Result<Tally, String>, Duration);

/// Run the selected scenarios; the exit code fails when one failed.
pub fn run(scenarios: &[Scenario]) -> ExitCode {
    let o = options();
    let selected: Vec<&Scenario> = scenarios.iter().filter(|s| o.selects(s.name)).collect();
    if o.list {
        for s in &selected {
            println!("{}: test", s.name);
        }
        return ExitCode::SUCCESS;
    }
    crate::faults_support::wire::self_check();
    thread::spawn(|| {
        thread::sleep(SUITE_LIMIT);
        eprintln!("fault scenarios: the suite took longer than {SUITE_LIMIT:?}: something hangs");
        std::process::exit(101);
    });
    println!("\nrunning {} fault scenarios", selected.len());
    let started = Instant::now();
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Finished>> = Mutex::new(Vec::new());
    thread::scope(|scope| {
        for _ in 0..o.threads.min(selected.len().max(1)) {
            scope.spawn(|| {
                while let Some(s) = selected.get(next.fetch_add(1, Ordering::SeqCst)) {
                    let t = Instant::now();
                    let result = run_one(s);
                    let took = t.elapsed();
                    match &result {
                        Ok(tally) => println!(
                            "fault scenario {} ... ok ({} faults, {} inputs fuzzed, {:.1} s)",
                            s.name,
                            tally.faults,
                            tally.fuzzed,
                            took.as_secs_f64()
                        ),
                        Err(e) => println!("fault scenario {} ... FAILED\n{e}", s.name),
                    }
                    results
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .push((s.name, result, took));
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap_or_else(|p| p.into_inner());
    // A scenario that failed runs once more, alone: whether it fails again
    // tells a broken scenario from a flaky one, and both outcomes are
    // printed. It has failed either way.
    let mut flaky: Vec<&str> = Vec::new();
    for (name, result, took) in results.iter_mut() {
        let Err(first) = result else { continue };
        let Some(s) = selected.iter().find(|s| s.name == *name) else {
            continue;
        };
        let first_line = first.lines().next().unwrap_or_default().to_string();
        let t = Instant::now();
        let again = run_one(s);
        *took += t.elapsed();
        match &again {
            Ok(_) => {
                println!(
                    "fault scenario {name} ... FLAKY: failed, then passed alone (a failure to fix; \
                     the first attempt: {first_line})"
                );
                flaky.push(name);
            }
            Err(e) => println!("fault scenario {name} ... FAILED again\n{e}"),
        }
    }
    let passed: Vec<Tally> = results
        .iter()
        .filter_map(|(_, r, _)| r.as_ref().ok().copied())
        .collect();
    let broken: Vec<&str> = results
        .iter()
        .filter(|(n, r, _)| r.is_err() && !flaky.contains(n))
        .map(|(n, _, _)| *n)
        .collect();
    let survived: u32 = passed.iter().map(|t| t.faults).sum();
    let fuzzed: u32 = passed.iter().map(|t| t.fuzzed).sum();
    println!(
        "\nfault scenarios: {} run, {} passed ({} flaky), {} faults survived, {} inputs fuzzed ({:.1} s)",
        results.len(),
        passed.len(),
        flaky.len(),
        survived,
        fuzzed,
        started.elapsed().as_secs_f64()
    );
    if !broken.is_empty() {
        println!("failed: {}", broken.join(", "));
    }
    if !flaky.is_empty() {
        println!(
            "flaky (failed, then passed alone; each a failure to fix): {}",
            flaky.join(", ")
        );
    }
    if broken.is_empty() && flaky.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn run_one(s: &Scenario) -> Result<Tally, String> {
    let tally = Arc::new(Mutex::new(Tally::default()));
    let inner = tally.clone();
    let run = s.run;
    let outcome = thread::Builder::new()
        .name(s.name.to_string())
        .spawn(move || {
            let mut t = Tally::default();
            run(&mut t);
            *inner.lock().unwrap_or_else(|p| p.into_inner()) = t;
        })
        .map_err(|e| format!("cannot start the scenario: {e}"))?
        .join();
    match outcome {
        Ok(()) => Ok(*tally.lock().unwrap_or_else(|p| p.into_inner())),
        Err(panic) => Err(panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "the scenario panicked".to_string())),
    }
}
