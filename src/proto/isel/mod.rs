//! isel @-format (iMC-M / iMC-MP / iMC-S8): DNC commands, CNC (stored program)
//! commands, init commands, control bytes and replies.
