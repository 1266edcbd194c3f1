//! The keypad panel: which key jogs which way (from the keymap in use, so
//! remapped keys show as they are), the mode and step or speed in the title
//! (toggle mode in the danger style, it is the one that moves without a
//! held key), the keys of the jog under way lit, and one status line: the
//! reason the last key was refused, what runs, the homing progress, or the
//! speed caps. Also the go-to prompt and the axis choice popups.

use std::time::Duration;

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Widget, Wrap};

use crate::axis::Axis;
use crate::config::profile::JogMode;
use crate::device::api::{Activity, Frame};
use crate::jog::{JogKind, LastOutcome, Vector};
use crate::ui::key::{KeyChord, KeyCode};
use crate::ui::keymap::{Action, Mode};
use crate::ui::model::{Model, PanelId};
use crate::ui::position::format_amount;

use super::popup_view::unit_label;
use crate::ui::view::flow::fit;
use crate::ui::view::frame;
use crate::ui::view::popup::{centred, framed};

use super::axes::AxisChoice;
use super::goto::GoToPrompt;
use super::{Homing, vector_of};

/// How long a refusal stays on the keypad's status line.
const REFUSAL_SHOWN: Duration = Duration::from_secs(10);

/// The grid: rows of (action, its place) cells, `None` for a gap.
const GRID: [[Option<Action>; 5]; 3] = [
    [
        Some(Action::JogXMinusYPlus),
        Some(Action::JogYPlus),
        Some(Action::JogXPlusYPlus),
        Some(Action::JogZPlus),
        Some(Action::JogAPlus),
    ],
    [
        Some(Action::JogXMinus),
        None,
        Some(Action::JogXPlus),
        None,
        None,
    ],
    [
        Some(Action::JogXMinusYMinus),
        Some(Action::JogYMinus),
        Some(Action::JogXPlusYMinus),
        Some(Action::JogZMinus),
        Some(Action::JogAMinus),
    ],
];

/// Rows the panel needs: its title, the key grid (one row for a machine
/// with X alone), the status line.
pub fn height(model: &Model) -> u16 {
    let axes = model.keypad.settings().axis_set();
    let grid = if axes.iter().any(|a| a != Axis::X) {
        3
    } else {
        1
    };
    2 + grid
}

fn ascii(model: &Model) -> bool {
    model.palette.symbols.lit.is_ascii()
}

/// The key shown for `action`: a named key (an arrow, PgUp) before a
/// character, as the keypad layout is about where keys are.
fn key_label(model: &Model, action: Action) -> Option<String> {
    let keys = model.keymap.keys_for(Mode::Jog, action);
    let key = keys
        .iter()
        .find(|k| !matches!(k.code, KeyCode::Char(_)) && !k.ctrl && !k.alt)
        .or(keys.first())?;
    Some(compact(key, ascii(model)))
}

fn compact(key: &KeyChord, ascii: bool) -> String {
    let plain = !key.ctrl && !key.alt && !key.shift;
    let arrow = match (key.code, ascii) {
        (KeyCode::Left, false) => Some("←"),
        (KeyCode::Right, false) => Some("→"),
        (KeyCode::Up, false) => Some("↑"),
        (KeyCode::Down, false) => Some("↓"),
        (KeyCode::Left, true) => Some("<"),
        (KeyCode::Right, true) => Some(">"),
        (KeyCode::Up, true) => Some("^"),
        (KeyCode::Down, true) => Some("v"),
        _ => None,
    };
    match arrow {
        Some(a) if plain => a.to_string(),
        _ => key.to_string(),
    }
}

/// What a cell says about its direction: `X+`, or for a diagonal an arrow
/// pointing its way from the middle of the grid.
fn direction_label(vector: &Vector, ascii: bool) -> String {
    use crate::device::api::Dir::{Minus, Plus};
    let diagonal = match (vector.get(Axis::X), vector.get(Axis::Y), ascii) {
        (Some(Minus), Some(Plus), false) => Some("↖"),
        (Some(Plus), Some(Plus), false) => Some("↗"),
        (Some(Minus), Some(Minus), false) => Some("↙"),
        (Some(Plus), Some(Minus), false) => Some("↘"),
        (Some(Minus), Some(Plus), true) | (Some(Plus), Some(Minus), true) => Some("\\"),
        (Some(Plus), Some(Plus), true) | (Some(Minus), Some(Minus), true) => Some("/"),
        _ => None,
    };
    diagonal.map_or_else(|| vector.to_string(), str::to_string)
}

fn cell_text(model: &Model, action: Action) -> Option<(String, Vector)> {
    let vector = vector_of(action)?;
    let machine = model.keypad.settings().axis_set();
    if vector.axes().iter().any(|a| !machine.contains(a)) {
        return None;
    }
    let key = key_label(model, action)?;
    let dir = direction_label(&vector, ascii(model));
    let gap = if key.chars().count() == 1 { "" } else { " " };
    Some((format!("{key}{gap}{dir}"), vector))
}

/// The vector that is moving now, as far as the keypad knows: the jog it
/// keeps alive, or the last step while steps run.
fn lit_vector(model: &Model) -> Option<Vector> {
    if let Some(a) = model.keypad.jogger.active() {
        return Some(a.vector);
    }
    match model.keypad.jogger.last() {
        Some(LastOutcome::Stepped { vector, .. })
            if model.machine.activity == Activity::Stepping =>
        {
            Some(*vector)
        }
        _ => None,
    }
}

fn one_decimal(v: f64) -> String {
    format!("{v:.1}")
}

pub struct KeypadView<'a>(pub &'a Model);

impl Widget for KeypadView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let unit = unit_label(model);
        let jogger = &model.keypad.jogger;
        let speed = model.jog_speed().map(format_amount).unwrap_or_default();
        let mut extra = match (jogger.kind(), jogger.mode()) {
            (JogKind::Step, _) => {
                let step = model.jog_step().map(format_amount).unwrap_or_default();
                vec![Span::styled(format!(" STEP {step} {unit} "), p.title)]
            }
            (JogKind::Continuous, JogMode::Hold) => {
                vec![Span::styled(" HOLD ".to_string(), p.warning)]
            }
            (JogKind::Continuous, JogMode::Toggle) => vec![Span::styled(
                " TOGGLE: any key stops ".to_string(),
                p.danger.patch(p.selected),
            )],
        };
        extra.push(Span::styled(format!(" {speed} {unit}/s "), p.dim));
        let pct = model.keypad.values.override_pct;
        if pct != 100 {
            // The override changes every jog's speed: not to be missed.
            extra.push(Span::styled(format!(" {pct}% "), p.warning));
        }
        let focused = model.focus == PanelId::Jog && model.popup.is_none();
        let inner = frame::panel("Jog", extra, focused, p, area, buf);
        if inner.height == 0 {
            return;
        }
        let mut lines = grid_lines(model);
        lines.push(status_line(model, usize::from(inner.width)));
        for (i, line) in lines.into_iter().enumerate() {
            let y = inner.y.saturating_add(i as u16);
            if y >= inner.bottom() {
                break;
            }
            line.render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
    }
}

fn grid_lines(model: &Model) -> Vec<Line<'static>> {
    let p = &model.palette;
    let lit = lit_vector(model);
    let rows: &[[Option<Action>; 5]] = if height(model) == 3 {
        &GRID[1..2]
    } else {
        &GRID
    };
    let cells: Vec<Vec<Option<(String, Vector)>>> = rows
        .iter()
        .map(|row| {
            row.iter()
                .map(|a| a.and_then(|a| cell_text(model, a)))
                .collect()
        })
        .collect();
    let columns = 5;
    let widths: Vec<usize> = (0..columns)
        .map(|c| {
            cells
                .iter()
                .filter_map(|r| r.get(c).and_then(|x| x.as_ref()))
                .map(|(t, _)| t.chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    cells
        .into_iter()
        .map(|row| {
            let mut spans = Vec::new();
            for (c, cell) in row.into_iter().enumerate() {
                let w = widths.get(c).copied().unwrap_or(0);
                if w == 0 {
                    continue;
                }
                // The XY block is tight; Z and A stand apart from it.
                let gap = if c == 3 { "   " } else { "  " };
                if c > 0 {
                    spans.push(Span::raw(gap));
                }
                match cell {
                    Some((text, vector)) => {
                        let style: Style = if lit == Some(vector) {
                            p.lit.patch(p.selected)
                        } else {
                            p.key
                        };
                        let pad = w.saturating_sub(text.chars().count());
                        spans.push(Span::styled(text, style));
                        spans.push(Span::raw(" ".repeat(pad)));
                    }
                    None => spans.push(Span::raw(" ".repeat(w))),
                }
            }
            Line::from(spans)
        })
        .collect()
}

fn status_line(model: &Model, width: usize) -> Line<'static> {
    let p = &model.palette;
    let jogger = &model.keypad.jogger;
    let now = model.now;
    let fresh = |at: std::time::Instant| now.saturating_duration_since(at) < REFUSAL_SHOWN;
    let moving = model.palette.symbols.moving;
    // The jog off a limit switch first: it runs without a key held.
    if let Some(text) =
        super::limit::status(&model.keypad.limit, model.keypad.settings(), &model.setup)
    {
        return Line::from(Span::styled(
            fit(&format!("{moving} {text}"), width),
            p.warning,
        ));
    }
    if let Some(LastOutcome::Refused { reason, at }) = jogger.last()
        && fresh(*at)
    {
        return Line::from(Span::styled(fit(&format!("!! {reason}"), width), p.danger));
    }
    if let Some(a) = jogger.active() {
        let how = if a.toggle {
            "any key stops"
        } else if jogger.releases() {
            "release stops"
        } else {
            "stops when the key repeats stop"
        };
        return Line::from(Span::styled(
            fit(&format!("{moving} jog {}: {how}", a.vector), width),
            p.warning,
        ));
    }
    if let Some(Homing {
        axes,
        since,
        before,
        ..
    }) = model.keypad.homing
    {
        let done: crate::axis::AxisSet = axes
            .iter()
            .filter(|a| model.machine.referenced.contains(*a) && !before.contains(*a))
            .collect();
        let secs = now.saturating_duration_since(since).as_secs_f64();
        let done = if done.is_empty() {
            String::new()
        } else {
            format!(", done {done}")
        };
        return Line::from(Span::styled(
            fit(&format!("{moving} homing {axes} {secs:.1} s{done}"), width),
            p.warning,
        ));
    }
    if model.machine.activity == Activity::Stepping {
        let dropped = jogger.dropped_steps();
        let text = if dropped > 0 {
            format!("{moving} stepping; {dropped} presses dropped (steps still running)")
        } else {
            format!("{moving} stepping")
        };
        return Line::from(Span::styled(fit(&text, width), p.warning));
    }
    if let Some(LastOutcome::Ended { end, at }) = jogger.last()
        && fresh(*at)
        && model.keypad.end_is_news(end)
    {
        return Line::from(Span::styled(
            fit(&format!("! jog ended: {}", end_words(end)), width),
            p.warning,
        ));
    }
    let text = match jogger.kind() {
        JogKind::Step => hint(
            model,
            &[
                (Action::JogKind, "continuous"),
                (Action::StepLarger, "step"),
                (Action::SpeedFaster, "speed"),
            ],
        ),
        JogKind::Continuous => match caps(model) {
            Some(text) => text,
            None => hint(
                model,
                &[(Action::JogKind, "steps"), (Action::SpeedFaster, "speed")],
            ),
        },
    };
    Line::from(Span::styled(fit(&text, width), p.dim))
}

fn end_words(end: &crate::device::api::JogEnd) -> String {
    use crate::device::api::JogEnd;
    match end {
        JogEnd::Released => "released".into(),
        JogEnd::DeadMan => "key repeats stopped (dead-man)".into(),
        JogEnd::Stopped => "stopped".into(),
        JogEnd::SoftLimit => "soft limit".into(),
        JogEnd::Refused(r) => r.to_string(),
        JogEnd::Fault(f) => f.meaning.clone(),
        JogEnd::LinkLost => "link lost".into(),
        JogEnd::OffLimit => "off the limit switch: reference the axes (h)".into(),
        JogEnd::StillOnLimit => "the limit switch still reads active".into(),
    }
}

fn hint(model: &Model, items: &[(Action, &str)]) -> String {
    items
        .iter()
        .filter_map(|(action, label)| {
            let keys = model.keymap.keys_for(Mode::Main, *action);
            let key = keys.first()?;
            // `[ ]` and `- +` read as a pair: the key for the other
            // direction goes in front.
            let other = match action {
                Action::StepLarger => Action::StepSmaller,
                Action::SpeedFaster => Action::SpeedSlower,
                _ => *action,
            };
            let before = model
                .keymap
                .keys_for(Mode::Main, other)
                .first()
                .filter(|_| other != *action)
                .map(|k| format!("{k} "))
                .unwrap_or_default();
            Some(format!("{before}{key} {label}"))
        })
        .collect::<Vec<_>>()
        .join("  ")
}

/// In continuous mode, what the overrun bound allows where it is below the
/// speed selected: the first lease (until the terminal's first repeat) and
/// once repeats flow.
fn caps(model: &Model) -> Option<String> {
    let s = model.keypad.settings();
    let speed = model.jog_speed()?;
    let x = [(s.axes.first()?.axis, crate::device::api::Dir::Plus)];
    let steady = s.speed_cap(&x, s.repeat_timeout)?;
    let unit = unit_label(model);
    let toggle = model.keypad.jogger.mode() == JogMode::Toggle;
    if toggle {
        return (speed > steady)
            .then(|| format!("capped to {} {unit}/s (overrun bound)", one_decimal(steady)));
    }
    let first = s.speed_cap(&x, s.grace)?;
    if speed <= first {
        return None;
    }
    Some(format!(
        "{} {unit}/s until the first repeat, then {}",
        one_decimal(first.min(speed)),
        one_decimal(steady.min(speed))
    ))
}

/// The go-to prompt.
pub struct GoToView<'a> {
    pub model: &'a Model,
    pub prompt: &'a GoToPrompt,
}

impl Widget for GoToView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.model;
        let p = &model.palette;
        let width = area.width.clamp(20, 60);
        let error = self.prompt.line.error.as_ref().map(|e| e.message.as_str());
        let height = 5 + super::popup_view::error_height(error, usize::from(width - 2));
        let box_area = centred(area, width, height);
        let title = match self.prompt.frame {
            Frame::Work => format!(
                "Go to ({} work coordinates)",
                model.keypad.offsets.table.active()
            ),
            Frame::Machine => "Go to (machine coordinates)".to_string(),
        };
        let inner = framed(model, &title, box_area, buf);
        let unit = unit_label(model);
        let speed = model.jog_speed().map(format_amount).unwrap_or_default();
        let w = usize::from(inner.width);
        let help = format!("e.g. X10 Y-2.5 F120: {unit}, F {unit}/min; else {speed} {unit}/s");
        let mut rows = vec![
            Line::from(Span::styled(fit(&help, w), p.dim)),
            super::popup_view::typed_line(model, "> ", &self.prompt.line, true, w),
        ];
        if let Some(e) = error {
            rows.extend(super::popup_view::error_rows(model, e, w));
        }
        let keys = |action| {
            model
                .keymap
                .key_for(Mode::GoTo, action)
                .map(|k| k.to_string())
                .unwrap_or_default()
        };
        let other = match self.prompt.frame {
            Frame::Work => " machine   ",
            Frame::Machine => " work   ",
        };
        rows.push(Line::from(vec![
            Span::styled(keys(Action::Submit), p.key),
            Span::styled(" go   ", p.text),
            Span::styled(keys(Action::ToggleFrame), p.key),
            Span::styled(other, p.text),
            Span::styled(keys(Action::Cancel), p.key),
            Span::styled(" cancel", p.text),
        ]));
        for (i, row) in rows.into_iter().enumerate() {
            let y = inner.y + i as u16;
            if y < inner.bottom() {
                row.render(Rect::new(inner.x, y, inner.width, 1), buf);
            }
        }
    }
}

/// The choice of an axis.
pub struct AxesView<'a> {
    pub model: &'a Model,
    pub choice: &'a AxisChoice,
}

impl Widget for AxesView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.model;
        let p = &model.palette;
        let question = self.choice.question();
        let width = area.width.clamp(20, 60);
        let text_w = usize::from(width.saturating_sub(2)).max(1);
        let text_rows = (question.chars().count().div_ceil(text_w) + 1) as u16;
        let box_area = centred(area, width, text_rows + 3);
        let inner = framed(model, self.choice.title(), box_area, buf);
        Paragraph::new(Span::styled(question, p.warning))
            .wrap(Wrap { trim: true })
            .render(
                Rect::new(
                    inner.x,
                    inner.y,
                    inner.width,
                    inner.height.saturating_sub(1),
                ),
                buf,
            );
        let cancel = model
            .keymap
            .key_for(Mode::Axes, Action::Cancel)
            .map(|k| k.to_string())
            .unwrap_or_default();
        if inner.height > 0 {
            Line::from(vec![
                Span::styled(cancel, p.key),
                Span::styled(" cancel", p.text),
            ])
            .render(Rect::new(inner.x, inner.bottom() - 1, inner.width, 1), buf);
        }
    }
}
