//! A held key told from new presses by the arrival times of its events, as
//! the jog keypad tells them (`docs/jogging.md`, "Continuous jog, hold"):
//! terminals without release events (no kitty keyboard protocol: tmux,
//! most SSH set-ups) send a held key's auto-repeats as presses, the first
//! after the terminal's repeat delay (within `jog.first_repeat_grace_ms`),
//! then one every 25-40 ms (within `jog.repeat_timeout_ms`). A press that
//! comes later than that is the key pressed again.
//!
//! For keys that must not act twice on one hold (a macro key). Sans-IO:
//! time is an argument.

use std::time::{Duration, Instant};

use super::pad::KeyPhase;

/// What an event of a key is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arrival {
    /// A new press: the key acts.
    Press,
    /// The key is still held (an auto-repeat, reported or timed): nothing.
    Held,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Last<K> {
    key: K,
    at: Instant,
    /// Repeats flow (at least one has come): the short timeout applies.
    repeating: bool,
}

/// The last key that acted, and when it was last seen.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HeldKey<K> {
    last: Option<Last<K>>,
}

impl<K> Default for HeldKey<K> {
    fn default() -> Self {
        HeldKey { last: None }
    }
}

impl<K: Copy + PartialEq> HeldKey<K> {
    /// An event of `key` at `now`. `grace`: the longest wait for the first
    /// repeat; `timeout`: the longest gap once repeats flow; `releases`:
    /// the terminal reports releases and repeats (then a press is a press).
    pub fn arrival(
        &mut self,
        key: K,
        phase: KeyPhase,
        now: Instant,
        grace: Duration,
        timeout: Duration,
        releases: bool,
    ) -> Arrival {
        if phase == KeyPhase::Release {
            if self.last.is_some_and(|l| l.key == key) {
                self.last = None;
            }
            return Arrival::Held;
        }
        let held = match (phase, self.last) {
            (KeyPhase::Repeat, _) => true,
            (_, Some(last)) if !releases && last.key == key => {
                let gap = now.saturating_duration_since(last.at);
                gap <= if last.repeating { timeout } else { grace }
            }
            _ => false,
        };
        if held {
            self.last = Some(Last {
                key,
                at: now,
                repeating: true,
            });
            Arrival::Held
        } else {
            self.last = Some(Last {
                key,
                at: now,
                repeating: false,
            });
            Arrival::Press
        }
    }

    /// A key arrived that is not taken as an act of its own (a burst): its
    /// time keeps a hold of the same key alive, and it ends the hold of
    /// another (terminals repeat only the last key pressed).
    pub fn seen(&mut self, key: K, now: Instant) {
        match self.last.as_mut() {
            Some(last) if last.key == key => {
                last.at = now;
                last.repeating = true;
            }
            _ => self.last = None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRACE: Duration = Duration::from_millis(750);
    const TIMEOUT: Duration = Duration::from_millis(150);

    fn ms(t0: Instant, n: u64) -> Instant {
        t0 + Duration::from_millis(n)
    }

    #[test]
    fn repeats_as_presses_are_held_a_press_after_a_pause_is_new() {
        let t0 = Instant::now();
        let mut h = HeldKey::default();
        let mut at =
            |n: u64, key: char| h.arrival(key, KeyPhase::Press, ms(t0, n), GRACE, TIMEOUT, false);
        assert_eq!(at(0, 'm'), Arrival::Press);
        // The X.Org repeat delay (660 ms), then every 40 ms.
        assert_eq!(at(660, 'm'), Arrival::Held);
        for n in 1..20 {
            assert_eq!(at(660 + 40 * n, 'm'), Arrival::Held, "repeat {n}");
        }
        // Let go (last repeat at 1420), pressed again 400 ms later: new,
        // although within the first-repeat grace: repeats had been flowing.
        assert_eq!(at(1820, 'm'), Arrival::Press);
        // Another key is a new press, and so is the first key after it.
        assert_eq!(at(1850, 'n'), Arrival::Press);
        assert_eq!(at(1880, 'm'), Arrival::Press);
        // A second tap after more than the grace: new.
        assert_eq!(at(1880 + 800, 'm'), Arrival::Press);
    }

    #[test]
    fn with_releases_a_press_is_a_press_and_repeats_are_held() {
        let t0 = Instant::now();
        let mut h = HeldKey::default();
        let k = 'm';
        assert_eq!(
            h.arrival(k, KeyPhase::Press, t0, GRACE, TIMEOUT, true),
            Arrival::Press
        );
        assert_eq!(
            h.arrival(k, KeyPhase::Repeat, ms(t0, 500), GRACE, TIMEOUT, true),
            Arrival::Held
        );
        assert_eq!(
            h.arrival(k, KeyPhase::Release, ms(t0, 520), GRACE, TIMEOUT, true),
            Arrival::Held
        );
        assert_eq!(
            h.arrival(k, KeyPhase::Press, ms(t0, 540), GRACE, TIMEOUT, true),
            Arrival::Press
        );
    }

    #[test]
    fn keys_seen_in_a_burst_keep_the_hold_alive() {
        let t0 = Instant::now();
        let mut h = HeldKey::default();
        assert_eq!(
            h.arrival('m', KeyPhase::Press, t0, GRACE, TIMEOUT, false),
            Arrival::Press
        );
        h.seen('m', ms(t0, 600));
        h.seen('m', ms(t0, 700));
        assert_eq!(
            h.arrival('m', KeyPhase::Press, ms(t0, 800), GRACE, TIMEOUT, false),
            Arrival::Held
        );
        h.seen('x', ms(t0, 810));
        assert_eq!(
            h.arrival('m', KeyPhase::Press, ms(t0, 840), GRACE, TIMEOUT, false),
            Arrival::Press
        );
    }
}
