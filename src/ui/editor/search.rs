//! Finding text in the program (case-insensitive, wrapping around the end)
//! and reading the go-to target (a line, or `#N` for command N).

use crate::program::Program;

use super::buffer::Cursor;

fn same(a: char, b: char) -> bool {
    a == b || a.to_lowercase().eq(b.to_lowercase())
}

/// Columns (in characters) where `needle` starts in `hay`.
fn matches_in(hay: &[char], needle: &[char]) -> impl Iterator<Item = usize> {
    let last = (hay.len() + 1).saturating_sub(needle.len().max(1));
    (0..last).filter(move |&i| {
        needle
            .iter()
            .enumerate()
            .all(|(k, n)| hay.get(i + k).is_some_and(|h| same(*h, *n)))
    })
}

/// The next place `needle` occurs after (`forward`) or before `from`,
/// wrapping around the program; `None` when it occurs nowhere.
pub fn find(program: &Program, needle: &str, from: Cursor, forward: bool) -> Option<Cursor> {
    let needle: Vec<char> = needle.chars().collect();
    let count = program.lines().len();
    if needle.is_empty() || count == 0 {
        return None;
    }
    let hits = |line: usize| -> Vec<usize> {
        let text: Vec<char> = program
            .line(line)
            .map(|l| l.text().chars().collect())
            .unwrap_or_default();
        matches_in(&text, &needle).collect()
    };
    let start = from.line.min(count - 1);
    // The cursor's line after the cursor, the other lines in order, the
    // cursor's line up to the cursor (the other way round backwards).
    let here = hits(start);
    let first = if forward {
        here.iter().copied().find(|&c| c > from.col)
    } else {
        here.iter().copied().rev().find(|&c| c < from.col)
    };
    if let Some(col) = first {
        return Some(Cursor::new(start, col));
    }
    for step in 1..count {
        let line = if forward {
            (start + step) % count
        } else {
            (start + count - step) % count
        };
        let found = hits(line);
        let col = if forward { found.first() } else { found.last() };
        if let Some(col) = col {
            return Some(Cursor::new(line, *col));
        }
    }
    let last = if forward {
        here.iter().copied().find(|&c| c <= from.col)
    } else {
        here.iter().copied().rev().find(|&c| c >= from.col)
    };
    last.map(|col| Cursor::new(start, col))
}

/// Where a go-to answer leads: `12` is line 12, `#12` command 12 (both
/// counted from 1, as shown); `None` when it names nothing there.
pub fn go_to(program: &Program, answer: &str) -> Result<usize, String> {
    let answer = answer.trim();
    let (command, number) = match answer.strip_prefix('#') {
        Some(n) => (true, n.trim()),
        None => (false, answer),
    };
    let n: usize = number
        .parse()
        .map_err(|_| format!("`{answer}` is no line number (12) or command number (#12)"))?;
    if n == 0 {
        return Err("lines and commands count from 1".into());
    }
    if command {
        program.line_of(n - 1).ok_or_else(|| {
            format!(
                "there is no command {n}: the program has {}",
                program.command_count()
            )
        })
    } else if n <= program.lines().len() {
        Ok(n - 1)
    } else {
        Err(format!(
            "there is no line {n}: the program has {}",
            program.lines().len()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Language;

    fn program(text: &str) -> Program {
        Program::parse(Language::Isel, text)
    }

    #[test]
    fn find_goes_forwards_and_backwards_and_wraps() {
        let p = program("; Loop\n3 5,-2\n; loop back\n9\n");
        let at = |l, c| Cursor::new(l, c);
        assert_eq!(find(&p, "loop", at(0, 0), true), Some(at(0, 2)));
        assert_eq!(find(&p, "loop", at(0, 2), true), Some(at(2, 2)));
        assert_eq!(
            find(&p, "LOOP", at(2, 2), true),
            Some(at(0, 2)),
            "wraps, any case"
        );
        assert_eq!(find(&p, "loop", at(0, 2), false), Some(at(2, 2)));
        assert_eq!(find(&p, "loop", at(2, 2), false), Some(at(0, 2)));
        assert_eq!(
            find(&p, "9", at(3, 0), true),
            Some(at(3, 0)),
            "the only one is here"
        );
        assert_eq!(find(&p, "nowhere", at(0, 0), true), None);
        assert_eq!(find(&p, "", at(0, 0), true), None);
        let umlaut = program("; Größe\n; GRÖSSE\n");
        assert_eq!(find(&umlaut, "ö", at(1, 0), true), Some(at(1, 4)));
        assert_eq!(find(&umlaut, "ö", at(1, 5), true), Some(at(0, 4)));
    }

    #[test]
    fn go_to_reads_lines_and_command_numbers() {
        let p = program("; head\n77\n; c\n9\n");
        assert_eq!(go_to(&p, "2"), Ok(1));
        assert_eq!(go_to(&p, "#2"), Ok(3));
        assert_eq!(go_to(&p, " # 1 "), Ok(1));
        assert!(go_to(&p, "#3").is_err());
        assert!(go_to(&p, "5").is_err());
        assert!(go_to(&p, "0").is_err());
        assert!(go_to(&p, "x").is_err());
    }
}
