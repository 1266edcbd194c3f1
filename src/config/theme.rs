//! Themes: one style per meaning on screen, and a symbol set, so that a theme
//! for a 16-colour console can say "lit" with bold, reverse and a symbol
//! instead of colour alone.

use std::str::FromStr;

use ratatui::style::{Color, Modifier, Style};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Theme {
    /// Which shipped theme this one patches; `dark` when absent.
    #[serde(default)]
    pub base: Option<String>,
    pub name: String,
    pub symbols: SymbolSet,
    pub styles: Styles,
}

/// Every meaning the screen distinguishes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Styles {
    pub text: StyleSpec,
    pub dim: StyleSpec,
    pub title: StyleSpec,
    pub border: StyleSpec,
    pub focus_border: StyleSpec,
    /// An input or output bit that is 1.
    pub lit: StyleSpec,
    pub unlit: StyleSpec,
    /// A bit that changed a moment ago (so a flickering switch is seen).
    pub changed: StyleSpec,
    pub ok: StyleSpec,
    pub warning: StyleSpec,
    pub danger: StyleSpec,
    /// A position read from the controller.
    pub measured: StyleSpec,
    /// A position estimated while the controller cannot be asked (isel moving).
    pub estimated: StyleSpec,
    pub key: StyleSpec,
    pub selected: StyleSpec,
    pub status_bar: StyleSpec,
    /// Traffic console: bytes sent and received.
    pub sent: StyleSpec,
    pub received: StyleSpec,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SymbolSet {
    Unicode,
    Ascii,
}

/// The glyphs a symbol set uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Symbols {
    pub lit: &'static str,
    pub unlit: &'static str,
    pub estimated: &'static str,
    pub measured: &'static str,
    pub referenced: &'static str,
    pub unreferenced: &'static str,
    pub moving: &'static str,
    /// A port timeline lane: an input at 1, at 0, a column with one change,
    /// with several.
    pub high: &'static str,
    pub low: &'static str,
    pub edge: &'static str,
    pub burst: &'static str,
    /// The title rule of the panel that has the focus (the others are
    /// drawn with a thin line), so focus shows without colour.
    pub focus_rule: &'static str,
}

impl SymbolSet {
    pub fn symbols(self) -> Symbols {
        match self {
            SymbolSet::Unicode => Symbols {
                lit: "●",
                unlit: "○",
                estimated: "≈",
                measured: " ",
                referenced: "⌂",
                unreferenced: "?",
                moving: "»",
                high: "▔",
                low: "▁",
                edge: "│",
                burst: "▒",
                focus_rule: "━",
            },
            SymbolSet::Ascii => Symbols {
                lit: "#",
                unlit: ".",
                estimated: "~",
                measured: " ",
                referenced: "R",
                unreferenced: "?",
                moving: ">",
                high: "=",
                low: "_",
                edge: "|",
                burst: "#",
                focus_rule: "=",
            },
        }
    }
}

/// A style as written in a theme file: colour names (`red`, `lightblue`,
/// `#ff8800`, `242`) and modifier flags.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StyleSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fg: Option<ColorName>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bg: Option<ColorName>,
    #[serde(default)]
    pub bold: bool,
    #[serde(default)]
    pub dim: bool,
    #[serde(default)]
    pub italic: bool,
    #[serde(default)]
    pub underline: bool,
    #[serde(default)]
    pub reverse: bool,
}

impl StyleSpec {
    pub fn style(&self) -> Style {
        let mut style = Style::default();
        if let Some(c) = &self.fg {
            style = style.fg(c.0);
        }
        if let Some(c) = &self.bg {
            style = style.bg(c.0);
        }
        let flags = [
            (self.bold, Modifier::BOLD),
            (self.dim, Modifier::DIM),
            (self.italic, Modifier::ITALIC),
            (self.underline, Modifier::UNDERLINED),
            (self.reverse, Modifier::REVERSED),
        ];
        for (on, modifier) in flags {
            if on {
                style = style.add_modifier(modifier);
            }
        }
        style
    }
}

/// A colour parsed from its theme-file spelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColorName(pub Color);

impl Serialize for ColorName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.0.to_string())
    }
}

impl<'de> Deserialize<'de> for ColorName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        Color::from_str(&text).map(ColorName).map_err(|_| {
            serde::de::Error::custom(format!(
                "`{text}` is not a colour: expected a name (red, lightblue, darkgray, …), #rrggbb, or 0-255"
            ))
        })
    }
}

impl Theme {
    pub fn symbols(&self) -> Symbols {
        self.symbols.symbols()
    }
}
