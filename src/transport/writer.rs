//! The paced writer: a std thread that owns a dup of the port's fd and writes
//! queued messages no faster than the line carries them, with a priority lane
//! for stop bytes.
//!
//! It runs on a std thread because the pacing is finer than tokio's 1 ms
//! timer: a byte takes 0.52 ms at 19200 baud (`docs/architecture.md`,
//! "Timing decisions"). Everything it does is reported back on a channel, so
//! the device task knows when a command has left and the traffic console sees
//! the bytes as they went out.
//!
//! How much goes in one write (issue 18, `docs/performance.md`, "Whole
//! commands"): a frame that must not be cut (an EMCU line, an EMP frame)
//! whole, since a stop waits for its end anyway; any other message (isel)
//! in chunks that keep at most the whole backlog (1.6 ms, three bytes at
//! 19200 baud) ahead of the wire, so a stop overtakes it within that. A
//! message sent while the thread is idle has its first write made from the
//! caller's thread before `send` returns: a poll then costs no thread
//! hand-over (an EMCU or EMP poll none at all, an isel `@0P` CR one, for
//! its CR, with 1 ms to spare before the line would idle).

use std::collections::VecDeque;
use std::io;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant, SystemTime};

use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};

use super::error::TransportError;
use super::fd;
use super::pacing::{Pace, Pacer};
use super::sink::{Sink, Taken};
use crate::traffic::{Direction, TrafficRecord};
use crate::wire::LineSettings;

/// Identifies one message handed to the writer; reports carry it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MessageId(pub u64);

/// Where a stop may be put relative to a message being written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interleave {
    /// A stop may go between any two bytes. isel: the controller reads the
    /// control bytes 0xFD/0xFE/0xFF in its receive interrupt, also in the
    /// middle of a command (`docs/architecture.md`, `docs/decisions.md` isel).
    BetweenBytes,
    /// The message is a frame that must not be split (EMCU lines, EMP frames):
    /// a stop waits until the frame has been handed over completely.
    WholeMessage,
}

/// Which lane a chunk was written from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lane {
    Normal,
    Stop,
}

/// Bytes actually handed to the port, in the order they were written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WrittenChunk {
    pub id: MessageId,
    pub lane: Lane,
    pub bytes: Vec<u8>,
    /// When the write returned.
    pub at: Instant,
    /// The same moment as wall-clock time, for the traffic console and logs.
    pub wall: SystemTime,
    /// Modelled: when the chunk's first byte starts on the wire (after what
    /// the OS buffer already held).
    pub wire_start: Instant,
    /// Modelled: when the chunk's last byte has left the wire.
    pub wire_end: Instant,
    /// This chunk completes the message.
    pub done: bool,
}

impl WrittenChunk {
    pub fn traffic(&self) -> TrafficRecord {
        TrafficRecord {
            at: self.wall,
            direction: Direction::Sent,
            bytes: self.bytes.clone(),
            messages: Vec::new(),
        }
    }
}

/// What the writer thread reports.
#[derive(Debug)]
pub enum WriterEvent {
    Written(WrittenChunk),
    /// A queued message was dropped by [`PacedWriter::cancel_queued`] before
    /// any byte of it was written.
    Cancelled {
        id: MessageId,
    },
    /// A stop was written but the port did not confirm within the bound that
    /// it has left (`tcdrain`); the writer goes on.
    DrainTimedOut {
        id: MessageId,
        waited: Duration,
    },
    /// Writing failed (usually [`TransportError::LinkLost`]); the thread has
    /// ended and nothing more will be written.
    Failed(TransportError),
}

/// Tuning of the paced writer.
#[derive(Debug, Clone, Copy)]
pub struct WriterConfig {
    /// Most not-yet-transmitted time the OS buffer may hold (at slow rates at
    /// least 1.5 byte times, see [`Pacer::new`]).
    pub max_backlog: Duration,
    /// The same for [`Pace::Bulk`] messages (sent with
    /// [`PacedWriter::send_bulk`]).
    pub bulk_backlog: Duration,
    /// Most not-yet-transmitted time the OS buffer may hold of a message
    /// that may be cut (isel), written in as few writes as fit
    /// ([`Pacer::chunk_allowance`]): `@0P` CR at 19200 baud goes as `@0P`
    /// and, 0.5 ms later, CR, instead of one byte per writer wake-up, and
    /// a late wake-up has 1 ms before the line idles. A stop waits for at
    /// most this. Frames that must not be cut go whole regardless.
    pub whole_backlog: Duration,
    /// Bound on waiting for stop bytes to drain from a terminal.
    pub drain_timeout: Duration,
}

impl Default for WriterConfig {
    fn default() -> Self {
        Self {
            max_backlog: Duration::from_millis(1),
            // 7 bytes at 19200 baud, 15 at 38400: a writer wake-up up to
            // 3.5 ms late still finds bytes on the wire. Measured (benches/editor.rs,
            // 1000-line isel upload at 19200): 1 ms keeps 92–94 % of the
            // wire limit, 4 ms 98.6 %.
            bulk_backlog: Duration::from_millis(4),
            // Three bytes at 19200 baud: a stop still reaches the wire
            // within 2 ms at p99 (the first draft wrote `@0P` CR whole,
            // 2.1 ms, and measured p99 2.06 ms: a stop asked for just
            // after a command was written waits for all of it).
            // docs/performance.md, "Whole commands".
            whole_backlog: Duration::from_micros(1600),
            drain_timeout: Duration::from_millis(250),
        }
    }
}

enum Command {
    Send(Pending),
    /// A message the handle has begun writing directly: its rest, from
    /// the given offset, goes before anything sent later.
    Resume(Pending, usize),
    Stop(Pending),
    Cancel,
    Shutdown,
}

struct Pending {
    id: MessageId,
    bytes: Vec<u8>,
    interleave: Interleave,
    pace: Pace,
}

/// Handle to the writer thread. Dropping it ends the thread as
/// [`PacedWriter::close`] does; messages not started are then dropped
/// without reports.
#[derive(Debug)]
pub struct PacedWriter {
    port: String,
    commands: mpsc::Sender<Command>,
    line: Arc<Mutex<Line>>,
    direct: Direct,
    next_id: AtomicU64,
    thread: Option<JoinHandle<()>>,
}

/// What the handle and the writer thread share. Whoever writes holds it
/// for the write and the model's update.
#[derive(Debug)]
struct Line {
    pacer: Pacer,
    /// How the last message handed over whole may be cut: decides whether
    /// the far end may drop what it still holds before a stop.
    last_interleave: Option<Interleave>,
    /// The thread has something to do (a message, a stop, a command on
    /// the channel): a message sent now queues behind it. Set by the handle
    /// as it hands the thread a command, cleared by the thread when it has
    /// nothing left and the channel is empty, both under this lock.
    busy: bool,
}

fn lock(line: &Mutex<Line>) -> MutexGuard<'_, Line> {
    line.lock().unwrap_or_else(|p| p.into_inner())
}

/// The handle's own way to the port: a message sent while the thread is
/// idle and the line can take it whole is written at once from the
/// caller's thread, instead of waking the writer thread to write it. On a
/// request/reply poll that saves one thread hand-over per exchange (about
/// 0.1-0.2 ms, issue 18: up to 4 % of an EMCU `@LX` exchange).
#[derive(Debug)]
struct Direct {
    sink: Sink,
    events: UnboundedSender<WriterEvent>,
}

impl std::fmt::Debug for Command {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Command::Send(p) => write!(f, "Send({:?})", p.id),
            Command::Resume(p, n) => write!(f, "Resume({:?}, {n})", p.id),
            Command::Stop(p) => write!(f, "Stop({:?})", p.id),
            Command::Cancel => f.write_str("Cancel"),
            Command::Shutdown => f.write_str("Shutdown"),
        }
    }
}

impl PacedWriter {
    pub(crate) fn spawn(
        sink: Sink,
        port: String,
        line: LineSettings,
        config: WriterConfig,
    ) -> Result<(Self, UnboundedReceiver<WriterEvent>), TransportError> {
        let (commands, command_rx) = mpsc::channel();
        let (events, event_rx) = unbounded_channel();
        let shared = Arc::new(Mutex::new(Line {
            pacer: Pacer::new(line, config.max_backlog)
                .with_bulk_backlog(config.bulk_backlog)
                .with_whole_backlog(config.whole_backlog),
            last_interleave: None,
            busy: false,
        }));
        let direct = Direct {
            sink: sink.try_clone().map_err(|source| TransportError::Io {
                port: port.clone(),
                action: "duplicating the fd for direct writes",
                source,
            })?,
            events: events.clone(),
        };
        let worker = Worker {
            sink,
            line: shared.clone(),
            port: port.clone(),
            drain_timeout: config.drain_timeout,
            queue: VecDeque::new(),
            stops: VecDeque::new(),
            current: None,
            blocked_until: None,
            commands: command_rx,
            events,
        };
        let thread = thread::Builder::new()
            .name(format!("jogterm-writer {port}"))
            .spawn(move || worker.run())
            .map_err(|source| TransportError::Io {
                port: port.clone(),
                action: "starting the writer thread",
                source,
            })?;
        Ok((
            Self {
                port,
                commands,
                line: shared,
                direct,
                next_id: AtomicU64::new(1),
                thread: Some(thread),
            },
            event_rx,
        ))
    }

    /// Queue a message behind those already queued.
    pub fn send(
        &self,
        bytes: impl Into<Vec<u8>>,
        interleave: Interleave,
    ) -> Result<MessageId, TransportError> {
        self.queue(bytes.into(), interleave, Pace::Tight)
    }

    /// Queue a message that may run up to `bulk_backlog` ahead of the wire
    /// ([`Pace::Bulk`]): only for streams during which nothing moves.
    pub fn send_bulk(
        &self,
        bytes: impl Into<Vec<u8>>,
        interleave: Interleave,
    ) -> Result<MessageId, TransportError> {
        self.queue(bytes.into(), interleave, Pace::Bulk)
    }

    fn queue(
        &self,
        bytes: Vec<u8>,
        interleave: Interleave,
        pace: Pace,
    ) -> Result<MessageId, TransportError> {
        let id = self.id();
        let pending = Pending {
            id,
            bytes,
            interleave,
            pace,
        };
        let mut line = lock(&self.line);
        let pending = if line.busy {
            Some((pending, 0))
        } else {
            self.write_directly(&mut line, pending)
        };
        if let Some((pending, written)) = pending {
            line.busy = true;
            // Sent under the lock: the thread cannot go idle between.
            let command = if written == 0 {
                Command::Send(pending)
            } else {
                Command::Resume(pending, written)
            };
            self.command(command)?;
        }
        Ok(id)
    }

    /// The thread is idle: write what the line takes of `pending` now (a
    /// frame that must not be cut whole, whenever a byte may go; any other
    /// message as much as `Pacer::chunk_allowance` lets). What is left (the
    /// rest, nothing fitted, an error: the thread meets it again and
    /// reports it) goes to the thread, with how much was written.
    fn write_directly(&self, line: &mut Line, pending: Pending) -> Option<(Pending, usize)> {
        let now = Instant::now();
        let len = pending.bytes.len();
        let frame = (pending.interleave == Interleave::WholeMessage).then_some(pending.id.0);
        let n = if frame.is_some() {
            if line.pacer.allowance_for(pending.pace, now) > 0 {
                len
            } else {
                0
            }
        } else {
            line.pacer.chunk_allowance(pending.pace, now).min(len)
        };
        if n == 0 {
            return Some((pending, 0));
        }
        let written = match self.direct.sink.write_part(frame, &pending.bytes, n) {
            Ok(Taken::Bytes(w)) => w,
            Ok(Taken::CompletedElsewhere) | Err(_) => 0,
        };
        if written == 0 {
            return Some((pending, 0));
        }
        let at = Instant::now();
        let (wire_start, wire_end) = line.pacer.wrote(written, at);
        let done = written >= len;
        if done {
            line.last_interleave = Some(pending.interleave);
        }
        let _ = self.direct.events.send(WriterEvent::Written(WrittenChunk {
            id: pending.id,
            lane: Lane::Normal,
            bytes: pending.bytes.get(..written).unwrap_or_default().to_vec(),
            at,
            wall: SystemTime::now(),
            wire_start,
            wire_end,
            done,
        }));
        (!done).then_some((pending, written))
    }

    /// Write stop bytes ahead of everything queued: at once between two bytes
    /// of a [`Interleave::BetweenBytes`] message, right after a
    /// [`Interleave::WholeMessage`] message being written. Then the port is
    /// drained (`tcdrain` on a terminal, bounded) before the report is sent.
    pub fn stop(&self, bytes: impl Into<Vec<u8>>) -> Result<MessageId, TransportError> {
        let id = self.id();
        self.command_busy(Command::Stop(Pending {
            id,
            bytes: bytes.into(),
            interleave: Interleave::WholeMessage,
            pace: Pace::Tight,
        }))?;
        Ok(id)
    }

    /// Drop every queued message that has not started; each is reported as
    /// [`WriterEvent::Cancelled`]. A message already partly written is
    /// finished, so the line never carries a truncated command or frame.
    pub fn cancel_queued(&self) -> Result<(), TransportError> {
        self.command_busy(Command::Cancel)
    }

    /// End the thread and wait for it: the stops handed over are written
    /// and a message partly written is completed (bounded, past the pacer);
    /// queued messages not started are dropped.
    pub fn close(mut self) {
        self.shut_down();
    }

    fn id(&self) -> MessageId {
        MessageId(self.next_id.fetch_add(1, Ordering::Relaxed))
    }

    /// Hand the thread a command (the line marked busy first).
    fn command_busy(&self, command: Command) -> Result<(), TransportError> {
        let mut line = lock(&self.line);
        line.busy = true;
        self.command(command)
    }

    fn command(&self, command: Command) -> Result<(), TransportError> {
        self.commands
            .send(command)
            .map_err(|_| TransportError::WriterStopped {
                port: self.port.clone(),
            })
    }

    fn shut_down(&mut self) {
        let _ = self.command_busy(Command::Shutdown);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for PacedWriter {
    fn drop(&mut self) {
        self.shut_down();
    }
}

struct Current {
    pending: Pending,
    written: usize,
}

impl Current {
    /// The sink's tag for a message that must not be cut (`Sink::write_part`).
    fn frame(&self) -> Option<u64> {
        (self.pending.interleave == Interleave::WholeMessage).then_some(self.pending.id.0)
    }
}

struct Worker {
    /// The port's fd and what its link does to the bytes (`sink.rs`).
    sink: Sink,
    /// The line's model, shared with the handle's direct writes.
    line: Arc<Mutex<Line>>,
    port: String,
    drain_timeout: Duration,
    queue: VecDeque<Pending>,
    stops: VecDeque<Pending>,
    current: Option<Current>,
    /// The OS buffer was full (EAGAIN): try again no earlier than this.
    blocked_until: Option<Instant>,
    commands: mpsc::Receiver<Command>,
    events: UnboundedSender<WriterEvent>,
}

enum Flow {
    Continue,
    Exit,
    /// Nothing to do; the handle may write directly.
    Idle,
}

impl Worker {
    fn run(mut self) {
        fd::tighten_timer_slack();
        loop {
            loop {
                match self.commands.try_recv() {
                    Ok(command) => {
                        if let Flow::Exit = self.accept(command) {
                            return;
                        }
                    }
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return,
                }
            }
            if let Err(e) = self.step() {
                self.report(WriterEvent::Failed(e));
                return;
            }
            let received = match self.wake_at() {
                None => match self.go_idle() {
                    Flow::Continue => continue,
                    Flow::Exit => return,
                    Flow::Idle => self
                        .commands
                        .recv()
                        .map_err(|_| RecvTimeoutError::Disconnected),
                },
                Some(at) => self
                    .commands
                    .recv_timeout(at.saturating_duration_since(Instant::now())),
            };
            match received {
                Ok(command) => {
                    if let Flow::Exit = self.accept(command) {
                        return;
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
        }
    }

    /// Nothing to do: let the handle write directly ([`Flow::Idle`]),
    /// unless a command came meanwhile (it is taken; the thread goes on).
    /// Under the line's lock, which the handle holds while it sends
    /// commands.
    fn go_idle(&mut self) -> Flow {
        let mut line = lock(&self.line);
        match self.commands.try_recv() {
            Ok(command) => {
                drop(line);
                self.accept(command)
            }
            Err(TryRecvError::Empty) => {
                line.busy = false;
                Flow::Idle
            }
            Err(TryRecvError::Disconnected) => Flow::Exit,
        }
    }

    fn accept(&mut self, command: Command) -> Flow {
        match command {
            Command::Send(p) => self.queue.push_back(p),
            // The thread was idle when the handle began it: nothing is
            // current or queued ahead of it.
            Command::Resume(pending, written) => match self.current.take() {
                None => self.current = Some(Current { pending, written }),
                Some(other) => {
                    self.queue.push_front(other.pending);
                    self.current = Some(Current { pending, written });
                }
            },
            Command::Stop(p) => self.stops.push_back(p),
            Command::Cancel => {
                for p in std::mem::take(&mut self.queue) {
                    self.report(WriterEvent::Cancelled { id: p.id });
                }
            }
            Command::Shutdown => {
                if let Err(e) = self.close_cleanly() {
                    self.report(WriterEvent::Failed(e));
                }
                return Flow::Exit;
            }
        }
        Flow::Continue
    }

    /// The port is about to close. The stops asked for go out, and a
    /// message partly on the line is completed: a fragment left behind
    /// would be completed by the next connection's first bytes into a
    /// malformed line (an EMCU `@…` plus the leading CR of `\r@B\r` sets
    /// the error flag, docs/protocols.md EMCU). Messages not started are
    /// dropped, as a close promises.
    fn close_cleanly(&mut self) -> Result<(), TransportError> {
        self.queue.clear();
        if self.current.as_ref().is_some_and(|c| c.written == 0) {
            self.current = None;
        }
        if !self.stops.is_empty() {
            self.write_stops()?;
        }
        self.finish_current_at_once()
    }

    /// The stops asked for, now. A frame on its way must not be split: its
    /// rest is handed over at once and the stops follow directly behind it;
    /// a message that may be interleaved gets them between two bytes.
    fn write_stops(&mut self) -> Result<(), TransportError> {
        let whole = self
            .current
            .as_ref()
            .is_some_and(|c| c.pending.interleave == Interleave::WholeMessage);
        if whole {
            self.finish_current_at_once()?;
        }
        self.discard_remote_queue()?;
        while let Some(stop) = self.stops.pop_front() {
            self.write_stop(stop)?;
        }
        Ok(())
    }

    fn wake_at(&self) -> Option<Instant> {
        if self.current.is_none() && self.queue.is_empty() && self.stops.is_empty() {
            return None;
        }
        let now = Instant::now();
        let head = self
            .current
            .as_ref()
            .map(|c| &c.pending)
            .or(self.queue.front());
        let pace = head.map_or(Pace::Tight, |p| p.pace);
        let line = lock(&self.line);
        let ready = match head.map(|p| p.interleave) {
            Some(Interleave::BetweenBytes) => line.pacer.chunk_ready_at(pace, now),
            _ => line.pacer.ready_at_for(pace, now),
        };
        Some(self.blocked_until.map_or(ready, |b| b.max(ready)))
    }

    /// Write whatever may be written now.
    fn step(&mut self) -> Result<(), TransportError> {
        loop {
            if !self.stops.is_empty() {
                if self.current.as_ref().is_some_and(|c| c.written == 0) {
                    // Nothing of it is on the way yet: the stop goes first.
                    if let Some(cur) = self.current.take() {
                        self.queue.push_front(cur.pending);
                    }
                }
                self.write_stops()?;
            }
            if self.current.is_none() {
                match self.queue.pop_front() {
                    Some(pending) => {
                        self.current = Some(Current {
                            pending,
                            written: 0,
                        })
                    }
                    None => return Ok(()),
                }
            }
            if !self.write_paced()? {
                return Ok(());
            }
        }
    }

    /// Hand over as many bytes of the current message as the pacer allows.
    /// Returns true when the message was completed (the caller moves on).
    fn write_paced(&mut self) -> Result<bool, TransportError> {
        let now = Instant::now();
        if self.blocked_until.is_some_and(|b| now < b) {
            return Ok(false);
        }
        let Some(cur) = self.current.as_mut() else {
            return Ok(false);
        };
        let rest = cur.pending.bytes.get(cur.written..).unwrap_or_default();
        if rest.is_empty() {
            // An empty message is complete as soon as it is its turn.
            let id = cur.pending.id;
            self.current = None;
            self.report_chunk(id, Lane::Normal, Vec::new(), now, true);
            return Ok(true);
        }
        let pace = cur.pending.pace;
        let frame = cur.frame();
        // A frame that must not be cut goes in one write once a byte may go:
        // a stop waits for its end anyway. Any other message goes in chunks
        // of the whole backlog.
        let n = {
            let line = lock(&self.line);
            match frame {
                Some(_) if line.pacer.allowance_for(pace, now) > 0 => rest.len(),
                Some(_) => 0,
                None => line.pacer.chunk_allowance(pace, now).min(rest.len()),
            }
        };
        if n == 0 {
            return Ok(false);
        }
        match self.sink.write_part(frame, rest, n) {
            Ok(Taken::Bytes(0)) => {
                self.blocked_until = Some(now + lock(&self.line).pacer.byte_time());
                Ok(false)
            }
            Ok(Taken::Bytes(w)) => {
                self.blocked_until = None;
                let bytes = rest.get(..w).unwrap_or_default().to_vec();
                let id = cur.pending.id;
                cur.written += w;
                let done = cur.written >= cur.pending.bytes.len();
                if done {
                    lock(&self.line).last_interleave = Some(cur.pending.interleave);
                    self.current = None;
                }
                let at = Instant::now();
                let (wire_start, wire_end) = lock(&self.line).pacer.wrote(w, at);
                self.send_chunk(id, Lane::Normal, bytes, at, wire_start, wire_end, done);
                Ok(done)
            }
            Ok(Taken::CompletedElsewhere) => {
                self.completed_elsewhere();
                Ok(true)
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                self.blocked_until = Some(now + lock(&self.line).pacer.byte_time());
                Ok(false)
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => Ok(false),
            Err(e) => Err(TransportError::from_io(&self.port, "write", e)),
        }
    }

    /// The emergency handle wrote the rest of the current frame ahead of
    /// its stop: report it written (the device task counts on every
    /// message's end) and go on with the next.
    fn completed_elsewhere(&mut self) {
        let Some(cur) = self.current.take() else {
            return;
        };
        let rest = cur.pending.bytes.get(cur.written..).unwrap_or_default();
        lock(&self.line).last_interleave = Some(cur.pending.interleave);
        let at = Instant::now();
        let (wire_start, wire_end) = lock(&self.line).pacer.wrote(rest.len(), at);
        self.send_chunk(
            cur.pending.id,
            Lane::Normal,
            rest.to_vec(),
            at,
            wire_start,
            wire_end,
            true,
        );
    }

    fn finish_current_at_once(&mut self) -> Result<(), TransportError> {
        let Some(cur) = self.current.take() else {
            return Ok(());
        };
        let rest = cur.pending.bytes.get(cur.written..).unwrap_or_default();
        let frame = cur.frame();
        lock(&self.line).last_interleave = Some(cur.pending.interleave);
        self.write_whole(cur.pending.id, frame, Lane::Normal, rest)
    }

    /// Before a stop, ask the far end to drop what it has not yet put on
    /// the serial line (RFC 2217 PURGE-DATA; `Sink::discard_queued`), when
    /// that cannot hurt: only at a message boundary on our side (a message
    /// we are still handing over would lose its middle and be completed
    /// into another command), and only after messages whose stop may cut
    /// them (isel: 0xFD/0xFF act between any two bytes, manual 2.2.31; a
    /// cut EMCU line or EMP frame would swallow the stop frame behind it).
    /// What the far end held is then never completed by us. Failure to ask
    /// is no reason to hold the stop back.
    fn discard_remote_queue(&mut self) -> Result<(), TransportError> {
        if self.current.is_some()
            || lock(&self.line).last_interleave != Some(Interleave::BetweenBytes)
            || !self.sink.can_discard()
        {
            return Ok(());
        }
        let deadline = Instant::now() + self.drain_timeout;
        match self.sink.discard_queued(deadline) {
            Ok(_) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(()),
            Err(e) => Err(TransportError::from_io(&self.port, "purge", e)),
        }
    }

    fn write_stop(&mut self, stop: Pending) -> Result<(), TransportError> {
        self.write_whole(stop.id, None, Lane::Stop, &stop.bytes)?;
        if self.sink.is_tty() {
            // To be sure a stop has left: write_all, then tcdrain
            // (`docs/field-notes.md`, "Serial ports").
            match fd::drain_bounded(self.sink.fd(), self.drain_timeout) {
                Ok(true) => {}
                Ok(false) => self.report(WriterEvent::DrainTimedOut {
                    id: stop.id,
                    waited: self.drain_timeout,
                }),
                Err(e) => return Err(TransportError::from_io(&self.port, "tcdrain", e)),
            }
        }
        Ok(())
    }

    /// `write_all` past the pacer: for stops and the rest of a frame ahead of
    /// a stop. Bounded so a wedged port cannot hold the thread for ever.
    fn write_whole(
        &mut self,
        id: MessageId,
        frame: Option<u64>,
        lane: Lane,
        bytes: &[u8],
    ) -> Result<(), TransportError> {
        let deadline = Instant::now() + self.drain_timeout;
        let taken = self.sink.write_rest_until(frame, bytes, deadline);
        taken.map_err(|e| {
            if e.kind() == io::ErrorKind::TimedOut {
                TransportError::DrainTimeout {
                    port: self.port.clone(),
                    waited: self.drain_timeout,
                }
            } else {
                TransportError::from_io(&self.port, "write", e)
            }
        })?;
        let at = Instant::now();
        let (wire_start, wire_end) = lock(&self.line).pacer.wrote(bytes.len(), at);
        self.send_chunk(id, lane, bytes.to_vec(), at, wire_start, wire_end, true);
        Ok(())
    }

    fn report_chunk(&self, id: MessageId, lane: Lane, bytes: Vec<u8>, at: Instant, done: bool) {
        let wire = lock(&self.line).pacer.wire_free_at(at);
        self.send_chunk(id, lane, bytes, at, wire, wire, done);
    }

    #[allow(clippy::too_many_arguments)]
    fn send_chunk(
        &self,
        id: MessageId,
        lane: Lane,
        bytes: Vec<u8>,
        at: Instant,
        wire_start: Instant,
        wire_end: Instant,
        done: bool,
    ) {
        self.report(WriterEvent::Written(WrittenChunk {
            id,
            lane,
            bytes,
            at,
            wall: SystemTime::now(),
            wire_start,
            wire_end,
            done,
        }));
    }

    fn report(&self, event: WriterEvent) {
        // Nobody listening is not an error: the device task may be gone.
        let _ = self.events.send(event);
    }
}
