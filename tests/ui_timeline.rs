//! The port timeline (`w`): fed as the running console is fed, by the
//! device layer's own input recorder over a run of isel port readings (a
//! 1 s pulse of limit X1, a chattering user input, the two E-stop circuits
//! opening 30 ms apart), then drawn at 80x24 and 160x48 in every theme.
//! Text snapshots, plus style checks where the theme carries the meaning.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod ui_support;

use std::time::{Duration, Instant};

use jogterm::config::{ConfigDirs, load_profile};
use jogterm::device::api::{Event, InputRead, InputSource, IoSnapshot, LinkState};
use jogterm::device::inputs::{InputRecorder, RecorderConfig};
use jogterm::device::isel::input_group;
use jogterm::proto::Protocol;
use jogterm::proto::isel::InputPort;
use jogterm::ui::keymap::Action;
use jogterm::ui::model::PanelId;
use jogterm::ui::{Model, Msg, update};
use ratatui::buffer::Buffer;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ui_support::{SIZES, THEMES, find, fresh, render, send};

const READ_EVERY: Duration = Duration::from_millis(17);

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// The isel ports at `t` (since the link came up) in the scenario.
fn ports(t: Duration) -> [(InputPort, u8); 4] {
    let within = |from: u64, to: u64| t >= ms(from) && t < ms(to);
    let mut estop = 0b11u8;
    if within(4500, 5200) {
        estop &= !0b01;
    }
    if within(4530, 5200) {
        estop &= !0b10;
    }
    let limits = u8::from(within(1000, 2000));
    // Ten flips, one every 40 ms, from 3 s on.
    let flips = if t >= ms(3000) {
        ((t - ms(3000)).as_millis() / 40 + 1).min(10)
    } else {
        0
    };
    let user = if flips % 2 == 1 { 0b1000 } else { 0 };
    [
        (InputPort::Status1, estop),
        (InputPort::LimitSwitches, limits),
        (InputPort::Status2, 0x62),
        (InputPort::User, user),
    ]
}

/// A model of the isel console in `theme` after six seconds of port
/// readings, with the timeline shown.
fn scenario(theme: &str) -> Model {
    let t0 = Instant::now();
    let mut model = fresh(Protocol::Isel, theme, t0);
    send(&mut model, [Event::Link(LinkState::Connected)]);
    let profile = load_profile("isel", &ConfigDirs::builtin_only()).expect("profile");
    let mut recorder = InputRecorder::new(RecorderConfig::from_profile(&profile));
    let wiring = profile.wiring().expect("the shipped wiring");
    recorder.connected(t0);
    let mut t = ms(200);
    while t <= ms(6000) {
        let at = t0 + t;
        let groups = ports(t)
            .into_iter()
            .map(|(port, value)| {
                let mut g = input_group(port, value, &wiring);
                g.read = Some(InputRead {
                    source: InputSource::IselPort(port.number()),
                    at,
                });
                g
            })
            .collect();
        let snapshot = IoSnapshot { at, groups };
        let changes = recorder.observe(&snapshot);
        send(&mut model, [Event::Io(snapshot)]);
        send(&mut model, changes.into_iter().map(Event::Input));
        t += READ_EVERY;
    }
    update(&mut model, Msg::Tick(t0 + ms(6000)));
    key(&mut model, KeyCode::Char('w'));
    assert_eq!(model.focus, PanelId::Timeline);
    model
}

fn key(model: &mut Model, code: KeyCode) {
    update(model, Msg::Key(KeyEvent::new(code, KeyModifiers::NONE)));
}

fn buffer(model: &Model, w: u16, h: u16) -> Buffer {
    render(model, w, h).backend().buffer().clone()
}

#[test]
fn timeline_screens() {
    for theme in THEMES {
        let model = scenario(theme);
        for (w, h) in SIZES {
            let terminal = render(&model, w, h);
            insta::assert_snapshot!(format!("timeline_{w}x{h}_{theme}"), terminal.backend());
        }
    }
}

#[test]
fn held_back_in_time_zoomed_in() {
    let mut model = scenario("dark");
    // Back a quarter screen at a time, then finer columns: the E-stop
    // skew fills three columns at 10 ms a column.
    key(&mut model, KeyCode::Left);
    for _ in 0..4 {
        key(&mut model, KeyCode::Char('-'));
    }
    key(&mut model, KeyCode::Char('+'));
    for _ in 0..2 {
        key(&mut model, KeyCode::Char('+'));
    }
    let terminal = render(&model, 80, 24);
    insta::assert_snapshot!("timeline_80x24_dark_held", terminal.backend());
    key(&mut model, KeyCode::End);
    assert_eq!(model.timeline.end, None, "End follows the readings again");
}

#[test]
fn the_lanes_carry_their_meaning_in_every_theme() {
    for theme in THEMES {
        let model = scenario(theme);
        let p = &model.palette;
        let s = &p.symbols;
        for (w, h) in SIZES {
            let buf = buffer(&model, w, h);
            // Both circuits closed again: the E-stop lanes end high.
            let (x, y) = find(&buf, "E-stop circuit 1")[0];
            // The newest column (none is drawn after now).
            let last = (0..buf.area.width)
                .rev()
                .find(|cx| buf[(*cx, y)].symbol() != " ")
                .expect("a drawn lane");
            assert_eq!(buf[(last, y)].symbol(), s.high, "{theme} {w}x{h}");
            assert!(
                buf[(last, y)]
                    .style()
                    .add_modifier
                    .contains(p.lit.add_modifier),
                "{theme}: a high level is drawn lit"
            );
            // The second circuit's lane shows the skew in the danger style.
            let (_, y2) = find(&buf, "E-stop circuit 2")[0];
            let danger = (x..buf.area.width).any(|cx| {
                let cell = &buf[(cx, y2)];
                cell.style().add_modifier.contains(p.danger.add_modifier)
                    && cell.fg == p.danger.fg.unwrap_or(cell.fg)
            });
            assert!(danger, "{theme} {w}x{h}: no skew marked");
            // The chattering input's label says so without colour alone.
            let (ux, uy) = find(&buf, "user input 3")[0];
            assert!(
                buf[(ux, uy)]
                    .style()
                    .add_modifier
                    .contains(p.warning.add_modifier),
                "{theme}: the chattering lane is marked"
            );
            let screen = ui_support::text(&buf);
            assert!(screen.contains("E-STOP SKEW"), "{theme} {w}x{h}:\n{screen}");
            assert!(screen.contains("CHATTER"), "{theme} {w}x{h}:\n{screen}");
        }
    }
}

#[test]
fn w_opens_and_closes_it_and_the_help_lists_its_keys() {
    let mut model = scenario("dark");
    key(&mut model, KeyCode::Char('w'));
    assert_eq!(model.focus, PanelId::Jog, "back where it was opened");
    key(&mut model, KeyCode::F(7));
    assert_eq!(model.focus, PanelId::Timeline);
    // Space stops from here as from anywhere.
    let effects = update(
        &mut model,
        Msg::Key(KeyEvent::new(KeyCode::Char(' '), KeyModifiers::NONE)),
    );
    assert_eq!(effects, [jogterm::ui::Effect::Stop]);
    let help = jogterm::ui::help::help_lines(&model.keymap, &model.setup.macros);
    for action in [Action::Timeline, Action::TimeEarlier, Action::ZoomIn] {
        assert!(
            help.iter().any(|l| matches!(
                l,
                jogterm::ui::help::HelpLine::Entry { description, .. }
                    if *description == action.description()
            )),
            "{action:?} is not in the help"
        );
    }
}
