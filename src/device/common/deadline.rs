//! Deadlines from physics, the parts every family shares: a query waits for
//! its bytes at the baud rate plus a margin; a move its planned duration
//! plus a quarter and a second (the controller's ramp is modelled, not
//! known); a reference run the travel of each axis at the reference speed.

use std::time::Duration;

use crate::wire::LineSettings;

/// A query or setting: `command_len` bytes out, `reply_len` back, plus
/// `margin` for the controller and the host's scheduling.
pub fn exchange(
    line: LineSettings,
    margin: Duration,
    command_len: usize,
    reply_len: usize,
) -> Duration {
    line.transfer_time(command_len + reply_len) + margin
}

/// A move planned to take `duration`.
pub fn motion(duration: Duration) -> Duration {
    duration + duration / 4 + Duration::from_secs(1)
}

/// A reference run of axes with these travels (steps) one after the other
/// at `speed_hz`: each may cross its whole travel and a half again (it may
/// start beyond a soft limit and overshoots its switch), then clear the
/// switch slowly.
pub fn reference(spans: impl IntoIterator<Item = i64>, speed_hz: f64) -> Duration {
    let speed = speed_hz.max(1.0);
    let secs: f64 = spans
        .into_iter()
        .map(|span| span.unsigned_abs() as f64 * 1.5 / speed + 1.0)
        .sum();
    motion(Duration::from_secs_f64(secs)) + Duration::from_secs(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_and_reference_runs_grow_with_their_travel() {
        assert_eq!(motion(Duration::from_secs(4)), Duration::from_secs(6));
        // 120000 steps * 1.5 / 4000 Hz = 45 s, plus 1 s to clear the switch.
        assert_eq!(
            reference([120_000], 4000.0),
            motion(Duration::from_secs(46)) + Duration::from_secs(1)
        );
        assert_eq!(
            exchange(LineSettings::new(19200), Duration::from_millis(100), 4, 19),
            LineSettings::new(19200).transfer_time(23) + Duration::from_millis(100)
        );
    }
}
