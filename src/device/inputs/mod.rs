//! Input diagnostics: which inputs a machine has ([`channels`]), the
//! recorder the device task feeds with every reading of them ([`recorder`]),
//! what it keeps ([`history`]), and the switch walk-test that reads it
//! ([`walk`], with its commissioning [`report`]). `jogterm watch`, `jogterm commission`
//! and the console's port timeline all read the same changes
//! (`docs/ui.md`, "Port timeline").

pub mod channels;
pub mod history;
pub mod recorder;
pub mod report;
pub mod walk;

pub use channels::channels;
pub use history::{InputHistory, Recorded, SkewMark};
pub use recorder::{InputRecorder, RecorderConfig, Sampling};

use crate::device::api::{InputKey, IoBit, IoGroup};

/// The input bits of a group read from the controller, keyed: the group's
/// bits that are no outputs, numbered from 0 in the group's order (the
/// numbering of [`InputKey::bit`]). Nothing for a group not read.
pub fn input_bits(group: &IoGroup) -> impl Iterator<Item = (InputKey, &IoBit)> {
    let source = group.read.map(|r| r.source);
    source.into_iter().flat_map(move |source| {
        (0u8..)
            .zip(group.bits.iter().filter(|b| b.output.is_none()))
            .map(move |(bit, b)| (InputKey { source, bit }, b))
    })
}

use crate::device::api::{InputChange, InputChannel, InputRole};

/// What a level means for the input, in a word: `hit`, `open`, `pressed` …
pub fn level_word(channel: &InputChannel, level: bool) -> &'static str {
    let active = level == channel.active;
    match (channel.role, active) {
        (InputRole::Limit, true) => "hit",
        (InputRole::Limit, false) => "free",
        (InputRole::Estop | InputRole::Hood, true) => "open",
        (InputRole::Estop | InputRole::Hood, false) => "closed",
        (InputRole::Key, true) => "pressed",
        (InputRole::Key, false) => "released",
        (InputRole::Probe, true) => "touched",
        (InputRole::Probe, false) => "free",
        (InputRole::Power, true) => "fault",
        (InputRole::Power, false) => "ok",
        (_, true) => "on",
        (_, false) => "off",
    }
}

fn ms(d: std::time::Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1000.0)
}

/// One change in words, for the traffic log and `jogterm watch`:
/// `limit X1 (in3.0) 1 hit, t 1.234 s, within 20.8 ms`, then chatter and
/// E-stop skew when there are.
pub fn describe(change: &InputChange) -> String {
    let c = &change.channel;
    let mut text = format!(
        "{} ({}) {} {}, t {:.3} s, within {}",
        c.label(),
        c.address,
        u8::from(change.level),
        level_word(c, change.level),
        change.t.as_secs_f64(),
        ms(change.window())
    );
    if let Some(ch) = change.chatter {
        text.push_str(&format!(
            "; CHATTER: {} changes in {}",
            ch.changes,
            ms(ch.within)
        ));
    }
    if let Some(s) = &change.skew {
        text.push_str(&format!(
            "; E-STOP SKEW {} after {} (between {} and {})",
            ms(s.measured),
            s.first.label(),
            ms(s.min),
            ms(s.max)
        ));
    }
    text
}
