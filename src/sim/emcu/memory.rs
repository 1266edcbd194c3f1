//! Where buffered commands wait: the data memory (manual 1.4.2, decision 1)
//! and the ROM job store (manual 1.5.17/1.5.18, decision 2). Bookkeeping only;
//! running the commands is the executor's job.

use std::collections::VecDeque;

use crate::proto::emcu::Command;
use crate::proto::emcu::job::DATA_MEMORY_CAPACITY;

/// What storing a command in the data memory came to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Stored {
    /// Stored with room left: acknowledged with CR.
    Room,
    /// Stored in the last free cell: acknowledged with 0x03 CR (decision 1).
    Filled,
    /// The memory was already full: not stored, acknowledged with 0x03 CR.
    Overflow,
}

/// The data memory. A command keeps its cell until it has run, so room frees
/// when a command finishes, not when it starts (`docs/protocols.md`, EMCU).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct DataMemory {
    commands: VecDeque<Command>,
    /// A 0x03 CR was sent and its 0x02 CR ("room again") is still owed.
    room_owed: bool,
}

impl DataMemory {
    /// Stores a buffered command. `last_of_batch`: it ended with 0x01, so no
    /// more commands follow and no "room again" is owed for it.
    pub fn store(&mut self, command: Command, last_of_batch: bool) -> Stored {
        if self.commands.len() >= DATA_MEMORY_CAPACITY {
            self.room_owed = true;
            return Stored::Overflow;
        }
        self.commands.push_back(command);
        if self.commands.len() < DATA_MEMORY_CAPACITY {
            return Stored::Room;
        }
        if !last_of_batch {
            self.room_owed = true;
        }
        Stored::Filled
    }

    /// The command that runs next.
    pub fn front(&self) -> Option<Command> {
        self.commands.front().copied()
    }

    /// The front command has run and frees its cell. True when that owes
    /// the sender a 0x02 CR.
    pub fn finish_front(&mut self) -> bool {
        if self.commands.pop_front().is_some() {
            std::mem::take(&mut self.room_owed)
        } else {
            false
        }
    }

    /// Forgets every command. True when that owes the sender a 0x02 CR.
    pub fn clear(&mut self) -> bool {
        self.commands.clear();
        std::mem::take(&mut self.room_owed)
    }

    pub fn len(&self) -> usize {
        self.commands.len()
    }
}

/// The ROM job store.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) enum Rom {
    #[default]
    Empty,
    /// An `@F` transfer is under way; `broken` once a line was refused or
    /// did not fit, so the job is discarded when the transfer ends.
    Receiving {
        commands: Vec<Command>,
        broken: bool,
    },
    Stored(Vec<Command>),
}

impl Rom {
    /// `@F`: a new transfer replaces the stored job (decision 2).
    pub fn begin_transfer(&mut self) {
        *self = Rom::Receiving {
            commands: Vec::new(),
            broken: false,
        };
    }

    pub fn is_receiving(&self) -> bool {
        matches!(self, Rom::Receiving { .. })
    }

    /// Stores a command of the transfer in a store of `capacity` commands;
    /// `last` (ended by 0x01) ends it. False when the command did not fit.
    pub fn receive(&mut self, command: Command, last: bool, capacity: usize) -> bool {
        let fits = match self {
            Rom::Receiving { commands, broken } => {
                let fits = commands.len() < capacity;
                if fits {
                    commands.push(command);
                } else {
                    *broken = true;
                }
                fits
            }
            Rom::Empty | Rom::Stored(_) => false,
        };
        if last {
            self.end_transfer();
        }
        fits
    }

    /// A refused line during the transfer spoils the job; when it was ended
    /// by 0x01 it also ends the transfer.
    pub fn refuse(&mut self, last: bool) {
        if let Rom::Receiving { broken, .. } = self {
            *broken = true;
        }
        if last {
            self.end_transfer();
        }
    }

    fn end_transfer(&mut self) {
        if let Rom::Receiving { commands, broken } = self {
            *self = if *broken {
                Rom::Empty
            } else {
                Rom::Stored(std::mem::take(commands))
            };
        }
    }

    /// `@R`/`@S` during a transfer: the half-sent job is gone.
    pub fn abort_transfer(&mut self) {
        if self.is_receiving() {
            *self = Rom::Empty;
        }
    }

    /// The command at `index` of the stored job.
    pub fn command(&self, index: usize) -> Option<Command> {
        match self {
            Rom::Stored(commands) => commands.get(index).copied(),
            Rom::Empty | Rom::Receiving { .. } => None,
        }
    }

    pub fn has_job(&self) -> bool {
        matches!(self, Rom::Stored(_))
    }

    /// Commands stored or received so far.
    pub fn len(&self) -> usize {
        match self {
            Rom::Empty => 0,
            Rom::Receiving { commands, .. } | Rom::Stored(commands) => commands.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::emcu::job::JOB_CAPACITY;

    fn wait() -> Command {
        "W1".parse().unwrap()
    }

    #[test]
    fn the_command_that_fills_the_memory_owes_a_ready_when_room_frees() {
        let mut m = DataMemory::default();
        for _ in 1..DATA_MEMORY_CAPACITY {
            assert_eq!(m.store(wait(), false), Stored::Room);
        }
        assert_eq!(m.store(wait(), false), Stored::Filled);
        assert_eq!(m.store(wait(), false), Stored::Overflow);
        assert_eq!(m.len(), DATA_MEMORY_CAPACITY);
        assert!(m.finish_front());
        assert!(!m.finish_front(), "owed once");
    }

    #[test]
    fn a_batch_ending_in_the_last_cell_owes_no_room_notice() {
        let mut m = DataMemory::default();
        for _ in 1..DATA_MEMORY_CAPACITY {
            m.store(wait(), false);
        }
        assert_eq!(m.store(wait(), true), Stored::Filled);
        assert!(!m.finish_front());
        assert!(!m.clear());
    }

    #[test]
    fn a_spoilt_transfer_stores_nothing() {
        let mut rom = Rom::default();
        rom.begin_transfer();
        assert!(rom.receive(wait(), false, JOB_CAPACITY));
        rom.refuse(false);
        assert!(rom.receive(wait(), true, JOB_CAPACITY));
        assert_eq!(rom, Rom::Empty);
        rom.begin_transfer();
        assert!(rom.receive(wait(), true, JOB_CAPACITY));
        assert!(rom.has_job());
        assert_eq!(rom.command(0), Some(wait()));
        assert_eq!(rom.command(1), None);
    }

    #[test]
    fn the_rom_holds_the_job_capacity() {
        let mut rom = Rom::default();
        rom.begin_transfer();
        for _ in 0..JOB_CAPACITY {
            assert!(rom.receive(wait(), false, JOB_CAPACITY));
        }
        assert!(!rom.receive(wait(), true, JOB_CAPACITY));
        assert_eq!(rom, Rom::Empty);
    }

    #[test]
    fn a_smaller_store_refuses_the_command_beyond_it() {
        let mut rom = Rom::default();
        rom.begin_transfer();
        assert!(rom.receive(wait(), false, 2));
        assert!(rom.receive(wait(), false, 2));
        assert!(!rom.receive(wait(), false, 2));
        assert!(rom.is_receiving(), "the transfer goes on to its 0x01 line");
        assert!(!rom.receive(wait(), true, 2));
        assert_eq!(rom, Rom::Empty);
    }
}
