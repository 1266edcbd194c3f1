//! The main screen of every controller family at 80x24 and 160x48, in every
//! shipped theme, in the states an operator meets: idle, moving (estimated on
//! isel), E-stop, limit switch hit, link lost. Text snapshots (review with
//! `cargo insta review`), plus explicit style checks where the theme is what
//! carries the meaning.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod ui_support;

use std::time::Instant;

use jogterm::proto::Protocol;
use jogterm::ui::Model;
use ratatui::buffer::Buffer;
use ratatui::style::{Color, Style};
use ui_support::{SIZES, State, THEMES, find, model_in, render};

fn snapshot_family(protocol: Protocol) {
    let t0 = Instant::now();
    for theme in THEMES {
        for state in State::ALL {
            let model = model_in(protocol, theme, state, t0);
            for (w, h) in SIZES {
                let terminal = render(&model, w, h);
                let name = format!("{protocol}_{}_{w}x{h}_{theme}", state.name());
                insta::assert_snapshot!(name, terminal.backend());
            }
        }
    }
}

#[test]
fn isel_screens() {
    snapshot_family(Protocol::Isel);
}

#[test]
fn emcu_screens() {
    snapshot_family(Protocol::Emcu);
}

#[test]
fn emp_screens() {
    snapshot_family(Protocol::Emp);
}

/// The style a cell was drawn with.
fn style_at(buf: &Buffer, (x, y): (u16, u16)) -> Style {
    buf[(x, y)].style()
}

/// Whether `cell` shows `expected`: same colours (where the theme sets one)
/// and at least its modifiers.
fn shows(cell: Style, expected: Style) -> bool {
    let colour = |c: Option<Color>, e: Option<Color>| e.is_none() || c == e;
    colour(cell.fg, expected.fg)
        && colour(cell.bg, expected.bg)
        && cell.add_modifier.contains(expected.add_modifier)
}

fn first(buf: &Buffer, needle: &str) -> (u16, u16) {
    *find(buf, needle)
        .first()
        .unwrap_or_else(|| panic!("`{needle}` is not on the screen"))
}

fn checked(model: &Model, w: u16, h: u16) -> Buffer {
    render(model, w, h).backend().buffer().clone()
}

#[test]
fn the_state_word_carries_the_theme_severity() {
    let t0 = Instant::now();
    for theme in THEMES {
        for (state, word, severity) in [
            (State::Idle, "READY", "ok"),
            (State::EStop, "E-STOP", "danger"),
            (State::Limit, "LIMIT", "danger"),
            (State::Moving, "MOVING", "warning"),
            (State::LinkLost, "UNKNOWN", "danger"),
        ] {
            let m = model_in(Protocol::Isel, theme, state, t0);
            let p = &m.palette;
            let expected = match severity {
                "ok" => p.status_bar.patch(p.ok),
                "warning" => p.status_bar.patch(p.warning),
                _ => p.status_bar.patch(p.danger),
            };
            for (w, h) in SIZES {
                let buf = checked(&m, w, h);
                let at = first(&buf, word);
                assert_eq!(at.1, 0, "{theme}: {word} is in the status bar");
                assert!(
                    shows(style_at(&buf, at), expected),
                    "{theme} {word}: {:?} is not {severity} {:?}",
                    style_at(&buf, at),
                    expected
                );
            }
        }
    }
}

#[test]
fn estimated_positions_look_different_from_measured_ones() {
    let t0 = Instant::now();
    for theme in THEMES {
        let moving = model_in(Protocol::Isel, theme, State::Moving, t0);
        let idle = model_in(Protocol::Isel, theme, State::Idle, t0);
        let p = &moving.palette;
        let buf = checked(&moving, 80, 24);
        // The X row's work value, right after the estimated symbol.
        let symbol = p.symbols.estimated;
        let (x, y) = first(&buf, &format!("X{}{symbol}", p.symbols.referenced));
        let value = (x + 4, y);
        assert!(shows(style_at(&buf, value), p.estimated), "{theme}");
        assert!(buf[(x + 2, y)].symbol() == symbol, "{theme}: symbol");
        let idle_buf = checked(&idle, 80, 24);
        let (ix, iy) = first(&idle_buf, &format!("X{}", p.symbols.referenced));
        assert!(
            shows(style_at(&idle_buf, (ix + 4, iy)), p.measured),
            "{theme}"
        );
        assert_ne!(
            style_at(&buf, value),
            style_at(&idle_buf, (ix + 4, iy)),
            "{theme}: estimated and measured must differ"
        );
    }
}

#[test]
fn a_hit_limit_switch_is_lit_and_highlighted() {
    let t0 = Instant::now();
    for theme in THEMES {
        let m = model_in(Protocol::Isel, theme, State::Limit, t0);
        let p = &m.palette;
        for (w, h) in SIZES {
            let buf = checked(&m, w, h);
            let lit = format!("{}X2", p.symbols.lit);
            let at = first(&buf, &lit);
            assert!(
                shows(style_at(&buf, at), p.lit.patch(p.changed)),
                "{theme} {w}x{h}: {:?}",
                style_at(&buf, at)
            );
            let unlit = first(&buf, &format!("{}X1", p.symbols.unlit));
            assert!(shows(style_at(&buf, unlit), p.unlit), "{theme}");
        }
    }
}

#[test]
fn a_lost_link_greys_the_last_known_positions() {
    let t0 = Instant::now();
    for theme in THEMES {
        let m = model_in(Protocol::Emcu, theme, State::LinkLost, t0);
        let buf = checked(&m, 80, 24);
        // The X row of the position panel starts the line.
        let (x, y) = *find(&buf, "X")
            .iter()
            .find(|(x, _)| *x == 0)
            .expect("the X row");
        assert!(shows(style_at(&buf, (x + 4, y)), m.palette.dim), "{theme}");
        // At 160x48 the large digits and the machine position beside them.
        let buf = checked(&m, 160, 48);
        assert!(!find(&buf, "last known").is_empty(), "{theme}");
        let (x, y) = first(&buf, "machine ");
        assert!(shows(style_at(&buf, (x + 8, y)), m.palette.dim), "{theme}");
        let ink = if m.palette.symbols.lit.is_ascii() {
            "#"
        } else {
            "█"
        };
        let (x, y) = *find(&buf, ink)
            .iter()
            .find(|(x, y)| *x > 8 && *y == 3)
            .expect("the digits of X");
        assert!(shows(style_at(&buf, (x, y)), m.palette.dim), "{theme}");
    }
}

/// mono16 is for consoles where colour cannot be trusted: everything that
/// means something must differ by symbol or by bold/reverse/underline.
#[test]
fn mono16_never_says_anything_by_colour_alone() {
    let t0 = Instant::now();
    let m = model_in(Protocol::Isel, "mono16", State::Limit, t0);
    let p = &m.palette;
    assert_ne!(p.symbols.lit, p.symbols.unlit);
    assert_ne!(p.symbols.estimated, p.symbols.measured);
    assert_ne!(p.symbols.referenced, p.symbols.unreferenced);
    for (name, style) in [
        ("lit", p.lit),
        ("changed", p.changed),
        ("danger", p.danger),
        ("warning", p.warning),
        ("estimated", p.estimated),
        ("selected", p.selected),
        ("status_bar", p.status_bar),
    ] {
        assert!(
            !style.add_modifier.is_empty(),
            "mono16 `{name}` needs a modifier, not only a colour"
        );
    }
    // Modifier sets that must tell things apart.
    assert_ne!(p.lit.add_modifier, p.unlit.add_modifier);
    assert_ne!(p.lit.add_modifier, p.lit.patch(p.changed).add_modifier);
    assert_ne!(p.estimated.add_modifier, p.measured.add_modifier);
    // Symbols and words are ASCII; only the frame lines and the ellipsis of
    // a cut name are drawn with other characters.
    let buf = checked(&m, 80, 24);
    for cell in buf.content() {
        assert!(
            cell.symbol().is_ascii() || "─┌┐└┘│…".contains(cell.symbol()),
            "non-ASCII `{}` on the mono16 screen",
            cell.symbol()
        );
    }
}

/// The help overlay (`?`) as a listing of every line it holds, and as drawn
/// at both sizes (first page, and the last at 80x24): generated from the
/// keymap, it must read the same whatever form the keymap's tables take.
#[test]
fn help_overlay() {
    use jogterm::ui::help::{HelpLine, help_lines};
    use jogterm::ui::model::Popup;
    let t0 = Instant::now();
    let mut model = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let lines = help_lines(&model.keymap, &model.setup.macros);
    let listing: Vec<String> = lines
        .iter()
        .map(|line| match line {
            HelpLine::Heading(title) => format!("# {title}"),
            HelpLine::Entry { keys, description } => format!("{keys:>24}  {description}"),
            HelpLine::Text(text) => format!("  {text}"),
            HelpLine::Blank => String::new(),
        })
        .collect();
    insta::assert_snapshot!("help_listing", listing.join("\n"));
    for (w, h) in SIZES {
        model.popup = Some(Popup::Help { scroll: 0 });
        insta::assert_snapshot!(format!("help_{w}x{h}"), render(&model, w, h).backend());
    }
    model.popup = Some(Popup::Help {
        scroll: lines.len(),
    });
    insta::assert_snapshot!("help_80x24_end", render(&model, 80, 24).backend());
}
