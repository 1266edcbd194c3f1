//! Each frame reaches the terminal as one synchronized update (DEC private
//! mode 2026): a terminal that knows the mode (kitty, WezTerm, foot,
//! iTerm2, Windows Terminal, tmux 3.4 on) shows the frame only once it is
//! complete, so that over SSH a large frame, written and read in pieces,
//! never shows half old and half new: a popup's title above the last
//! frame's lines. A terminal that does not know the mode ignores it.
//!
//! The update opens with the first write of a frame (a clear on resize, the
//! cells, the cursor) and closes with ratatui's flush, which ends every
//! frame. The markers go through their own handle of the backend's writer
//! (the console's: a second `Stdout`, which shares its one buffer), as the
//! backend lends its writer only behind an unstable feature.

use std::io::{self, Write};

use ratatui::backend::{Backend, ClearType, WindowSize};
use ratatui::buffer::Cell;
use ratatui::crossterm::queue;
use ratatui::crossterm::terminal::{BeginSynchronizedUpdate, EndSynchronizedUpdate};
use ratatui::layout::{Position, Size};

/// A backend whose frames are synchronized updates; `markers` writes into
/// the same stream as `inner`.
pub struct WholeFrames<B, M> {
    inner: B,
    markers: M,
    open: bool,
}

impl<B, M> WholeFrames<B, M> {
    pub fn new(inner: B, markers: M) -> Self {
        WholeFrames {
            inner,
            markers,
            open: false,
        }
    }
}

impl<B, M: Write> WholeFrames<B, M> {
    fn begin(&mut self) -> io::Result<()> {
        if !self.open {
            queue!(self.markers, BeginSynchronizedUpdate)?;
            self.open = true;
        }
        Ok(())
    }
}

impl<B: Backend<Error = io::Error>, M: Write> Backend for WholeFrames<B, M> {
    type Error = io::Error;

    fn draw<'a, I>(&mut self, content: I) -> io::Result<()>
    where
        I: Iterator<Item = (u16, u16, &'a Cell)>,
    {
        self.begin()?;
        self.inner.draw(content)
    }

    fn hide_cursor(&mut self) -> io::Result<()> {
        self.begin()?;
        self.inner.hide_cursor()
    }

    fn show_cursor(&mut self) -> io::Result<()> {
        self.begin()?;
        self.inner.show_cursor()
    }

    fn get_cursor_position(&mut self) -> io::Result<Position> {
        self.inner.get_cursor_position()
    }

    fn set_cursor_position<P: Into<Position>>(&mut self, position: P) -> io::Result<()> {
        self.begin()?;
        self.inner.set_cursor_position(position)
    }

    fn clear(&mut self) -> io::Result<()> {
        self.begin()?;
        self.inner.clear()
    }

    fn clear_region(&mut self, clear_type: ClearType) -> io::Result<()> {
        self.begin()?;
        self.inner.clear_region(clear_type)
    }

    fn size(&self) -> io::Result<Size> {
        self.inner.size()
    }

    fn window_size(&mut self) -> io::Result<WindowSize> {
        self.inner.window_size()
    }

    fn flush(&mut self) -> io::Result<()> {
        if self.open {
            self.open = false;
            queue!(self.markers, EndSynchronizedUpdate)?;
        }
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;
    use std::io::{self, Write};
    use std::rc::Rc;

    use ratatui::Terminal;
    use ratatui::backend::CrosstermBackend;
    use ratatui::widgets::Paragraph;

    use super::WholeFrames;

    /// One stream that the backend and the markers both write to.
    #[derive(Clone, Default)]
    struct Shared(Rc<RefCell<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.0.borrow_mut().extend_from_slice(buf);
            Ok(buf.len())
        }

        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    const BEGIN: &[u8] = b"\x1b[?2026h";
    const END: &[u8] = b"\x1b[?2026l";

    fn count(haystack: &[u8], needle: &[u8]) -> usize {
        haystack
            .windows(needle.len())
            .filter(|w| *w == needle)
            .count()
    }

    fn position(haystack: &[u8], needle: &[u8]) -> Option<usize> {
        haystack.windows(needle.len()).position(|w| w == needle)
    }

    #[test]
    fn every_frame_is_one_update_from_its_first_byte_to_its_last() {
        let stream = Shared::default();
        let backend = WholeFrames::new(CrosstermBackend::new(stream.clone()), stream.clone());
        let mut terminal = Terminal::with_options(
            backend,
            ratatui::TerminalOptions {
                viewport: ratatui::Viewport::Fixed(ratatui::layout::Rect::new(0, 0, 20, 2)),
            },
        )
        .expect("terminal");
        for text in ["first frame", "second frame", "second frame"] {
            terminal
                .draw(|f| f.render_widget(Paragraph::new(text), f.area()))
                .expect("draw");
        }
        let written = stream.0.borrow().clone();
        assert_eq!(count(&written, BEGIN), 3, "{written:?}");
        assert_eq!(count(&written, END), 3, "{written:?}");
        assert_eq!(
            position(&written, BEGIN),
            Some(0),
            "nothing before the first"
        );
        assert!(written.ends_with(END), "{written:?}");
        let first_end = position(&written, END).expect("an end");
        let text = position(&written, b"first").expect("the text");
        assert!(text < first_end, "the cells inside the update");
    }
}
