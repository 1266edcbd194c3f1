//! `jogterm run --sim-start-key WHEN` on the built-in simulator: the
//! machine's start key pressed for the operator, so that a job that waits
//! for it (M0, M1, a tool change: `docs/gcode.md`) can be run without
//! hardware. Pressed every few seconds while the job runs (a press while
//! nothing waits for the key is taken by nothing: the controller runs a
//! program already), or once for each line read on standard input.

use std::io::BufRead;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::cli::out;
use crate::sim::shell::ShellControl;
use crate::sim::start_key::StartKey;

/// When the start key is pressed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SimStart {
    /// This long after the job starts, and again each time as long after.
    Every(Duration),
    /// Once for each line on standard input (a pipe, not the terminal).
    Stdin,
}

/// The longest time between presses accepted: an hour.
const MAX_EVERY_S: f64 = 3600.0;

/// `--sim-start-key`'s value: `stdin`, or seconds (0.1 to 3600).
pub fn parse(text: &str) -> Result<SimStart, String> {
    if text.eq_ignore_ascii_case("stdin") {
        return Ok(SimStart::Stdin);
    }
    match text.parse::<f64>() {
        Ok(s) if (0.1..=MAX_EVERY_S).contains(&s) => {
            Ok(SimStart::Every(Duration::from_secs_f64(s)))
        }
        _ => Err(format!(
            "`{text}`: expected seconds between presses (0.1 to {MAX_EVERY_S}) or `stdin`"
        )),
    }
}

/// Presses under way; they end when this is dropped (the job has ended:
/// an isel start key pressed then would run the stored program again).
pub struct Presses {
    ended: Arc<AtomicBool>,
    timer: Option<tokio::task::JoinHandle<()>>,
}

impl Presses {
    /// Start pressing `key` on the simulator `control` as `when` says.
    pub fn start(when: SimStart, control: ShellControl, key: StartKey) -> Presses {
        let ended = Arc::new(AtomicBool::new(false));
        let timer = match when {
            SimStart::Every(every) => {
                let ended = ended.clone();
                Some(tokio::spawn(async move {
                    loop {
                        tokio::time::sleep(every).await;
                        let (control, key, ended) = (control.clone(), key.clone(), ended.clone());
                        // The shell answers over a blocking channel.
                        let _ = tokio::task::spawn_blocking(move || press(&control, &key, &ended))
                            .await;
                    }
                }))
            }
            SimStart::Stdin => {
                let ended = ended.clone();
                std::thread::Builder::new()
                    .name("sim-start-key".into())
                    .spawn(move || {
                        for line in std::io::stdin().lock().lines() {
                            if line.is_err() {
                                return;
                            }
                            press(&control, &key, &ended);
                        }
                    })
                    .ok();
                None
            }
        };
        Presses { ended, timer }
    }
}

impl Drop for Presses {
    fn drop(&mut self) {
        self.ended.store(true, Ordering::SeqCst);
        if let Some(t) = &self.timer {
            t.abort();
        }
    }
}

fn press(control: &ShellControl, key: &StartKey, ended: &AtomicBool) {
    if ended.load(Ordering::SeqCst) {
        return;
    }
    match control.input(key.press()) {
        Ok(()) => out::say(format_args!(
            "jogterm run: the simulator's start key ({}) pressed",
            key.name
        )),
        Err(e) => out::say(format_args!(
            "jogterm run: the simulator's start key ({}) was not pressed: {e}",
            key.name
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_time_or_stdin() {
        assert_eq!(parse("stdin"), Ok(SimStart::Stdin));
        assert_eq!(parse("2"), Ok(SimStart::Every(Duration::from_secs(2))));
        assert_eq!(
            parse("0.5"),
            Ok(SimStart::Every(Duration::from_millis(500)))
        );
        for bad in ["0", "-1", "4000", "soon", "NaN"] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }
}
