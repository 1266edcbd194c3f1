//! Which controller program a toolpath becomes, and what that family's
//! counters hold.

use jogterm_proto::Protocol;

/// Which controller program to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    Isel,
    Emcu,
}

impl Target {
    /// The profile's family, or why it has none.
    pub fn of(protocol: Protocol) -> Result<Target, String> {
        match protocol {
            Protocol::Isel => Ok(Target::Isel),
            Protocol::Emcu => Ok(Target::Emcu),
            Protocol::Emp => Err(
                "the EMP (MSR DRS-500-ECS) drives run independently: they have no interpolated path, so G-code cannot run on them".into(),
            ),
        }
    }

    /// The positions in steps the family's counter holds: isel 24-bit two's
    /// complement (`@0P`, manual 3.2.16), EMCU `L` moves ±999999 steps.
    pub fn counter(self) -> std::ops::RangeInclusive<i64> {
        match self {
            Target::Isel => {
                let r = jogterm_proto::isel::STEPS;
                i64::from(*r.start())..=i64::from(*r.end())
            }
            Target::Emcu => {
                use jogterm_proto::emcu::values::Steps;
                i64::from(Steps::MIN)..=i64::from(Steps::MAX)
            }
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Target::Isel => "isel",
            Target::Emcu => "emcu",
        }
    }
}
