//! Checking a typed raw command with the family's own parser before it is
//! sent, so the operator sees what is wrong (and where) instead of a
//! controller's one-letter answer, or, on EMCU, nothing at all (EMCU decision
//! 4: the interface acknowledges everything).

use crate::axis::AxisSet;
use crate::proto::Protocol;
use crate::proto::isel::AxisConfig;
use crate::proto::{emcu, emp, isel};

use super::line_edit::{LineError, char_span};

/// What the check needs to know about the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawContext {
    pub protocol: Protocol,
    /// The isel device number (the digit after `@`) from the profile.
    pub isel_device: u8,
    /// The axes the controller has been initialised with, as the driver
    /// reports them.
    pub initialised: AxisSet,
}

/// Check `line`; `Ok` is the line to send (surrounding blanks removed).
pub fn validate(ctx: &RawContext, line: &str) -> Result<String, LineError> {
    let trimmed = line.trim();
    let lead = line.len() - line.trim_start().len();
    if trimmed.is_empty() {
        return Err(LineError {
            message: "type a command first".into(),
            span: None,
        });
    }
    let at =
        |range: std::ops::Range<usize>| Some(char_span(line, range.start + lead..range.end + lead));
    match ctx.protocol {
        Protocol::Isel => {
            let config = isel_config(ctx.initialised);
            match isel::validate_frame(trimmed, config) {
                Ok(parsed) if parsed.value.device.get() != ctx.isel_device => Err(LineError {
                    message: format!(
                        "addressed to device {}, but this controller is device {} \
                         (profile: isel.device); it would not answer",
                        parsed.value.device.get(),
                        ctx.isel_device
                    ),
                    span: at(1..2),
                }),
                Ok(_) => Ok(trimmed.to_string()),
                Err(rejection) => Err(LineError {
                    message: format!(
                        "{} (the controller would answer {})",
                        rejection.message, rejection.code
                    ),
                    span: rejection.span.and_then(at),
                }),
            }
        }
        Protocol::Emcu => match emcu::parse_line(trimmed) {
            Ok(_) => Ok(trimmed.to_string()),
            Err(e) => Err(LineError {
                message: e.kind.to_string(),
                span: at(e.offset..e.offset + 1),
            }),
        },
        Protocol::Emp => match trimmed.parse::<emp::Request>() {
            Ok(_) => Ok(trimmed.to_string()),
            Err(emp::ParseRequestError::Frame(e)) => {
                // The fault's index counts the hex characters only (blanks
                // are skipped when typed text is read as a frame).
                let index = match e.fault {
                    emp::FrameFault::LowerCase { at } | emp::FrameFault::NotHex { at, .. } => {
                        Some(at)
                    }
                    _ => None,
                };
                let span = index.and_then(|n| {
                    trimmed
                        .char_indices()
                        .filter(|(_, c)| !c.is_ascii_whitespace())
                        .nth(n)
                        .map(|(i, c)| i..i + c.len_utf8())
                });
                Err(LineError {
                    message: e.fault.to_string(),
                    span: span.and_then(at),
                })
            }
            Err(emp::ParseRequestError::Request(e)) => Err(LineError {
                message: e.to_string(),
                span: None,
            }),
        },
    }
}

/// The isel axis configuration for the initialised axes, `None` before the
/// axes are set (isel manual 2.2.1).
pub fn isel_config(axes: AxisSet) -> Option<AxisConfig> {
    AxisConfig::ALL.into_iter().find(|c| c.axes() == axes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ctx(protocol: Protocol, initialised: AxisSet) -> RawContext {
        RawContext {
            protocol,
            isel_device: 0,
            initialised,
        }
    }

    #[test]
    fn isel_lines_are_checked_against_the_initialised_axes() {
        let xyz = ctx(Protocol::Isel, AxisSet::XYZ);
        assert_eq!(validate(&xyz, " @0P ").as_deref(), Ok("@0P"));
        let err = validate(&xyz, "@0A5000,900").expect_err("pair count");
        assert!(
            err.message.contains("4 steps,speed pairs"),
            "{}",
            err.message
        );
        assert!(err.message.contains("`7`"), "{}", err.message);
        let err = validate(&xyz, "@1P").expect_err("device");
        assert_eq!(err.span, Some(1..2));
        let err = validate(&xyz, "@0Q").expect_err("unknown letter");
        assert!(err.span.is_some(), "{err:?}");
    }

    #[test]
    fn emcu_errors_point_at_the_column() {
        let c = ctx(Protocol::Emcu, AxisSet::XYZ);
        assert!(validate(&c, "@LX").is_ok());
        let err = validate(&c, "  @LQ").expect_err("bad axis");
        let span = err.span.expect("span");
        assert!(span.start >= 2, "{span:?} counts the blanks in front");
    }

    #[test]
    fn emp_frames_may_be_typed_without_blanks_and_faults_are_placed() {
        let c = ctx(Protocol::Emp, AxisSet::EMPTY);
        assert!(validate(&c, "2C11000000000000").is_ok());
        let err = validate(&c, "2c11000000000000").expect_err("lower case");
        assert_eq!(err.span, Some(1..2));
        assert!(validate(&c, "2C1100").is_err());
        let err = validate(&c, "2D11000000000000").expect_err("a reply code");
        assert!(err.message.contains("reply"), "{}", err.message);
    }

    #[test]
    fn empty_lines_are_refused_for_every_family() {
        for p in Protocol::ALL {
            assert!(validate(&ctx(p, AxisSet::EMPTY), "   ").is_err());
        }
    }

    #[test]
    fn axis_sets_map_to_isel_configurations() {
        assert_eq!(isel_config(AxisSet::XYZ), Some(AxisConfig::XYZ));
        assert_eq!(isel_config(AxisSet::EMPTY), None);
        assert_eq!(isel_config(AxisSet::from_mask(0b0101)), None);
    }
}
