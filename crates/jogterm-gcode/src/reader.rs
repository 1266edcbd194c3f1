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

/// Reads a whole file: [`blocks`] collected.
pub fn read(text: &str) -> Read {
    let mut blocks = blocks(text);
    let mut out = Read::default();
    for item in blocks.by_ref() {
        match item {
            Ok(block) => out.blocks.push(block),
            Err(e) => out.errors.push(e),
        }
    }
    out.lines = blocks.lines();
    out
}

/// The blocks of a file one at a time, in line order, as [`read`] reads
/// them: each line's block, or the error of a line that could not be read
/// (a line with no words and no comment yields nothing). The interpreter
/// takes them as they come, so that a file's blocks are never all in
/// memory at once.
///
/// The scanner works on the line's bytes: every byte that means something
/// here is ASCII, and in UTF-8 no byte of a multi-byte character is ASCII,
/// so a `(` or a digit found by byte is one. Columns are counted in
/// characters (what an editor shows) only where a line holds non-ASCII
/// text; for the ASCII lines CAM posts write, a byte index is the column.
pub fn blocks(text: &str) -> Blocks<'_> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    Blocks {
        rest: Some(text),
        seen: 0,
        spare: Vec::new(),
        // The piece after a final newline is no line (and an empty text
        // has none).
        last_is_no_line: text.is_empty() || text.ends_with('\n'),
    }
}

/// The iterator of [`blocks`].
#[derive(Debug, Clone)]
pub struct Blocks<'a> {
    /// The text after the lines taken so far, as `str::split('\n')`
    /// would go on from there; `None` once its last piece was taken.
    rest: Option<&'a str>,
    /// Pieces of the text taken so far.
    seen: usize,
    last_is_no_line: bool,
    /// The words of a block given back ([`Blocks::recycle`]), for the next
    /// block's: no allocation a line.
    spare: Vec<Word>,
}

impl<'a> Blocks<'a> {
    /// The next piece of the text between newlines, as `split('\n')` gives
    /// it: the newline found by `memchr`, which looks at 16 or 32 bytes at
    /// once where the standard library's search looks at 8 (this runs once
    /// a line of the file).
    fn next_piece(&mut self) -> Option<&'a str> {
        let rest = self.rest?;
        match memchr::memchr(b'\n', rest.as_bytes()) {
            // A newline is one byte, and no byte of a multi-byte character.
            Some(at) => {
                self.rest = rest.get(at + 1..);
                rest.get(..at)
            }
            None => {
                self.rest = None;
                Some(rest)
            }
        }
    }

    /// Lines in the file (a final line without newline counts); what
    /// [`Read::lines`] says once the iterator is through.
    pub fn lines(&self) -> u32 {
        let lines = if self.last_is_no_line {
            self.seen.saturating_sub(1)
        } else {
            self.seen
        };
        u32::try_from(lines).unwrap_or(u32::MAX)
    }

    /// A block done with: its words' memory holds the next block's.
    pub fn recycle(&mut self, block: Block) {
        if block.words.capacity() > self.spare.capacity() {
            self.spare = block.words;
        }
    }
}

impl Iterator for Blocks<'_> {
    type Item = Result<Block, Diagnostic>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let raw = self.next_piece()?;
            self.seen += 1;
            let line_no = u32::try_from(self.seen).unwrap_or(u32::MAX);
            let raw = raw.strip_suffix('\r').unwrap_or(raw);
            match read_line(raw, line_no, std::mem::take(&mut self.spare)) {
                Ok(Some(block)) => return Some(Ok(block)),
                Ok(None) => {}
                Err(e) => return Some(Err(e)),
            }
        }
    }
}

fn error(line: u32, col: u32, message: impl Into<String>) -> Diagnostic {
    Diagnostic {
        severity: Severity::Error,
        origin: Origin { line, col },
        message: message.into(),
    }
}

/// One line's text and how to turn its byte indices into columns.
struct Line<'a> {
    text: &'a str,
    bytes: &'a [u8],
    ascii: bool,
    number: u32,
}

impl Line<'_> {
    /// The 1-based column, in characters, of the character at byte `at`
    /// (always the first byte of a character: the scanner stops only at
    /// ASCII bytes and at the first byte of a character it refuses).
    fn col(&self, at: usize) -> u32 {
        let chars = if self.ascii {
            at
        } else {
            self.text.get(..at).map_or(at, |s| s.chars().count())
        };
        u32::try_from(chars + 1).unwrap_or(u32::MAX)
    }

    fn error(&self, at: usize, message: impl Into<String>) -> Diagnostic {
        error(self.number, self.col(at), message)
    }
}

/// One line to a block; `None` for a line with no words and no comment
/// (blank, tape marker). `words`: memory for the block's words (emptied).
fn read_line(raw: &str, line: u32, words: Vec<Word>) -> Result<Option<Block>, Diagnostic> {
    let l = Line {
        text: raw,
        bytes: raw.as_bytes(),
        ascii: raw.is_ascii(),
        number: line,
    };
    let bytes = l.bytes;
    let mut words = words;
    words.clear();
    if words.capacity() == 0 {
        // One allocation of the right size for the words: a word starts
        // with a letter, and the letters before any comment are at most
        // the words (CAM lines hold 2-6; a Vec would start at 4 and
        // double). A block given back has room already (`recycle`).
        let letters = bytes
            .iter()
            .take_while(|&&b| b != b'(' && b != b';')
            .filter(|b| b.is_ascii_alphabetic())
            .count();
        words.reserve_exact(letters);
    }
    let mut block = Block {
        line,
        words,
        ..Block::default()
    };
    let mut i = 0;
    while i < bytes.len() && is_blank(bytes[i]) {
        i += 1;
    }
    match bytes.get(i) {
        None | Some(b'%') => return Ok(None),
        Some(b'/') => {
            block.deleted = true;
            i += 1;
        }
        Some(_) => {}
    }
    let mut any = false;
    while i < bytes.len() {
        let b = bytes[i];
        match b {
            b if is_blank(b) => i += 1,
            b'(' => {
                let (text, next) = comment(raw, i).ok_or_else(|| {
                    l.error(i, "a comment opened with `(` is not closed on its line")
                })?;
                block.comments.push(text.to_owned());
                any = true;
                i = next;
            }
            b';' => {
                block.comments.push(raw[i + 1..].trim().to_owned());
                any = true;
                break;
            }
            b'*' => {
                checksum(&l, i)?;
                break;
            }
            b'#' | b'[' => return Err(refused_value(&l, i)),
            b'o' | b'O' => {
                return Err(l.error(
                    i,
                    "O-words (subroutines, loops, conditions) are refused: jogterm runs straight-line G-code as CAM posts write it",
                ));
            }
            b if b.is_ascii_alphabetic() => {
                let letter = b.to_ascii_uppercase();
                if !is_word_letter(letter) {
                    return Err(l.error(i, format!("`{}` is not a G-code word", char::from(b))));
                }
                let letter = char::from(letter);
                let (value, next) = number(raw, i + 1).map_err(|why| {
                    // `X#1`, `X[1+2]`: say what the value is, not only that
                    // it is no number. Looked for only when no number was
                    // read (a number never starts with them): this runs
                    // for every word of the file.
                    match (i + 1..bytes.len()).find(|&k| !is_blank(bytes[k])) {
                        Some(at) if matches!(bytes[at], b'#' | b'[') => refused_value(&l, at),
                        _ => l.error(i, format!("`{letter}` must be followed by {why}")),
                    }
                })?;
                block.words.push(Word {
                    letter,
                    value,
                    origin: Origin {
                        line,
                        col: l.col(i),
                    },
                });
                any = true;
                i = next;
            }
            _ => {
                // `i` is the first byte of a character: every byte before
                // it was ASCII or inside a comment, which ends at a `)`.
                let c = raw.get(i..).and_then(|s| s.chars().next()).unwrap_or('?');
                let shown = if c.is_control() || !c.is_ascii() {
                    format!("U+{:04X}", u32::from(c))
                } else {
                    format!("`{c}`")
                };
                return Err(l.error(
                    i,
                    format!(
                        "{shown} cannot stand here: a G-code line holds words (letter and number) and comments"
                    ),
                ));
            }
        }
    }
    Ok(any.then_some(block))
}

/// A `#` parameter or a `[` expression at byte `at`.
fn refused_value(l: &Line<'_>, at: usize) -> Diagnostic {
    if l.bytes.get(at) == Some(&b'#') {
        l.error(
            at,
            "`#` parameters are refused: jogterm runs no G-code variables (write the values out in the CAM post)",
        )
    } else {
        l.error(
            at,
            "`[` expressions are refused: jogterm evaluates no G-code expressions",
        )
    }
}

fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

/// Letters RS-274/NGC gives a meaning (upper case); `O` is refused
/// separately.
fn is_word_letter(letter: u8) -> bool {
    letter.is_ascii_uppercase() && letter != b'O'
}

/// The comment opening at byte `open`: its text (trimmed) and the byte
/// index after its `)`.
fn comment(raw: &str, open: usize) -> Option<(&str, usize)> {
    let mut depth = 0usize;
    for (k, &b) in raw.as_bytes().iter().enumerate().skip(open) {
        match b {
            b'(' => depth += 1,
            b')' => {
                depth -= 1;
                if depth == 0 {
                    return Some((raw[open + 1..k].trim(), k + 1));
                }
            }
            _ => {}
        }
    }
    None
}

/// The longest number a word may spell with its blanks removed; longer is
/// refused rather than copied (no CAM post writes 64 digits).
const NUMBER_MAX: usize = 64;

/// The largest value a word may hold: no coordinate, feed, time or code
/// comes near it, and a value beyond (400 nines read as infinity) would
/// turn into endless work or NaN downstream (issue 37).
pub const VALUE_MAX: f64 = 1e9;

const TOO_LARGE: &str = "a number of at most 1000000000 in size";

/// `v`, or the refusal of a value beyond [`VALUE_MAX`] (or no number).
fn bounded(v: f64) -> Result<f64, &'static str> {
    if v.abs() <= VALUE_MAX {
        Ok(v)
    } else {
        Err(TOO_LARGE)
    }
}

/// A number from byte `start`, blanks allowed inside: value and the byte
/// index after it (trailing blanks belong to no word).
///
/// The value is the correctly rounded f64 of the decimal text, never
/// through f32. CAM posts write at most a dozen digits, so the digits are
/// gathered into an integer while scanning and the value is that integer
/// divided by a power of ten (Clinger's fast path, the one `str::parse`
/// takes for such numbers itself): when the integer is below 2^53 and the
/// power at most 10^22, both are exact f64s and IEEE division rounds their
/// exact quotient correctly, so the result is the exact decimal's nearest
/// f64. Any other number goes to `str::parse::<f64>`.
fn number(raw: &str, start: usize) -> Result<(f64, usize), &'static str> {
    match number_plain(raw.as_bytes(), start) {
        Some(found) => Ok(found),
        None => number_spelt(raw, start),
    }
}

/// [`number`] of a number spelt as CAM posts write it, with what it reads
/// the same as [`number_spelt`] would: an optional sign, digits and one
/// `.`, no blank inside, at most 19 digits below 2^53 and 22 after the
/// dot, at most [`VALUE_MAX`] in size. `None` for any other, which
/// [`number_spelt`] reads (this runs for every word of the file, and a
/// loop over digits alone is a fraction of the general one's work).
fn number_plain(bytes: &[u8], start: usize) -> Option<(f64, usize)> {
    let (negative, mut i) = match bytes.get(start) {
        Some(b'-') => (true, start + 1),
        Some(b'+') => (false, start + 1),
        _ => (false, start),
    };
    let mut mantissa = 0u64;
    let mut digits = 0usize;
    while let Some(&b) = bytes.get(i)
        && b.is_ascii_digit()
    {
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
        digits += 1;
        i += 1;
    }
    let mut fraction_digits = 0usize;
    if bytes.get(i) == Some(&b'.') {
        i += 1;
        while let Some(&b) = bytes.get(i)
            && b.is_ascii_digit()
        {
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
            digits += 1;
            fraction_digits += 1;
            i += 1;
        }
    }
    let end = i;
    // A digit or a dot after blanks would belong to this number (`X1 2.5`):
    // the general scan reads it.
    let after = bytes.get(end..)?.iter().find(|&&b| !is_blank(b));
    if matches!(after, Some(b) if b.is_ascii_digit() || *b == b'.') {
        return None;
    }
    // 19 digits always fit a u64 (the wrapping above never wrapped).
    if digits == 0 || digits > 19 || mantissa >= 1 << 53 {
        return None;
    }
    let power = POWERS_OF_TEN.get(fraction_digits)?;
    let v = mantissa as f64 / power;
    let v = if negative { -v } else { v };
    (v.abs() <= VALUE_MAX).then_some((v, end))
}

/// [`number`] as RS-274/NGC spells it: blanks anywhere inside, any
/// length.
fn number_spelt(raw: &str, start: usize) -> Result<(f64, usize), &'static str> {
    let bytes = raw.as_bytes();
    let mut i = start;
    let mut first = None; // the first byte of the number (sign or digit)
    let mut end = start; // after its last byte
    let mut blanks_inside = false;
    let mut negative = false;
    let mut digits = 0usize;
    let mut fraction_digits = 0usize;
    let mut mantissa = 0u64; // the digits as an integer, while they fit
    let mut dot = false;
    while i < bytes.len() {
        let b = bytes[i];
        match b {
            b if is_blank(b) => {
                i += 1;
                continue;
            }
            b'+' | b'-' if first.is_none() => negative = b == b'-',
            b'.' if !dot => dot = true,
            b if b.is_ascii_digit() => {
                digits += 1;
                fraction_digits += usize::from(dot);
                mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(b - b'0'));
            }
            _ => break,
        }
        if first.is_none() {
            first = Some(i);
        } else if end != i {
            blanks_inside = true;
        }
        i += 1;
        end = i;
    }
    let Some(first) = first.filter(|_| digits > 0) else {
        return Err("a number");
    };
    // 19 digits always fit a u64 (the wrapping above never wrapped).
    if digits <= 19 && mantissa < 1 << 53 && fraction_digits < POWERS_OF_TEN.len() {
        let v = mantissa as f64 / POWERS_OF_TEN[fraction_digits];
        return bounded(if negative { -v } else { v }).map(|v| (v, end));
    }
    let parsed = if blanks_inside {
        let mut buf = [0u8; NUMBER_MAX];
        let mut n = 0;
        for &b in bytes[first..end].iter().filter(|b| !is_blank(**b)) {
            *buf.get_mut(n).ok_or("a number of at most 64 characters")? = b;
            n += 1;
        }
        // Only ASCII sign, dot and digits were gathered.
        std::str::from_utf8(&buf[..n])
            .map_err(|_| "a number")?
            .parse::<f64>()
    } else {
        raw[first..end].parse::<f64>()
    };
    let v = parsed.map_err(|_| "a number")?;
    bounded(v).map(|v| (v, end))
}

/// 10^0 … 10^22: every one an exact f64 (10^22 = 2^22 x 5^22, and 5^22 <
/// 2^53).
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// `*NN` at byte `star`: the XOR of every byte before it must be NN.
fn checksum(l: &Line<'_>, star: usize) -> Result<(), Diagnostic> {
    let after_star = &l.bytes[star + 1..];
    let digits = after_star.iter().take_while(|b| b.is_ascii_digit()).count();
    let rest_blank = after_star[digits..].iter().all(|b| is_blank(*b));
    let expected: Option<u8> = l.text[star + 1..star + 1 + digits].parse().ok();
    let (Some(expected), true) = (expected, rest_blank) else {
        return Err(l.error(star, "`*` must end the line with a checksum (0-255)"));
    };
    let sum = l.bytes[..star].iter().fold(0u8, |acc, b| acc ^ b);
    if sum != expected {
        return Err(l.error(
            star,
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

    /// The reader as it was before it scanned bytes (a `Vec<char>` a line,
    /// a `String` a number): the oracle the byte scanner must agree with.
    mod reference {
        use super::super::{Block, Diagnostic, Origin, Read, Severity, Word};

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
                        // The one change to the old reader: `X#1` and `X[1]`
                        // name the parameter or expression (its test asked
                        // for that; it read "a number").
                        if let Some(at) = (i + 1..chars.len()).find(|&k| !is_blank(chars[k]))
                            && matches!(chars[at], '#' | '[')
                        {
                            let what = if chars[at] == '#' {
                                "`#` parameters are refused: jogterm runs no G-code variables (write the values out in the CAM post)"
                            } else {
                                "`[` expressions are refused: jogterm evaluates no G-code expressions"
                            };
                            return Err(error(line, at + 1, what));
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
            // The second change: values beyond `VALUE_MAX` are refused.
            let v = text.parse::<f64>().map_err(|_| "a number")?;
            super::super::bounded(v).map(|v| (v, i))
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
    }

    proptest::proptest! {
        /// On G-code-like text (words, blanks inside numbers, comments,
        /// checksums, refused characters, non-ASCII), the byte scanner reads
        /// exactly what the character-based reader read: the same blocks,
        /// values, columns and errors.
        #[test]
        fn the_byte_scanner_reads_as_the_character_reader(
            text in "[gGxXyYzZiIjJrRnNfFmMoO0-9 .+\\-()%;/*#\\[\tüé€\r\n]{0,80}",
        ) {
            proptest::prop_assert_eq!(read(&text), reference::read(&text));
        }

        /// The fast path gives what `str::parse::<f64>` gives, bit for bit,
        /// from one digit to 25, with the dot anywhere.
        #[test]
        fn numbers_are_the_correctly_rounded_parse_of_their_text(
            sign in "[+-]?",
            int in "[0-9]{0,9}",
            frac in "[0-9]{0,16}",
            dot in proptest::bool::ANY,
        ) {
            let text = if dot || int.is_empty() {
                format!("{sign}{int}.{frac}")
            } else {
                format!("{sign}{int}")
            };
            proptest::prop_assume!(text.bytes().any(|b| b.is_ascii_digit()));
            let want: f64 = text.parse().unwrap();
            let (got, _) = number(&text, 0).unwrap();
            proptest::prop_assert_eq!(got.to_bits(), want.to_bits(), "{}", text);
        }

        /// Where the plain scan reads a number (CAM's spelling), the
        /// general scan reads the same value to the same byte: the plain
        /// one only saves work.
        #[test]
        fn the_plain_number_scan_reads_as_the_general_one(
            text in "[+-]?[0-9]{0,21}(\\.[0-9]{0,24})?[ \t]{0,2}[0-9.xX+\\-# ]{0,3}",
            noise in "[0-9 .+\\-xX#\t]{0,30}",
        ) {
            for text in [&text, &noise] {
                if let Some((v, end)) = number_plain(text.as_bytes(), 0) {
                    let (want, want_end) = number_spelt(text, 0).unwrap();
                    proptest::prop_assert_eq!(
                        (v.to_bits(), end),
                        (want.to_bits(), want_end),
                        "{:?}",
                        text
                    );
                }
            }
        }

        /// Numbers with blanks anywhere inside read as without them.
        #[test]
        fn blanks_inside_a_number_change_nothing(
            digits in "[0-9]{1,6}\\.[0-9]{0,4}",
            sign in "[+-]?",
            spaces in proptest::collection::vec(0..3usize, 12),
        ) {
            let plain = format!("{sign}{digits}");
            let mut spaced = String::new();
            for (k, c) in plain.chars().enumerate() {
                spaced.push(c);
                spaced.push_str(&" ".repeat(spaces[k % spaces.len()]));
            }
            let want: f64 = plain.parse().unwrap();
            let w = words(&format!("X{spaced}Y1"));
            proptest::prop_assert_eq!(w, vec![('X', want), ('Y', 1.0)]);
        }
    }

    #[test]
    fn columns_count_characters_after_non_ascii_text() {
        let read = read("(Fräser Ø6) G0 X1\nG1 X2 (ü) Y3 \u{20ac}");
        let b = &read.blocks[0];
        assert_eq!(b.words[1].origin, Origin { line: 1, col: 16 });
        assert_eq!(b.comments, vec!["Fräser Ø6"]);
        let e = &read.errors[0];
        assert_eq!(e.origin, Origin { line: 2, col: 14 });
        assert!(e.message.contains("U+20AC"), "{}", e.message);
    }

    #[test]
    fn numbers_off_the_fast_path_are_still_exact() {
        for text in [
            "900719925.4740993", // 2^53 + 1 digits: above the fast path's integers
            "0.1000000000000000055511151231257827", // 34 digits
            "1.00000000000000000000000001", // 27 fraction digits
            "123456789.01234567890", // 20 digits
            "-0",
            "0.30000000000000004",
        ] {
            let (got, _) = number(text, 0).unwrap();
            let want: f64 = text.parse().unwrap();
            assert_eq!(got.to_bits(), want.to_bits(), "{text}");
        }
    }

    #[test]
    fn values_beyond_a_billion_are_refused_not_read_as_infinity() {
        let nines = format!("G4 P{}", "9".repeat(400));
        let (line, col, m) = first_error(&nines);
        assert_eq!((line, col), (1, 4));
        assert!(m.contains("at most 1000000000"), "{m}");
        assert!(first_error("F1 0000000000").2.contains("at most"));
        assert_eq!(words("X-999999999.5"), vec![('X', -999_999_999.5)]);
    }

    #[test]
    fn signs_and_dots_with_blanks_between() {
        assert_eq!(
            words("X - 1 . 5 Y+ 2 Z . 5 0"),
            vec![('X', -1.5), ('Y', 2.0), ('Z', 0.5)]
        );
    }

    #[test]
    fn a_number_of_more_than_64_characters_is_refused_not_truncated() {
        let long = format!("X{}", "1 ".repeat(70));
        assert!(first_error(&long).2.contains("at most 64"));
    }

    #[test]
    fn binary_garbage_gives_errors_not_a_panic() {
        let garbage: String = (0u8..=255).map(char::from).collect();
        let read = read(&garbage);
        assert!(!read.errors.is_empty());
    }
}
