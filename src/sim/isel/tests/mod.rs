//! Conversation tests of the isel simulator.
