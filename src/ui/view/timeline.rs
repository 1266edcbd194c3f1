//! The port timeline screen: every input as a lane over time, logic-analyzer
//! style, one column a time step (`▔` at 1, `▁` at 0, `│` a change, `▒`
//! several; ASCII `=`, `_`, `|`, `#`), a ruler of `t` (seconds since the
//! link came up), and the changes in view with their times below. A column
//! of a change that chattered is drawn in the warning style, the time
//! between two E-stop channels opening in the danger style on the second
//! channel's lane.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::Span;
use ratatui::widgets::Widget;

use crate::device::api::InputChannel;
use crate::device::inputs::{Recorded, SkewMark, level_word};
use crate::ui::model::Model;

use super::flow::fit;
use super::{frame, status};

/// The parts of the screen, from the terminal's size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Parts {
    status: Rect,
    message: Rect,
    panel: Rect,
    ruler: Rect,
    lanes: Rect,
    changes_title: Rect,
    changes: Rect,
    hints: Option<Rect>,
}

fn row(area: Rect, y: u16, height: u16) -> Rect {
    let y = y.min(area.bottom());
    Rect::new(area.x, y, area.width, height.min(area.bottom() - y))
}

fn parts(area: Rect, lane_count: usize) -> Parts {
    let status = row(area, area.y, 1);
    let message = row(area, area.y + 1, 1);
    let hints = (area.height >= 12).then(|| row(area, area.bottom() - 1, 1));
    let top = area.y + 2;
    let bottom = hints.map_or(area.bottom(), |h| h.y).max(top);
    let panel = Rect::new(area.x, top, area.width, bottom - top);
    // Inside the panel's title rule: the ruler, the lanes, then the
    // changes, which get at least a third of the room (2 to 12 lines) and
    // whatever the lanes leave.
    let inner = panel.height.saturating_sub(2);
    let changes_min = (inner / 3).clamp(2, 12).min(inner.saturating_sub(1));
    let lanes_h = inner
        .saturating_sub(changes_min + 1)
        .min(u16::try_from(lane_count).unwrap_or(u16::MAX));
    let changes_h = inner.saturating_sub(lanes_h + 1);
    let ruler = row(panel, panel.y + 1, 1);
    let lanes = row(panel, ruler.y + 1, lanes_h);
    let changes_title = row(panel, lanes.bottom(), u16::from(changes_h > 0));
    let changes = row(panel, changes_title.bottom(), changes_h);
    Parts {
        status,
        message,
        panel,
        ruler,
        lanes,
        changes_title,
        changes,
        hints,
    }
}

/// Lanes shown on a terminal of this size, of `lane_count`.
pub fn lane_rows(width: u16, height: u16, lane_count: usize) -> u16 {
    parts(Rect::new(0, 0, width, height), lane_count)
        .lanes
        .height
}

/// Width of a lane's label.
fn label_width(width: u16) -> u16 {
    (width / 5).clamp(10, 26)
}

/// Columns of time a lane has on a terminal this wide: after the label,
/// the level read last and a blank each side of it.
pub fn lane_columns(width: u16) -> u16 {
    width.saturating_sub(label_width(width) + 3)
}

/// `text` at `(x, y)` when that cell is on the screen, cut at its right
/// edge: the screen may be smaller than any of its parts.
fn put(buf: &mut Buffer, x: u16, y: u16, text: impl AsRef<str>, style: Style) {
    let area = buf.area;
    if x < area.right() && y < area.bottom() && x >= area.x && y >= area.y {
        let room = usize::from(area.right() - x);
        buf.set_stringn(x, y, text.as_ref(), room, style);
    }
}

fn ms(d: std::time::Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1000.0)
}

pub struct TimelineScreen<'a>(pub &'a Model);

impl Widget for TimelineScreen<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let t = &model.timeline;
        let all = t.shown();
        let parts = parts(area, all.len());
        status::StatusBar(model).render(parts.status, buf);
        status::MessageLine(model).render(parts.message, buf);
        if let Some(h) = parts.hints {
            status::Hints(model).render(h, buf);
        }

        let shown = usize::from(parts.lanes.height);
        let top = t.top.min(all.len().saturating_sub(shown.max(1)));
        let lanes: Vec<&std::sync::Arc<InputChannel>> =
            all.iter().skip(top).take(shown).copied().collect();
        let scale = t.scale();
        // Each title part in a long and a short form: at 80 columns the
        // short forms keep every part in sight rather than cutting the last.
        let mut parts_title: Vec<(String, String, ratatui::style::Style)> = vec![(
            format!(" {} ms/column ", scale.as_millis()),
            format!(" {} ms/col ", scale.as_millis()),
            p.text,
        )];
        let label_w = label_width(area.width);
        let columns = lane_columns(area.width);
        let x0 = parts.ruler.x + label_w + 3;
        let scale_us = scale.as_micros().max(1) as i128;
        // Until the lanes are full, they fill from the left, as a chart
        // recorder's paper does; then they scroll.
        let span_us = i128::from(columns) * scale_us;
        let left_us = (t.right_edge(model.now).as_micros() as i128 - span_us).max(0);
        let right_us = left_us + span_us;
        parts_title.push(match t.end {
            None => (" live ".to_owned(), " live ".to_owned(), p.ok),
            Some(_) => {
                let held = format!(
                    " held: {:.1}-{:.1} s",
                    left_us as f64 / 1e6,
                    right_us as f64 / 1e6
                );
                (
                    format!("{held} (End: live) "),
                    format!("{held} "),
                    p.warning,
                )
            }
        });
        if all.len() > shown {
            let lanes_shown = format!(" lanes {}-{} of {} ", top + 1, top + lanes.len(), all.len());
            parts_title.push((lanes_shown.clone(), lanes_shown, p.dim));
        }
        if let Some(every) = t.read_every() {
            parts_title.push((
                format!(" read every {} ", ms(every)),
                format!(" every {} ", ms(every)),
                p.dim,
            ));
        }
        let unread = t.unread();
        if unread > 0 {
            parts_title.push((
                format!(" {unread} inputs not polled here (jogterm watch reads all) "),
                format!(" {unread} not polled "),
                p.dim,
            ));
        }
        let full_width: usize = parts_title
            .iter()
            .map(|(full, _, _)| full.chars().count())
            .sum();
        // The panel's own name and its border corners take the rest.
        let room = usize::from(area.width).saturating_sub(" Port timeline ".len() + 4);
        let extra: Vec<Span> = parts_title
            .into_iter()
            .map(|(full, short, style)| {
                Span::styled(if full_width <= room { full } else { short }, style)
            })
            .collect();
        frame::panel("Port timeline", extra, true, p, parts.panel, buf);
        let col_start = |c: u16| left_us + i128::from(c) * scale_us;
        let to_duration = |us: i128| std::time::Duration::from_micros(us.max(0) as u64);

        // Ruler: a tick every 10 columns of absolute time, so the ticks move
        // with the picture.
        put(
            buf,
            parts.ruler.x,
            parts.ruler.y,
            fit("t (s)", usize::from(label_w)),
            p.dim,
        );
        let tick_every = 10 * scale_us;
        let decimals = match tick_every {
            n if n >= 1_000_000 => 0,
            n if n >= 100_000 => 1,
            n if n >= 10_000 => 2,
            _ => 3,
        };
        let mut c = 0;
        while c < columns {
            let start = col_start(c);
            if start >= 0 && start % tick_every == 0 {
                let label = format!("|{:.*}", decimals, start as f64 / 1e6);
                let room = usize::from(columns - c).min(10);
                let label = if label.len() <= room {
                    label.as_str()
                } else {
                    "|"
                };
                put(buf, x0 + c, parts.ruler.y, label, p.dim);
            }
            c += 1;
        }

        let skews: Vec<&SkewMark> = t.history.skews().collect();
        // Nothing is known after now (lanes that fill from the left).
        let now_us = t.t_of(model.now).map_or(0, |d| d.as_micros() as i128);
        let known = u16::try_from(((now_us - left_us).max(0) + scale_us - 1) / scale_us)
            .unwrap_or(u16::MAX)
            .min(columns);
        for (i, lane) in lanes.iter().enumerate() {
            let y = parts.lanes.y + i as u16;
            self.lane(lane, &skews, y, x0, known, left_us, scale_us, buf);
            let chattered = t
                .history
                .between(lane.key, to_duration(left_us), to_duration(right_us))
                .any(|r| r.chatter);
            let label_style = if chattered { p.warning } else { p.text };
            put(
                buf,
                parts.lanes.x,
                y,
                fit(&lane.label(), usize::from(label_w)),
                label_style,
            );
            let (text, style) = match t.levels.get(&lane.key) {
                Some(true) => ("1", p.lit),
                Some(false) => ("0", p.unlit),
                None => ("?", p.dim),
            };
            put(buf, parts.lanes.x + label_w + 1, y, text, style);
        }
        if all.is_empty() {
            put(
                buf,
                parts.lanes.x,
                parts.lanes.y,
                "no input read yet",
                p.dim,
            );
        }

        // The changes in view, newest last.
        if parts.changes_title.height > 0 {
            put(
                buf,
                parts.changes_title.x,
                parts.changes_title.y,
                fit(
                    "Changes in view (t since the link came up)",
                    usize::from(area.width),
                ),
                p.title,
            );
        }
        let rows = usize::from(parts.changes.height);
        let mut lines: Vec<(String, Style)> = Vec::new();
        let recent = t.history.newest_before(to_duration(right_us), rows);
        for r in recent
            .iter()
            .rev()
            .filter(|r| r.t.as_micros() as i128 >= left_us)
        {
            lines.push((change_line(r), if r.chatter { p.warning } else { p.text }));
            if let Some(s) = skews
                .iter()
                .find(|s| s.second.key == r.channel.key && s.t_second == r.t)
            {
                lines.push((skew_line(s), p.danger));
            }
        }
        if lines.is_empty() {
            let text = if t.history.is_empty() {
                "no input has changed since the link came up"
            } else {
                "no change in view (Left/Right: earlier/later, End: live)"
            };
            lines.push((text.to_owned(), p.dim));
        }
        let skip = lines.len().saturating_sub(rows);
        for (i, (text, style)) in lines.iter().skip(skip).enumerate() {
            put(
                buf,
                parts.changes.x,
                parts.changes.y + i as u16,
                fit(text, usize::from(parts.changes.width)),
                *style,
            );
        }
    }
}

impl TimelineScreen<'_> {
    /// One lane: a column per time step from `left_us`.
    #[allow(clippy::too_many_arguments)]
    fn lane(
        &self,
        lane: &InputChannel,
        skews: &[&SkewMark],
        y: u16,
        x0: u16,
        columns: u16,
        left_us: i128,
        scale_us: i128,
        buf: &mut Buffer,
    ) {
        let model = self.0;
        let p = &model.palette;
        let sym = &p.symbols;
        let t = &model.timeline;
        let n = usize::from(columns);
        let mut count = vec![0u32; n];
        let mut chatter = vec![false; n];
        let mut last_level: Vec<Option<bool>> = vec![None; n];
        let from = std::time::Duration::from_micros(left_us.max(0) as u64);
        let to_us = left_us + i128::from(columns) * scale_us;
        let to = std::time::Duration::from_micros(to_us.max(0) as u64);
        for r in t.history.between(lane.key, from, to) {
            let c = ((r.t.as_micros() as i128 - left_us) / scale_us) as usize;
            if let Some(slot) = count.get_mut(c) {
                *slot += 1;
                chatter[c] |= r.chatter;
                last_level[c] = Some(r.level);
            }
        }
        let first = (0..columns).find(|c| left_us + i128::from(*c) * scale_us >= 0);
        let Some(first) = first else { return };
        let start = std::time::Duration::from_micros(
            (left_us + i128::from(first) * scale_us).max(0) as u64,
        );
        let mut level = t.level_before(lane.key, start);
        for c in first..columns {
            let i = usize::from(c);
            let col_from = left_us + i128::from(c) * scale_us;
            let col_to = col_from + scale_us;
            let (glyph, mut style) = match (count[i], level) {
                (0, Some(true)) => (sym.high, p.lit),
                (0, Some(false)) => (sym.low, p.unlit),
                (0, None) => (" ", p.dim),
                (1, _) => (sym.edge, p.text),
                _ => (sym.burst, p.warning),
            };
            if chatter[i] {
                style = p.warning;
            }
            let in_skew = skews.iter().any(|s| {
                s.second.key == lane.key
                    && (s.t_first.as_micros() as i128) < col_to
                    && (s.t_second.as_micros() as i128) >= col_from
            });
            if in_skew {
                style = p.danger;
            }
            put(buf, x0 + c, y, glyph, style);
            if let Some(l) = last_level[i] {
                level = Some(l);
            }
        }
    }
}

fn change_line(r: &Recorded) -> String {
    let c = &r.channel;
    let mut text = format!(
        "{:>9.3} s  {} ({}) {} {}  within {}",
        r.t.as_secs_f64(),
        c.label(),
        c.address,
        u8::from(r.level),
        level_word(c, r.level),
        ms(r.window)
    );
    if r.chatter {
        text.push_str("  CHATTER");
    }
    text
}

fn skew_line(s: &SkewMark) -> String {
    format!(
        "             E-STOP SKEW {} after {} (between {} and {})",
        ms(s.measured),
        s.first.label(),
        ms(s.min),
        ms(s.max)
    )
}
