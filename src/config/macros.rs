//! Macros: named command sequences of a profile (`[macros.park]`), each line
//! in the family's own command syntax as the console's command line takes it
//! (isel DNC commands, EMCU commands, EMP frames). Every line is checked with
//! the family's parser when the profile loads, so a macro with a bad line
//! stops jogterm before anything starts, with the file, line and column of
//! the mistake (`docs/profiles.md`, "Macros").

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::axis::AxisSet;
use crate::proto::Protocol;
use crate::proto::typed::{self, LineContext};

/// A macro as the profile writes it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MacroProfile {
    /// What it does, for the help and the question before it runs.
    #[serde(default)]
    pub description: Option<String>,
    /// The commands, in order.
    pub lines: Vec<String>,
    /// Ask before it runs. A macro that may move asks unless this is
    /// `false`; one that cannot move asks only when this is `true`.
    #[serde(default)]
    pub confirm: Option<bool>,
}

/// A macro whose lines passed the family's checks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Macro {
    pub name: String,
    pub description: Option<String>,
    /// The lines to send, blanks around them removed.
    pub lines: Vec<String>,
    /// Some line may set an axis in motion.
    pub moves: bool,
    /// The operator is asked before it runs.
    pub confirm: bool,
}

/// Longest macro name (the help and the keymap show it whole).
pub const MAX_NAME_CHARS: usize = 24;

/// A problem with one macro: the key path below the profile's root, what
/// is wrong, and for a bad line the byte offset in that line's text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MacroProblem {
    pub key: Vec<String>,
    pub message: String,
    pub offset: Option<usize>,
}

/// Check every macro against the controller family and the machine's axes
/// (isel lines are checked for the axis configuration the console sets).
pub fn check(
    macros: &BTreeMap<String, MacroProfile>,
    protocol: Protocol,
    isel_device: u8,
    axes: AxisSet,
) -> Result<Vec<Macro>, Vec<MacroProblem>> {
    let ctx = LineContext {
        protocol,
        isel_device,
        initialised: axes,
    };
    let mut out = Vec::new();
    let mut problems = Vec::new();
    for (name, m) in macros {
        let key = |rest: &[&str]| {
            let mut k = vec!["macros".to_owned(), name.clone()];
            k.extend(rest.iter().map(|s| s.to_string()));
            k
        };
        let good_name = !name.is_empty()
            && name.chars().count() <= MAX_NAME_CHARS
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !good_name {
            problems.push(MacroProblem {
                key: key(&[]),
                message: format!(
                    "macro name `{name}`: expected 1 to {MAX_NAME_CHARS} letters, digits, `-` or `_`"
                ),
                offset: None,
            });
        }
        if m.lines.is_empty() {
            problems.push(MacroProblem {
                key: key(&["lines"]),
                message: format!("macro `{name}` has no lines: expected at least one command"),
                offset: None,
            });
        }
        let mut lines = Vec::with_capacity(m.lines.len());
        let mut moves = false;
        for (i, line) in m.lines.iter().enumerate() {
            match typed::check_line(&ctx, line) {
                Ok(checked) => {
                    moves |= checked.may_move;
                    lines.push(checked.text);
                }
                Err(fault) => problems.push(MacroProblem {
                    key: key(&["lines", &i.to_string()]),
                    message: format!(
                        "macro `{name}`, line {}: {} command expected: {}",
                        i + 1,
                        protocol,
                        fault.message
                    ),
                    offset: Some(fault.span.map_or(0, |s| s.start)),
                }),
            }
        }
        out.push(Macro {
            name: name.clone(),
            description: m.description.clone(),
            lines,
            moves,
            confirm: m.confirm.unwrap_or(moves),
        });
    }
    if problems.is_empty() {
        Ok(out)
    } else {
        Err(problems)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(lines: &[&str], confirm: Option<bool>) -> BTreeMap<String, MacroProfile> {
        BTreeMap::from([(
            "park".to_owned(),
            MacroProfile {
                description: None,
                lines: lines.iter().map(|s| s.to_string()).collect(),
                confirm,
            },
        )])
    }

    #[test]
    fn a_macro_that_moves_asks_first_unless_told_not_to() {
        let check_isel = |m| check(&m, Protocol::Isel, 0, AxisSet::XYZ);
        let moving = one(&["@0P", " @0M 100,900,0,900,0,900,0,900 "], None);
        let got = check_isel(moving).expect("valid");
        assert_eq!(got[0].lines, ["@0P", "@0M 100,900,0,900,0,900,0,900"]);
        assert!(got[0].moves && got[0].confirm);
        let unasked = check_isel(one(&["@0M 100,900,0,900,0,900,0,900"], Some(false))).expect("ok");
        assert!(unasked[0].moves && !unasked[0].confirm);
        let reading = check_isel(one(&["@0P"], None)).expect("ok");
        assert!(!reading[0].moves && !reading[0].confirm);
    }

    #[test]
    fn a_bad_line_names_its_index_and_place() {
        let err = check(
            &one(&["@0P", "@0M 100,900"], None),
            Protocol::Isel,
            0,
            AxisSet::XYZ,
        )
        .expect_err("pairs");
        assert_eq!(err[0].key, ["macros", "park", "lines", "1"]);
        assert!(err[0].message.contains("line 2"), "{}", err[0].message);
        assert!(err[0].offset.is_some());
        let err = check(&one(&["@LQ"], None), Protocol::Emcu, 0, AxisSet::XYZ).expect_err("emcu");
        assert!(
            err[0].message.contains("emcu command expected"),
            "{}",
            err[0].message
        );
        let err = check(&one(&[], None), Protocol::Emp, 0, AxisSet::XYZ).expect_err("empty");
        assert_eq!(err[0].key, ["macros", "park", "lines"]);
    }
}
