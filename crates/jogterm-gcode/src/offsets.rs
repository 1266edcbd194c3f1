//! The work coordinate systems and their arithmetic. Pure.

use std::fmt;

use jogterm_proto::axis::Axis;

/// The farthest a work zero may lie from the reference point, in steps: far
/// beyond any controller's counter (isel 24 bits, EMP 25), near enough that
/// work and machine positions never overflow. A file or a typed value that
/// puts a zero beyond it is refused.
pub const MAX_ZERO_STEPS: i64 = i32::MAX as i64;

/// One work coordinate system, G54 (index 0) to G59 (index 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct System(u8);

impl System {
    pub const COUNT: usize = 6;
    pub const G54: System = System(0);
    pub const ALL: [System; System::COUNT] = [
        System(0),
        System(1),
        System(2),
        System(3),
        System(4),
        System(5),
    ];

    const NAMES: [&'static str; System::COUNT] = ["G54", "G55", "G56", "G57", "G58", "G59"];

    pub fn from_index(index: usize) -> Option<System> {
        System::ALL.get(index).copied()
    }

    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// `G54` … `G59`.
    pub fn name(self) -> &'static str {
        System::NAMES.get(self.index()).copied().unwrap_or("G54")
    }

    /// `G55` or `g55`.
    pub fn from_name(name: &str) -> Option<System> {
        System::ALL
            .into_iter()
            .find(|s| s.name().eq_ignore_ascii_case(name))
    }
}

impl fmt::Display for System {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The six systems' work zeros and the active one. A zero is the machine
/// position (steps from the reference point) where the system's work
/// coordinates are 0; an axis without one has it at the reference point,
/// so an untouched system is machine coordinates.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WorkOffsets {
    /// Per system, per axis (X, Y, Z, A order).
    zeros: [[i64; 4]; System::COUNT],
    active: System,
}

impl Default for WorkOffsets {
    fn default() -> Self {
        WorkOffsets {
            zeros: [[0; 4]; System::COUNT],
            active: System::G54,
        }
    }
}

impl WorkOffsets {
    pub fn active(&self) -> System {
        self.active
    }

    pub fn select(&mut self, system: System) {
        self.active = system;
    }

    /// The machine position of `system`'s work zero on `axis`, steps.
    pub fn zero(&self, system: System, axis: Axis) -> i64 {
        self.zeros
            .get(system.index())
            .and_then(|z| z.get(axis.index()))
            .copied()
            .unwrap_or(0)
    }

    /// The active system's work zero on `axis`.
    pub fn active_zero(&self, axis: Axis) -> i64 {
        self.zero(self.active, axis)
    }

    /// Put `system`'s work zero of `axis` at machine position `steps`
    /// (clamped to [`MAX_ZERO_STEPS`]; callers refuse beyond it first).
    pub fn set(&mut self, system: System, axis: Axis, steps: i64) {
        if let Some(z) = self
            .zeros
            .get_mut(system.index())
            .and_then(|z| z.get_mut(axis.index()))
        {
            *z = steps.clamp(-MAX_ZERO_STEPS, MAX_ZERO_STEPS);
        }
    }

    /// The active system's work position of machine position `machine`.
    pub fn work(&self, axis: Axis, machine: i64) -> i64 {
        machine.saturating_sub(self.active_zero(axis))
    }

    /// The machine position of the active system's work position `work`.
    pub fn machine(&self, axis: Axis, work: i64) -> i64 {
        work.saturating_add(self.active_zero(axis))
    }

    /// The work zero that makes machine position `machine` read `work` in
    /// the active system: "set X = 10 here". `None` beyond
    /// [`MAX_ZERO_STEPS`].
    pub fn zero_for(machine: i64, work: i64) -> Option<i64> {
        let zero = machine.checked_sub(work)?;
        (zero.abs() <= MAX_ZERO_STEPS).then_some(zero)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn systems_are_named_g54_to_g59() {
        let names: Vec<&str> = System::ALL.iter().map(|s| s.name()).collect();
        assert_eq!(names, ["G54", "G55", "G56", "G57", "G58", "G59"]);
        assert_eq!(System::from_name("g57"), System::from_index(3));
        assert_eq!(System::from_name("G53"), None);
        assert_eq!(System::from_index(6), None);
    }

    #[test]
    fn work_positions_count_from_the_active_systems_zero() {
        let mut t = WorkOffsets::default();
        assert_eq!(t.active(), System::G54);
        // Untouched: machine coordinates.
        assert_eq!(t.work(Axis::X, 1234), 1234);
        let g55 = System::ALL[1];
        t.set(g55, Axis::X, 4000);
        assert_eq!(t.work(Axis::X, 1234), 1234, "G54 is still active");
        t.select(g55);
        assert_eq!(t.work(Axis::X, 1234), 1234 - 4000);
        assert_eq!(t.machine(Axis::X, -2766), 1234);
        assert_eq!(t.zero(System::G54, Axis::X), 0);
        // X = 10 mm here (400 steps/mm) at machine 12000: the zero at 8000.
        assert_eq!(WorkOffsets::zero_for(12_000, 4_000), Some(8_000));
        assert_eq!(WorkOffsets::zero_for(0, MAX_ZERO_STEPS + 1), None);
        assert_eq!(WorkOffsets::zero_for(i64::MIN, 1), None);
    }
}
