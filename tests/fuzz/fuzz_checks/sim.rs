//! What a simulator receives: the bytes go through the shell's sans-IO
//! engine (wire timing, both directions) into the device model, with
//! operator controls in between, in synthetic time.

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use jogterm::config::{ConfigDirs, Profile, load_profile};
use jogterm::proto::Protocol;
use jogterm::sim::InputControl;
use jogterm::sim::engine::Engine;
use jogterm::sim::registry;

use super::{Choices, chunks, split_head};

/// The shipped profile of each family, loaded once (parsing TOML for every
/// input would be most of the work).
pub fn profile(protocol: Protocol) -> &'static Profile {
    static PROFILES: OnceLock<Vec<Profile>> = OnceLock::new();
    let all = PROFILES.get_or_init(|| {
        Protocol::ALL
            .iter()
            .map(|p| load_profile(p.name(), &ConfigDirs::builtin_only()).expect("shipped profile"))
            .collect()
    });
    let i = Protocol::ALL
        .iter()
        .position(|p| *p == protocol)
        .unwrap_or(0);
    &all[i]
}

/// The first byte picks the family; the rest arrives on the simulator's line
/// in pieces, with the line's time passing between them.
pub fn drive(data: &[u8]) {
    let (head, stream) = split_head(data);
    let protocol = Protocol::ALL[usize::from(head) % Protocol::ALL.len()];
    drive_family(protocol, stream, &mut Choices::new(data));
}

pub fn drive_family(protocol: Protocol, stream: &[u8], choices: &mut Choices) {
    let device = registry::build(protocol, profile(protocol)).expect("shipped simulator");
    let mut engine = Engine::new(device);
    let names = engine.input_names();
    let byte_time = engine.line().byte_time();
    let mut now = Instant::now();
    let mut out = Vec::new();
    engine.run_until(now, &mut out);
    for piece in chunks(stream, choices) {
        engine.receive(piece, now);
        // The piece arrives, and up to 40 byte times of answer go out before
        // the next one is written.
        let wait = piece.len() as u32 + choices.below(40) as u32;
        now += byte_time * wait;
        engine.run_until(now, &mut out);
        if !names.is_empty() && choices.one_in(8) {
            let name = names[choices.below(names.len() as u64) as usize].to_string();
            let control = match choices.below(3) {
                0 => InputControl::Set {
                    name,
                    level: choices.one_in(2),
                },
                1 => InputControl::Press { name },
                _ => InputControl::Value {
                    name,
                    value: choices.below(40_001) as f64 - 20_000.0,
                },
            };
            // Refusals (a button that cannot be set) are fine; a panic is not.
            let _ = engine.control(&control, now);
        }
        if choices.one_in(16) {
            // A smaller program store (`memory <n>`), also in the middle of
            // a transfer; a refusal (EMP, beyond the controller's) is fine.
            let _ = engine.set_program_memory(choices.below(300) as usize);
        }
        if choices.one_in(32) {
            let _ = engine.describe(now);
        }
    }
    // Let moves, dwells and stored programs run out (the engine bounds the
    // events of one call, so a program that loops for ever cannot hang this).
    for step in [1, 60, 3600] {
        now += Duration::from_secs(step);
        engine.run_until(now, &mut out);
    }
    let _ = engine.describe(now);
    let stats = engine.stats();
    assert_eq!(stats.bytes_received, stream.len() as u64);
    assert_eq!(stats.bytes_sent, out.len() as u64);
}
