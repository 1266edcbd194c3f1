//! The toolpath preview: the program's path in XY (and XZ) in the axes'
//! units, drawn in braille on a ratatui canvas with equal scales on both
//! axes (a circle stays round), the soft-limit box, the machine's position
//! (`+`), where the program will end (`o`), and the segments of the line
//! under the cursor highlighted (and marked `*`, for themes without
//! colour). The path is the linter's (`program::path`): it runs from where
//! the machine stands, with its work zero.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line as TextLine, Span};
use ratatui::widgets::Widget;
use ratatui::widgets::canvas::{Canvas, Context, Line, Rectangle};

use crate::axis::Axis;
use crate::program::{PathEnd, Segment, SegmentKind};
use crate::ui::editor::{Context as EditorContext, Editor, Planes};
use crate::ui::position::format_units;
use crate::ui::view::flow::fit;
use crate::ui::view::frame;

/// Rows a plane needs to be worth drawing.
const MIN_ROWS: u16 = 6;

pub struct PreviewView<'a> {
    pub editor: &'a Editor,
    pub context: &'a EditorContext<'a>,
}

fn colour(style: Style) -> Color {
    style.fg.unwrap_or(Color::Reset)
}

/// The planes to draw, each with its horizontal and vertical axis.
fn planes(view: &PreviewView, rows: u16) -> Vec<(Axis, Axis)> {
    let has = |a| view.context.setup.axis(a).is_some();
    let xy = has(Axis::X) && has(Axis::Y);
    let xz = has(Axis::X) && has(Axis::Z);
    let mut out = Vec::new();
    match view.editor.planes {
        Planes::Off => {}
        Planes::Both | Planes::Job => {
            if xy {
                out.push((Axis::X, Axis::Y));
            }
            if xz && (out.is_empty() || rows >= 2 * MIN_ROWS + 2) {
                out.push((Axis::X, Axis::Z));
            }
        }
        Planes::Xy if xy => out.push((Axis::X, Axis::Y)),
        Planes::Xz if xz => out.push((Axis::X, Axis::Z)),
        _ => {}
    }
    if out.is_empty() && has(Axis::X) {
        // A one-axis machine: X against nothing.
        out.push((Axis::X, Axis::X));
    }
    out
}

/// Steps of `axis` in its unit.
fn units(view: &PreviewView, axis: Axis, steps: f64) -> f64 {
    view.context
        .setup
        .axis(axis)
        .map_or(steps, |p| steps / p.steps_per_unit)
}

/// Visit the points along a segment in steps of X, Y, Z, A: the ends of a
/// line, enough points of an arc that it looks round. No allocation: the
/// preview visits every segment of the program every frame.
fn for_points(segment: &Segment, mut visit: impl FnMut([f64; 4])) {
    let from = segment.from.map(|v| v as f64);
    let to = segment.to.map(|v| v as f64);
    let arc = match &segment.kind {
        SegmentKind::Arc(arc) | SegmentKind::Helix { arc, .. } => arc,
        _ => {
            visit(from);
            visit(to);
            return;
        }
    };
    let (a1, a2) = arc.plane.axes();
    let n = ((arc.geometry.sweep.abs() / std::f64::consts::TAU) * 64.0)
        .ceil()
        .clamp(4.0, 64.0) as usize;
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (u, v) = arc.geometry.point_at(t);
        let mut p: [f64; 4] = std::array::from_fn(|k| {
            from.get(k).copied().unwrap_or(0.0)
                + (to.get(k).copied().unwrap_or(0.0) - from.get(k).copied().unwrap_or(0.0)) * t
        });
        if let Some(c) = p.get_mut(a1.index()) {
            *c = arc.centre.0 as f64 + u;
        }
        if let Some(c) = p.get_mut(a2.index()) {
            *c = arc.centre.1 as f64 + v;
        }
        visit(p);
    }
}

/// Visit the strokes of a segment in a plane: `(from, to)` pairs.
fn for_strokes(
    segment: &Segment,
    coord: &impl Fn(&[f64; 4]) -> (f64, f64),
    mut visit: impl FnMut((f64, f64), (f64, f64)),
) {
    let mut last: Option<(f64, f64)> = None;
    for_points(segment, |p| {
        let here = coord(&p);
        if let Some(before) = last {
            visit(before, here);
        }
        last = Some(here);
    });
}

/// Bounds with equal units per dot on both axes, everything in view.
fn bounds(extent: [(f64, f64); 2], width: u16, height: u16) -> ([f64; 2], [f64; 2]) {
    let dots = [
        f64::from(width.max(1)) * 2.0,
        f64::from(height.max(1)) * 4.0,
    ];
    let mut spans = [extent[0].1 - extent[0].0, extent[1].1 - extent[1].0];
    for s in &mut spans {
        if !(s.is_finite() && *s > 1e-9) {
            *s = 1.0;
        }
    }
    let per_dot = (spans[0] / dots[0]).max(spans[1] / dots[1]) * 1.08;
    let centre = [
        (extent[0].0 + extent[0].1) / 2.0,
        (extent[1].0 + extent[1].1) / 2.0,
    ];
    let half = [per_dot * dots[0] / 2.0, per_dot * dots[1] / 2.0];
    (
        [centre[0] - half[0], centre[0] + half[0]],
        [centre[1] - half[1], centre[1] + half[1]],
    )
}

impl Widget for PreviewView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let view = &self;
        let p = view.context.palette;
        let path = view.editor.checks.path.as_ref();
        let mut extra = Vec::new();
        if let Some(path) = path {
            let end: Vec<String> = view
                .context
                .setup
                .axes
                .iter()
                .map(|(a, prof)| {
                    let steps = path.end.get(a.index()).copied().unwrap_or(0);
                    format!("{a}{}", format_units(prof, steps))
                })
                .collect();
            extra.push(Span::styled(format!("ends {} ", end.join(" ")), p.dim));
            let note = match path.finish {
                PathEnd::Endless { line } => Some(format!("repeats from line {} ", line + 1)),
                PathEnd::Cut { line } => Some(format!("cut at line {} ", line + 1)),
                PathEnd::OutOfProgram { line } => Some(format!("jumps out at line {} ", line + 1)),
                PathEnd::TooDeep { line } => Some(format!("loops too deep at line {} ", line + 1)),
                PathEnd::End { .. } | PathEnd::Finished => None,
            };
            if let Some(note) = note {
                extra.push(Span::styled(note, p.warning));
            }
        }
        let inner = frame::panel("Toolpath", extra, false, p, area, buf);
        if inner.height == 0 || inner.width < 4 {
            return;
        }
        let Some(path) = path else {
            TextLine::from(Span::styled(
                fit("checking the program…", usize::from(inner.width)),
                p.dim,
            ))
            .render(inner, buf);
            return;
        };
        let shown = planes(view, inner.height);
        let count = shown.len().max(1) as u16;
        let each = inner.height / count;
        for (i, (h, v)) in shown.into_iter().enumerate() {
            let y = inner.y + i as u16 * each;
            let height = if i as u16 + 1 == count {
                inner.bottom() - y
            } else {
                each
            };
            plane(
                view,
                path,
                h,
                v,
                Rect::new(inner.x, y, inner.width, height),
                buf,
            );
        }
    }
}

fn plane(
    view: &PreviewView,
    path: &crate::program::Path,
    h: Axis,
    v: Axis,
    area: Rect,
    buf: &mut Buffer,
) {
    let p = view.context.palette;
    if area.height < 2 {
        return;
    }
    // The plane's name on its first row, the drawing below.
    let label = if h == v {
        format!("{h}")
    } else {
        format!("{h}{v}")
    };
    TextLine::from(Span::styled(label, p.title))
        .render(Rect::new(area.x, area.y, area.width, 1), buf);
    let area = Rect::new(area.x, area.y + 1, area.width, area.height - 1);
    let flat = h == v;
    let coord = |pt: &[f64; 4]| -> (f64, f64) {
        let x = units(view, h, pt.get(h.index()).copied().unwrap_or(0.0));
        let y = if flat {
            0.0
        } else {
            units(view, v, pt.get(v.index()).copied().unwrap_or(0.0))
        };
        (x, y)
    };
    let drawn = |s: &&Segment| !matches!(s.kind, SegmentKind::SimulatedReference(_));
    let cursor_line = view.editor.buffer.cursor().line;
    let start = coord(&path.start.map(|v| v as f64));
    let end = coord(&path.end.map(|v| v as f64));
    let limit = |axis: Axis| {
        view.context
            .setup
            .axis(axis)
            .map(|prof| (prof.min, prof.max))
    };
    let (hl, vl) = (limit(h), if flat { Some((0.0, 0.0)) } else { limit(v) });
    let mut lo = [start.0.min(end.0), start.1.min(end.1)];
    let mut hi = [start.0.max(end.0), start.1.max(end.1)];
    let mut take = |x: f64, y: f64| {
        if x.is_finite() && y.is_finite() {
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
    };
    for segment in path.segments.iter().filter(drawn) {
        for_points(segment, |p| {
            let (x, y) = coord(&p);
            take(x, y);
        });
    }
    if let (Some((h0, h1)), Some((v0, v1))) = (hl, vl) {
        take(h0, v0);
        take(h1, v1);
    }
    let (xb, yb) = bounds([(lo[0], hi[0]), (lo[1], hi[1])], area.width, area.height);
    let (path_c, dim_c, here_c, pos_c) = (
        colour(p.text),
        colour(p.dim),
        colour(p.warning),
        colour(p.ok),
    );
    let position: Option<(f64, f64)> = {
        let get = |a: Axis| view.context.positions.get(a).map(|r| r.steps as f64);
        match (get(h), if flat { Some(0.0) } else { get(v) }) {
            (Some(x), Some(y)) => Some((
                units(view, h, x),
                if flat { 0.0 } else { units(view, v, y) },
            )),
            _ => None,
        }
    };
    let canvas = Canvas::default()
        .marker(Marker::Braille)
        .x_bounds(xb)
        .y_bounds(yb)
        .paint(|ctx: &mut Context| {
            if let (Some((h0, h1)), Some((v0, v1))) = (hl, vl) {
                ctx.draw(&Rectangle {
                    x: h0,
                    y: v0,
                    width: h1 - h0,
                    height: v1 - v0,
                    color: dim_c,
                });
            }
            ctx.layer();
            for segment in path.segments.iter().filter(drawn) {
                if segment.line == cursor_line {
                    continue;
                }
                let c = if matches!(segment.kind, SegmentKind::Reference(_)) {
                    dim_c
                } else {
                    path_c
                };
                for_strokes(segment, &coord, |a, b| {
                    ctx.draw(&Line::new(a.0, a.1, b.0, b.1, c));
                });
            }
            ctx.layer();
            // The cursor's line on top, and marked for themes without colour.
            for segment in path
                .segments
                .iter()
                .filter(drawn)
                .filter(|s| s.line == cursor_line)
            {
                let mut last = None;
                for_strokes(segment, &coord, |a, b| {
                    ctx.draw(&Line::new(a.0, a.1, b.0, b.1, here_c));
                    last = Some(b);
                });
                if let Some(last) = last {
                    ctx.print(last.0, last.1, TextLine::styled("*", p.warning));
                }
            }
            ctx.print(end.0, end.1, TextLine::styled("o", p.text));
            if let Some((x, y)) = position {
                ctx.print(
                    x,
                    y,
                    TextLine::styled("+", Style::new().fg(pos_c).patch(p.ok)),
                );
            }
        });
    canvas.render(area, buf);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_keep_equal_scales_and_hold_everything() {
        // 40x10 cells = 80x40 dots: a square extent fills the height.
        let (x, y) = bounds([(0.0, 100.0), (0.0, 100.0)], 40, 10);
        let per_dot_x = (x[1] - x[0]) / 80.0;
        let per_dot_y = (y[1] - y[0]) / 40.0;
        assert!((per_dot_x - per_dot_y).abs() < 1e-9);
        assert!(x[0] <= 0.0 && x[1] >= 100.0 && y[0] <= 0.0 && y[1] >= 100.0);
        // A degenerate extent (one point) still gives a box around it.
        let (x, y) = bounds([(5.0, 5.0), (0.0, 0.0)], 10, 5);
        assert!(x[0] < 5.0 && x[1] > 5.0 && y[0] < 0.0 && y[1] > 0.0);
    }
}
