//! Byte conversations with the isel driver on synthetic time: every bullet
//! of the driver's behaviour, one test (or a few) each.

mod harness;

mod checkout;
mod connect;
mod faults;
mod limit_jog;
mod motion;
mod polling;
mod probe;
mod properties;
mod raw;
mod timeouts;
mod traffic;
mod upload;
mod with_sim;
