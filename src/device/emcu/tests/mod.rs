//! Byte conversations with the EMCU driver on synthetic time: every bullet
//! of the driver's behaviour, one test (or a few) each.

mod harness;

mod checkout;
mod connect;
mod faults;
mod motion;
mod polling;
mod properties;
mod raw;
mod traffic;
mod upload;
mod with_sim;
