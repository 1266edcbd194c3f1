//! One command line in a family's own syntax, as an operator types it (the
//! console's command line) or a profile writes it (a macro's lines): checked
//! with the family's parser before anything is sent, so the mistake is shown
//! with its place instead of a controller's one-letter answer, or, on EMCU,
//! nothing at all (EMCU decision 4: the interface acknowledges everything).

use std::ops::Range;

use crate::axis::AxisSet;

use super::isel::AxisConfig;
use super::{Protocol, emcu, emp, isel};

/// What the check needs to know about the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineContext {
    pub protocol: Protocol,
    /// The isel device number (the digit after `@`) from the profile.
    pub isel_device: u8,
    /// The axes the controller has been (or will be) initialised with.
    pub initialised: AxisSet,
}

/// A line that passed: the text to send (surrounding blanks removed) and
/// whether it can set an axis in motion.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckedLine {
    pub text: String,
    pub may_move: bool,
}

/// Why a line is refused, and where: a byte range of the line as given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineFault {
    pub message: String,
    pub span: Option<Range<usize>>,
}

/// Check `line` as the family's parser reads it.
pub fn check_line(ctx: &LineContext, line: &str) -> Result<CheckedLine, LineFault> {
    let trimmed = line.trim();
    let lead = line.len() - line.trim_start().len();
    if trimmed.is_empty() {
        return Err(LineFault {
            message: "type a command first".into(),
            span: None,
        });
    }
    let at = |range: Range<usize>| Some(range.start + lead..range.end + lead);
    let ok = |may_move: bool| {
        Ok(CheckedLine {
            text: trimmed.to_string(),
            may_move,
        })
    };
    match ctx.protocol {
        Protocol::Isel => {
            let config = isel_config(ctx.initialised);
            match isel::validate_frame(trimmed, config) {
                Ok(parsed) if parsed.value.device.get() != ctx.isel_device => Err(LineFault {
                    message: format!(
                        "addressed to device {}, but this controller is device {} \
                         (profile: isel.device); it would not answer",
                        parsed.value.device.get(),
                        ctx.isel_device
                    ),
                    span: at(1..2),
                }),
                Ok(parsed) => ok(parsed.value.command.may_move()),
                Err(rejection) => Err(LineFault {
                    message: format!(
                        "{} (the controller would answer {})",
                        rejection.message, rejection.code
                    ),
                    span: rejection.span.and_then(at),
                }),
            }
        }
        Protocol::Emcu => match emcu::parse_line(trimmed) {
            Ok(command) => ok(command.may_move()),
            Err(e) => Err(LineFault {
                message: e.kind.to_string(),
                span: at(e.offset..e.offset + 1),
            }),
        },
        Protocol::Emp => match trimmed.parse::<emp::Request>() {
            Ok(request) => ok(request.command.may_move()),
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
                Err(LineFault {
                    message: e.fault.to_string(),
                    span: span.and_then(at),
                })
            }
            Err(emp::ParseRequestError::Request(e)) => Err(LineFault {
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

    fn ctx(protocol: Protocol, initialised: AxisSet) -> LineContext {
        LineContext {
            protocol,
            isel_device: 0,
            initialised,
        }
    }

    #[test]
    fn lines_that_move_are_told_apart_in_every_family() {
        let isel = ctx(Protocol::Isel, AxisSet::XYZ);
        let moves = |c: &LineContext, l: &str| check_line(c, l).map(|c| c.may_move);
        assert_eq!(moves(&isel, "@0P"), Ok(false));
        assert_eq!(moves(&isel, " @0M 100,900,0,900,0,900,0,900"), Ok(true));
        let emcu = ctx(Protocol::Emcu, AxisSet::XYZ);
        assert_eq!(moves(&emcu, "@X"), Ok(false));
        let emp = ctx(Protocol::Emp, AxisSet::EMPTY);
        assert_eq!(moves(&emp, "2C11000000000000"), Ok(false));
        assert_eq!(moves(&emp, "26 11 00 00 00140400"), Ok(true));
    }

    #[test]
    fn spans_are_bytes_of_the_line_as_given() {
        let isel = ctx(Protocol::Isel, AxisSet::XYZ);
        let err = check_line(&isel, "  @1P").expect_err("device");
        assert_eq!(err.span, Some(3..4));
    }

    #[test]
    fn axis_sets_map_to_isel_configurations() {
        assert_eq!(isel_config(AxisSet::XYZ), Some(AxisConfig::XYZ));
        assert_eq!(isel_config(AxisSet::EMPTY), None);
        assert_eq!(isel_config(AxisSet::from_mask(0b0101)), None);
    }
}
