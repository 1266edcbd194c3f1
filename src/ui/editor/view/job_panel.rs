//! The job panel beside the editor (issue 40): what the import of the open
//! G-code job found (`job_report`), kept on screen while the job is open.
//! Lines wrap to the panel's width; what does not fit ends in a line that
//! says how much more there is.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Widget, Wrap};

use crate::ui::editor::Context;
use crate::ui::editor::gcode_open::OpenJob;
use crate::ui::editor::job_report::Tone;
use crate::ui::view::flow::wrapped_rows;
use crate::ui::view::frame;

pub struct JobPanelView<'a> {
    pub job: &'a OpenJob,
    pub context: &'a Context<'a>,
}

impl Widget for JobPanelView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let p = self.context.palette;
        let name = crate::ui::editor::gcode_open::header_name(&self.job.path);
        let extra = if self.job.checking {
            vec![Span::styled("checking… ", p.dim)]
        } else {
            Vec::new()
        };
        let framed = frame::panel(&format!("Job {name}"), extra, false, p, area, buf);
        if framed.height == 0 || framed.width < 5 {
            return;
        }
        // One blank column apart from the program's comments beside it.
        let inner = Rect {
            x: framed.x + 1,
            width: framed.width - 1,
            ..framed
        };
        let width = usize::from(inner.width);
        let height = usize::from(inner.height);
        let all = self.job.report.lines();
        let mut shown = Vec::new();
        let mut used = 0;
        for (k, (tone, text)) in all.iter().enumerate() {
            let need = wrapped_rows(text, width);
            let left = all.len() - k;
            // Room for this line, and for the "more" line if others follow.
            let reserve = usize::from(left > 1);
            if used + need + reserve > height && !(left == 1 && used + need <= height) {
                shown.push(Line::from(Span::styled(
                    format!("… {left} more lines (jogterm import shows all)"),
                    p.dim,
                )));
                break;
            }
            used += need;
            let style = match tone {
                Tone::Text => p.text,
                Tone::Good => p.ok,
                Tone::Warning => p.warning,
                Tone::Danger => p.danger,
            };
            shown.push(Line::from(Span::styled(text.clone(), style)));
        }
        Paragraph::new(shown)
            .wrap(Wrap { trim: false })
            .render(inner, buf);
    }
}
