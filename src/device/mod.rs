//! The device layer: one task per connected controller owns the port; clients
//! talk to it only through [`api::Request`]s in and [`api::Event`]s out.
//!
//! - [`api`]: requests, events, machine state, refusals (family-neutral).
//! - [`driver`]: the sans-IO [`driver::Driver`] trait each family implements.
//! - [`isel`]: the isel @-format driver.

pub mod api;
pub mod describe;
pub mod driver;
pub mod isel;
