//! The console (`jogterm --port …`) in a 40x200 pseudo-terminal against a
//! `jogterm sim --pty` that shares its configuration directory, and the
//! steps every such test takes: wait for a text, initialise and reference,
//! quit. Wide, so that whole messages and the traffic console show.

use std::path::Path;

use crate::sim_process::{JOGTERM, SimProcess, WAIT};
use crate::ui_pty::PtyRun;

/// The console against `sim`, its state (offsets, recovery) in `state`.
pub fn spawn(sim: &SimProcess, state: &Path) -> PtyRun {
    let link = sim.link.display().to_string();
    spawn_on(sim, state, &["--port", &link])
}

/// The console with `args`, configured from `sim`'s directory.
pub fn spawn_on(sim: &SimProcess, state: &Path, args: &[&str]) -> PtyRun {
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", sim.dir.path().display().to_string()),
        ("JOGTERM_STATE_DIR", state.display().to_string()),
        ("RUST_BACKTRACE", "0".to_string()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    PtyRun::spawn_sized(Path::new(JOGTERM), args, &env, 40, 200)
}

pub fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

/// Initialise and reference (the question answered).
pub fn reference(run: &mut PtyRun) {
    wait_for(run, "connected");
    run.type_keys(&[b"i"]);
    wait_for(run, "NOT REF");
    run.type_keys(&[b"h"]);
    wait_for(run, "Reference run");
    run.type_keys(&[b"y"]);
    wait_for(run, "READY");
}

/// `q`, and the console ends with status 0.
pub fn quit(run: &mut PtyRun) {
    run.type_keys(&[b"q"]);
    assert_eq!(
        run.wait_exit(WAIT),
        Some(0),
        "{}",
        run.screen().screen().contents()
    );
}
