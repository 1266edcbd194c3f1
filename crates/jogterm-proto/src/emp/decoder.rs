//! Streaming decoder: bytes in any split, frames out.
//!
//! A frame is exactly the characters between two EOFs (or between the start of
//! the stream and the first EOF). Anything else up to the next EOF is dropped
//! and reported, which resynchronises the stream on the next EOF: the manual
//! ends every string with EOF ("Ein EOF Zeichen bildet den Abschluss von jedem
//! Sende- und Empfangs Kommandostring"), so no valid frame can start anywhere
//! but right after one.

use super::error::{FrameError, FrameFault, MAX_REPORTED_BYTES};
use super::frame::{EOF, FRAME_HEX_LEN, Frame, check_hex_run};
use super::ident::{IDENT_PREFIX, IdentText};

/// One complete message off the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Incoming {
    Frame(Frame),
    /// The text answer to `00` (see [`IdentText`]).
    Identity(IdentText),
}

impl Incoming {
    pub fn encode(&self) -> [u8; super::FRAME_WIRE_LEN] {
        match self {
            Incoming::Frame(f) => f.encode(),
            Incoming::Identity(t) => t.encode(),
        }
    }
}

impl std::fmt::Display for Incoming {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Incoming::Frame(frame) => frame.fmt(f),
            Incoming::Identity(text) => text.fmt(f),
        }
    }
}

/// Incremental decoder with a bounded buffer (at most [`MAX_REPORTED_BYTES`]).
#[derive(Debug, Clone, Default)]
pub struct FrameDecoder {
    run: Vec<u8>,
    /// The current run already overflowed and was reported: drop everything up
    /// to the next EOF, whatever it looks like.
    overflowed: bool,
}

impl FrameDecoder {
    pub fn new() -> FrameDecoder {
        FrameDecoder::default()
    }

    /// Take one byte. Returns a message or a framing report when the byte
    /// completes one, `None` while more bytes are needed.
    pub fn push(&mut self, byte: u8) -> Option<Result<Incoming, FrameError>> {
        if byte == EOF {
            let result = self.finish_run();
            self.run.clear();
            self.overflowed = false;
            return Some(result);
        }
        if self.run.len() < MAX_REPORTED_BYTES {
            self.run.push(byte);
            return None;
        }
        // The run cannot be a frame any more. Report what we hold, so memory
        // stays bounded and the operator sees the garbage without waiting for
        // an EOF that may never come, and keep dropping up to the next EOF.
        let report = FrameError::new(
            FrameFault::NoEof {
                chars: self.run.len(),
            },
            &self.run,
        );
        self.run.clear();
        self.run.push(byte);
        self.overflowed = true;
        Some(Err(report))
    }

    /// Take a chunk of bytes; every message and report it completes, in order.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Result<Incoming, FrameError>> {
        bytes.iter().filter_map(|&b| self.push(b)).collect()
    }

    /// Bytes of an unfinished run, waiting for their EOF.
    pub fn pending(&self) -> &[u8] {
        &self.run
    }

    /// Drop an unfinished run (after a reply timeout or when the link is
    /// reopened), reporting it if there was one.
    pub fn reset(&mut self) -> Option<FrameError> {
        let report = (!self.run.is_empty()).then(|| {
            FrameError::new(
                FrameFault::NoEof {
                    chars: self.run.len(),
                },
                &self.run,
            )
        });
        self.run.clear();
        self.overflowed = false;
        report
    }

    fn finish_run(&self) -> Result<Incoming, FrameError> {
        let mut dropped = self.run.clone();
        dropped.push(EOF);
        if self.overflowed {
            return Err(FrameError::new(
                FrameFault::LongRunEnd {
                    chars: self.run.len(),
                },
                &dropped,
            ));
        }
        if self.run.len() == FRAME_HEX_LEN
            && self.run.starts_with(IDENT_PREFIX)
            && let Ok(text) = IdentText::new(&self.run)
        {
            return Ok(Incoming::Identity(text));
        }
        match check_hex_run(&self.run) {
            Ok(()) => Frame::from_hex(&self.run).map(Incoming::Frame),
            Err(e) => Err(FrameError::new(e.fault, &dropped)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(results: &[Result<Incoming, FrameError>]) -> Vec<String> {
        results
            .iter()
            .map(|r| match r {
                Ok(m) => m.to_string(),
                Err(e) => format!("ERR {:?}", e.fault),
            })
            .collect()
    }

    #[test]
    fn decodes_back_to_back_frames_and_identity_text() {
        let mut d = FrameDecoder::new();
        let out = d.feed(b"2D11002200000064\x1aDRS-500-EC_V08.2\x1a0311002200000000\x1a");
        assert_eq!(
            frames(&out),
            ["2D11002200000064", "DRS-500-EC_V08.2", "0311002200000000"]
        );
        assert!(d.pending().is_empty());
    }

    #[test]
    fn lower_case_wrong_lengths_and_non_hex_are_dropped_with_their_bytes() {
        let mut d = FrameDecoder::new();
        let out = d.feed(b"2d11002200000064\x1a");
        let e = out[0].as_ref().unwrap_err();
        assert_eq!(e.fault, FrameFault::LowerCase { at: 1 });
        assert_eq!(e.bytes, b"2d11002200000064\x1a");

        let out = d.feed(b"2D1100220000006\x1a2D110022000000640\x1a");
        assert_eq!(
            frames(&out),
            [
                "ERR WrongLength { chars: 15 }",
                "ERR WrongLength { chars: 17 }"
            ]
        );

        let out = d.feed(b"2D11002200\r\n0064\x1a");
        assert_eq!(
            out[0].as_ref().unwrap_err().fault,
            FrameFault::NotHex {
                at: 10,
                byte: b'\r'
            }
        );
    }

    #[test]
    fn eof_in_the_middle_of_a_frame_drops_both_halves() {
        let mut d = FrameDecoder::new();
        let out = d.feed(b"2D110022\x1a00000064\x1a2D11002200000064\x1a");
        assert_eq!(
            frames(&out),
            [
                "ERR WrongLength { chars: 8 }",
                "ERR WrongLength { chars: 8 }",
                "2D11002200000064"
            ]
        );
    }

    #[test]
    fn a_text_that_is_not_the_identity_form_is_garbage() {
        let mut d = FrameDecoder::new();
        let out = d.feed(b"DRS-500-EC_V08.\x1aDRS-500-EC\x07V08.2\x1a");
        // Character faults are named before the length: `R` is no hex digit.
        assert_eq!(
            frames(&out),
            [
                "ERR NotHex { at: 1, byte: 82 }",
                "ERR NotHex { at: 1, byte: 82 }"
            ]
        );
    }

    #[test]
    fn an_endless_run_is_reported_in_bounded_pieces_until_the_next_eof() {
        let mut d = FrameDecoder::new();
        let mut garbage = vec![b'0'; 150];
        garbage.extend_from_slice(b"2D11002200000064\x1a2D11002200000064\x1a");
        let out = d.feed(&garbage);
        assert_eq!(
            frames(&out),
            [
                "ERR NoEof { chars: 64 }",
                "ERR NoEof { chars: 64 }",
                // 22 zeros and the frame's 16 characters: the first frame is
                // swallowed because nothing separated it from the garbage.
                "ERR LongRunEnd { chars: 38 }",
                "2D11002200000064"
            ]
        );
        for r in &out {
            if let Err(e) = r {
                assert!(e.bytes.len() <= MAX_REPORTED_BYTES + 1);
            }
        }
    }

    #[test]
    fn a_lone_eof_is_reported_as_an_empty_frame() {
        let mut d = FrameDecoder::new();
        let out = d.feed(b"\x1a");
        assert_eq!(frames(&out), ["ERR WrongLength { chars: 0 }"]);
    }

    #[test]
    fn reset_reports_and_drops_a_partial_run() {
        let mut d = FrameDecoder::new();
        assert!(d.feed(b"2D1100").is_empty());
        assert_eq!(d.pending(), b"2D1100");
        let e = d.reset().unwrap();
        assert_eq!(e.fault, FrameFault::NoEof { chars: 6 });
        assert!(d.reset().is_none());
        let out = d.feed(b"2D11002200000064\x1a");
        assert_eq!(frames(&out), ["2D11002200000064"]);
    }
}
