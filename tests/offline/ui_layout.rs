//! The screen at any size: panels inside the terminal and never on top of
//! each other, nothing panics from 1x1 to 220x70, and the small sizes an SSH
//! session may have (60x20) still show every panel.

use crate::ui_support;

use std::time::Instant;

use jogterm::proto::Protocol;
use jogterm::ui::model::PanelId;
use jogterm::ui::view::layout::areas;
use proptest::prelude::*;
use ratatui::layout::Rect;
use ui_support::{State, find, model_in, render, text};

fn inside(outer: Rect, inner: Rect) -> bool {
    inner.area() == 0
        || (inner.x >= outer.x
            && inner.y >= outer.y
            && inner.right() <= outer.right()
            && inner.bottom() <= outer.bottom())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn any_size_lays_out_without_overlap_and_renders(
        w in 1u16..220,
        h in 1u16..70,
        family in prop::sample::select(Protocol::ALL.to_vec()),
        state in prop::sample::select(State::ALL.to_vec()),
        focus in prop::sample::select(vec![PanelId::Io, PanelId::Console, PanelId::Sim]),
    ) {
        let mut m = model_in(family, "dark", state, Instant::now());
        if m.focus_ring().contains(&focus) {
            m.focus = focus;
        }
        let screen = Rect::new(0, 0, w, h);
        let a = areas(&m, screen);
        let mut rects = vec![a.status, a.message, a.dro, a.io, a.console];
        rects.extend(a.sim);
        rects.extend(a.messages);
        rects.extend(a.preview);
        rects.extend(a.hints);
        for r in &rects {
            prop_assert!(inside(screen, *r), "{r:?} outside {screen:?}");
        }
        for (i, r) in rects.iter().enumerate() {
            for s in rects.iter().skip(i + 1) {
                prop_assert!(
                    r.area() == 0 || s.area() == 0 || !r.intersects(*s),
                    "{r:?} overlaps {s:?} at {w}x{h}"
                );
            }
        }
        // Drawing must not panic at any size.
        let _ = render(&m, w, h);
    }

    #[test]
    fn the_port_timeline_renders_at_any_size_and_zoom(
        w in 1u16..220,
        h in 1u16..70,
        family in prop::sample::select(Protocol::ALL.to_vec()),
        scale in 0usize..13,
        top in 0usize..40,
        back in prop::option::of(0u64..20_000),
    ) {
        let mut m = model_in(family, "mono16", State::Limit, Instant::now());
        m.focus = PanelId::Timeline;
        m.timeline.scale = scale;
        m.timeline.top = top;
        m.timeline.end = back.map(std::time::Duration::from_millis);
        let _ = render(&m, w, h);
    }
}

#[test]
fn sixty_by_twenty_still_shows_every_panel() {
    for family in Protocol::ALL {
        let m = model_in(family, "dark", State::Limit, Instant::now());
        let terminal = render(&m, 60, 20);
        let buf = terminal.backend().buffer();
        for title in ["Position", "I/O", "Traffic"] {
            assert!(
                !find(buf, title).is_empty(),
                "{family}: {title}\n{}",
                text(buf)
            );
        }
        assert!(!find(buf, "LIMIT").is_empty(), "{family}: the state word");
    }
    // The switch that just tripped is scrolled into view, though the
    // selection is elsewhere.
    let m = model_in(Protocol::Isel, "dark", State::Limit, Instant::now());
    let lit = format!("{}X2", m.palette.symbols.lit);
    let terminal = render(&m, 60, 20);
    let buf = terminal.backend().buffer();
    assert!(!find(buf, &lit).is_empty(), "{}", text(buf));
    let m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    insta::assert_snapshot!("isel_idle_60x20_dark", render(&m, 60, 20).backend());
}

#[test]
fn a_focused_simulator_panel_is_never_squeezed_out() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    m.focus = PanelId::Sim;
    let buf = render(&m, 60, 20).backend().buffer().clone();
    assert!(!find(&buf, "Simulator inputs").is_empty(), "{}", text(&buf));
}

/// Issue 24: at 160x48 the left column below the keypad (and the isel
/// simulator's inputs) held an empty block of ~11 rows. The rows between
/// the position panel and the traffic console are every one some panel's,
/// and the latest messages are where the block was.
#[test]
fn at_160x48_the_left_column_has_no_empty_block_the_latest_messages_fill_it() {
    for family in Protocol::ALL {
        let m = model_in(family, "dark", State::Limit, Instant::now());
        let a = areas(&m, Rect::new(0, 0, 160, 48));
        let left: Vec<Rect> = [Some(a.dro), Some(a.keypad), a.sim, a.messages]
            .into_iter()
            .flatten()
            .collect();
        for y in a.dro.y..a.console.y {
            assert!(
                left.iter().any(|r| r.y <= y && y < r.bottom()),
                "{family}: row {y} of the left column is no panel's: {a:?}"
            );
        }
        let messages = a
            .messages
            .unwrap_or_else(|| panic!("{family}: no messages panel"));
        assert!(messages.height >= 8, "{family}: {messages:?}");
        let buf = render(&m, 160, 48).backend().buffer().clone();
        let title = find(&buf, "Messages (M: all)");
        assert!(!title.is_empty(), "{family}:\n{}", text(&buf));
        assert!(!find(&buf, "limit switch").is_empty(), "{}", text(&buf));
    }
    // Drawn: the `isel_*_160x48_*` snapshots of `ui_snapshots.rs`.
}
