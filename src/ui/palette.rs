//! A loaded theme turned into what the view draws with: one ratatui `Style`
//! per meaning, and the symbol set. Resolved once, so drawing never parses.

use ratatui::style::Style;

use crate::config::Theme;
use crate::config::theme::Symbols;

#[derive(Debug, Clone, PartialEq)]
pub struct Palette {
    pub name: String,
    pub text: Style,
    pub dim: Style,
    pub title: Style,
    pub border: Style,
    pub focus_border: Style,
    pub lit: Style,
    pub unlit: Style,
    pub changed: Style,
    pub ok: Style,
    pub warning: Style,
    pub danger: Style,
    pub measured: Style,
    pub estimated: Style,
    pub key: Style,
    pub selected: Style,
    pub status_bar: Style,
    pub sent: Style,
    pub received: Style,
    pub symbols: Symbols,
}

impl From<&Theme> for Palette {
    fn from(theme: &Theme) -> Self {
        let s = &theme.styles;
        Palette {
            name: theme.name.clone(),
            text: s.text.style(),
            dim: s.dim.style(),
            title: s.title.style(),
            border: s.border.style(),
            focus_border: s.focus_border.style(),
            lit: s.lit.style(),
            unlit: s.unlit.style(),
            changed: s.changed.style(),
            ok: s.ok.style(),
            warning: s.warning.style(),
            danger: s.danger.style(),
            measured: s.measured.style(),
            estimated: s.estimated.style(),
            key: s.key.style(),
            selected: s.selected.style(),
            status_bar: s.status_bar.style(),
            sent: s.sent.style(),
            received: s.received.style(),
            symbols: theme.symbols(),
        }
    }
}
