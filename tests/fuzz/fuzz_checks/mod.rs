//! The properties every fuzz input is checked against, one function per
//! target, each taking the raw input bytes. Two engines drive them: the
//! proptest suites `tests/fuzz/` (stable, in `cargo test` and CI) and the
//! cargo-fuzz targets in `fuzz/` (nightly, coverage-guided), which include
//! this directory by path. A property that fails panics with what it saw, so
//! a crash found by either engine is reproduced by calling the same function
//! with the same bytes (`docs/fuzzing.md`).
//!
//! What is checked everywhere: no panic; every decoder makes progress (at
//! most one event per byte it was fed, plus one per silence) so it cannot
//! loop; what it buffers is bounded by a constant of the protocol, so no input
//! grows its memory; decoding does not depend on how the bytes were split;
//! what decodes re-encodes to bytes that decode to the same value.
pub mod config;
pub mod emcu;
pub mod emp;
pub mod isel;
pub mod program;
pub mod sim;

/// Small deterministic generator for the choices a target makes from its
/// input (chunk lengths, when to call `silence`): the same input always
/// takes the same path, so every failure reproduces.
#[derive(Debug, Clone)]
pub struct Choices(u64);

impl Choices {
    pub fn new(seed: &[u8]) -> Choices {
        // FNV-1a over the input: different inputs take different splits.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for &b in seed {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        Choices(h | 1)
    }

    pub fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A value in `0..n` (`n` > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }

    /// True about once in `n` calls.
    pub fn one_in(&mut self, n: u64) -> bool {
        self.below(n) == 0
    }
}

/// `bytes` cut into pieces of 0 to 16 bytes (empty pieces too: a read may
/// return nothing new).
pub fn chunks<'a>(bytes: &'a [u8], choices: &mut Choices) -> Vec<&'a [u8]> {
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        let n = (choices.below(17) as usize).min(rest.len());
        let (head, tail) = rest.split_at(n);
        out.push(head);
        rest = tail;
    }
    out
}

/// Decoding does not depend on how the bytes were split: `decode` of `data`
/// fed byte by byte and in the pieces `choices` picks equals `decode` of it
/// all at once, which is returned.
pub fn split_independent<T: PartialEq + std::fmt::Debug>(
    data: &[u8],
    choices: &mut Choices,
    decode: impl Fn(&[&[u8]]) -> T,
) -> T {
    let whole = decode(&[data]);
    let single: Vec<&[u8]> = data.chunks(1).collect();
    assert_eq!(
        decode(&single),
        whole,
        "byte by byte differs from all at once"
    );
    let pieces = chunks(data, choices);
    assert_eq!(decode(&pieces), whole, "a split differs from all at once");
    whole
}

/// The first byte of an input picks a variant (expectation, language, file
/// kind); the rest is the payload.
pub fn split_head(data: &[u8]) -> (u8, &[u8]) {
    match data.split_first() {
        Some((&head, rest)) => (head, rest),
        None => (0, &[]),
    }
}
