//! Serial line timing. Every controller here runs 8N1: a start bit, eight data
//! bits and a stop bit, so one byte occupies ten bit times on the wire.

use std::time::Duration;

/// Bits one byte occupies on an 8N1 line.
pub const BITS_PER_BYTE: u32 = 10;

/// The settings of a serial line that decide how long bytes take on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LineSettings {
    pub baud: u32,
}

impl LineSettings {
    pub const fn new(baud: u32) -> Self {
        Self { baud }
    }

    /// Time one byte occupies on the wire.
    pub fn byte_time(&self) -> Duration {
        self.transfer_time(1)
    }

    /// Time `bytes` bytes occupy on the wire, back to back.
    pub fn transfer_time(&self, bytes: usize) -> Duration {
        let bits = bytes as u128 * BITS_PER_BYTE as u128;
        Duration::from_nanos((bits * 1_000_000_000 / self.baud.max(1) as u128) as u64)
    }

    /// Bytes the line can carry per second.
    pub fn bytes_per_second(&self) -> f64 {
        self.baud as f64 / BITS_PER_BYTE as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isel_poll_round_trip_wire_limit_matches_the_issue() {
        // `@0P` CR (4 bytes) and `0` + 18 hex digits (19 bytes) at 19200 baud.
        let t = LineSettings::new(19200).transfer_time(23);
        assert_eq!(t.as_micros(), 11979);
    }

    #[test]
    fn emp_frame_takes_4_4_ms_at_38400() {
        let t = LineSettings::new(38400).transfer_time(17);
        assert_eq!(t.as_micros(), 4427);
    }
}
