//! A long file's blocks read on a second thread, ahead of the interpreter:
//! the reader thread fills chunks of a few thousand blocks, the
//! interpreter's thread runs them as they come. On two cores the read and
//! the interpretation of a long file overlap: a 16 MB CAM file takes about
//! the interpretation's time alone (`cargo bench --bench gcode`, issue 41
//! item 7).
//!
//! The blocks, their order, line numbers and errors are exactly those of
//! one reader ([`reader::blocks`]): the same reader makes them, on another
//! thread. At most [`CHUNKS_AHEAD`] chunks wait, so memory does not grow
//! with the file; the chunks and the blocks run go back to the reader to
//! be filled again. A scoped thread is no I/O and no runtime; it ends
//! before [`crate::interpret`] returns.

use std::sync::mpsc;

use crate::reader::{self, Block, Blocks};
use crate::toolpath::Diagnostic;

/// Files shorter than this are read on the interpreter's thread: most
/// files are short, and a thread's start (tens of microseconds) would cost
/// them more than it saves.
pub const SPLIT_MIN_BYTES: usize = 1 << 20;

/// Blocks a chunk holds: a few hundred kilobytes, handed over a few
/// hundred times in a CAM file of half a million lines.
pub const CHUNK_BLOCKS: usize = 4096;

/// Chunks read and not yet run, at most.
pub const CHUNKS_AHEAD: usize = 4;

/// Where the interpreter takes its blocks from, one at a time: what
/// [`Blocks`] gives, and a block done with given back for its memory.
pub trait Source: Iterator<Item = Result<Block, Diagnostic>> {
    fn recycle(&mut self, block: Block);
    /// Lines in the file, once the source is through.
    fn lines(&self) -> u32;
}

impl Source for Blocks<'_> {
    fn recycle(&mut self, block: Block) {
        Blocks::recycle(self, block);
    }

    fn lines(&self) -> u32 {
        Blocks::lines(self)
    }
}

/// Blocks read, handed over, and the blocks run given back for their
/// memory: a block's words are read into the vector of a block run before
/// (no copy of the words, no allocation a line).
#[derive(Debug, Default)]
struct Chunk {
    /// In reverse: the interpreter's side takes them from the end.
    items: Vec<Result<Block, Diagnostic>>,
    /// Blocks run, going back to the reader.
    spares: Vec<Block>,
    /// The file's lines, in the last chunk.
    lines: Option<u32>,
}

/// The reader thread: fills chunks until the file is through or the
/// interpreter's side is gone.
fn read_ahead(
    mut blocks: Blocks<'_>,
    chunk_blocks: usize,
    full: &mpsc::SyncSender<Chunk>,
    empty: &mpsc::Receiver<Chunk>,
) {
    let mut spares = Vec::new();
    loop {
        let mut chunk = empty.try_recv().unwrap_or_default();
        spares.append(&mut chunk.spares);
        chunk.items.clear();
        chunk.lines = None;
        while chunk.items.len() < chunk_blocks.max(1) {
            if let Some(spare) = spares.pop() {
                blocks.recycle(spare);
            }
            match blocks.next() {
                Some(item) => chunk.items.push(item),
                None => {
                    chunk.items.reverse();
                    chunk.lines = Some(blocks.lines());
                    // Nobody to take it: the interpreter has returned.
                    let _ = full.send(chunk);
                    return;
                }
            }
        }
        chunk.items.reverse();
        if full.send(chunk).is_err() {
            return;
        }
    }
}

/// The interpreter's side: the chunks' blocks in order.
struct Ahead {
    full: mpsc::Receiver<Chunk>,
    empty: mpsc::Sender<Chunk>,
    chunk: Chunk,
    lines: Option<u32>,
}

impl Ahead {
    /// The next chunk, the one run given back; `false` at the end.
    fn next_chunk(&mut self) -> bool {
        if self.lines.is_some() {
            return false;
        }
        if let Some(lines) = self.chunk.lines {
            self.lines = Some(lines);
            return false;
        }
        let Ok(next) = self.full.recv() else {
            // The reader thread ended without its last chunk: it panicked,
            // and the scope carries that panic on.
            return false;
        };
        let done = std::mem::replace(&mut self.chunk, next);
        // The reader has ended once the last chunk is sent: nobody then.
        let _ = self.empty.send(done);
        true
    }
}

impl Iterator for Ahead {
    type Item = Result<Block, Diagnostic>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(item) = self.chunk.items.pop() {
                return Some(item);
            }
            if !self.next_chunk() {
                return None;
            }
        }
    }
}

impl Source for Ahead {
    fn recycle(&mut self, block: Block) {
        self.chunk.spares.push(block);
    }

    fn lines(&self) -> u32 {
        self.lines.unwrap_or_default()
    }
}

/// Runs `f` on the blocks of `text`: for a text of [`SPLIT_MIN_BYTES`] or
/// more, read ahead on a second thread, else on this one.
pub fn with_blocks<R>(text: &str, f: impl FnOnce(&mut dyn Source) -> R) -> R {
    if text.len() < SPLIT_MIN_BYTES {
        return f(&mut reader::blocks(text));
    }
    with_blocks_ahead(text, CHUNK_BLOCKS, f)
}

/// [`with_blocks`] always read ahead, in chunks of `chunk_blocks`; the
/// tests read short texts so.
pub fn with_blocks_ahead<R>(
    text: &str,
    chunk_blocks: usize,
    f: impl FnOnce(&mut dyn Source) -> R,
) -> R {
    std::thread::scope(|scope| {
        let (full_sender, full) = mpsc::sync_channel(CHUNKS_AHEAD);
        let (empty, empty_receiver) = mpsc::channel();
        let blocks = reader::blocks(text);
        let reading = std::thread::Builder::new()
            .name("gcode-read-ahead".into())
            .spawn_scoped(scope, move || {
                read_ahead(blocks, chunk_blocks, &full_sender, &empty_receiver);
            });
        if reading.is_err() {
            // A thread the system would not start (its limit reached):
            // read on this one, as a short file is.
            return f(&mut reader::blocks(text));
        }
        // Dropped before the scope waits for the reader, so that a reader
        // blocked on a full channel sees the interpreter gone and ends.
        let mut ahead = Ahead {
            full,
            empty,
            chunk: Chunk::default(),
            lines: None,
        };
        f(&mut ahead)
    })
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::interp::interpret_ahead;
    use crate::reader::Read;
    use crate::setup::{Setup, Units};

    fn setup() -> Setup {
        Setup {
            default_units: Some(Units::Mm),
            ..Setup::default()
        }
    }

    /// What a source gives, collected as [`reader::read`] collects it.
    fn collect(source: &mut dyn Source) -> Read {
        let mut read = Read::default();
        while let Some(item) = source.next() {
            match item {
                Ok(block) => {
                    read.blocks.push(block.clone());
                    source.recycle(block);
                }
                Err(e) => read.errors.push(e),
            }
        }
        read.lines = source.lines();
        read
    }

    /// Lines of the kinds a file holds: moves, arcs, comments, blank and
    /// tape-marker lines, block delete, lines the reader refuses, the end
    /// of the program, CR LF line ends.
    fn line() -> impl Strategy<Value = String> {
        prop_oneof![
            (-50.0..50.0f64, -50.0..50.0f64).prop_map(|(x, y)| format!("G1 X{x:.3} Y{y:.3} F500")),
            (-5.0..5.0f64).prop_map(|z| format!("G0 Z{z:.2}")),
            Just("G2 X10 Y0 I5 J0 F300".to_owned()),
            Just("(a comment (nested)) G1 X1".to_owned()),
            Just("; only a comment".to_owned()),
            Just(String::new()),
            Just("%".to_owned()),
            Just("/G1 X2".to_owned()),
            Just("G1 X#1".to_owned()),
            Just("G1 X(unclosed".to_owned()),
            Just("M30".to_owned()),
            Just("G21 G90 G17\r".to_owned()),
            Just("ü G1".to_owned()),
        ]
    }

    fn file() -> impl Strategy<Value = String> {
        (
            any::<bool>(),
            proptest::collection::vec(line(), 0..40),
            any::<bool>(),
        )
            .prop_map(|(bom, lines, final_newline)| {
                let mut text = if bom {
                    "\u{feff}".to_owned()
                } else {
                    String::new()
                };
                text.push_str(&lines.join("\n"));
                if final_newline {
                    text.push('\n');
                }
                text
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]

        /// Read ahead in chunks of any size, the blocks are what one
        /// thread reads: the same blocks, errors and number of lines.
        #[test]
        fn read_ahead_reads_as_one_reader(text in file(), chunk in 1..12usize) {
            let ahead = with_blocks_ahead(&text, chunk, collect);
            prop_assert_eq!(ahead, reader::read(&text));
        }

        /// And the interpreter makes the same toolpath or the same errors
        /// from them.
        #[test]
        fn read_ahead_interprets_as_one_reader(text in file(), chunk in 1..12usize) {
            prop_assert_eq!(
                interpret_ahead(&text, &setup(), chunk),
                crate::interpret(&text, &setup())
            );
        }
    }

    /// A file long enough to be read ahead reads as one reader reads it,
    /// and interprets as when read in other chunks.
    #[test]
    fn a_long_file_read_ahead_is_read_as_by_one_reader() {
        let mut text = String::from("\u{feff}G21 G90\n");
        let mut k = 0u32;
        while text.len() < SPLIT_MIN_BYTES + 1000 {
            text.push_str(&format!("G1 X{}.5 Y-{} (move {k})\n", k % 97, k % 89));
            k += 1;
        }
        text.push_str("G1 X#2\nM30\n");
        let read = with_blocks(&text, collect);
        let one = reader::read(&text);
        assert_eq!(read, one);
        assert_eq!(read.errors.len(), 1);
        assert_eq!(read.errors[0].origin.line, one.lines - 1);
        assert_eq!(
            crate::interpret(&text, &setup()),
            interpret_ahead(&text, &setup(), 7)
        );
    }
}
