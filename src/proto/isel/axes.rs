//! Axis configurations (`@0<n>`) and what they mean for parameter counts,
//! axis masks and the width of the `@0P` reply.

use std::fmt;

use crate::axis::{Axis, AxisSet};

/// The axes a controller has been initialised with. Only these four exist:
/// `@01` (X), `@03` (XY), `@07` (XYZ), and `@08` after `@07` (XYZA)
/// (isel manual 2.2.1, `docs/decisions.md` isel 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AxisConfig {
    X,
    XY,
    XYZ,
    XYZA,
}

impl AxisConfig {
    pub const ALL: [AxisConfig; 4] = [
        AxisConfig::X,
        AxisConfig::XY,
        AxisConfig::XYZ,
        AxisConfig::XYZA,
    ];

    /// The initialised axes.
    pub fn axes(self) -> AxisSet {
        AxisSet::from_mask(match self {
            AxisConfig::X => 0b0001,
            AxisConfig::XY => 0b0011,
            AxisConfig::XYZ => 0b0111,
            AxisConfig::XYZA => 0b1111,
        })
    }

    pub fn axis_count(self) -> usize {
        self.axes().len()
    }

    /// Number of steps,speed pairs `A`/`M` (and CNC `0`/`m`) take: one per
    /// axis, except that 3 axes take 4 (x, y, z1, z2)
    /// (isel manual 2.2.2, `docs/decisions.md` isel 5).
    pub fn move_pairs(self) -> usize {
        match self {
            AxisConfig::X => 1,
            AxisConfig::XY => 2,
            AxisConfig::XYZ | AxisConfig::XYZA => 4,
        }
    }

    /// Axes reported by `@0P`: always X, Y, Z up to 3 axes, plus A with 4
    /// (isel manual 2.2.21).
    pub fn position_axes(self) -> usize {
        if self == AxisConfig::XYZA { 4 } else { 3 }
    }

    /// The configuration after an axis setting command, or the reply code
    /// `3` the controller gives when the setting is not allowed. `@08` only
    /// adds A to a controller that already has X, Y and Z
    /// (`docs/protocols.md`, isel).
    pub fn after_setting(
        current: Option<AxisConfig>,
        setting: AxisSetting,
    ) -> Result<AxisConfig, super::ReplyCode> {
        match setting {
            AxisSetting::X => Ok(AxisConfig::X),
            AxisSetting::XY => Ok(AxisConfig::XY),
            AxisSetting::XYZ => Ok(AxisConfig::XYZ),
            AxisSetting::A => match current {
                Some(AxisConfig::XYZ | AxisConfig::XYZA) => Ok(AxisConfig::XYZA),
                _ => Err(super::ReplyCode::BadAxis),
            },
        }
    }

    /// Whether `mask` is an axis mask the controller accepts for `R`, `n`,
    /// `N` and CNC `7`/`n`/`N`: not empty, only initialised axes, and A only
    /// on its own (`docs/decisions.md` isel 3).
    pub fn accepts_mask(self, mask: AxisSet) -> bool {
        !mask.is_empty()
            && mask.iter().all(|axis| self.axes().contains(axis))
            && (!mask.contains(Axis::A) || mask.len() == 1)
    }

    pub fn name(self) -> &'static str {
        match self {
            AxisConfig::X => "X",
            AxisConfig::XY => "XY",
            AxisConfig::XYZ => "XYZ",
            AxisConfig::XYZA => "XYZA",
        }
    }
}

impl fmt::Display for AxisConfig {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The value of an axis setting command `@0<n>`: 1, 3, 7 or 8. The controller
/// answers `3` to every other value (isel manual 2.2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AxisSetting {
    /// `@01`
    X,
    /// `@03`
    XY,
    /// `@07`
    XYZ,
    /// `@08`: switches the A axis on after `@07`.
    A,
}

impl AxisSetting {
    pub fn value(self) -> u8 {
        match self {
            AxisSetting::X => 1,
            AxisSetting::XY => 3,
            AxisSetting::XYZ => 7,
            AxisSetting::A => 8,
        }
    }

    pub fn from_value(value: u64) -> Option<AxisSetting> {
        match value {
            1 => Some(AxisSetting::X),
            3 => Some(AxisSetting::XY),
            7 => Some(AxisSetting::XYZ),
            8 => Some(AxisSetting::A),
            _ => None,
        }
    }

    /// The settings to send, in order, to reach `config` from power-up.
    pub fn sequence_for(config: AxisConfig) -> &'static [AxisSetting] {
        match config {
            AxisConfig::X => &[AxisSetting::X],
            AxisConfig::XY => &[AxisSetting::XY],
            AxisConfig::XYZ => &[AxisSetting::XYZ],
            AxisConfig::XYZA => &[AxisSetting::XYZ, AxisSetting::A],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::isel::ReplyCode;

    #[test]
    fn counts_follow_decision_5() {
        let pairs: Vec<_> = AxisConfig::ALL.iter().map(|c| c.move_pairs()).collect();
        assert_eq!(pairs, [1, 2, 4, 4]);
        let counts: Vec<_> = AxisConfig::ALL.iter().map(|c| c.axis_count()).collect();
        assert_eq!(counts, [1, 2, 3, 4]);
        let pos: Vec<_> = AxisConfig::ALL.iter().map(|c| c.position_axes()).collect();
        assert_eq!(pos, [3, 3, 3, 4]);
    }

    #[test]
    fn a_axis_only_after_xyz() {
        assert_eq!(
            AxisConfig::after_setting(Some(AxisConfig::XYZ), AxisSetting::A),
            Ok(AxisConfig::XYZA)
        );
        assert_eq!(
            AxisConfig::after_setting(Some(AxisConfig::XY), AxisSetting::A),
            Err(ReplyCode::BadAxis)
        );
        assert_eq!(
            AxisConfig::after_setting(None, AxisSetting::A),
            Err(ReplyCode::BadAxis)
        );
        assert_eq!(
            AxisConfig::after_setting(Some(AxisConfig::XYZA), AxisSetting::XY),
            Ok(AxisConfig::XY)
        );
        for config in AxisConfig::ALL {
            let mut current = None;
            for &s in AxisSetting::sequence_for(config) {
                current = AxisConfig::after_setting(current, s).ok();
            }
            assert_eq!(current, Some(config));
        }
    }

    #[test]
    fn masks_follow_decision_3() {
        let xyza = AxisConfig::XYZA;
        assert!(xyza.accepts_mask(AxisSet::from_mask(7)));
        assert!(xyza.accepts_mask(AxisSet::from_mask(8)));
        assert!(!xyza.accepts_mask(AxisSet::from_mask(9)));
        assert!(!xyza.accepts_mask(AxisSet::from_mask(0)));
        assert!(!AxisConfig::XY.accepts_mask(AxisSet::from_mask(4)));
        assert!(!AxisConfig::XYZ.accepts_mask(AxisSet::from_mask(8)));
        assert!(AxisConfig::XY.accepts_mask(AxisSet::from_mask(2)));
    }

    #[test]
    fn only_1_3_7_8_are_settings() {
        let valid: Vec<u64> = (0..=20)
            .filter(|v| AxisSetting::from_value(*v).is_some())
            .collect();
        assert_eq!(valid, [1, 3, 7, 8]);
    }
}
