//! Flowing labelled items into lines of a given width, like words in a
//! paragraph: the port bit panels and the simulator panel fit as many bits
//! per line as the terminal allows, so the same panel works at 60 and at
//! 200 columns. An item is never split; one wider than the line is cut with
//! an ellipsis.

use ratatui::text::{Line, Span};

/// One item: its spans, and whether it starts a new line.
#[derive(Debug, Clone)]
pub struct Item<'a> {
    pub spans: Vec<Span<'a>>,
    pub break_before: bool,
}

impl<'a> Item<'a> {
    pub fn new(spans: Vec<Span<'a>>) -> Self {
        Self {
            spans,
            break_before: false,
        }
    }

    pub fn on_new_line(mut self) -> Self {
        self.break_before = true;
        self
    }

    fn width(&self) -> usize {
        self.spans.iter().map(Span::width).sum()
    }
}

/// The lines, and for every item the line it landed on.
#[derive(Debug, Clone, Default)]
pub struct Flowed<'a> {
    pub lines: Vec<Line<'a>>,
    pub line_of: Vec<usize>,
}

/// Lay `items` out in lines of `width` columns; continuation lines are
/// indented by `indent`.
pub fn flow<'a>(items: Vec<Item<'a>>, width: usize, indent: usize) -> Flowed<'a> {
    let mut out = Flowed::default();
    let width = width.max(1);
    let indent = indent.min(width / 2);
    let mut current: Vec<Span<'a>> = Vec::new();
    let mut used = 0usize;
    for item in items {
        let w = item.width();
        let fresh = current.is_empty();
        let fits = used + usize::from(!fresh) + w <= width;
        if !fresh && (item.break_before || !fits) {
            out.lines.push(Line::from(std::mem::take(&mut current)));
            used = 0;
            if !item.break_before && indent > 0 {
                current.push(Span::raw(" ".repeat(indent)));
                used = indent;
            }
        } else if !fresh {
            current.push(Span::raw(" "));
            used += 1;
        }
        let room = width.saturating_sub(used);
        if w <= room {
            current.extend(item.spans);
            used += w;
        } else {
            let (spans, taken) = cut(item.spans, room);
            current.extend(spans);
            used += taken;
        }
        out.line_of.push(out.lines.len());
    }
    if !current.is_empty() {
        out.lines.push(Line::from(current));
    }
    out
}

/// The spans cut to `room` columns, the last one ending in `…`.
fn cut(spans: Vec<Span<'_>>, room: usize) -> (Vec<Span<'_>>, usize) {
    let mut out = Vec::new();
    let mut used = 0usize;
    let limit = room.saturating_sub(1);
    for span in spans {
        let mut text = String::new();
        for c in span.content.chars() {
            let cw = unicode_width(c);
            if used + cw > limit {
                break;
            }
            text.push(c);
            used += cw;
        }
        let full = text.len() == span.content.len();
        out.push(Span::styled(text, span.style));
        if !full {
            break;
        }
    }
    if room > 0 {
        let style = out.last().map(|s| s.style).unwrap_or_default();
        out.push(Span::styled("…", style));
        used += 1;
    }
    (out, used)
}

fn unicode_width(c: char) -> usize {
    Span::raw(c.to_string()).width()
}

/// Cut a string to `width` columns with an ellipsis when it is longer.
pub fn fit(text: &str, width: usize) -> String {
    if Span::raw(text).width() <= width {
        return text.to_string();
    }
    let mut out = String::new();
    let mut used = 0;
    for c in text.chars() {
        let cw = unicode_width(c);
        if used + cw + 1 > width {
            break;
        }
        out.push(c);
        used += cw;
    }
    if width > 0 {
        out.push('…');
    }
    out
}

/// Rows `text` takes when ratatui's `Wrap` breaks it between words at
/// `width` columns (a word longer than the line is cut): what a popup
/// must make room for so that its last words are not lost (a count of
/// characters over the width comes short when words move to the next row).
pub fn wrapped_rows(text: &str, width: usize) -> usize {
    let width = width.max(1);
    let mut rows = 1;
    let mut used = 0;
    for word in text.split_whitespace() {
        let w = Span::raw(word).width();
        let need = if used == 0 { w } else { used + 1 + w };
        if need <= width {
            used = need;
            continue;
        }
        if used > 0 {
            rows += 1;
        }
        // A word longer than a row takes rows of its own.
        rows += w.saturating_sub(1) / width;
        used = match w % width {
            0 => width,
            r => r,
        };
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapped_rows_count_the_words_that_move_to_the_next_row() {
        assert_eq!(wrapped_rows("", 10), 1);
        assert_eq!(wrapped_rows("aaaa bbbb", 9), 1);
        // 14 characters in 10 columns: 2 by count, 2 by words.
        assert_eq!(wrapped_rows("aaaaaa bbbbbbb", 10), 2);
        // 20 characters, 2 rows by count, 3 by words.
        assert_eq!(wrapped_rows("aaaaaaa bbbbbbb cccc", 10), 3);
        assert_eq!(wrapped_rows("x aaaaaaaaaaaaaaaaaaaaaaaaa", 10), 4);
    }

    fn items(words: &[&'static str]) -> Vec<Item<'static>> {
        words
            .iter()
            .map(|w| Item::new(vec![Span::raw(*w)]))
            .collect()
    }

    fn text(f: &Flowed) -> Vec<String> {
        f.lines.iter().map(|l| l.to_string()).collect()
    }

    #[test]
    fn items_wrap_with_indent_and_long_ones_are_cut() {
        let f = flow(items(&["aaa", "bb", "cccc", "dddddddddddd"]), 8, 1);
        assert_eq!(text(&f), ["aaa bb", " cccc", " dddddd…"]);
        assert_eq!(f.line_of, [0, 0, 1, 2]);
        for line in &f.lines {
            assert!(line.width() <= 8);
        }
    }

    #[test]
    fn forced_breaks_start_a_line_without_indent() {
        let mut it = items(&["a", "b", "c"]);
        it[2].break_before = true;
        let f = flow(it, 20, 2);
        assert_eq!(text(&f), ["a b", "c"]);
    }

    #[test]
    fn fit_cuts_with_an_ellipsis() {
        assert_eq!(fit("hello", 5), "hello");
        assert_eq!(fit("hello", 4), "hel…");
        assert_eq!(fit("hello", 0), "");
    }
}
