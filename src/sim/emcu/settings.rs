//! The interface's configuration: start speed, the nine end-speed slots, the
//! ramp length and the E1 linkage. `@R` keeps it (manual 1.5.1: "Die gültigen
//! Konfigurationseinstellungen werden nicht verändert").

use crate::motion::Ramp;
use crate::proto::emcu::{RampMillis, Slot, Speed};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Settings {
    /// `#S`: start speed, also the reference-run speed (manual 1.5.5, 1.5.8).
    pub start: Speed,
    /// `#E1..9` (manual 1.5.6, decision 3).
    end: [Speed; 9],
    /// `#R` (manual 1.5.7).
    pub ramp: RampMillis,
    /// `&V1`: vector moves wait for input E1 (manual 1.5.19).
    pub link_e1: bool,
}

impl Default for Settings {
    /// Manual 1.4.2: 200 Hz, 600 Hz, 500 ms, E1 linkage off.
    fn default() -> Self {
        Settings {
            start: Speed::DEFAULT_START,
            end: [Speed::DEFAULT_END; 9],
            ramp: RampMillis::DEFAULT,
            link_e1: false,
        }
    }
}

impl Settings {
    fn slot_index(slot: Slot) -> usize {
        usize::from(slot.get().saturating_sub(1))
    }

    pub fn end_speed(&self, slot: Slot) -> Speed {
        self.end
            .get(Self::slot_index(slot))
            .copied()
            .unwrap_or(Speed::DEFAULT_END)
    }

    pub fn set_end_speed(&mut self, slot: Slot, speed: Speed) {
        if let Some(cell) = self.end.get_mut(Self::slot_index(slot)) {
            *cell = speed;
        }
    }

    /// The profile of the leading axis of an `L` move: the ramp takes `#R`
    /// ms from the start speed to the slot's end speed (manual 1.5.7: start
    /// and brake ramp follow from start speed and ramp length, and are the
    /// same). An end speed at or below the start speed leaves no ramp: the
    /// move runs at the lower of the two throughout.
    pub fn vector_ramp(&self, slot: Slot) -> Ramp {
        let start = f64::from(self.start.get());
        let end = f64::from(self.end_speed(slot).get());
        let ramp_s = f64::from(self.ramp.get()) / 1000.0;
        Ramp {
            start_hz: start,
            max_hz: end,
            accel_hz_per_s: if end > start {
                (end - start) / ramp_s
            } else {
                0.0
            },
        }
    }

    /// A reference run goes at the start speed without a ramp (manual 1.5.8).
    pub fn reference_ramp(&self) -> Ramp {
        let start = f64::from(self.start.get());
        Ramp {
            start_hz: start,
            max_hz: start,
            accel_hz_per_s: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_ramp_takes_500_ms_from_200_to_600_hz() {
        let ramp = Settings::default().vector_ramp(Slot::FIRST);
        assert_eq!(ramp.start_hz, 200.0);
        assert_eq!(ramp.max_hz, 600.0);
        assert_eq!(ramp.accel_hz_per_s, 800.0);
        assert_eq!(ramp.braking_time(600.0).as_millis(), 500);
    }

    #[test]
    fn slots_are_independent() {
        let mut s = Settings::default();
        let nine = Slot::new(9).unwrap();
        s.set_end_speed(nine, Speed::new(1200).unwrap());
        assert_eq!(s.end_speed(nine).get(), 1200);
        assert_eq!(s.end_speed(Slot::FIRST).get(), 600);
    }
}
