//! The I/O of every drive as an `IoSnapshot` (decision 5): limit switches
//! and the reference switch from `40`'s PROP, inputs I1-I4, and outputs
//! O1-O4 as last written (switchable, with their `OutputId`).

use std::time::Instant;

use crate::device::api::{InputSource, IoGroup, IoSnapshot};
use crate::device::common::io::{group, input, output};

use super::context::{Context, DriveState};
use super::output::output_id;

fn drive_group(index: usize, d: &DriveState) -> IoGroup {
    let mut bits = Vec::new();
    let limits = d.limits.unwrap_or_default();
    bits.push(input("limit +", limits.plus));
    bits.push(input("limit -", limits.minus));
    bits.push(input("reference", limits.reference));
    let inputs = d.inputs.map_or(0, |i| i.bits());
    for n in 1..=4u8 {
        bits.push(input(format!("I{n}"), inputs & (1 << (n - 1)) != 0));
    }
    let outputs = d.outputs.map_or(0, |o| o.bits());
    for n in 0..4u8 {
        bits.push(output(
            format!("O{}", n + 1),
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

pub fn snapshot(cx: &Context, now: Instant) -> IoSnapshot {
    IoSnapshot {
        at: now,
        groups: cx
            .drives
            .iter()
            .enumerate()
            .map(|(i, d)| drive_group(i, d))
            .collect(),
    }
}
