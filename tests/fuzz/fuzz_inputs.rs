//! Inputs for the proptest fuzz suites: the cargo-fuzz seed corpus
//! (`fuzz/seeds/<target>/`) mutated the way a fuzzer mutates it, sequences of
//! the target's dictionary tokens (`fuzz/dict/<target>.dict`), and plain
//! random bytes. Both engines start from the same seeds and tokens.
//!
//! Cases per suite: `JOGTERM_FUZZ_CASES` (`.ci/run` sets a large count),
//! else [`DEFAULT_CASES`], few enough for a quick `cargo test`.
use std::path::PathBuf;

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::Config;

/// Cases per property when `JOGTERM_FUZZ_CASES` is not set.
pub const DEFAULT_CASES: u32 = 256;

/// Longest input generated; the cargo-fuzz runs use `-max_len=4096`.
pub const MAX_LEN: usize = 4096;

pub fn config() -> Config {
    let cases = std::env::var("JOGTERM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(DEFAULT_CASES);
    Config {
        cases,
        // Shrinking a failure of a big input can take long; the failure is
        // reported with its input either way.
        max_shrink_iters: 2048,
        ..Config::default()
    }
}

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

/// The seed files of a target, in name order.
pub fn seeds(target: &str) -> Vec<Vec<u8>> {
    let dir = fuzz_dir().join("seeds").join(target);
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    paths.sort();
    let seeds: Vec<Vec<u8>> = paths.iter().filter_map(|p| std::fs::read(p).ok()).collect();
    assert!(!seeds.is_empty(), "no seeds in {}", dir.display());
    seeds
}

/// The tokens of a libFuzzer dictionary: one `"..."` per line (optionally
/// `name="..."`), with `\\`, `\"` and `\xNN` escapes; `#` comments.
pub fn dictionary(target: &str) -> Vec<Vec<u8>> {
    let path = fuzz_dir().join("dict").join(format!("{target}.dict"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let tokens: Vec<Vec<u8>> = text.lines().filter_map(dictionary_token).collect();
    assert!(!tokens.is_empty(), "no tokens in {}", path.display());
    tokens
}

fn dictionary_token(line: &str) -> Option<Vec<u8>> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return None;
    }
    let start = line.find('"')? + 1;
    let body = line.get(start..line.len().checked_sub(1)?)?;
    let mut out = Vec::new();
    let mut bytes = body.bytes();
    while let Some(b) = bytes.next() {
        if b != b'\\' {
            out.push(b);
            continue;
        }
        match bytes.next()? {
            b'x' => {
                let hi = char::from(bytes.next()?).to_digit(16)?;
                let lo = char::from(bytes.next()?).to_digit(16)?;
                out.push((hi * 16 + lo) as u8);
            }
            other => out.push(other),
        }
    }
    Some(out)
}

/// One edit of the kinds libFuzzer's mutator makes.
#[derive(Debug, Clone)]
enum Edit {
    Insert {
        at: usize,
        byte: u8,
    },
    Delete {
        at: usize,
        len: usize,
    },
    Replace {
        at: usize,
        byte: u8,
    },
    FlipBit {
        at: usize,
        bit: u8,
    },
    InsertToken {
        at: usize,
        token: usize,
    },
    Duplicate {
        at: usize,
        len: usize,
        to: usize,
    },
    Splice {
        at: usize,
        seed: usize,
        from: usize,
        len: usize,
    },
}

fn edit() -> impl Strategy<Value = Edit> {
    let at = any::<usize>();
    prop_oneof![
        (at, any::<u8>()).prop_map(|(at, byte)| Edit::Insert { at, byte }),
        (at, 1usize..16).prop_map(|(at, len)| Edit::Delete { at, len }),
        (at, any::<u8>()).prop_map(|(at, byte)| Edit::Replace { at, byte }),
        (at, 0u8..8).prop_map(|(at, bit)| Edit::FlipBit { at, bit }),
        (at, any::<usize>()).prop_map(|(at, token)| Edit::InsertToken { at, token }),
        (at, 1usize..32, any::<usize>()).prop_map(|(at, len, to)| Edit::Duplicate { at, len, to }),
        (at, any::<usize>(), any::<usize>(), 1usize..64).prop_map(|(at, seed, from, len)| {
            Edit::Splice {
                at,
                seed,
                from,
                len,
            }
        }),
    ]
}

fn apply(mut data: Vec<u8>, edits: &[Edit], seeds: &[Vec<u8>], tokens: &[Vec<u8>]) -> Vec<u8> {
    // The first byte picks the target's variant; edits keep it unless they
    // replace it on purpose (at 0), so most inputs stay on their seed's path.
    for e in edits {
        let len = data.len();
        let pos = |at: usize| if len == 0 { 0 } else { at % (len + 1) };
        match *e {
            Edit::Insert { at, byte } => data.insert(pos(at), byte),
            Edit::Delete { at, len: n } if len > 0 => {
                let start = at % len;
                let end = (start + n).min(len);
                data.drain(start..end);
            }
            Edit::Replace { at, byte } if len > 0 => data[at % len] = byte,
            Edit::FlipBit { at, bit } if len > 0 => data[at % len] ^= 1 << bit,
            Edit::InsertToken { at, token } => {
                let t = &tokens[token % tokens.len()];
                let p = pos(at);
                data.splice(p..p, t.iter().copied());
            }
            Edit::Duplicate { at, len: n, to } if len > 0 => {
                let start = at % len;
                let piece = data[start..(start + n).min(len)].to_vec();
                let p = to % (len + 1);
                data.splice(p..p, piece);
            }
            Edit::Splice {
                at,
                seed,
                from,
                len: n,
            } => {
                let other = &seeds[seed % seeds.len()];
                if !other.is_empty() {
                    let start = from % other.len();
                    let piece = &other[start..(start + n).min(other.len())];
                    let p = pos(at);
                    data.splice(p..p, piece.iter().copied());
                }
            }
            _ => {}
        }
        data.truncate(MAX_LEN);
    }
    data
}

/// Inputs for `target`: mutated seeds (most), token sequences after a
/// variant byte, random bytes.
pub fn inputs(target: &str) -> impl Strategy<Value = Vec<u8>> {
    let seeds = seeds(target);
    let tokens = dictionary(target);
    let mutated = {
        let (seeds, tokens) = (seeds.clone(), tokens.clone());
        (0..seeds.len(), vec(edit(), 0..12))
            .prop_map(move |(i, edits)| apply(seeds[i].clone(), &edits, &seeds, &tokens))
    };
    let sequences = {
        let tokens = tokens.clone();
        (any::<u8>(), vec(0..tokens.len(), 0..48)).prop_map(move |(head, picks)| {
            let mut out = vec![head];
            for i in picks {
                out.extend_from_slice(&tokens[i]);
            }
            out.truncate(MAX_LEN);
            out
        })
    };
    prop_oneof![
        6 => mutated,
        3 => sequences,
        1 => vec(any::<u8>(), 0..512),
    ]
}
