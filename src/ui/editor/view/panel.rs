//! The editor panel: the program with command numbers in the gutter (the
//! controller's command index counted from 1; comments and blank lines have
//! none), syntax highlighting, problems inline (a gutter letter `E`/`W`/`!`
//! and the message after the line), the upload bar, and the cursor's line.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::device::api::Activity;
use crate::program::Severity;
use crate::ui::editor::checkout::RunState;
use crate::ui::editor::highlight::{Class, Mark, runs};
use crate::ui::editor::job::Phase as JobPhase;
use crate::ui::editor::layout::{ProgramAreas, gutter_width};
use crate::ui::editor::upload::Phase;
use crate::ui::editor::{Context, Editor, unit_label};
use crate::ui::palette::Palette;
use crate::ui::position::format_amount;
use crate::ui::view::flow::fit;
use crate::ui::view::frame;

pub struct EditorView<'a> {
    pub editor: &'a Editor,
    pub context: &'a Context<'a>,
    pub areas: &'a ProgramAreas,
}

fn class_style(p: &Palette, class: Class) -> Style {
    match class {
        Class::Plain => p.text,
        Class::Code => p.key,
        Class::Param => p.text,
        Class::Punct => p.dim,
        Class::Comment => p.dim,
    }
}

fn mark_style(p: &Palette, mark: Mark) -> Style {
    // Underlined as well as coloured: the meaning survives mono16.
    let under = Style::new().add_modifier(Modifier::UNDERLINED);
    match mark {
        Mark::None => Style::new(),
        Mark::Note => under,
        Mark::Warning => p.warning.patch(under),
        Mark::Error => p.danger.patch(under),
    }
}

/// The problem shown for a line: the controller's refusal first, then the
/// worst diagnostic, then (for a line not yet linted) its syntax error.
fn problem(e: &Editor, p: &Palette, line: usize) -> Option<(char, Style, String)> {
    if let Some(mark) = e.upload.mark.as_ref().filter(|m| m.line == line) {
        return Some(('!', p.danger, mark.message.clone()));
    }
    let checked = e.checks.is_checked(line);
    let diagnostics = if checked { e.checks.on_line(line) } else { &[] };
    if let Some(d) = diagnostics
        .iter()
        .find(|d| d.severity == Severity::Error)
        .or(diagnostics.first())
    {
        return Some(match d.severity {
            Severity::Error => ('E', p.danger, d.message.clone()),
            Severity::Warning => ('W', p.warning, d.message.clone()),
        });
    }
    if !checked {
        let statement = e.buffer.program().line(line).and_then(|l| l.statement());
        if let Some(Err(err)) = statement.map(|s| &s.command) {
            return Some(('E', p.danger, err.message.clone()));
        }
    }
    None
}

/// The panel title's words, as text (for tests and the message history).
pub fn title_text(e: &Editor, ctx: &Context) -> String {
    title_extra(e, ctx)
        .iter()
        .map(|s| s.content.as_ref())
        .collect()
}

/// `spans` within `room` columns, cut only between words and then marked
/// `…`: "PAUSED be" would say less than nothing (the status line has the
/// whole of a running job).
fn whole_words(spans: Vec<Span<'static>>, room: usize) -> Vec<Span<'static>> {
    let mut out = Vec::new();
    let mut used = 0;
    for span in spans {
        let width = span.width();
        if used + width <= room {
            used += width;
            out.push(span);
            continue;
        }
        let left = room.saturating_sub(used + 1);
        let mut kept = String::new();
        for word in span.content.split(' ') {
            let more = if kept.is_empty() {
                word.len()
            } else {
                word.len() + 1
            };
            if kept.chars().count() + more > left {
                break;
            }
            if !kept.is_empty() {
                kept.push(' ');
            }
            kept.push_str(word);
        }
        if !kept.is_empty() {
            out.push(Span::styled(format!("{kept}…"), span.style));
        }
        break;
    }
    out
}

fn title_extra(e: &Editor, ctx: &Context) -> Vec<Span<'static>> {
    let p = ctx.palette;
    let mut out = Vec::new();
    let modified = if e.modified() { "[+]" } else { "" };
    out.push(Span::styled(format!("{}{modified} ", e.name()), p.title));
    if let Some(c) = &e.checkout {
        // First, and alone: at 80 columns the state must not be cut off.
        let style = match c.state {
            RunState::Paused { .. } | RunState::Stopped { .. } => p.danger,
            RunState::Running | RunState::Dwelling { .. } => p.ok,
            RunState::Ready | RunState::Finished => p.warning,
        };
        let line = c
            .buffer_line()
            .map(|l| format!(" line {}", l + 1))
            .unwrap_or_default();
        if let Some((gcode, share, elapsed, left)) =
            c.stream_progress(c.program(e.buffer.program()), ctx.now)
        {
            let gcode = gcode
                .map(|l| format!(" G-code line {l}"))
                .unwrap_or_default();
            let left = e
                .stream_left(left)
                .map(|(l, waits)| format!(", {} s left{waits}", l.as_secs()))
                .unwrap_or_default();
            out.push(Span::styled(
                format!(
                    "STREAM {}{gcode} {:.0} % {} s{left} {} % ",
                    c.label(),
                    share * 100.0,
                    elapsed.as_secs(),
                    c.factor
                ),
                style,
            ));
            return out;
        }
        let elapsed = ctx.now.saturating_duration_since(c.started).as_secs();
        let single = if c.single { " single step" } else { "" };
        out.push(Span::styled(
            format!(
                "CHECK-OUT {}{line} {} %{single} {elapsed} s ",
                c.label(),
                c.factor
            ),
            style,
        ));
        return out;
    }
    if let Some(c) = &e.chunked {
        // A job in parts: which part and what it does, first at 80 columns.
        let (state, style) = match c.phase {
            JobPhase::Uploading => ("STORING", p.warning),
            JobPhase::Starting | JobPhase::Running => ("RUNNING", p.ok),
            // The stream's own line comes first (the check-out above).
            JobPhase::Streaming => ("STREAM", p.ok),
            JobPhase::Paused => ("PAUSED before", p.danger),
            JobPhase::Waiting => ("WAIT", p.danger),
            JobPhase::Measuring => ("MEASURE", p.warning),
        };
        if let Some(m) = c.pieces.as_ref().and_then(|p| p.measure.as_ref()) {
            let elapsed = ctx.now.saturating_duration_since(c.started).as_secs();
            out.push(Span::styled(
                format!("{state} {} {elapsed} s ", m.tool),
                style,
            ));
            return out;
        }
        // A job with waits at one: what for, not the piece that ended.
        if let Some(w) = c
            .pieces
            .as_ref()
            .filter(|_| c.phase == JobPhase::Waiting)
            .and_then(|p| p.current_wait())
        {
            let elapsed = ctx.now.saturating_duration_since(c.started).as_secs();
            out.push(Span::styled(
                format!(
                    "{state} {} {elapsed} s ",
                    crate::ui::editor::job::wait_short(w)
                ),
                style,
            ));
            return out;
        }
        let elapsed = ctx.now.saturating_duration_since(c.started).as_secs();
        let next = if c.pause_next { " pause next" } else { "" };
        let left = c
            .time_left(ctx.now)
            .map(|l| format!(", {} s left{}", l.as_secs(), c.waits_ahead()))
            .unwrap_or_default();
        out.push(Span::styled(
            format!("{state} {} {elapsed} s{left}{next} ", c.label()),
            style,
        ));
        return out;
    }
    let commands = e.buffer.program().command_count();
    out.push(Span::styled(
        format!(
            "{} {} command{} ",
            e.language(),
            commands,
            if commands == 1 { "" } else { "s" }
        ),
        p.dim,
    ));
    let (errors, warnings) = e.checks.counts();
    if errors > 0 {
        out.push(Span::styled(format!("{errors} E "), p.danger));
    }
    if warnings > 0 {
        out.push(Span::styled(format!("{warnings} W "), p.warning));
    }
    if e.read_only().is_some() {
        out.push(Span::styled("read-only while uploading ", p.warning));
    }
    if ctx.machine.activity == Activity::RunningProgram {
        let mut elapsed = e
            .run_started
            .map(|t| format!("{} s ", ctx.now.saturating_duration_since(t).as_secs()))
            .unwrap_or_default();
        // Progress where positions are read while it runs (EMCU).
        if let (Some(path), Some(k)) = (&e.run_path, e.run_segment)
            && let Some(segment) = path.get(k)
        {
            elapsed.push_str(&format!(
                "line {} ({}/{}) ",
                segment.line + 1,
                k + 1,
                path.len()
            ));
        }
        if e.run_paused {
            out.push(Span::styled(format!("PAUSED {elapsed}"), p.danger));
        } else {
            out.push(Span::styled(format!("RUNNING {elapsed}"), p.ok));
        }
    }
    if let Some(speed) = e.teach_speed(ctx.setup) {
        let unit = unit_label(ctx.setup);
        out.push(Span::styled(
            format!("teach {} {unit}/s ", format_amount(speed)),
            p.dim,
        ));
    }
    out
}

impl Widget for EditorView<'_> {
    fn render(self, _area: Rect, buf: &mut Buffer) {
        let (e, ctx) = (self.editor, self.context);
        let p = ctx.palette;
        let a = self.areas;
        let focused = ctx.focused && !ctx.popup_open;
        let room = usize::from(a.editor.width).saturating_sub(" Program ".len() + 1);
        let extra = whole_words(title_extra(e, ctx), room);
        frame::panel("Program", extra, focused, p, a.editor, buf);
        text(e, p, a.text, focused, buf);
        if let Some(bar) = a.upload {
            upload_bar(e, ctx, bar, buf);
        }
        line_info(e, p, a.line_info, buf);
    }
}

fn text(e: &Editor, p: &Palette, area: Rect, focused: bool, buf: &mut Buffer) {
    let b = &e.buffer;
    let program = b.program();
    let gutter = gutter_width(e);
    let width = usize::from(area.width);
    let room = width.saturating_sub(gutter);
    let rows = usize::from(area.height);
    let cursor = b.cursor();
    // The cursor is always in view, whatever the stored scroll says.
    let top = e
        .top
        .min(cursor.line)
        .max((cursor.line + 1).saturating_sub(rows));
    let left = e
        .left
        .min(cursor.col)
        .max((cursor.col + 1).saturating_sub(room.max(1)));
    for row in 0..rows {
        let index = top + row;
        let Some(line) = program.line(index) else {
            break;
        };
        let y = area.y + row as u16;
        let mut spans: Vec<Span> = Vec::new();
        let number = line
            .statement()
            .map(|s| (s.index + 1).to_string())
            .unwrap_or_default();
        let here = index == cursor.line;
        let number_style = if here { p.title } else { p.dim };
        spans.push(Span::styled(
            format!("{number:>w$}", w = gutter.saturating_sub(2)),
            number_style,
        ));
        let problem = problem(e, p, index);
        // The check-out's current line: marked in the gutter (for themes
        // without colour) and shown reversed.
        let current = e
            .checkout
            .as_ref()
            .and_then(|c| c.buffer_line())
            .is_some_and(|l| l == index);
        match &problem {
            _ if current => spans.push(Span::styled("> ", p.warning)),
            Some((letter, style, _)) => spans.push(Span::styled(format!("{letter} "), *style)),
            None => spans.push(Span::raw("  ")),
        }
        let unchecked = !e.checks.is_checked(index);
        let diagnostics = if unchecked {
            &[][..]
        } else {
            e.checks.on_line(index)
        };
        let mut col = 0usize;
        let mut used = 0usize;
        for run in runs(line, diagnostics, unchecked) {
            let style = class_style(p, run.class).patch(mark_style(p, run.mark));
            let piece = line.slice(run.bytes.clone());
            for ch in piece.chars() {
                if col >= left && used < room {
                    let mut s = style;
                    if current || (focused && here && col == cursor.col) {
                        s = s.patch(p.selected);
                    }
                    let shown = if ch.is_control() { ' ' } else { ch };
                    spans.push(Span::styled(shown.to_string(), s));
                    used += 1;
                }
                col += 1;
            }
        }
        if focused && here && cursor.col >= col && used < room {
            spans.push(Span::styled(" ", p.selected));
            used += 1;
        }
        // The problem's message after the text, where it fits.
        if let Some((_, style, message)) = problem {
            let free = room.saturating_sub(used + 2);
            if free >= 8 {
                spans.push(Span::raw("  "));
                spans.push(Span::styled(
                    fit(&message, free),
                    style.add_modifier(Modifier::ITALIC),
                ));
            }
        }
        Line::from(spans).render(Rect::new(area.x, y, area.width, 1), buf);
    }
}

fn upload_bar(e: &Editor, ctx: &Context, area: Rect, buf: &mut Buffer) {
    let p = ctx.palette;
    let u = &e.upload;
    let width = usize::from(area.width);
    let line = match &u.phase {
        Phase::Idle => return,
        Phase::Requested => Line::from(Span::styled(
            fit("upload: waiting for the controller…", width),
            p.dim,
        )),
        Phase::Running {
            done,
            total,
            lines_per_second,
        } => {
            let left = u
                .time_left()
                .map(|s| format!(" {:.0} s left", s.ceil()))
                .unwrap_or_default();
            let tail = format!(" {done}/{total} {lines_per_second:.1}/s{left}");
            let bar_w = width.saturating_sub(tail.chars().count() + 9).clamp(4, 40);
            let filled = if *total > 0 {
                (bar_w * done / total).min(bar_w)
            } else {
                0
            };
            let (full, empty) = if p.symbols.lit == "●" {
                ("█", "░")
            } else {
                ("#", ".")
            };
            Line::from(vec![
                Span::styled("upload ", p.title),
                Span::styled(full.repeat(filled), p.ok),
                Span::styled(empty.repeat(bar_w - filled), p.dim),
                Span::styled(fit(&tail, width.saturating_sub(bar_w + 7)), p.text),
            ])
        }
        // A job in parts or pieces says itself what F6 does.
        Phase::Finished { total, elapsed } if e.chunked.is_some() => Line::from(Span::styled(
            fit(
                &format!("stored {total} commands in {:.1} s", elapsed.as_secs_f64()),
                width,
            ),
            p.ok,
        )),
        Phase::Finished { total, elapsed } => {
            let run = ctx
                .keymap
                .key_for(
                    crate::ui::keymap::Mode::Main,
                    crate::ui::keymap::Action::RunProgram,
                )
                .map(|k| format!("; {k} runs it"))
                .unwrap_or_default();
            Line::from(Span::styled(
                fit(
                    &format!(
                        "stored {total} commands in {:.1} s{run}",
                        elapsed.as_secs_f64()
                    ),
                    width,
                ),
                p.ok,
            ))
        }
        Phase::Failed {
            command,
            code,
            meaning,
        } => {
            let at = u
                .line_of(*command)
                .filter(|_| u.ours)
                .map(|l| format!(" (line {})", l + 1))
                .unwrap_or_default();
            Line::from(Span::styled(
                fit(
                    &format!(
                        "upload failed at command {}{at}: `{code}` {meaning}",
                        command + 1
                    ),
                    width,
                ),
                p.danger,
            ))
        }
        Phase::Aborted { done, reason } => Line::from(Span::styled(
            fit(&format!("upload stopped after {done}: {reason}"), width),
            p.danger,
        )),
    };
    line.render(area, buf);
}

fn line_info(e: &Editor, p: &Palette, area: Rect, buf: &mut Buffer) {
    let b = &e.buffer;
    let c = b.cursor();
    let mut text = format!("Ln {}/{} Col {}", c.line + 1, b.line_count(), c.col + 1);
    if let Some(i) = b.program().index_of(c.line) {
        text.push_str(&format!("  cmd {}/{}", i + 1, b.program().command_count()));
    }
    let width = usize::from(area.width);
    let mut spans = vec![Span::styled(text.clone(), p.dim)];
    match problem(e, p, c.line) {
        Some((letter, style, message)) => {
            let free = width.saturating_sub(text.chars().count() + 4);
            spans.push(Span::styled(format!("  {letter} "), style));
            spans.push(Span::styled(fit(&message, free), style));
        }
        None if !e.checks.fresh(b.state()) => spans.push(Span::styled("  checking…", p.dim)),
        None => {}
    }
    Line::from(spans).render(area, buf);
}

#[cfg(test)]
mod whole_word_tests {
    use super::*;

    #[test]
    fn a_title_is_cut_between_words_and_says_so() {
        let spans = vec![
            Span::raw("part.isel "),
            Span::raw("PAUSED before part 3/4 12 s "),
        ];
        let text =
            |v: Vec<Span<'static>>| -> String { v.iter().map(|s| s.content.as_ref()).collect() };
        assert_eq!(
            text(whole_words(spans.clone(), 80)),
            "part.isel PAUSED before part 3/4 12 s "
        );
        assert_eq!(text(whole_words(spans.clone(), 20)), "part.isel PAUSED…");
        assert_eq!(text(whole_words(spans, 15)), "part.isel ");
    }
}
