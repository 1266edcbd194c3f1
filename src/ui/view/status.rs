//! The status bar (link, machine state, poll rate), the message line under
//! it (the latest refusal or notice while fresh, else what the machine state
//! needs), and the key hints at the bottom.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::device::api::{LinkState, UploadEvent};
use crate::ui::key::KeyChord;
use crate::ui::keymap::{Action, Mode};
use crate::ui::model::Model;
use crate::ui::palette::Palette;
use crate::ui::summary::{Severity, summarise};
use crate::ui::traffic_log::NoteLevel;

use super::flow::fit;

pub fn severity_style(palette: &Palette, severity: Severity) -> Style {
    match severity {
        Severity::Ok => palette.ok,
        Severity::Warning => palette.warning,
        Severity::Danger => palette.danger,
    }
}

pub fn note_style(palette: &Palette, level: NoteLevel) -> Style {
    match level {
        NoteLevel::Info => palette.text,
        NoteLevel::Warning => palette.warning,
        NoteLevel::Danger => palette.danger,
    }
}

/// A marker that says the level without colour (mono16, screen readers).
pub fn note_marker(level: NoteLevel) -> &'static str {
    match level {
        NoteLevel::Info => "·",
        NoteLevel::Warning => "!",
        NoteLevel::Danger => "!!",
    }
}

pub struct StatusBar<'a>(pub &'a Model);

impl Widget for StatusBar<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let base = p.status_bar;
        buf.set_style(area, base);
        let width = usize::from(area.width);
        let summary = summarise(model);
        let port = if model.setup.is_simulator() {
            "sim".to_string()
        } else {
            model.setup.port.clone()
        };
        let (link_text, link_style) = match &model.link {
            LinkState::Connecting => ("connecting", base),
            LinkState::Connected => ("connected", base),
            LinkState::Lost { .. } => ("link lost", base.patch(p.danger)),
            LinkState::Reconnecting { .. } => ("reconnecting", base.patch(p.warning)),
            LinkState::Closed => ("closed", base),
        };
        let mut poll = match &model.stats {
            Some(s) if width >= 70 => {
                format!("poll {:.0}/{:.0} Hz ", s.position_rate_hz, s.wire_limit_hz)
            }
            Some(s) => format!("{:.0} Hz ", s.position_rate_hz),
            None => "poll - ".to_string(),
        };
        // An upload in progress is worth a glance from any panel.
        match &model.upload {
            Some(UploadEvent::Started { total }) => {
                poll.insert_str(0, &format!("upload 0/{total} "))
            }
            Some(UploadEvent::Progress { done, total, .. }) => {
                poll.insert_str(0, &format!("upload {done}/{total} "))
            }
            _ => {}
        }
        // A job run from the editor: its progress in place of the bare
        // word, and the rest of the line made to give way to it.
        let job = model.job_status();
        if job.is_some() && width < 100 {
            poll = match &model.stats {
                Some(s) => format!("{:.0} Hz ", s.position_rate_hz),
                None => String::new(),
            };
        }
        let short_link = format!(" {} ", model.setup.protocol);
        let state_text = match &job {
            Some(j) => {
                let room = width
                    .saturating_sub(short_link.len() + link_text.len() + 1 + poll.len() + 2)
                    .max(j.word.len() + 2);
                fit(&format!(" {} {} ", j.word, j.progress), room)
            }
            None => format!(" {} ", summary.word),
        };
        let state_style = match &job {
            Some(j) if j.waiting.is_some() => base.patch(p.danger),
            Some(_) => base.patch(p.ok),
            None => base.patch(severity_style(p, summary.severity)),
        };
        let state = Span::styled(state_text, state_style);
        let right = Span::styled(poll, base);
        let fixed = state.width() + right.width() + 2;
        let link_full = format!(
            " {} {} {} ",
            model.setup.protocol, port, model.setup.line.baud
        );
        let link = if fixed + link_full.len() + link_text.len() <= width {
            link_full
        } else {
            short_link
        };
        let mut spans = vec![
            Span::styled(link, base),
            Span::styled(link_text, link_style),
            Span::styled(" ", base),
            state,
        ];
        let used: usize = spans.iter().map(Span::width).sum();
        let gap = width.saturating_sub(used + right.width());
        spans.push(Span::styled(" ".repeat(gap), base));
        spans.push(right);
        Line::from(spans).render(area, buf);
    }
}

pub struct MessageLine<'a>(pub &'a Model);

impl Widget for MessageLine<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let width = usize::from(area.width);
        let line = if let Some(m) = model.fresh_message() {
            let marker = note_marker(m.level);
            let room = width.saturating_sub(marker.len() + 1);
            // A message cut to the line says where it is whole; not where
            // that key types a letter (the editor, the command line).
            let typing = crate::ui::typing::text_field(model).is_some() && model.popup.is_none();
            let whole = model
                .keymap
                .key_for(Mode::Main, Action::Messages)
                .filter(|k| !(typing && k.typed_char().is_some()))
                .map(|k| format!(" [{k}: all]"))
                .filter(|_| Span::raw(m.text.as_str()).width() > room)
                .unwrap_or_default();
            let room = room.saturating_sub(whole.chars().count());
            Line::from(vec![
                Span::styled(format!("{marker} "), note_style(p, m.level)),
                Span::styled(fit(&m.text, room), note_style(p, m.level)),
                Span::styled(whole, p.key),
            ])
        } else if let Some(waiting) = model.job_status().and_then(|j| j.waiting) {
            // A job waiting for the operator says so until it goes on.
            Line::from(Span::styled(fit(&waiting, width), p.warning))
        } else {
            let summary = summarise(model);
            match summary.detail {
                Some(detail) => Line::from(Span::styled(
                    fit(&detail, width),
                    severity_style(p, summary.severity),
                )),
                None => Line::from(Span::styled(
                    fit("ready: Space stops, ? lists every key", width),
                    p.dim,
                )),
            }
        };
        line.render(area, buf);
    }
}

/// The hints at the bottom: the keys that matter where the operator is.
pub struct Hints<'a>(pub &'a Model);

impl Widget for Hints<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let map = &model.keymap;
        // On the command line and in the editor Space may type a blank
        // (`ui::typing`): the stop key that always stops there is shown.
        // (In a popup Esc closes it; Space is the one shown.)
        let stop_key = match crate::ui::typing::text_field(model) {
            Some(_) if model.popup.is_none() => map
                .key_for(Mode::Main, Action::Stop)
                .or_else(|| map.key_for(Mode::Safety, Action::Stop)),
            _ => map.key_for(Mode::Safety, Action::Stop),
        };
        let mut hints: Vec<(Option<KeyChord>, &str)> = vec![(stop_key, "stop")];
        let context: &[(Mode, Action, &str)] = match &model.popup {
            Some(popup) => match popup.mode() {
                Mode::Confirm => &[
                    (Mode::Confirm, Action::Confirm, "yes"),
                    (Mode::Confirm, Action::Cancel, "no"),
                ],
                Mode::Form => &[
                    (Mode::Form, Action::Submit, "ok"),
                    (Mode::Form, Action::NextField, "next field"),
                    (Mode::Form, Action::Cancel, "cancel"),
                ],
                Mode::Unsaved => &[
                    (Mode::Unsaved, Action::Save, "save"),
                    (Mode::Unsaved, Action::Discard, "discard"),
                    (Mode::Unsaved, Action::Cancel, "back"),
                ],
                Mode::GoTo => &[
                    (Mode::GoTo, Action::Submit, "go"),
                    (Mode::GoTo, Action::Cancel, "cancel"),
                ],
                Mode::Offsets => &[
                    (Mode::Offsets, Action::Activate, "activate"),
                    (Mode::Offsets, Action::Cancel, "close"),
                ],
                Mode::Entry => &[
                    (Mode::Entry, Action::Submit, "ok"),
                    (Mode::Entry, Action::Cancel, "cancel"),
                ],
                Mode::Axes => &[
                    (Mode::Axes, Action::AxisAll, "all axes"),
                    (Mode::Axes, Action::Cancel, "cancel"),
                ],
                Mode::Outputs => &[
                    (Mode::Outputs, Action::ToggleOutput, "switch"),
                    (Mode::Outputs, Action::SelectNext, "next"),
                    (Mode::Outputs, Action::Close, "close"),
                ],
                Mode::Messages => &[
                    (Mode::Messages, Action::ScrollUp, "older"),
                    (Mode::Messages, Action::PageUp, "page"),
                    (Mode::Messages, Action::ScrollBottom, "newest"),
                    (Mode::Messages, Action::Close, "close"),
                ],
                _ => &[
                    (Mode::Help, Action::ScrollDown, "scroll"),
                    (Mode::Help, Action::Close, "close"),
                ],
            },
            None => match model.panel_mode() {
                Mode::Jog => &[
                    (Mode::Main, Action::Help, "help"),
                    (Mode::Main, Action::FocusNext, "focus"),
                    (Mode::Main, Action::JogKind, "step/cont."),
                    (Mode::Main, Action::GoTo, "go to"),
                    (Mode::Main, Action::Initialise, "init"),
                    (Mode::Main, Action::Home, "home"),
                    (Mode::Main, Action::Quit, "quit"),
                    // Shown where the line has room (wide terminals).
                    (Mode::Main, Action::LargeDro, "large DRO"),
                    (Mode::Main, Action::Outputs, "outputs"),
                    (Mode::Main, Action::Messages, "messages"),
                ],
                Mode::Console => &[
                    (Mode::Console, Action::Submit, "send"),
                    (Mode::Console, Action::HistoryPrev, "history"),
                    (Mode::Main, Action::FocusNext, "leave the command line"),
                ],
                Mode::Editor => &[
                    (Mode::Editor, Action::CloseEditor, "machine"),
                    (Mode::Editor, Action::Save, "save"),
                    (Mode::Main, Action::Upload, "upload"),
                    (Mode::Main, Action::RunProgram, "run"),
                    (Mode::Editor, Action::Find, "find"),
                    (Mode::Editor, Action::NextProblem, "problem"),
                    (Mode::Editor, Action::Undo, "undo"),
                    (Mode::Editor, Action::TypeBlank, "blank"),
                ],
                Mode::Checkout => &[
                    (Mode::Checkout, Action::CheckoutHold, "hold: run"),
                    (Mode::Checkout, Action::CheckoutSingle, "single step"),
                    (Mode::Checkout, Action::CheckoutSlower, "slower"),
                    (Mode::Checkout, Action::CheckoutFaster, "faster"),
                    (Mode::Checkout, Action::CheckoutAbort, "end"),
                ],
                Mode::Timeline => &[
                    (Mode::Timeline, Action::Timeline, "machine"),
                    (Mode::Timeline, Action::TimeEarlier, "earlier"),
                    (Mode::Timeline, Action::TimeLater, "later"),
                    (Mode::Timeline, Action::TimeLive, "live"),
                    (Mode::Timeline, Action::ZoomIn, "zoom in"),
                    (Mode::Timeline, Action::ZoomOut, "zoom out"),
                    (Mode::Timeline, Action::ScrollDown, "lanes"),
                ],
                Mode::Sim => &[
                    (Mode::Sim, Action::SimToggle, "flip"),
                    (Mode::Sim, Action::SimOn, "on"),
                    (Mode::Sim, Action::SimOff, "off"),
                    (Mode::Sim, Action::SimPress, "press"),
                    (Mode::Sim, Action::SimStart, "start key"),
                    (Mode::Main, Action::FocusNext, "focus"),
                ],
                _ => &[
                    (Mode::Main, Action::Help, "help"),
                    (Mode::Main, Action::FocusNext, "focus"),
                    (Mode::Io, Action::ToggleOutput, "switch"),
                    (Mode::Main, Action::Initialise, "init"),
                    (Mode::Main, Action::Home, "home"),
                    (Mode::Main, Action::FocusConsole, "command"),
                    (Mode::Main, Action::Quit, "quit"),
                ],
            },
        };
        hints.extend(
            context
                .iter()
                .map(|(m, a, label)| (map.key_for(*m, *a), *label)),
        );
        let width = usize::from(area.width);
        let mut spans = Vec::new();
        let mut used = 0;
        for (key, label) in hints {
            let Some(key) = key else { continue };
            let key = key.to_string();
            let w = key.chars().count() + label.len() + 3;
            if used + w > width {
                break;
            }
            spans.push(Span::styled(key, p.key));
            spans.push(Span::styled(format!(" {label}  "), p.dim));
            used += w;
        }
        Line::from(spans).render(area, buf);
    }
}
