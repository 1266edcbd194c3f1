//! Conversation tests of the EMP simulator: a host sends frames byte by byte
//! at line speed with synthetic time and reads what the drives answer, when.

mod harness;
mod link;
mod manual;
mod motion;
mod peripherals;
mod probe;
mod proptests;
