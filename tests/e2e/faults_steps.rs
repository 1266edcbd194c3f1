//! Steps and checks only the fault scenarios take (the e2e tests that
//! share the harness do not): the console made ready by a raw command, and
//! the motion the controller received compared whole.

use crate::faults_support::console::Console;
use crate::faults_support::wire::isel_motion;

impl Console {
    /// Type a raw command on the console's command line and send it, then
    /// leave the command line (Tab: back to the panel `:` was typed in,
    /// where `i`, `q` reach the main keys). Commands never contain a blank:
    /// Space stops whenever the machine may move.
    pub fn command(&mut self, line: &str) {
        assert!(!line.contains(' '), "Space would stop, not type: {line}");
        self.keys(b":\x15");
        self.keys(line.as_bytes());
        self.wait_for(&format!("> {line}"));
        self.keys(b"\r\t");
    }

    /// Initialise (`i`) and set the reference where the axes stand (`@0N7`),
    /// so moves are allowed; waits for READY.
    ///
    /// Each step is taken once: no fault has been injected yet, so a link
    /// lost meanwhile (a reply that missed its deadline) is a failure to
    /// fix, not something to try again.
    pub fn make_ready(&mut self) {
        let bar_has =
            |word: &'static str| move |s: &str| s.lines().next().is_some_and(|l| l.contains(word));
        self.wait_ready_step("NOT INIT", bar_has("NOT INIT"));
        self.keys(b"i");
        self.wait_ready_step("NOT REF after `i`", bar_has("NOT REF"));
        self.command("@0N7");
        self.wait_ready_step("READY after @0N7", bar_has("READY"));
    }

    /// [`Console::wait_until`], failing at once when the link was lost.
    fn wait_ready_step(&self, what: &str, done: impl Fn(&str) -> bool) {
        self.wait_until(what, |s| {
            assert!(
                !s.contains("link lost"),
                "the link was lost before any fault was injected (waiting for {what}):\n{s}\n\
                 --- traffic log (tail):\n{}",
                self.log_tail()
            );
            done(s)
        });
    }
}

/// The controller received exactly `expected` motion commands, in order:
/// none repeated, none added.
pub fn assert_isel_motion(readable: &str, expected: &[&str]) {
    let got = isel_motion(readable);
    assert_eq!(
        got, expected,
        "motion commands received (a repeat or an extra one is a fault):\n{readable}"
    );
}
