//! Checking a typed raw command with the family's own parser before it is
//! sent, so the operator sees what is wrong (and where) instead of a
//! controller's one-letter answer, or, on EMCU, nothing at all (EMCU decision
//! 4: the interface acknowledges everything).

use crate::proto::typed;
pub use crate::proto::typed::LineContext as RawContext;

use super::line_edit::{LineError, char_span};

/// Check `line`; `Ok` is the line to send (surrounding blanks removed).
pub fn validate(ctx: &RawContext, line: &str) -> Result<String, LineError> {
    typed::check_line(ctx, line)
        .map(|checked| checked.text)
        .map_err(|fault| LineError {
            message: fault.message,
            span: fault.span.map(|bytes| char_span(line, bytes)),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisSet;
    use crate::proto::Protocol;

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
}
