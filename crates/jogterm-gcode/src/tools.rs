//! The file's own tool table: the comments CAM posts write at the top of a
//! job, one per tool, so that the wait at a tool change can name the tool
//! the operator has to put in (`docs/gcode.md`, "Tool changes").
//!
//! Fusion 360 writes `(T2 D=3.175 CR=0 - ZMIN=-12.438 - flat end mill)`:
//! the tool number with `KEY=value` words, then ` - `-separated groups, each
//! either more `KEY=value` words or the tool's description. Other posts
//! write `(T1 D=6 - bull nose)` or `; T3 D=2.0 drill` the same way. A
//! comment is a tool's when its text begins with `T` and a number followed
//! by a blank; the first comment for a number wins (Fusion repeats the
//! tool's name later, before its operations, without the table's words).

use std::collections::BTreeMap;

use super::toolpath::Origin;

/// One tool as the file's comments describe it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ToolInfo {
    pub number: u32,
    /// `KEY=value` words in the order written (`D=3.175`, `CR=0`,
    /// `ZMIN=-12.438`), values as the file wrote them (the file's unit).
    pub fields: Vec<(String, String)>,
    /// The words that are no `KEY=value` (`flat end mill`).
    pub description: String,
    /// The comment's line and column.
    pub origin: Origin,
}

impl ToolInfo {
    /// A field's value as written (`D` → `3.175`).
    pub fn field(&self, key: &str) -> Option<&str> {
        self.fields
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(key))
            .map(|(_, v)| v.as_str())
    }

    /// How a wait names the tool: `T2 flat end mill, D=3.175`.
    pub fn label(&self) -> String {
        let mut out = format!("T{}", self.number);
        if !self.description.is_empty() {
            out.push(' ');
            out.push_str(&self.description);
        }
        if let Some(d) = self.field("D") {
            out.push_str(if self.description.is_empty() {
                " "
            } else {
                ", "
            });
            out.push_str("D=");
            out.push_str(d);
        }
        out
    }
}

/// The tools described by the comments of `text`, by number.
pub fn tool_table(text: &str) -> BTreeMap<u32, ToolInfo> {
    let mut table = BTreeMap::new();
    let bytes = text.as_bytes();
    // Most lines of a CAM file hold no comment: the text is searched for
    // the two bytes that open one (both ASCII, so no byte of another
    // character is taken for them) and only the lines that hold one are
    // looked at, numbered by counting the newlines before them; those are
    // the lines `str::lines` gives, a `\r` before the `\n` dropped.
    let mut newlines = 0usize; // `\n` before `counted`
    let mut counted = 0usize;
    let mut from = 0usize;
    while let Some(hit) = next_opener(bytes, from) {
        let start = bytes
            .get(..hit)
            .and_then(|b| memchr::memrchr(b'\n', b))
            .map_or(0, |k| k + 1);
        let end = bytes
            .get(hit..)
            .and_then(|b| memchr::memchr(b'\n', b))
            .map_or(bytes.len(), |k| hit + k);
        newlines += bytes
            .get(counted..start)
            .map_or(0, |b| memchr::memchr_iter(b'\n', b).count());
        counted = start;
        let mut line = text.get(start..end).unwrap_or_default();
        if end < bytes.len() {
            line = line.strip_suffix('\r').unwrap_or(line);
        }
        let line_no = u32::try_from(newlines + 1).unwrap_or(u32::MAX);
        for (col, comment) in comments(line) {
            if let Some(tool) = parse_tool(comment) {
                table.entry(tool.number).or_insert(ToolInfo {
                    origin: Origin { line: line_no, col },
                    ..tool
                });
            }
        }
        from = end + 1;
    }
    table
}

/// The first `(` or `;` of `bytes` from `from` on (`memchr2` tests 16 or
/// 32 bytes at once).
fn next_opener(bytes: &[u8], from: usize) -> Option<usize> {
    let rest = bytes.get(from..)?;
    memchr::memchr2(b'(', b';', rest).map(|k| from + k)
}

/// The comments of one line with their 1-based columns (in characters):
/// every `( … )`, and the rest of the line after a `;` outside them.
fn comments(line: &str) -> Vec<(u32, &str)> {
    let mut out = Vec::new();
    let mut open: Option<(u32, usize)> = None;
    for (col, (byte, c)) in line.char_indices().enumerate() {
        let col = u32::try_from(col + 1).unwrap_or(u32::MAX);
        match (c, open) {
            ('(', None) => open = Some((col, byte + 1)),
            (')', Some((at, from))) => {
                out.push((at, line.get(from..byte).unwrap_or_default()));
                open = None;
            }
            (';', None) => {
                out.push((col, line.get(byte + 1..).unwrap_or_default()));
                break;
            }
            _ => {}
        }
    }
    out
}

/// A comment's text as a tool's entry: `T<n>` and a blank first.
fn parse_tool(comment: &str) -> Option<ToolInfo> {
    let text = comment.trim();
    let rest = text.strip_prefix(['T', 't'])?;
    let digits = rest.chars().take_while(char::is_ascii_digit).count();
    let number: u32 = rest.get(..digits)?.parse().ok()?;
    let after = rest.get(digits..)?;
    // `T2 …` only: `TC: 3mm Drill`, `Tool 1` and `T2` alone are no table.
    if !after.starts_with(' ') {
        return None;
    }
    let mut fields = Vec::new();
    let mut words = Vec::new();
    for group in after.split(" - ") {
        let mut plain = Vec::new();
        for word in group.split_whitespace() {
            match word.split_once('=') {
                Some((k, v)) if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric()) => {
                    fields.push((k.to_owned(), v.to_owned()));
                }
                _ => plain.push(word),
            }
        }
        if !plain.is_empty() {
            words.push(plain.join(" "));
        }
    }
    // A tool table line says something of the tool: a comment such as
    // `(T1 roughing pass)` is a note, not the table.
    if fields.is_empty() {
        return None;
    }
    Some(ToolInfo {
        number,
        fields,
        description: words.join(" - "),
        origin: Origin::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::Strategy as _;

    #[test]
    fn a_fusion_tool_table_names_each_tool() {
        let text = "%\n(1001)\n(T1 D=6 CR=0 - ZMIN=-5 - flat end mill)\n\
                    (T2 D=3.175 CR=0 - ZMIN=-12.438 - flat end mill)\nG90 G94\n\
                    (2D Contour1)\nM6 T2 (T2 again, no table)\n";
        let table = tool_table(text);
        assert_eq!(table.len(), 2);
        let t2 = &table[&2];
        assert_eq!(t2.field("D"), Some("3.175"));
        assert_eq!(t2.field("zmin"), Some("-12.438"));
        assert_eq!(t2.description, "flat end mill");
        assert_eq!(t2.origin, Origin { line: 4, col: 1 });
        assert_eq!(t2.label(), "T2 flat end mill, D=3.175");
        assert_eq!(table[&1].label(), "T1 flat end mill, D=6");
    }

    #[test]
    fn semicolon_comments_and_other_posts_count_too() {
        let table = tool_table("G21 ; T3 D=2.0 drill\n(T4 D=1 - bull nose - 2 flutes)\n");
        assert_eq!(table[&3].description, "drill");
        assert_eq!(table[&3].origin, Origin { line: 1, col: 5 });
        assert_eq!(table[&4].description, "bull nose - 2 flutes");
        assert_eq!(table[&4].label(), "T4 bull nose - 2 flutes, D=1");
    }

    /// The table as it was read line by line (`str::lines`), the
    /// reference of the byte search.
    fn by_lines(text: &str) -> BTreeMap<u32, ToolInfo> {
        let mut table = BTreeMap::new();
        for (index, line) in text.lines().enumerate() {
            let line_no = u32::try_from(index + 1).unwrap_or(u32::MAX);
            for (col, comment) in comments(line) {
                if let Some(tool) = parse_tool(comment) {
                    table.entry(tool.number).or_insert(ToolInfo {
                        origin: Origin { line: line_no, col },
                        ..tool
                    });
                }
            }
        }
        table
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(500))]

        /// Lines of G-code, tool comments and others, CR LF or LF, blank
        /// lines, a last line with or without its newline, long lines
        /// across the search's 64-byte blocks: the same table, the same
        /// lines and columns, as reading line by line.
        #[test]
        fn the_byte_search_finds_what_the_lines_hold(
            lines in proptest::collection::vec(
                proptest::prop_oneof![
                    proptest::prelude::Just("G1 X1.5 Y-2".to_owned()),
                    proptest::prelude::Just(String::new()),
                    (1u32..5, "[a-z ]{0,80}").prop_map(|(n, d)| format!("(T{n} D=3 - {d})")),
                    (1u32..5, "[ GX0-9.]{0,70}").prop_map(|(n, g)| format!("{g}; T{n} D=2 drill")),
                    "[ -~]{0,150}",
                    "[ (;)T1D=é\r]{0,20}",
                ],
                0..40,
            ),
            crlf in proptest::bool::ANY,
            last_newline in proptest::bool::ANY,
        ) {
            let newline = if crlf { "\r\n" } else { "\n" };
            let mut text = lines.join(newline);
            if last_newline {
                text.push_str(newline);
            }
            proptest::prop_assert_eq!(tool_table(&text), by_lines(&text));
        }
    }

    #[test]
    fn comments_that_are_no_table_are_left_alone() {
        for text in [
            "(TC: 3mm Drill)\n",
            "(T2)\n",
            "(Tool 1 D=3)\n",
            "(T1 roughing pass)\n",
            "(T1 D=3\n",
            "G0 X1 T2\n",
        ] {
            assert!(tool_table(text).is_empty(), "{text}");
        }
        // The first entry for a number wins.
        let table = tool_table("(T1 D=6 - first)\n(T1 D=3 - second)\n");
        assert_eq!(table[&1].description, "first");
        // Without a description the diameter names it alone.
        assert_eq!(tool_table("(T7 D=0.5)")[&7].label(), "T7 D=0.5");
    }
}
