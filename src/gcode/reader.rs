//! The reader: G-code text as CAM posts write it, to blocks of words, each
//! word with its line and column. No meaning yet (that is the
//! interpreter's); only what RS-274/NGC says about how a line is spelt.
//!
//! Why our own reader and not a crate (`docs/gcode.md`, "Reader"): `gcode`
//! 0.7 keeps numbers as f32 and lets an unclosed `(` eat the next line;
//! `g-code` 0.6 rejects a final `%` line, spaces inside numbers and nested
//! parentheses, and stops at the first error.
//!
//! Spelling rules, in the order a line is read:
//! - a byte order mark before the first line is dropped, CR LF is a line end;
//! - a line whose first character (after blanks) is `%` is a tape marker,
//!   text after it included, and is skipped;
//! - `/` first is block delete: the block is read and marked, the
//!   interpreter decides (`Block::deleted`);
//! - blanks (spaces, tabs) are ignored everywhere outside comments, also
//!   inside numbers (`X 1 2.5` is `X12.5`), as RS-274/NGC says;
//! - `( … )` is a comment, nested parentheses included; an unclosed one is
//!   an error at its `(`; `;` makes the rest of the line a comment;
//! - `*` and digits end a line with a checksum: the XOR of every byte
//!   before the `*` must equal it, else the line is refused;
//! - a word is a letter and a number (`+`/`-`, digits, one `.`); numbers
//!   are read from their decimal text into f64 (correctly rounded, never
//!   through f32); `#` parameters, `[` expressions and `O` words are
//!   refused with what they are.

use super::toolpath::{Diagnostic, Origin, Severity};

/// A word: letter (upper case) and value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Word {
    pub letter: char,
    pub value: f64,
    pub origin: Origin,
}

/// One line's words.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Block {
    pub line: u32,
    pub words: Vec<Word>,
    /// The line began with `/`.
    pub deleted: bool,
    /// The comments' text, for headers (Fusion's `(T1 D=6 …)`).
    pub comments: Vec<String>,
}

impl Block {
    /// Where a thing the whole block made is reported: its first word, or
    /// column 1.
    pub fn origin(&self) -> Origin {
        self.words.first().map_or(
            Origin {
                line: self.line,
                col: 1,
            },
            |w| w.origin,
        )
    }
}

/// What a file read as.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Read {
    pub blocks: Vec<Block>,
    /// Lines in the file (a final line without newline counts).
    pub lines: u32,
    /// Errors of lines that could not be read; their blocks are left out.
    pub errors: Vec<Diagnostic>,
}

/// Letters RS-274/NGC gives a meaning; `O` is refused separately.
const WORD_LETTERS: &str = "ABCDEFGHIJKLMNPQRSTUVWXYZ";

/// Reads a whole file.
pub fn read(text: &str) -> Read {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Read::default();
    for (index, raw) in text.split('\n').enumerate() {
        let line_no = u32::try_from(index + 1).unwrap_or(u32::MAX);
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        match read_line(raw, line_no) {
            Ok(Some(block)) => out.blocks.push(block),
            Ok(None) => {}
            Err(e) => out.errors.push(e),
        }
    }
    out.lines = count_lines(text);
    out
}

fn count_lines(text: &str) -> u32 {
    let newlines = text.matches('\n').count();
    let lines = if text.is_empty() || text.ends_with('\n') {
        newlines
    } else {
        newlines + 1
    };
    u32::try_from(lines).unwrap_or(u32::MAX)
}

fn error(line: u32, col: usize, message: impl Into<String>) -> Diagnostic {
    Diagnostic {
        severity: Severity::Error,
        origin: Origin {
            line,
            col: u32::try_from(col).unwrap_or(u32::MAX),
        },
        message: message.into(),
    }
}

/// One line to a block; `None` for a line with no words and no comment
/// (blank, tape marker).
fn read_line(raw: &str, line: u32) -> Result<Option<Block>, Diagnostic> {
    let chars: Vec<char> = raw.chars().collect();
    let mut block = Block {
        line,
        ..Block::default()
    };
    let mut i = 0;
    while i < chars.len() && is_blank(chars[i]) {
        i += 1;
    }
    match chars.get(i) {
        None => return Ok(None),
        Some('%') => return Ok(None),
        Some('/') => {
            block.deleted = true;
            i += 1;
        }
        Some(_) => {}
    }
    let mut any = false;
    while i < chars.len() {
        let c = chars[i];
        let col = i + 1;
        match c {
            c if is_blank(c) => i += 1,
            '(' => {
                let (text, next) = comment(&chars, i).ok_or_else(|| {
                    error(
                        line,
                        col,
                        "a comment opened with `(` is not closed on its line",
                    )
                })?;
                block.comments.push(text);
                any = true;
                i = next;
            }
            ';' => {
                block
                    .comments
                    .push(chars[i + 1..].iter().collect::<String>().trim().to_owned());
                any = true;
                break;
            }
            '*' => {
                checksum(&chars, i, line)?;
                break;
            }
            '#' => {
                return Err(error(
                    line,
                    col,
                    "`#` parameters are refused: jogterm runs no G-code variables (write the values out in the CAM post)",
                ));
            }
            '[' => {
                return Err(error(
                    line,
                    col,
                    "`[` expressions are refused: jogterm evaluates no G-code expressions",
                ));
            }
            c if c.eq_ignore_ascii_case(&'o') => {
                return Err(error(
                    line,
                    col,
                    "O-words (subroutines, loops, conditions) are refused: jogterm runs straight-line G-code as CAM posts write it",
                ));
            }
            c if c.is_ascii_alphabetic() => {
                let letter = c.to_ascii_uppercase();
                if !WORD_LETTERS.contains(letter) {
                    return Err(error(line, col, format!("`{c}` is not a G-code word")));
                }
                let (value, next) = number(&chars, i + 1).map_err(|why| {
                    error(line, col, format!("`{letter}` must be followed by {why}"))
                })?;
                block.words.push(Word {
                    letter,
                    value,
                    origin: Origin {
                        line,
                        col: u32::try_from(col).unwrap_or(u32::MAX),
                    },
                });
                any = true;
                i = next;
            }
            c => {
                let shown = if c.is_control() || !c.is_ascii() {
                    format!("U+{:04X}", u32::from(c))
                } else {
                    format!("`{c}`")
                };
                return Err(error(
                    line,
                    col,
                    format!(
                        "{shown} cannot stand here: a G-code line holds words (letter and number) and comments"
                    ),
                ));
            }
        }
    }
    Ok(any.then_some(block))
}

fn is_blank(c: char) -> bool {
    c == ' ' || c == '\t'
}

/// The comment opening at `open`: its text and the index after its `)`.
fn comment(chars: &[char], open: usize) -> Option<(String, usize)> {
    let mut depth = 0usize;
    for (k, &c) in chars.iter().enumerate().skip(open) {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    let text: String = chars[open + 1..k].iter().collect();
                    return Some((text.trim().to_owned(), k + 1));
                }
            }
            _ => {}
        }
    }
    None
}

/// A number from `start`, blanks allowed inside: value and the index after.
fn number(chars: &[char], start: usize) -> Result<(f64, usize), &'static str> {
    let mut text = String::new();
    let mut i = start;
    let mut digits = 0;
    let mut dot = false;
    while i < chars.len() {
        let c = chars[i];
        match c {
            c if is_blank(c) => {}
            '+' | '-' if text.is_empty() => text.push(c),
            '.' if !dot => {
                dot = true;
                text.push(c);
            }
            c if c.is_ascii_digit() => {
                digits += 1;
                text.push(c);
            }
            _ => break,
        }
        i += 1;
    }
    if digits == 0 {
        return Err("a number");
    }
    // Trailing blanks belong to no word.
    while i > start && is_blank(chars[i - 1]) {
        i -= 1;
    }
    text.parse::<f64>().map(|v| (v, i)).map_err(|_| "a number")
}

/// `*NN` at `star`: the XOR of every byte before it must be NN.
fn checksum(chars: &[char], star: usize, line: u32) -> Result<(), Diagnostic> {
    let digits: String = chars[star + 1..]
        .iter()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    let after = star + 1 + digits.len();
    let rest_blank = chars[after..].iter().all(|c| is_blank(*c));
    let expected: Option<u8> = digits.parse().ok();
    let (Some(expected), true) = (expected, rest_blank) else {
        return Err(error(
            line,
            star + 1,
            "`*` must end the line with a checksum (0-255)",
        ));
    };
    let before: String = chars[..star].iter().collect();
    let sum = before.bytes().fold(0u8, |acc, b| acc ^ b);
    if sum != expected {
        return Err(error(
            line,
            star + 1,
            format!(
                "checksum {expected} does not match the line (its bytes give {sum}): the line was damaged"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(line: &str) -> Vec<(char, f64)> {
        let read = read(line);
        assert!(read.errors.is_empty(), "{:?}", read.errors);
        read.blocks
            .iter()
            .flat_map(|b| b.words.iter().map(|w| (w.letter, w.value)))
            .collect()
    }

    fn first_error(text: &str) -> (u32, u32, String) {
        let read = read(text);
        let e = read.errors.first().expect("an error");
        (e.origin.line, e.origin.col, e.message.clone())
    }

    #[test]
    fn words_without_blanks_in_lower_case() {
        assert_eq!(
            words("g0x0y0z1"),
            vec![('G', 0.0), ('X', 0.0), ('Y', 0.0), ('Z', 1.0)]
        );
    }

    #[test]
    fn blanks_inside_numbers_and_between_words() {
        assert_eq!(
            words("G 1 X 1 2.5 Y-.5  F 300"),
            vec![('G', 1.0), ('X', 12.5), ('Y', -0.5), ('F', 300.0)]
        );
    }

    #[test]
    fn numbers_are_read_exactly_from_their_decimal_text() {
        let w = words("X1234.5678");
        assert_eq!(w[0].1, 1234.5678);
        assert_eq!(format!("{}", w[0].1), "1234.5678");
    }

    #[test]
    fn line_numbers_comments_and_columns() {
        let read = read("N10 G1 (cut) X5 ; the rest\n");
        let b = &read.blocks[0];
        assert_eq!(b.words.iter().map(|w| w.letter).collect::<String>(), "NGX");
        assert_eq!(b.words[2].origin, Origin { line: 1, col: 14 });
        assert_eq!(b.comments, vec!["cut".to_owned(), "the rest".to_owned()]);
    }

    #[test]
    fn nested_parentheses_are_one_comment() {
        let read = read("(T1 D=3 - flat end mill (2 flute)) G0 X1");
        assert!(read.errors.is_empty());
        assert_eq!(
            read.blocks[0].comments,
            vec!["T1 D=3 - flat end mill (2 flute)"]
        );
        assert_eq!(read.blocks[0].words.len(), 2);
    }

    #[test]
    fn an_unclosed_comment_is_an_error_and_swallows_no_line() {
        let read = read("G0 X1 (open\nG0 X2\n");
        assert_eq!(read.errors.len(), 1);
        assert_eq!(read.errors[0].origin, Origin { line: 1, col: 7 });
        assert_eq!(read.blocks.len(), 1);
        assert_eq!(read.blocks[0].line, 2);
    }

    #[test]
    fn tape_markers_with_text_bom_crlf_and_a_last_line_without_newline() {
        let read = read("\u{feff}%\r\nG21\r\n%  end of program\r\nG0 X1");
        assert!(read.errors.is_empty());
        assert_eq!(read.lines, 4);
        assert_eq!(read.blocks.len(), 2);
        assert_eq!(read.blocks[1].line, 4);
    }

    #[test]
    fn line_count_with_a_final_newline() {
        assert_eq!(read("G0\nG1\n").lines, 2);
        assert_eq!(read("").lines, 0);
    }

    #[test]
    fn block_delete_is_marked() {
        let read = read("/G0 X1\nG0 X2");
        assert!(read.blocks[0].deleted);
        assert!(!read.blocks[1].deleted);
    }

    #[test]
    fn checksums_are_checked() {
        let line = "N3 G1 X5";
        let sum = line.bytes().fold(0u8, |a, b| a ^ b);
        assert!(read(&format!("{line}*{sum}")).errors.is_empty());
        let (l, c, m) = first_error(&format!("{line}*{}", sum ^ 1));
        assert_eq!((l, c), (1, 9));
        assert!(m.contains("checksum"), "{m}");
    }

    #[test]
    fn refused_spellings_name_what_they_are() {
        assert!(first_error("G0 X#1").2.contains("parameters"));
        assert!(first_error("G0 X[1+2]").2.contains("expressions"));
        assert!(first_error("o100 sub").2.contains("O-words"));
        assert!(first_error("G0 X").2.contains("number"));
        let (_, col, m) = first_error("G0 X1 \u{0}\u{7f}");
        assert_eq!(col, 7);
        assert!(m.contains("U+0000"), "{m}");
    }

    #[test]
    fn binary_garbage_gives_errors_not_a_panic() {
        let garbage: String = (0u8..=255).map(char::from).collect();
        let read = read(&garbage);
        assert!(!read.errors.is_empty());
    }
}
