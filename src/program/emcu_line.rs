//! One line of an EMCU job, parsed by the protocol core's [`parse_line`]
//! (EMCU manual 1.5, `docs/protocols.md` EMCU) and placed in the source line.

use std::ops::Range;

use crate::proto::emcu::parse_line;

use super::model::{Command, Parsed, SyntaxError};

/// Parse the command text `code`, which starts at byte `base` of its line.
pub(crate) fn parse(code: &str, base: usize) -> Parsed {
    match parse_line(code) {
        Ok(command) => Parsed {
            command: Ok(Command::Emcu(command)),
            params: params(code).map(|r| r.start + base..r.end + base).collect(),
            notes: Vec::new(),
        },
        Err(e) => {
            let start = e.offset.min(code.len());
            Parsed {
                command: Err(SyntaxError {
                    message: e.kind.to_string(),
                    cols: start + base..token_end(code, start) + base,
                    reply: None,
                }),
                params: Vec::new(),
                notes: Vec::new(),
            }
        }
    }
}

/// Where the parameter starting at `start` ends: at the next `,` or the end.
fn token_end(code: &str, start: usize) -> usize {
    let rest = code.get(start..).unwrap_or_default();
    let len = rest.find(',').unwrap_or(rest.len());
    // An error at a `,` itself still gets a visible span.
    start + len.max(usize::from(start < code.len()))
}

/// The parameters of a valid command line, lexically: after the command token
/// (`@L`, `#E`, `$H`, `&V`, `L`, `A`, `W`; manual 1.5), split at commas.
fn params(code: &str) -> impl Iterator<Item = Range<usize>> + '_ {
    let token = match code.as_bytes().first() {
        Some(b'@' | b'#' | b'$' | b'&') => 2,
        Some(_) => 1,
        None => 0,
    }
    .min(code.len());
    let rest = code.get(token..).unwrap_or_default();
    let mut at = token;
    rest.split(',')
        .filter(move |_| !rest.is_empty())
        .map(move |piece| {
            let range = at..at + piece.len();
            at += piece.len() + 1;
            range
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spans(code: &str) -> Vec<Range<usize>> {
        params(code).collect()
    }

    #[test]
    fn parameters_follow_the_command_token() {
        assert_eq!(spans("L1,x500,y1000"), vec![1..2, 3..7, 8..13]);
        assert_eq!(spans("#E1,800"), vec![2..3, 4..7]);
        assert_eq!(spans("$HZXY"), vec![2..5]);
        assert_eq!(spans("@LX"), vec![2..3]);
        assert!(spans("@X").is_empty());
        assert_eq!(spans("W250"), vec![1..4]);
    }

    #[test]
    fn errors_cover_the_offending_parameter() {
        let parsed = parse("L1,q500", 4);
        let err = parsed.command.err();
        assert_eq!(err.as_ref().map(|e| e.cols.clone()), Some(7..11));
        let parsed = parse("#S", 0);
        assert_eq!(parsed.command.err().map(|e| e.cols), Some(2..2));
    }
}
