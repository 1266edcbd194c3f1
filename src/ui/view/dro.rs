//! The position panel (DRO): every axis of the machine in its units (work
//! position from the active work offset's zero, named in the title, machine
//! position from the reference point) and in steps; estimated positions
//! (isel while moving) marked with their own symbol and style; referenced
//! or not per axis (the jog step and speed are on the jog keypad). On isel,
//! the title says when stored programs count from another zero than the
//! active offset's (`ui::jog::offsets::programs_differ`). Columns are
//! dropped from the right when the panel is narrow.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::device::api::{LinkState, PositionSource};
use crate::ui::model::Model;
use crate::ui::position::{decimals, format_units};

use super::frame;

pub struct DroView<'a>(pub &'a Model);

/// Rows the panel needs: title, header, one per axis.
pub fn height(model: &Model) -> u16 {
    2 + model.setup.axes.len() as u16
}

/// Column widths reserved from the profile (soft limits, resolution), not
/// from the values on screen: the columns and the panel width then stay put
/// while an axis moves, so a frame only rewrites the digits that changed.
#[derive(Debug, Clone, Copy)]
struct Widths {
    work: usize,
    unit: usize,
    machine: usize,
    steps: usize,
    words: usize,
}

fn digits(n: f64) -> usize {
    let n = n.abs().floor();
    if n < 1.0 {
        1
    } else {
        n.log10().floor() as usize + 1
    }
}

fn widths(model: &Model) -> Widths {
    let mut w = Widths {
        work: 4,
        unit: 0,
        machine: 7,
        steps: 5,
        words: WORDS.iter().map(|s| s.len()).max().unwrap_or(0),
    };
    for (_, p) in &model.setup.axes {
        // Work positions reach (max - min) away from a zero set anywhere
        // within the limits; machine positions a little beyond them.
        let span = [p.min.abs(), p.max.abs(), p.max - p.min]
            .into_iter()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let dec = decimals(p);
        let units = 1 + digits(span) + if dec > 0 { dec + 1 } else { 0 };
        w.work = w.work.max(units);
        w.machine = w.machine.max(units);
        w.steps = w.steps.max(1 + digits(span * p.steps_per_unit));
        w.unit = w.unit.max(p.unit.symbol().chars().count());
    }
    w
}

const WORDS: [&str; 5] = [
    "last known",
    "not initialised",
    "not referenced",
    "referenced, estimated",
    "referenced",
];

/// Characters the work value of any axis may take (sign, digits, point,
/// decimals), from the profile: the large display sizes its digits by it.
pub fn work_chars(model: &Model) -> usize {
    widths(model).work
}

/// The position in one line, for the program screen: the active offset,
/// each axis with its marks and work value (columns from the profile, so
/// nothing shifts while an axis runs).
pub fn compact_line(model: &Model) -> Line<'static> {
    let p = &model.palette;
    let w = widths(model).work;
    let mut spans = vec![Span::styled(" Position ", p.title)];
    spans.extend(title_extra(model));
    for ((axis, r), (_, profile)) in readings(model).into_iter().zip(&model.setup.axes) {
        spans.push(Span::styled(format!(" {axis}"), p.title));
        spans.push(Span::styled(r.referenced.0, r.referenced.1));
        spans.push(Span::styled(r.source.0, r.source.1));
        spans.push(Span::styled(format!("{:>w$}", r.work), r.value_style));
        spans.push(Span::styled(format!(" {}", profile.unit.symbol()), p.dim));
    }
    Line::from(spans)
}

/// Columns wide: marks, work, unit, machine, steps, with one blank between.
pub fn width(model: &Model) -> u16 {
    let w = widths(model);
    (3 + w.work + 1 + w.unit + 1 + w.machine + 1 + w.steps) as u16
}

struct Row {
    cells: Vec<(String, Style)>,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Col {
    Marks,
    Work,
    Unit,
    Machine,
    Steps,
    Words,
}

/// The panel's title after its name: the active work offset (`G54!` when
/// its file was refused), `≈ estimated`, `programs ≠ G55`, and the tool in
/// the spindle with its length offset (`T2 +1.000`).
pub fn title_extra(model: &Model) -> Vec<Span<'static>> {
    let p = &model.palette;
    let sym = p.symbols;
    let any_estimated = model.setup.axes.iter().any(|(a, _)| {
        model
            .positions
            .get(*a)
            .is_some_and(|r| r.source == PositionSource::Estimated)
    });
    let offsets = &model.keypad.offsets;
    let name = offsets.table.active().name();
    let mut extra = vec![if offsets.refused {
        // The file was refused at start: `O` says why.
        Span::styled(format!("{name}! "), p.warning)
    } else {
        Span::styled(format!("{name} "), p.title)
    }];
    let differ =
        crate::ui::jog::offsets::programs_differ(&model.keypad.offsets, &model.jog_context());
    if any_estimated {
        extra.push(Span::styled(
            format!("{} estimated ", sym.estimated),
            p.estimated,
        ));
    }
    if !differ.is_empty() {
        let ne = if sym.lit.is_ascii() { "!=" } else { "≠" };
        extra.push(Span::styled(format!("programs {ne} {name} "), p.warning));
    }
    // Every Z of a job imported now carries the offset (`ui::tools`).
    if let Some((tool, offset)) = model.tools.table.active_tool() {
        extra.push(Span::styled(format!("{tool} {offset:+.3} "), p.title));
    }
    extra
}

/// One axis as every position display shows it: its marks (referenced,
/// measured or estimated) with their styles, the work, machine and step
/// values, and the state in words.
pub struct AxisReading {
    pub referenced: (&'static str, Style),
    pub source: (&'static str, Style),
    pub value_style: Style,
    pub other_style: Style,
    pub work: String,
    pub machine: String,
    pub steps: String,
    pub words: &'static str,
}

pub fn readings(model: &Model) -> Vec<(crate::axis::Axis, AxisReading)> {
    let p = &model.palette;
    let sym = p.symbols;
    let offsets = &model.keypad.offsets;
    let live = matches!(model.link, LinkState::Connected);
    let m = &model.machine;
    model
        .setup
        .axes
        .iter()
        .map(|(axis, profile)| {
            let reading = model.positions.get(*axis);
            let initialised = m.initialised.contains(*axis);
            let referenced = initialised && m.referenced.contains(*axis);
            let (ref_sym, ref_style) = if referenced {
                (sym.referenced, p.ok)
            } else {
                (sym.unreferenced, p.warning)
            };
            let estimated = reading.is_some_and(|r| r.source == PositionSource::Estimated);
            let (src_sym, value_style) = match (live, estimated) {
                (false, _) => (" ", p.dim),
                (true, true) => (sym.estimated, p.estimated),
                (true, false) => (sym.measured, p.measured),
            };
            let other_style = if live { p.text } else { p.dim };
            let zero = offsets.table.active_zero(*axis);
            let (work, machine, steps) = match reading {
                Some(r) => (
                    format_units(profile, r.steps.saturating_sub(zero)),
                    format_units(profile, r.steps),
                    r.steps.to_string(),
                ),
                None => ("-".into(), "-".into(), "-".into()),
            };
            let words = match (initialised, referenced, live, estimated) {
                (_, _, false, _) => "last known",
                (false, _, _, _) => "not initialised",
                (true, false, _, _) => "not referenced",
                (true, true, _, true) => "referenced, estimated",
                (true, true, _, false) => "referenced",
            };
            (
                *axis,
                AxisReading {
                    referenced: (ref_sym, ref_style),
                    source: (src_sym, value_style),
                    value_style,
                    other_style,
                    work,
                    machine,
                    steps,
                    words,
                },
            )
        })
        .collect()
}

impl Widget for DroView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let extra = title_extra(model);
        let inner = frame::panel("Position", extra, false, p, area, buf);
        if inner.height == 0 {
            return;
        }
        let rows: Vec<Row> = readings(model)
            .into_iter()
            .zip(&model.setup.axes)
            .map(|((axis, r), (_, profile))| Row {
                cells: vec![
                    (axis.to_string(), p.title),
                    (r.referenced.0.to_string(), r.referenced.1),
                    (r.source.0.to_string(), r.source.1),
                    (r.work, r.value_style),
                    (profile.unit.symbol().to_string(), p.dim),
                    (r.machine, r.other_style),
                    (r.steps, r.other_style),
                    (r.words.to_string(), p.dim),
                ],
            })
            .collect();
        let w = widths(model);
        let (work_w, unit_w, mach_w, steps_w) = (w.work, w.unit, w.machine, w.steps);
        let layouts: [&[Col]; 4] = [
            &[
                Col::Marks,
                Col::Work,
                Col::Unit,
                Col::Machine,
                Col::Steps,
                Col::Words,
            ],
            &[Col::Marks, Col::Work, Col::Unit, Col::Machine, Col::Steps],
            &[Col::Marks, Col::Work, Col::Unit, Col::Steps],
            &[Col::Marks, Col::Work, Col::Unit],
        ];
        let col_width = |c: Col| match c {
            Col::Marks => 3,
            Col::Work => work_w + 1,
            Col::Unit => unit_w,
            Col::Machine => mach_w + 1,
            Col::Steps => steps_w + 1,
            Col::Words => w.words + 2,
        };
        let cols = layouts
            .iter()
            .find(|cols| {
                cols.iter().map(|c| col_width(*c)).sum::<usize>() <= usize::from(inner.width)
            })
            .copied()
            .unwrap_or(&[Col::Marks, Col::Work]);
        let mut lines = Vec::new();
        let header: Vec<Span> = cols
            .iter()
            .map(|c| {
                let text = match c {
                    Col::Marks => "   ".to_string(),
                    Col::Work => format!("{:>work_w$} ", "work"),
                    Col::Unit => " ".repeat(unit_w),
                    Col::Machine => format!(" {:>mach_w$}", "machine"),
                    Col::Steps => format!(" {:>steps_w$}", "steps"),
                    Col::Words => String::new(),
                };
                Span::styled(text, p.dim)
            })
            .collect();
        lines.push(Line::from(header));
        for row in &rows {
            let cell = |i: usize| row.cells.get(i).cloned().unwrap_or_default();
            let mut spans = Vec::new();
            for c in cols {
                match c {
                    Col::Marks => {
                        for i in 0..3 {
                            let (t, s) = cell(i);
                            spans.push(Span::styled(t, s));
                        }
                    }
                    Col::Work => {
                        let (t, s) = cell(3);
                        spans.push(Span::styled(format!("{t:>work_w$}"), s));
                        spans.push(Span::raw(" "));
                    }
                    Col::Unit => {
                        let (t, s) = cell(4);
                        spans.push(Span::styled(format!("{t:<unit_w$}"), s));
                    }
                    Col::Machine => {
                        let (t, s) = cell(5);
                        spans.push(Span::styled(format!(" {t:>mach_w$}"), s));
                    }
                    Col::Steps => {
                        let (t, s) = cell(6);
                        spans.push(Span::styled(format!(" {t:>steps_w$}"), s));
                    }
                    Col::Words => {
                        let (t, s) = cell(7);
                        spans.push(Span::styled(format!("  {t}"), s));
                    }
                }
            }
            lines.push(Line::from(spans));
        }
        for (i, line) in lines.into_iter().enumerate() {
            let y = inner.y.saturating_add(i as u16);
            if y >= inner.bottom() {
                break;
            }
            line.render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile, load_theme};
    use crate::ui::keymap::Keymap;
    use crate::ui::palette::Palette;
    use crate::ui::setup::Setup;

    fn title(tool: Option<(String, f64)>) -> String {
        let dirs = ConfigDirs::builtin_only();
        let profile = load_profile("default", &dirs).expect("profile");
        let theme = load_theme("dark", &dirs).expect("theme");
        let setup = Setup::from_profile(&profile, None);
        let mut model = Model::new(
            setup,
            Keymap::builtin().expect("keys"),
            Palette::from(&theme),
            std::time::Instant::now(),
        );
        // The reference T1 at 30 mm, the tool in the spindle `tool`.
        if let Some((name, offset)) = tool {
            model.tools.table.measured("T1", 30.0);
            model.tools.table.measured(&name, 30.0 + offset);
        }
        title_extra(&model)
            .iter()
            .map(|s| s.content.to_string())
            .collect()
    }

    #[test]
    fn the_title_shows_the_tool_in_the_spindle_and_its_offset() {
        assert_eq!(title(Some(("T2".into(), 1.0))), "G54 T2 +1.000 ");
        assert_eq!(title(None), "G54 ");
    }
}
