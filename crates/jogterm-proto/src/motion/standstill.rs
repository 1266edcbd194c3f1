//! How long a moving axis stood still in between: a jog that cannot change
//! the speed of a running move (isel, EMCU) stops and restarts once when
//! it speeds up at the first key repeat (`docs/jogging.md`, "Speed caps").
//! Measured on a trace of sampled positions (`benches/jog.rs`, the
//! drivers' simulator tests). Pure arithmetic.

use std::time::{Duration, Instant};

/// The longest time the position stood still between the first and the
/// last movement of `trace` (samples in time order): from the first to the
/// last of a run of equal readings, so a late sample widens nothing. A run
/// still open at the end (at rest after the last movement) is no
/// standstill between movements, nor is the rest before the first. At the
/// slowest speeds one step period looks like a standstill too.
pub fn standstill(trace: &[(Instant, f64)]) -> Duration {
    let Some(&(_, first)) = trace.first() else {
        return Duration::ZERO;
    };
    let Some(moved) = trace.iter().position(|(_, x)| *x != first) else {
        return Duration::ZERO;
    };
    let mut longest = Duration::ZERO;
    // (first sample of the run, last sample of the run, its reading)
    let (t, x) = trace[moved];
    let mut run = (t, t, x);
    for &(t, x) in &trace[moved + 1..] {
        if x == run.2 {
            run.1 = t;
        } else {
            longest = longest.max(run.1.saturating_duration_since(run.0));
            run = (t, t, x);
        }
    }
    longest
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(points: &[(u64, f64)]) -> Vec<(Instant, f64)> {
        let t0 = Instant::now();
        points
            .iter()
            .map(|(ms, x)| (t0 + Duration::from_millis(*ms), *x))
            .collect()
    }

    #[test]
    fn only_a_rest_between_two_movements_counts() {
        // At rest, moving, 40 ms still, moving, at rest for good.
        let t = trace(&[
            (0, 0.0),
            (10, 0.0),
            (20, 1.0),
            (30, 2.0),
            (40, 2.0),
            (60, 2.0),
            (80, 2.0),
            (90, 3.0),
            (100, 4.0),
            (500, 4.0),
        ]);
        assert_eq!(standstill(&t), Duration::from_millis(50));
        assert_eq!(standstill(&[]), Duration::ZERO);
        assert_eq!(standstill(&trace(&[(0, 1.0), (9, 1.0)])), Duration::ZERO);
        // A gap in the samples while it moves is no standstill.
        let gap = trace(&[(0, 0.0), (1, 1.0), (40, 9.0), (41, 10.0)]);
        assert_eq!(standstill(&gap), Duration::ZERO);
    }
}
