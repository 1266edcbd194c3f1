//! The device layer: one task per connected controller owns the port; clients
//! talk to it only through [`api::Request`]s in and [`api::Event`]s out.
//!
//! - [`api`]: requests, events, machine state, refusals (family-neutral).
//! - [`driver`]: the sans-IO [`driver::Driver`] trait each family implements.
//! - [`common`]: what the drivers of all families share (refusals, jog
//!   vectors and leases, step coalescing, polling, the request queue).
//! - [`isel`], [`emcu`], [`emp`]: the drivers of the three families.
//! - [`inputs`]: the input recorder (every change of every input bit) and
//!   the inputs a profile names.
//! - [`task`]: the async task that owns the port ([`spawn`]); [`handle`]:
//!   what clients hold ([`DeviceHandle`]); [`events`]: the fan-out of events
//!   with its drop policy; [`log`]: the traffic log.
//!
//! `docs/device.md` describes the layer as a whole.

pub mod api;
pub mod common;
pub mod connector;
pub mod describe;
pub mod driver;
pub mod emcu;
pub mod emp;
pub mod events;
pub mod handle;
#[cfg(test)]
mod imports;
pub mod inputs;
pub mod isel;
pub mod log;
mod stream_guard;
pub mod task;
mod traffic_buffer;

pub use connector::{Backoff, Connector};
pub use events::{EventBus, EventReceiver, TryRecvError};
pub use handle::{DeviceHandle, EmergencyHandle, InputLog, RequestError, StopTicket, StopWritten};
pub use task::{
    DeviceError, SessionMoves, TaskOptions, driver_for, spawn, spawn_recording, spawn_with,
};
