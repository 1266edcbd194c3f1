//! One line of an isel CNC program, parsed by the protocol core's
//! [`parse_cnc`] (isel manual chapter 3, `docs/decisions.md` isel 10-12)
//! and placed in the source line.

use std::ops::Range;

use crate::proto::isel::parse_cnc;

use super::model::{Command, Note, Parsed, SyntaxError};

/// Parse the command text `code`, which starts at byte `base` of its line.
pub(crate) fn parse(code: &str, base: usize) -> Parsed {
    let shift = |r: Range<usize>| r.start + base..r.end + base;
    match parse_cnc(code) {
        Ok(parsed) => Parsed {
            command: Ok(Command::Isel(parsed.value)),
            params: parsed.params.into_iter().map(shift).collect(),
            notes: parsed
                .notes
                .into_iter()
                .map(|n| Note {
                    kind: n.kind,
                    cols: shift(n.span),
                })
                .collect(),
        },
        Err(e) => {
            let mut message = e.message;
            // The core reads bytes; a program is text, so name the character.
            let odd = code
                .get(e.span.start.min(code.len())..)
                .and_then(|rest| rest.chars().next())
                .filter(|c| !(' '..='~').contains(c));
            if let Some(c) = odd {
                message = format!("unexpected character {c:?}: commands are printable ASCII");
            }
            if code.starts_with('#') {
                // `#x` is neither a command nor, without a blank after `#`, a
                // comment (`docs/programs.md`).
                message.push_str("; a comment starts with `;`, or with `#` and a blank");
            }
            // The core's spans are in the line it was given, which is `code`.
            let cols = shift(e.span.start.min(code.len())..e.span.end.min(code.len()));
            Parsed {
                command: Err(SyntaxError {
                    message,
                    cols,
                    reply: Some(e.code),
                }),
                params: Vec::new(),
                notes: Vec::new(),
            }
        }
    }
}
