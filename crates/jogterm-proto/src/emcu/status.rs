//! The six status flags of `@X` (manual 1.5.3), each with what it means and
//! what the operator or the console has to do about it.

use std::fmt;

/// One character of the `@X` reply, in wire order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StatusFlag {
    /// 1st character: the machine is running.
    Moving,
    /// 2nd: a `W` wait time is running.
    Waiting,
    /// 3rd: a general error occurred (also a malformed command, decision 4).
    Error,
    /// 4th: the current position is not known.
    PositionUnknown,
    /// 5th: a reference run is in progress.
    Referencing,
    /// 6th: a job (the data memory or a ROM job) is running.
    JobRunning,
}

impl StatusFlag {
    /// Wire order of the `@X` characters.
    pub const ALL: [StatusFlag; 6] = [
        StatusFlag::Moving,
        StatusFlag::Waiting,
        StatusFlag::Error,
        StatusFlag::PositionUnknown,
        StatusFlag::Referencing,
        StatusFlag::JobRunning,
    ];

    /// Position of the flag's character in the six (0-based).
    pub fn index(self) -> usize {
        self as usize
    }

    /// What the set flag means (manual 1.5.3).
    pub fn meaning(self) -> &'static str {
        match self {
            StatusFlag::Moving => "the machine is moving (which axis cannot be told)",
            StatusFlag::Waiting => "a wait time (W) is running",
            StatusFlag::Error => "an error occurred (also a malformed or unknown command)",
            StatusFlag::PositionUnknown => "the current position is not known",
            StatusFlag::Referencing => "a reference run is in progress",
            StatusFlag::JobRunning => "a job is running (data memory or ROM job)",
        }
    }

    /// What to do while the flag is set (manual 1.5.3 for error, position
    /// unknown and job running; 1.5.11/1.5.12 for stopping).
    pub fn remedy(self) -> &'static str {
        match self {
            StatusFlag::Moving => {
                "wait for the move to end; @B halts with ramp (positions kept), \
                 @S stops at once (positions lost)"
            }
            StatusFlag::Waiting => "the stored commands go on when the wait time has passed",
            StatusFlag::Error => "reset (@R), then run a reference ($H) before going on",
            StatusFlag::PositionUnknown => {
                "run a reference ($H): no defined move is possible until then"
            }
            StatusFlag::Referencing => "wait: the position is known when the reference run ends",
            StatusFlag::JobRunning => {
                "send only master commands (@…) until the interface sends 0x02 CR"
            }
        }
    }
}

impl fmt::Display for StatusFlag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StatusFlag::Moving => "moving",
            StatusFlag::Waiting => "waiting",
            StatusFlag::Error => "error",
            StatusFlag::PositionUnknown => "position unknown",
            StatusFlag::Referencing => "referencing",
            StatusFlag::JobRunning => "job running",
        })
    }
}

/// The state reported by `@X`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Status {
    pub moving: bool,
    pub waiting: bool,
    pub error: bool,
    pub position_unknown: bool,
    pub referencing: bool,
    pub job_running: bool,
}

impl Status {
    pub fn get(&self, flag: StatusFlag) -> bool {
        match flag {
            StatusFlag::Moving => self.moving,
            StatusFlag::Waiting => self.waiting,
            StatusFlag::Error => self.error,
            StatusFlag::PositionUnknown => self.position_unknown,
            StatusFlag::Referencing => self.referencing,
            StatusFlag::JobRunning => self.job_running,
        }
    }

    pub fn set(&mut self, flag: StatusFlag, on: bool) {
        let cell = match flag {
            StatusFlag::Moving => &mut self.moving,
            StatusFlag::Waiting => &mut self.waiting,
            StatusFlag::Error => &mut self.error,
            StatusFlag::PositionUnknown => &mut self.position_unknown,
            StatusFlag::Referencing => &mut self.referencing,
            StatusFlag::JobRunning => &mut self.job_running,
        };
        *cell = on;
    }

    /// The flags that are set, in wire order.
    pub fn flags(&self) -> impl Iterator<Item = StatusFlag> + '_ {
        StatusFlag::ALL.into_iter().filter(|f| self.get(*f))
    }

    /// The six characters `0`/`1` of the reply, in wire order.
    pub fn digits(&self) -> [u8; 6] {
        StatusFlag::ALL.map(|f| if self.get(f) { b'1' } else { b'0' })
    }

    /// From the six characters after `@X`; `None` unless exactly six `0`/`1`.
    pub fn from_digits(digits: &[u8]) -> Option<Status> {
        if digits.len() != StatusFlag::ALL.len() {
            return None;
        }
        let mut status = Status::default();
        for (flag, digit) in StatusFlag::ALL.into_iter().zip(digits) {
            match digit {
                b'0' => {}
                b'1' => status.set(flag, true),
                _ => return None,
            }
        }
        Some(status)
    }

    /// Something is still going on: motion, a wait, a reference run or a job.
    pub fn is_busy(&self) -> bool {
        self.moving || self.waiting || self.referencing || self.job_running
    }

    /// A reference run is needed before any defined move (manual 1.5.3:
    /// after an error, reset and reference; with an unknown position,
    /// reference).
    pub fn needs_reference(&self) -> bool {
        self.error || self.position_unknown
    }

    /// The interface must be reset (`@R`) first (manual 1.5.3).
    pub fn needs_reset(&self) -> bool {
        self.error
    }

    /// Idle, no error and a known position: a new move may be sent.
    pub fn ready_for_motion(&self) -> bool {
        !self.is_busy() && !self.needs_reference()
    }
}

impl fmt::Display for Status {
    /// `moving, position unknown` or `idle`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut any = false;
        for flag in self.flags() {
            if any {
                f.write_str(", ")?;
            }
            write!(f, "{flag}")?;
            any = true;
        }
        if !any {
            f.write_str("idle")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_round_trip_in_wire_order() {
        let status = Status {
            moving: true,
            position_unknown: true,
            referencing: true,
            ..Status::default()
        };
        assert_eq!(&status.digits(), b"100110");
        assert_eq!(Status::from_digits(b"100110"), Some(status));
        assert_eq!(Status::from_digits(b"10011"), None);
        assert_eq!(Status::from_digits(b"1001101"), None);
        assert_eq!(Status::from_digits(b"100112"), None);
        assert_eq!(status.to_string(), "moving, position unknown, referencing");
        assert_eq!(Status::default().to_string(), "idle");
    }

    #[test]
    fn readiness_follows_the_manual_advice() {
        assert!(Status::default().ready_for_motion());
        let error = Status {
            error: true,
            ..Status::default()
        };
        assert!(error.needs_reset() && error.needs_reference() && !error.ready_for_motion());
        let lost = Status {
            position_unknown: true,
            ..Status::default()
        };
        assert!(!lost.needs_reset() && lost.needs_reference());
        let waiting = Status {
            waiting: true,
            ..Status::default()
        };
        assert!(waiting.is_busy() && !waiting.ready_for_motion());
    }
}
