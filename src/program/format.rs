//! The formatter: every command in its canonical spelling (the protocol
//! core's encoder: section letters, no blanks in or before the parameters,
//! CCW as `-1`, no leading zeros), one per line, without indentation;
//! comments and blank lines kept as they are (trailing blanks dropped, a
//! trailing comment one blank after its command). A line that does not parse
//! is kept as written, so formatting never loses text.
//!
//! `Program::parse(l, &format(&p)).items() == p.items()` for every program.

use std::fmt::Write as _;

use super::model::{LineKind, Program};

/// The program in canonical form, each line ended by LF.
pub fn format(program: &Program) -> String {
    let mut out = String::with_capacity(program.lines().iter().map(|l| l.text().len() + 1).sum());
    for line in program.lines() {
        match line.kind() {
            LineKind::Blank => {}
            LineKind::Comment(cols) => out.push_str(line.slice(cols.clone())),
            LineKind::Statement(s) => {
                let code_start = out.len();
                match &s.command {
                    // Writing to a String cannot fail.
                    Ok(command) => {
                        let _ = write!(out, "{command}");
                    }
                    Err(_) => out.push_str(line.slice(s.code.clone())),
                }
                if let Some(comment) = &s.comment {
                    // `#` and a blank start a whole-line comment
                    // (`docs/programs.md`): a line that is just `#` and its
                    // comment keeps them together, or it would read back as
                    // a comment.
                    if out.get(code_start..) != Some("#") {
                        out.push(' ');
                    }
                    out.push_str(line.slice(comment.clone()));
                }
            }
        }
        out.push('\n');
    }
    out
}
