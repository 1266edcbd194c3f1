//! Tests across the isel modules: every example of the manual (chapters
//! 2–5) as a table, the negative tables per reply code, reply decoding
//! tables, and property tests for round trips, byte splits and garbage.

mod manual_examples;
mod negative;
mod properties;
mod replies;
mod strategies;
