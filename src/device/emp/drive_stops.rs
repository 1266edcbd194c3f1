//! The stop frames an operation that moves drives asks for, and the
//! answers it waits for before it may end: an operation that ended while a
//! stop frame was unanswered would let the next one start on a drive that
//! is still braking.

use crate::proto::emp::DriveAddress;

#[derive(Debug, Default)]
pub struct DriveStops {
    stopping: bool,
    /// Drives whose stop frame has not been answered yet.
    unanswered: Vec<DriveAddress>,
    /// Drives the driver has yet to send a stop frame to.
    wanted: Vec<DriveAddress>,
}

impl DriveStops {
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// Every stop frame has been answered (or none was sent).
    pub fn answered(&self) -> bool {
        self.unanswered.is_empty()
    }

    /// The operation stops `drives` of its own accord (release, lease
    /// expiry, a fault); false when a stop is under way already.
    pub fn halt(&mut self, drives: Vec<DriveAddress>) -> bool {
        if self.stopping {
            return false;
        }
        self.stopping = true;
        self.unanswered.clone_from(&drives);
        self.wanted = drives;
        true
    }

    /// The operator stopped everything: the driver sends the frames to
    /// `drives` itself.
    pub fn stopped(&mut self, drives: &[DriveAddress]) {
        self.stopping = true;
        self.wanted.clear();
        for ds in drives {
            if !self.unanswered.contains(ds) {
                self.unanswered.push(*ds);
            }
        }
    }

    /// The stop frame to `ds` was answered (or rejected).
    pub fn answer(&mut self, ds: DriveAddress) {
        self.unanswered.retain(|d| *d != ds);
    }

    /// The drives the driver is to send stop frames to now.
    pub fn take(&mut self) -> Vec<DriveAddress> {
        std::mem::take(&mut self.wanted)
    }

    /// The link is gone: no answer will come.
    pub fn link_lost(&mut self) {
        self.stopping = true;
        self.unanswered.clear();
    }
}
