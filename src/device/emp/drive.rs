//! One drive as the driver last saw it, and the ids of its outputs: what
//! the driver's context keeps per drive and what its I/O snapshot reads,
//! with nothing of the driver's own (a leaf the other modules use).

use std::time::Instant;

use crate::axis::Axis;
use crate::device::api::OutputId;
use crate::proto::emp::{DriveAddress, Inputs, Limits, OperatingMode, Outputs, ReloadValue};

/// The id of output `n` (0-3 = O1-O4) of the drive at `index` in the profile.
pub fn output_id(index: usize, n: u8) -> OutputId {
    OutputId {
        group: u16::try_from(index).unwrap_or(u16::MAX),
        bit: Some(n),
    }
}

/// One drive as last seen.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveState {
    pub ds: DriveAddress,
    pub axis: Axis,
    /// `Some(true)` after `02` was answered or a command other than `0A` was
    /// taken; `Some(false)` after `04` or a "not switched on" error.
    pub on: Option<bool>,
    pub mode: Option<OperatingMode>,
    pub reload: Option<ReloadValue>,
    /// The position counter (encoder counts).
    pub position: Option<i64>,
    pub limits: Option<Limits>,
    pub inputs: Option<Inputs>,
    /// When the last `41` (switches and inputs) arrived, for the input
    /// recorder.
    pub inputs_read: Option<Instant>,
    /// Outputs as last written (no query reads them back: manual "42").
    pub outputs: Option<Outputs>,
}

impl DriveState {
    pub(super) fn new(ds: DriveAddress, axis: Axis) -> DriveState {
        DriveState {
            ds,
            axis,
            on: None,
            mode: None,
            reload: None,
            position: None,
            limits: None,
            inputs: None,
            inputs_read: None,
            outputs: None,
        }
    }

    /// Forget what may have changed while the link was down; the outputs
    /// stay as written (a drive keeps them through `04`, docs/protocols.md).
    pub(super) fn unknown(&mut self) {
        self.on = None;
        self.mode = None;
        self.reload = None;
        self.position = None;
        self.limits = None;
        self.inputs = None;
        self.inputs_read = None;
    }
}
