//! The state behind the port bit panels: the last I/O snapshot (without the
//! bits the manual lists as "not used"), when each bit last changed (so a
//! change stays highlighted for a moment and a flickering switch can be
//! seen), and the operator's selection.

use std::time::{Duration, Instant};

use crate::device::api::{IoBit, IoGroup, IoSnapshot, OutputId, Request};

use super::keymap::Action;
use super::msg::Effect;
use super::outcome::Outcome;
use super::traffic_log::NoteLevel;

/// How long a changed bit stays highlighted.
pub const HIGHLIGHT: Duration = Duration::from_millis(1500);

#[derive(Debug, Clone, PartialEq)]
pub struct BitState {
    pub bit: IoBit,
    /// When the bit last changed value; `None` since the first snapshot.
    pub changed_at: Option<Instant>,
    /// Changes seen since jogterm started.
    pub changes: u32,
}

#[derive(Debug, Clone, PartialEq)]
pub struct GroupState {
    pub name: String,
    pub raw: Option<u8>,
    /// The bits the panel shows (unused ones left out).
    pub bits: Vec<BitState>,
    /// Every bit of the group as the driver sent it, unused ones included.
    pub all_bits: Vec<IoBit>,
}

/// Bits the profile (or the manual) calls unused carry nothing to look at
/// or switch; they are left out of the panel (the raw byte still shows
/// them). A "not used" bit the profile gives a role is shown.
fn is_unused(bit: &IoBit) -> bool {
    match &bit.wiring {
        Some(w) => w.role == crate::wiring::Role::Unused,
        None => bit.name.eq_ignore_ascii_case("not used"),
    }
}

/// Which bit is selected: group and bit index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Selection {
    pub group: usize,
    pub bit: usize,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct IoPanel {
    pub groups: Vec<GroupState>,
    pub selected: Option<Selection>,
    /// When the last snapshot was read.
    pub at: Option<Instant>,
    /// When the operator last moved the selection.
    pub moved_at: Option<Instant>,
}

impl IoPanel {
    /// Take a new snapshot. Bits are matched to the previous snapshot by group
    /// and bit name, so a driver that adds or drops a group does not make
    /// every bit look changed.
    pub fn apply(&mut self, snapshot: &IoSnapshot) {
        let selected_names = self.selected_names();
        let groups = snapshot
            .groups
            .iter()
            .map(|group| self.merge_group(group, snapshot.at))
            .collect();
        self.groups = groups;
        self.at = Some(snapshot.at);
        self.selected = selected_names
            .and_then(|(g, b)| self.find(&g, &b))
            .or_else(|| self.first());
    }

    fn merge_group(&self, group: &IoGroup, at: Instant) -> GroupState {
        let old = self.groups.iter().find(|g| g.name == group.name);
        let bits = group
            .bits
            .iter()
            .filter(|bit| !is_unused(bit))
            .enumerate()
            .map(|(i, bit)| {
                let before = old.and_then(|g| {
                    g.bits
                        .get(i)
                        .filter(|b| b.bit.name == bit.name)
                        .or_else(|| g.bits.iter().find(|b| b.bit.name == bit.name))
                });
                match before {
                    Some(b) if b.bit.value != bit.value => BitState {
                        bit: bit.clone(),
                        changed_at: Some(at),
                        changes: b.changes.saturating_add(1),
                    },
                    Some(b) => BitState {
                        bit: bit.clone(),
                        changed_at: b.changed_at,
                        changes: b.changes,
                    },
                    None => BitState {
                        bit: bit.clone(),
                        changed_at: None,
                        changes: 0,
                    },
                }
            })
            .collect();
        GroupState {
            name: group.name.clone(),
            raw: group.raw,
            bits,
            all_bits: group.bits.clone(),
        }
    }

    fn selected_names(&self) -> Option<(String, String)> {
        let s = self.selected?;
        let group = self.groups.get(s.group)?;
        let bit = group.bits.get(s.bit)?;
        Some((group.name.clone(), bit.bit.name.clone()))
    }

    fn find(&self, group: &str, bit: &str) -> Option<Selection> {
        let g = self.groups.iter().position(|x| x.name == group)?;
        let b = self
            .groups
            .get(g)?
            .bits
            .iter()
            .position(|x| x.bit.name == bit)?;
        Some(Selection { group: g, bit: b })
    }

    fn first(&self) -> Option<Selection> {
        self.groups
            .iter()
            .position(|g| !g.bits.is_empty())
            .map(|group| Selection { group, bit: 0 })
    }

    pub fn selected_bit(&self) -> Option<(&GroupState, &BitState)> {
        self.bit_at(self.selected?)
    }

    pub fn bit_at(&self, s: Selection) -> Option<(&GroupState, &BitState)> {
        let group = self.groups.get(s.group)?;
        Some((group, group.bits.get(s.bit)?))
    }

    /// The outputs an operator switches by name: wired, with a role such
    /// as spindle, coolant, clamp, vacuum or lamp
    /// (`wiring::Role::is_named_output`), in the panel's order.
    pub fn named_outputs(&self) -> Vec<Selection> {
        self.groups
            .iter()
            .enumerate()
            .flat_map(|(g, group)| {
                group.bits.iter().enumerate().filter_map(move |(b, bit)| {
                    let named = bit.bit.output.is_some()
                        && bit
                            .bit
                            .wiring
                            .as_ref()
                            .is_some_and(|w| w.wired && w.role.is_named_output());
                    named.then_some(Selection { group: g, bit: b })
                })
            })
            .collect()
    }

    /// Whether the bit is in its highlight time at `now`.
    pub fn highlighted(bit: &BitState, now: Instant) -> bool {
        bit.changed_at
            .is_some_and(|t| now.saturating_duration_since(t) < HIGHLIGHT)
    }

    /// Number of bits highlighted at `now` (a change of it means a redraw).
    pub fn highlight_count(&self, now: Instant) -> usize {
        self.groups
            .iter()
            .flat_map(|g| &g.bits)
            .filter(|b| Self::highlighted(b, now))
            .count()
    }

    /// The bit a small panel keeps in view: one that changed a moment ago
    /// (and after the operator last moved the selection), else the selection.
    pub fn in_view(&self, now: Instant) -> Option<Selection> {
        let latest_change = self
            .groups
            .iter()
            .enumerate()
            .flat_map(|(g, group)| {
                group
                    .bits
                    .iter()
                    .enumerate()
                    .map(move |(b, bit)| (g, b, bit))
            })
            .filter(|(_, _, bit)| Self::highlighted(bit, now))
            .filter(|(_, _, bit)| match (bit.changed_at, self.moved_at) {
                (Some(c), Some(m)) => c > m,
                _ => true,
            })
            .max_by_key(|(_, _, bit)| bit.changed_at)
            .map(|(group, bit, _)| Selection { group, bit });
        latest_change.or(self.selected)
    }

    /// Move the selection by `delta` bits, across groups, wrapping.
    pub fn step_bit(&mut self, delta: isize, now: Instant) {
        self.moved_at = Some(now);
        let flat: Vec<Selection> = self
            .groups
            .iter()
            .enumerate()
            .flat_map(|(g, group)| {
                (0..group.bits.len()).map(move |b| Selection { group: g, bit: b })
            })
            .collect();
        if flat.is_empty() {
            self.selected = None;
            return;
        }
        let at = self
            .selected
            .and_then(|s| flat.iter().position(|x| *x == s))
            .unwrap_or(0) as isize;
        let len = flat.len() as isize;
        let next = (at + delta).rem_euclid(len) as usize;
        self.selected = flat.get(next).copied();
    }

    /// Move to the previous or next group that has bits, keeping the bit
    /// index where the group is long enough.
    pub fn step_group(&mut self, delta: isize, now: Instant) {
        self.moved_at = Some(now);
        let candidates: Vec<usize> = self
            .groups
            .iter()
            .enumerate()
            .filter(|(_, g)| !g.bits.is_empty())
            .map(|(i, _)| i)
            .collect();
        if candidates.is_empty() {
            self.selected = None;
            return;
        }
        let current = self.selected.unwrap_or(Selection { group: 0, bit: 0 });
        let at = candidates
            .iter()
            .position(|g| *g == current.group)
            .unwrap_or(0) as isize;
        let len = candidates.len() as isize;
        let group = candidates
            .get((at + delta).rem_euclid(len) as usize)
            .copied()
            .unwrap_or(0);
        let bits = self.groups.get(group).map_or(0, |g| g.bits.len());
        self.selected = Some(Selection {
            group,
            bit: current.bit.min(bits.saturating_sub(1)),
        });
    }
}

/// What switching the selected output means.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputToggle {
    pub output: OutputId,
    pub name: String,
    /// The value to write: the opposite of what the bit shows, or the
    /// whole byte of [`OutputToggle::byte`].
    pub value: u8,
    pub hazardous: bool,
    /// Set when the bit belongs to a byte-wide port whose other bits are
    /// unknown (outputs cannot be read back, and jogterm has not written
    /// the port yet): the whole byte is written, every bit named.
    pub byte: Option<ByteWrite>,
}

/// A whole output byte to write instead of one bit of it.
#[derive(Debug, Clone, PartialEq)]
pub struct ByteWrite {
    /// The port (group) name, `out 0: user outputs`.
    pub port: String,
    /// Every bit of the port, bit 0 first.
    pub bits: Vec<ByteBit>,
}

/// One bit of a [`ByteWrite`].
#[derive(Debug, Clone, PartialEq)]
pub struct ByteBit {
    pub bit: u8,
    pub name: String,
    /// What jogterm believes it is now (on = its active level); `None`:
    /// unknown.
    pub now: Option<bool>,
    /// What it will be: on for the bit switched, off for the others.
    pub then: bool,
}

impl IoPanel {
    /// The toggle for the selected bit, or why there is none.
    pub fn toggle_selected(&self) -> Result<OutputToggle, String> {
        match self.selected {
            Some(s) => self.toggle_at(s),
            None => Err("no port bits yet: nothing to switch".to_string()),
        }
    }

    /// The toggle for the bit at `s`, or why there is none.
    pub fn toggle_at(&self, s: Selection) -> Result<OutputToggle, String> {
        let (group, bit) = self
            .bit_at(s)
            .ok_or_else(|| "no port bits yet: nothing to switch".to_string())?;
        let output = bit
            .bit
            .output
            .ok_or_else(|| format!("{} is an input: it cannot be switched", bit.bit.name))?;
        if let (Some(index), None) = (output.bit, group.raw)
            && let Some(byte) = Self::unknown_byte(group, output)
        {
            // Switch the chosen bit on, every other one off (the state
            // a machine is safe in), at the levels the profile gives.
            let mut value = 0u8;
            let bits = byte
                .iter()
                .map(|(n, b)| {
                    let then = *n == index;
                    let active_high = b
                        .wiring
                        .as_ref()
                        .is_none_or(|w| w.active == crate::wiring::Level::High);
                    if then == active_high {
                        value |= 1 << n;
                    }
                    ByteBit {
                        bit: *n,
                        name: b.name.clone(),
                        now: None,
                        then,
                    }
                })
                .collect();
            return Ok(OutputToggle {
                output: OutputId {
                    group: output.group,
                    bit: None,
                },
                name: group.name.clone(),
                value,
                hazardous: true,
                byte: Some(ByteWrite {
                    port: group.name.clone(),
                    bits,
                }),
            });
        }
        Ok(OutputToggle {
            output,
            name: bit.bit.name.clone(),
            value: u8::from(!bit.bit.value),
            hazardous: bit.bit.hazardous,
            byte: None,
        })
    }

    /// The eight bits of a byte-wide output port that has not been
    /// written (`raw: None`), from the snapshot's full list (the panel
    /// leaves unused bits out; the byte has them all).
    fn unknown_byte(group: &GroupState, output: OutputId) -> Option<Vec<(u8, IoBit)>> {
        let bits: Vec<(u8, IoBit)> = group
            .all_bits
            .iter()
            .filter_map(|b| match b.output {
                Some(id) if id.group == output.group => id.bit.map(|n| (n, b.clone())),
                _ => None,
            })
            .collect();
        (bits.len() == 8 && bits.iter().all(|(n, _)| *n < 8)).then_some(bits)
    }
}

/// The I/O panel as a component: a key of the focused panel.
impl IoPanel {
    pub fn update(&mut self, now: Instant, action: Action) -> Outcome {
        match action {
            Action::SelectPrev => self.step_bit(-1, now),
            Action::SelectNext => self.step_bit(1, now),
            Action::GroupPrev => self.step_group(-1, now),
            Action::GroupNext => self.step_group(1, now),
            Action::ToggleOutput => return switch(self.toggle_selected()),
            _ => {}
        }
        Outcome::default()
    }
}

/// Switching an output: at once, or asked first when it is hazardous or
/// writes a whole byte; why not when it cannot be switched.
fn switch<P>(toggle: Result<OutputToggle, String>) -> Outcome<P> {
    let t = match toggle {
        Ok(t) => t,
        Err(why) => return Outcome::note(NoteLevel::Warning, why),
    };
    let effects = vec![Effect::Request(Request::SetOutput {
        output: t.output,
        value: t.value,
    })];
    let title = "Switch an output";
    if let Some(byte) = &t.byte {
        // One confirm for the whole byte: outputs cannot be read back, so
        // the other bits are written too (off), each named.
        let lines: Vec<String> = byte
            .bits
            .iter()
            .map(|b| {
                let now = match b.now {
                    None => "?",
                    Some(true) => "on",
                    Some(false) => "off",
                };
                let then = if b.then { "ON" } else { "off" };
                format!("{} {}: {now} -> {then}", b.bit, b.name)
            })
            .collect();
        let question = format!(
            "Write {} = {:02X}? Outputs cannot be read back and jogterm has not written this \
             port yet (? = unknown), so every bit is set:\n{}",
            byte.port,
            t.value,
            lines.join("\n")
        );
        return Outcome::ask(title, question, effects);
    }
    let state = if t.value == 0 { "off" } else { "on" };
    if t.hazardous {
        let question = format!(
            "Switch {} {state}? It moves or powers something on the machine.",
            t.name
        );
        return Outcome::ask(title, question, effects);
    }
    Outcome::effects(effects)
}

/// The named outputs popup (spindle, coolant …) as a component: its state
/// is the entry selected (an index into [`IoPanel::named_outputs`]), its
/// context the I/O panel. Enter switches the output through the same
/// toggle as the panel's; the popup stays open for the next unless a
/// question takes its place.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Outputs {
    pub selected: usize,
}

impl Outputs {
    /// `o`: the popup, or why there is none.
    pub fn open(io: &IoPanel) -> Outcome<Outputs> {
        if io.named_outputs().is_empty() {
            return Outcome::note(
                NoteLevel::Info,
                "no named outputs: give outputs a role in the profile's [io] (spindle, \
                 coolant, clamp, vacuum, lamp; docs/profiles.md)",
            );
        }
        Outcome::popup(Outputs::default())
    }

    /// A key of the open popup (taken out of the popup slot).
    pub fn update(self, io: &IoPanel, action: Action) -> Outcome<Outputs> {
        let entries = io.named_outputs();
        let last = entries.len().saturating_sub(1);
        let selected = self.selected.min(last);
        let keep = |selected| Outcome::popup(Outputs { selected });
        match action {
            Action::Close => Outcome::default(),
            Action::SelectPrev => keep(selected.saturating_sub(1)),
            Action::SelectNext => keep((selected + 1).min(last)),
            Action::ToggleOutput => {
                let toggle = entries
                    .get(selected)
                    .ok_or_else(|| "no named outputs yet".to_string())
                    .and_then(|s| io.toggle_at(*s));
                switch(toggle).with_popup(Outputs { selected })
            }
            _ => keep(selected),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bit(name: &str, value: bool) -> IoBit {
        IoBit {
            name: name.into(),
            value,
            output: None,
            hazardous: false,
            wiring: None,
        }
    }

    fn snapshot(at: Instant, groups: Vec<(&str, Vec<IoBit>)>) -> IoSnapshot {
        IoSnapshot {
            at,
            groups: groups
                .into_iter()
                .map(|(name, bits)| IoGroup {
                    name: name.into(),
                    raw: None,
                    bits,
                    read: None,
                })
                .collect(),
        }
    }

    #[test]
    fn a_change_is_highlighted_for_a_moment_and_counted() {
        let t0 = Instant::now();
        let mut panel = IoPanel::default();
        panel.apply(&snapshot(
            t0,
            vec![("p3", vec![bit("X1", false), bit("X2", false)])],
        ));
        assert_eq!(
            panel.highlight_count(t0),
            0,
            "the first snapshot is no change"
        );
        let t1 = t0 + Duration::from_millis(100);
        panel.apply(&snapshot(
            t1,
            vec![("p3", vec![bit("X1", true), bit("X2", false)])],
        ));
        assert_eq!(panel.highlight_count(t1), 1);
        let t2 = t1 + Duration::from_millis(100);
        panel.apply(&snapshot(
            t2,
            vec![("p3", vec![bit("X1", false), bit("X2", false)])],
        ));
        let x1 = &panel.groups[0].bits[0];
        assert_eq!((x1.changes, x1.changed_at), (2, Some(t2)));
        assert!(IoPanel::highlighted(
            x1,
            t2 + HIGHLIGHT - Duration::from_millis(1)
        ));
        assert!(!IoPanel::highlighted(x1, t2 + HIGHLIGHT));
    }

    #[test]
    fn a_fresh_change_is_kept_in_view_until_the_operator_moves() {
        let t0 = Instant::now();
        let mut panel = IoPanel::default();
        let groups = |x2: bool| {
            vec![
                ("p1", vec![bit("a", false)]),
                ("p3", vec![bit("X1", false), bit("X2", x2)]),
            ]
        };
        panel.apply(&snapshot(t0, groups(false)));
        assert_eq!(panel.in_view(t0), Some(Selection { group: 0, bit: 0 }));
        let t1 = t0 + Duration::from_millis(10);
        panel.apply(&snapshot(t1, groups(true)));
        assert_eq!(panel.in_view(t1), Some(Selection { group: 1, bit: 1 }));
        panel.step_bit(1, t1 + Duration::from_millis(1));
        assert_eq!(panel.in_view(t1), Some(Selection { group: 1, bit: 0 }));
        assert_eq!(
            panel.in_view(t1 + HIGHLIGHT),
            Some(Selection { group: 1, bit: 0 })
        );
    }

    #[test]
    fn selection_survives_new_snapshots_and_wraps() {
        let t = Instant::now();
        let mut panel = IoPanel::default();
        let groups = || {
            vec![
                ("a", vec![bit("a0", false), bit("a1", false)]),
                ("b", vec![bit("b0", false)]),
            ]
        };
        panel.apply(&snapshot(t, groups()));
        assert_eq!(panel.selected, Some(Selection { group: 0, bit: 0 }));
        panel.step_bit(-1, t);
        assert_eq!(panel.selected, Some(Selection { group: 1, bit: 0 }));
        panel.apply(&snapshot(t, groups()));
        assert_eq!(panel.selected, Some(Selection { group: 1, bit: 0 }));
        panel.step_group(1, t);
        assert_eq!(panel.selected, Some(Selection { group: 0, bit: 0 }));
        panel.step_bit(1, t);
        panel.step_group(1, t);
        assert_eq!(panel.selected, Some(Selection { group: 1, bit: 0 }));
    }

    #[test]
    fn unused_bits_are_left_out() {
        let t = Instant::now();
        let mut panel = IoPanel::default();
        panel.apply(&snapshot(
            t,
            vec![("p1", vec![bit("probe", true), bit("not used", false)])],
        ));
        assert_eq!(panel.groups[0].bits.len(), 1);
    }

    #[test]
    fn a_bit_of_an_unwritten_byte_port_writes_the_whole_byte() {
        let t = Instant::now();
        let mut panel = IoPanel::default();
        let out = |n: u8| IoBit {
            name: if n == 1 {
                "coolant".into()
            } else {
                format!("user output {n}")
            },
            value: false,
            output: Some(OutputId {
                group: 0,
                bit: Some(n),
            }),
            hazardous: true,
            wiring: None,
        };
        let groups = |raw: Option<u8>| IoSnapshot {
            at: t,
            groups: vec![IoGroup {
                name: "out 0: user outputs".into(),
                raw,
                bits: (0..8).map(out).collect(),
                read: None,
            }],
        };
        panel.apply(&groups(None));
        panel.step_bit(1, t);
        let toggle = panel.toggle_selected().expect("toggle");
        assert_eq!(
            toggle.output,
            OutputId {
                group: 0,
                bit: None
            }
        );
        assert_eq!(toggle.value, 0b10);
        let byte = toggle.byte.expect("the whole byte");
        assert_eq!(byte.bits.len(), 8);
        assert_eq!(
            (byte.bits[1].name.as_str(), byte.bits[1].then),
            ("coolant", true)
        );
        assert!(byte.bits.iter().all(|b| b.now.is_none()));
        assert!(byte.bits.iter().filter(|b| b.then).count() == 1);
        // Once written, one bit is switched as usual.
        panel.apply(&groups(Some(0)));
        let toggle = panel.toggle_selected().expect("toggle");
        assert_eq!(toggle.byte, None);
        assert_eq!(toggle.output.bit, Some(1));
    }

    #[test]
    fn only_outputs_toggle_to_the_opposite_value() {
        let t = Instant::now();
        let mut panel = IoPanel::default();
        let mut spindle = bit("spindle", true);
        spindle.output = Some(OutputId {
            group: 2,
            bit: None,
        });
        spindle.hazardous = true;
        panel.apply(&snapshot(
            t,
            vec![("in", vec![bit("X1", false)]), ("out", vec![spindle])],
        ));
        assert!(panel.toggle_selected().unwrap_err().contains("input"));
        panel.step_bit(1, t);
        let toggle = panel.toggle_selected().expect("output");
        assert_eq!((toggle.value, toggle.hazardous), (0, true));
    }
}
