//! The I/O of every drive as an `IoSnapshot` (decision 5): limit switches
//! and the reference switch from `40`'s PROP, inputs I1-I4, and outputs
//! O1-O4 as last written (switchable, with their `OutputId`).

use std::time::Instant;

use crate::device::api::{InputSource, IoGroup, IoSnapshot};
use crate::device::common::io::{group, input_at, output_at};
use crate::wiring::{BitWiring, Wiring};

use super::drive::{DriveState, output_id};

/// The drive's wired inputs with a safety role (`estop`, `power`) that
/// read active, once its `40` has been read: the only inputs jogterm
/// refuses motion on itself (`docs/profiles.md`). Their names.
pub fn interlocks(index: usize, d: &DriveState, wiring: &Wiring) -> Vec<String> {
    let guards = |w: &BitWiring| {
        w.interlocks()
            && matches!(
                w.role,
                crate::wiring::Role::Estop | crate::wiring::Role::Power
            )
    };
    // Asked at every reply: the drive's bits are named and built only when
    // the profile wires one of them as such a contact (none by default).
    let prefix = format!("{}.", d.ds);
    let wired = wiring
        .bits()
        .iter()
        .any(|w| guards(w) && w.address.starts_with(&prefix));
    if d.inputs.is_none() || !wired {
        return Vec::new();
    }
    drive_group(index, d, wiring)
        .bits
        .iter()
        .filter(|b| b.output.is_none() && b.active())
        .filter_map(|b| b.wiring.as_ref())
        .filter(|w| guards(w))
        .map(|w| w.label())
        .collect()
}

/// One drive's bits under the profile's names (`11.limit+` …,
/// `crate::wiring`).
fn drive_group(index: usize, d: &DriveState, wiring: &Wiring) -> IoGroup {
    let mut bits = Vec::new();
    let ds = d.ds.to_string();
    let at = |suffix: &str| format!("{ds}.{suffix}");
    let limits = d.limits.unwrap_or_default();
    bits.push(input_at(wiring, &at("limit+"), "limit +", limits.plus));
    bits.push(input_at(wiring, &at("limit-"), "limit -", limits.minus));
    bits.push(input_at(wiring, &at("ref"), "reference", limits.reference));
    let inputs = d.inputs.map_or(0, |i| i.bits());
    for n in 1..=4u8 {
        let name = format!("I{n}");
        bits.push(input_at(
            wiring,
            &at(&name),
            &name,
            inputs & (1 << (n - 1)) != 0,
        ));
    }
    let outputs = d.outputs.map_or(0, |o| o.bits());
    for n in 0..4u8 {
        let name = format!("O{}", n + 1);
        bits.push(output_at(
            wiring,
            &at(&name),
            &name,
            outputs & (1 << n) != 0,
            output_id(index, n),
            true,
        ));
    }
    let written = if d.outputs.is_some() {
        ""
    } else {
        ", outputs not yet written"
    };
    group(
        format!("drive {} ({}){written}", d.ds, d.axis),
        d.inputs.map(|i| i.bits()),
        bits,
    )
    .read_from(InputSource::EmpDrive(d.ds.byte()), d.inputs_read)
}

/// The bits of every drive (`drives`, in the profile's order) at `now`.
pub fn snapshot(drives: &[DriveState], wiring: &Wiring, now: Instant) -> IoSnapshot {
    IoSnapshot {
        at: now,
        groups: drives
            .iter()
            .enumerate()
            .map(|(i, d)| drive_group(i, d, wiring))
            .collect(),
    }
}
