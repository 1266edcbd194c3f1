//! The suite's runner (`harness = false`) on libtest-mimic, which gives it
//! the arguments, filters, listing, parallel threads and output of libtest.
//! Two things are the suite's own and are why it is not a plain `#[test]`
//! crate:
//!
//! - A scenario that fails runs once more, alone (no other scenario beside
//!   it), to tell a flaky scenario from a broken one; either way it has
//!   failed and the suite fails with it (a scenario that passes only on a
//!   second attempt is a failure to fix, not a pass).
//! - The totals of what the scenarios did, after libtest's summary:
//!
//! ```text
//! fault scenarios: 19 run, 19 passed (0 flaky), 20 faults survived, 40 inputs fuzzed (17.5 s)
//! ```

use std::process::ExitCode;
use std::sync::{Arc, Mutex, RwLock};
use std::thread;
use std::time::{Duration, Instant};

use libtest_mimic::{Arguments, Failed, Trial};

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
/// (which `.cargo/config.toml` sets for `cargo test`; libtest reads it,
/// libtest-mimic does not) says: each runs two processes with a few
/// threads, and the suite must stay well inside a minute on two cores.
const DEFAULT_PARALLEL: usize = 2;

/// The whole suite is stopped after this, whatever hangs.
const SUITE_LIMIT: Duration = Duration::from_secs(300);

/// How each scenario ended: passed first time, flaky (failed, then passed
/// alone) or broken (failed twice).
#[derive(Default)]
struct Totals {
    passed: Vec<Tally>,
    flaky: Vec<&'static str>,
    broken: Vec<&'static str>,
}

/// Run the selected scenarios; the exit code fails when one failed.
pub fn run(scenarios: &[Scenario]) -> ExitCode {
    let mut args = Arguments::from_args();
    if args.test_threads.is_none() {
        args.test_threads = Some(
            std::env::var("RUST_TEST_THREADS")
                .ok()
                .and_then(|n| n.parse::<usize>().ok())
                .map_or(DEFAULT_PARALLEL, |n| n.max(1)),
        );
    }
    if !args.list {
        crate::faults_support::wire::self_check();
        thread::spawn(|| {
            thread::sleep(SUITE_LIMIT);
            eprintln!(
                "fault scenarios: the suite took longer than {SUITE_LIMIT:?}: something hangs"
            );
            std::process::exit(101);
        });
    }
    let totals = Arc::new(Mutex::new(Totals::default()));
    // Scenarios run under the read side; a second attempt takes the write
    // side, so it runs alone once those already running have ended.
    let alone = Arc::new(RwLock::new(()));
    let trials = scenarios
        .iter()
        .map(|s| {
            let (name, run) = (s.name, s.run);
            let totals = totals.clone();
            let alone = alone.clone();
            Trial::test(name, move || attempt(name, run, &alone, &totals))
        })
        .collect();
    let started = Instant::now();
    let conclusion = libtest_mimic::run(&args, trials);
    if !args.list {
        let t = totals.lock().unwrap_or_else(|p| p.into_inner());
        let run = t.passed.len() + t.flaky.len() + t.broken.len();
        println!(
            "fault scenarios: {run} run, {} passed ({} flaky), {} faults survived, {} inputs fuzzed ({:.1} s)",
            t.passed.len(),
            t.flaky.len(),
            t.passed.iter().map(|t| t.faults).sum::<u32>(),
            t.passed.iter().map(|t| t.fuzzed).sum::<u32>(),
            started.elapsed().as_secs_f64()
        );
        if !t.flaky.is_empty() {
            println!(
                "flaky (failed, then passed alone; each a failure to fix): {}",
                t.flaky.join(", ")
            );
        }
    }
    conclusion.exit_code()
}

/// One scenario, and once more alone when it fails.
fn attempt(
    name: &'static str,
    run: fn(&mut Tally),
    alone: &RwLock<()>,
    totals: &Mutex<Totals>,
) -> Result<(), Failed> {
    let first = {
        let _beside_others = alone.read().unwrap_or_else(|p| p.into_inner());
        run_one(name, run)
    };
    let first = match first {
        Ok(tally) => {
            lock(totals).passed.push(tally);
            return Ok(());
        }
        Err(e) => e,
    };
    let again = {
        let _alone = alone.write().unwrap_or_else(|p| p.into_inner());
        run_one(name, run)
    };
    match again {
        Ok(_) => {
            lock(totals).flaky.push(name);
            Err(format!(
                "FLAKY: failed, then passed alone (a failure to fix); the first attempt:\n{first}"
            )
            .into())
        }
        Err(e) => {
            lock(totals).broken.push(name);
            Err(format!("failed, and again alone:\n{e}\n(the first attempt: {first})").into())
        }
    }
}

fn lock(totals: &Mutex<Totals>) -> std::sync::MutexGuard<'_, Totals> {
    totals.lock().unwrap_or_else(|p| p.into_inner())
}

/// A scenario on a thread of its own, named after it (its panic message
/// names the scenario), with its panic turned into the failure's text.
fn run_one(name: &'static str, run: fn(&mut Tally)) -> Result<Tally, String> {
    let tally = Arc::new(Mutex::new(Tally::default()));
    let inner = tally.clone();
    let outcome = thread::Builder::new()
        .name(name.to_string())
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
