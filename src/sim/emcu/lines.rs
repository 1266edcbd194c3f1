//! What the interface does with a received command line (manual 1.4.2):
//! master commands at once, buffered ones into the data memory or, during an
//! `@F` transfer, into the ROM; every line is acknowledged, refused ones with
//! CR too, setting the error flag (decision 4).

use std::time::Instant;

use crate::proto::emcu::{Command, ParseError, Received, Reply, Terminator, VersionText};
use crate::traffic::readable;

use super::memory::Stored;
use super::{EmcuSim, VERSION};

// `VERSION` makes a version reply: checked when the crate compiles.
const _: () = assert!(VersionText::is_valid(VERSION));

impl EmcuSim {
    pub(super) fn on_line(&mut self, line: Received, now: Instant) {
        let last = line.terminator == Terminator::RunBuffer;
        match line.command {
            Ok(command) => self.execute(command, last, now),
            // An empty line is no command (`docs/protocols.md`, EMCU): a
            // console may send a bare CR to see that the line is alive.
            Err(_) if line.raw.is_empty() && !last => self.send(Reply::Ack),
            Err(error) => self.refuse(&line.raw, &error, last),
        }
    }

    fn execute(&mut self, command: Command, last: bool, now: Instant) {
        match command {
            Command::Reset => {
                // Manual 1.5.1: stop without ramp, positions 0 and lost,
                // memory cleared, configuration kept.
                self.send(Reply::Ack);
                self.abort(now);
                self.mech.zero_counters();
                self.position_unknown = true;
                self.error = false;
                self.last_error = None;
            }
            Command::Version => {
                // Never `Err`: checked at compile time (above).
                if let Ok(text) = VersionText::new(VERSION) {
                    self.send(Reply::Version(text));
                }
            }
            Command::Status => self.send(Reply::Status(self.current_status())),
            Command::Position(axis) => self.send(Reply::Position {
                axis,
                steps: self.mech.counter(axis, now),
            }),
            Command::Halt => {
                self.send(Reply::Ack);
                self.halt_job(now);
            }
            Command::Stop => {
                // Manual 1.5.12, decision 5.
                self.send(Reply::Ack);
                self.abort(now);
                self.position_unknown = true;
            }
            Command::Pause => {
                self.send(Reply::Ack);
                self.pause(now);
            }
            Command::Resume => {
                self.send(Reply::Ack);
                self.resume(now);
            }
            Command::StoreJob => {
                self.send(Reply::Ack);
                // Replacing the job that is running is refused.
                if self.exec.rom_next.is_some() {
                    self.flag_error("@F while the ROM job runs".into());
                } else {
                    self.rom.begin_transfer();
                }
            }
            Command::RunJob => {
                self.send(Reply::Ack);
                if !self.start_rom_job() {
                    self.flag_error(if self.exec.is_active() {
                        "@J while a job runs".into()
                    } else {
                        "@J without a stored job".into()
                    });
                    // No job was started: a console waiting for the job's
                    // 0x02 CR gets it at once, unless the job already running
                    // sends its own.
                    if !self.exec.is_active() {
                        self.send(Reply::Ready);
                    }
                }
            }
            Command::StartSpeed(_)
            | Command::EndSpeed { .. }
            | Command::Ramp(_)
            | Command::Reference(_)
            | Command::Move(_)
            | Command::SetOutput { .. }
            | Command::Wait(_)
            | Command::LinkE1(_) => self.store(command, last),
        }
    }

    /// A buffered command: into the ROM during a transfer (decision 2), else
    /// into the data memory (decision 1). A command the ROM store has no room
    /// for is answered 0x03 CR, the interface's only "memory full" (decision
    /// 1; `docs/protocols.md`, EMCU), and spoils the transfer.
    fn store(&mut self, command: Command, last: bool) {
        if self.rom.is_receiving() {
            if self.rom.receive(command, last, self.job_capacity) {
                self.send(Reply::Ack);
            } else {
                self.flag_error(format!("ROM job full: `{command}` not stored"));
                self.send(Reply::MemoryFull);
            }
            return;
        }
        match self.memory.store(command, last) {
            Stored::Room => self.send(Reply::Ack),
            Stored::Filled => {
                self.send(Reply::MemoryFull);
                self.exec.memory_armed = true;
            }
            Stored::Overflow => {
                self.flag_error(format!("data memory full: `{command}` lost"));
                self.send(Reply::MemoryFull);
            }
        }
        if last {
            self.exec.memory_armed = true;
        }
    }

    /// Decision 4: acknowledged with CR, not executed, error flag set. A
    /// refused line ended by 0x01 starts nothing (the batch is incomplete);
    /// when no job runs, 0x02 CR follows at once so that nobody waits for a
    /// run that never comes. During a transfer it spoils the ROM job.
    fn refuse(&mut self, raw: &[u8], error: &ParseError, last: bool) {
        self.flag_error(format!("refused `{}`: {error}", readable(raw)));
        self.send(Reply::Ack);
        if self.rom.is_receiving() {
            self.rom.refuse(last);
        } else if last && !self.exec.is_active() {
            self.send(Reply::Ready);
        }
    }

    /// Sets the `@X` error flag; `why` is for `describe`.
    fn flag_error(&mut self, why: String) {
        self.error = true;
        self.last_error = Some(why);
    }
}
