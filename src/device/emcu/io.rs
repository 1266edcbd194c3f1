//! The EMCU's I/O as an `IoSnapshot`: the six `@X` flags (manual 1.5.3)
//! with the core's names, the outputs A1 and A2 (manual 1.5.15) as jogterm
//! last switched them (no command reads them back: `raw: None` and off until
//! jogterm switched them), and the E1 link (`&V`, manual 1.5.19).

use std::time::Instant;

use crate::device::api::{InputSource, IoGroup, IoSnapshot, OutputId};
use crate::device::common::io;
use crate::proto::emcu::{Output, Status, StatusFlag};
use crate::wiring::Wiring;

/// The `@X` flags as a byte, bit 0 the first character (moving).
pub fn status_byte(status: &Status) -> u8 {
    StatusFlag::ALL
        .iter()
        .enumerate()
        .filter(|(_, f)| status.get(**f))
        .fold(0u8, |b, (i, _)| b | (1 << i))
}

/// The `OutputId` of A1 / A2: the output's number, a whole on/off value.
pub fn output_id(output: Output) -> OutputId {
    OutputId {
        group: output.get(),
        bit: None,
    }
}

/// The `@X` flags as an I/O group, `raw` the [`status_byte`].
pub fn status_group(status: &Status) -> IoGroup {
    let bits = StatusFlag::ALL
        .iter()
        .map(|f| io::input(f.to_string(), status.get(*f)))
        .collect();
    io::group("status: @X flags", Some(status_byte(status)), bits)
}

fn outputs_group(outputs: [Option<bool>; 2], wiring: &Wiring) -> IoGroup {
    let bits = [(1u16, "A1", "A1 (K1)"), (2, "A2", "A2 (K2)")]
        .into_iter()
        .zip(outputs)
        .map(|((n, address, name), value)| {
            // Relais K1/K2 switch a drilling spindle or a coolant pump
            // (manual 1.5.15): the UI asks before switching them.
            io::output_at(
                wiring,
                address,
                name,
                value.unwrap_or(false),
                OutputId {
                    group: n,
                    bit: None,
                },
                true,
            )
        })
        .collect();
    let raw = match outputs {
        [Some(a1), Some(a2)] => Some(u8::from(a1) | u8::from(a2) << 1),
        _ => None,
    };
    io::group("outputs: A1, A2 (as last switched)", raw, bits)
}

fn link_group(e1_link: Option<bool>) -> IoGroup {
    io::group(
        "E1 link (&V)",
        e1_link.map(u8::from),
        vec![io::input("moves wait for E1", e1_link.unwrap_or(false))],
    )
}

/// What jogterm knows of the interface's bits (the driver's context holds
/// it): the last `@X` and when it was read, the outputs it wrote, the E1
/// link.
#[derive(Debug, Clone, Copy)]
pub struct Known<'a> {
    pub status: Option<&'a Status>,
    pub status_read: Option<Instant>,
    pub outputs: [Option<bool>; 2],
    pub e1_link: Option<bool>,
    pub wiring: &'a Wiring,
}

/// Everything jogterm knows: the flags once `@X` was read, then the outputs
/// and the E1 link.
pub fn snapshot(known: Known<'_>, at: Instant) -> IoSnapshot {
    let mut groups = Vec::new();
    if let Some(status) = known.status {
        groups.push(status_group(status).read_from(InputSource::EmcuStatus, known.status_read));
    }
    groups.push(outputs_group(known.outputs, known.wiring));
    groups.push(link_group(known.e1_link));
    IoSnapshot { at, groups }
}

/// The set flags in words, for `jogterm send`.
pub fn describe_status(status: &Status) -> String {
    status.to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_become_a_named_byte() {
        let s = Status {
            moving: true,
            position_unknown: true,
            referencing: true,
            ..Status::default()
        };
        assert_eq!(status_byte(&s), 0b1_1001);
        let g = status_group(&s);
        assert_eq!(g.bits.len(), 6);
        assert_eq!(g.bits[3].name, "position unknown");
        assert!(g.bits[3].value && !g.bits[2].value);
        assert_eq!(describe_status(&s), "moving, position unknown, referencing");
    }

    #[test]
    fn outputs_show_what_jogterm_switched() {
        let w = Wiring::defaults(crate::proto::Protocol::Emcu, crate::axis::AxisSet::XYZ, &[]);
        let g = outputs_group([Some(true), None], &w);
        assert_eq!(g.bits[0].name, "A1 (K1)");
        assert_eq!(g.raw, None);
        assert!(g.bits[0].value && g.bits.iter().all(|b| b.hazardous));
        assert_eq!(
            g.bits[1].output,
            Some(OutputId {
                group: 2,
                bit: None
            })
        );
        assert_eq!(outputs_group([Some(false), Some(true)], &w).raw, Some(2));
    }
}
