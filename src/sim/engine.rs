//! The simulator shell's core, sans-IO: the wire model in both directions and
//! the fault injection, around one [`SimDevice`]. The shell's thread only
//! feeds it the bytes it read (with the time it read them), asks it when to
//! wake next, and writes out the bytes that have become due.
//!
//! Wire model (`docs/architecture.md`, "Timing decisions"):
//! - receive: a byte read at `t` arrives at `max(t, previous arrival) + one
//!   byte time`; the device gets `on_byte` at that time, never before.
//! - send: a message the device produces at `t` starts on the wire at
//!   `max(t, line free)`; its byte `k` (0-based) is due at `start + (k + 1)`
//!   byte times and is not handed out before. So a request/reply cycle can
//!   never be faster than the real line.
//! - delivery: like the receiving UART of a host, the shell hands bytes over
//!   in chunks of [`HOST_RX_FIFO_TRIGGER`] (a 16550's receive FIFO interrupts
//!   at that fill level, a USB adapter sends a packet), and the last byte of
//!   every message exactly when it is due. Handing each byte over on its own
//!   would wake the client once per byte, which no real serial port does.
//!
//! Time handed to the device is the modelled time of each event (arrival,
//! deadline), not the wall clock at which the thread got round to it, so the
//! thread's wake-up latency does not add up from one cycle to the next.

use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, Instant};

use super::fault::{ArmedFaults, Fault};
use super::{InputControl, SimDevice, Timed, TimedControl};
use crate::wire::LineSettings;

/// Counters for `show`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WireStats {
    pub bytes_received: u64,
    pub bytes_sent: u64,
    pub messages_sent: u64,
    pub messages_withheld: u64,
    pub bytes_dropped: u64,
    pub bytes_corrupted: u64,
    pub garbage_bytes: u64,
}

/// When the shell should next call `run_until`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wake {
    pub at: Instant,
    /// The wake-up hands out the last byte of a message: a client waiting for
    /// the whole reply sees it at this moment, so it should be met as exactly
    /// as the machine allows, not with the kernel's usual timer lateness.
    pub exact: bool,
}

#[derive(Debug, Clone, Copy)]
struct Outgoing {
    byte: u8,
    due: Instant,
    ends_message: bool,
}

/// The device and its wire, advanced by the caller.
pub struct Engine {
    device: Box<dyn SimDevice>,
    line: LineSettings,
    /// The latest time handed to the device; it never goes backwards.
    clock: Option<Instant>,
    last_arrival: Option<Instant>,
    incoming: VecDeque<(u8, Instant)>,
    /// Bytes on their way out, each with the time it is due at the receiver.
    outgoing: VecDeque<Outgoing>,
    line_free: Option<Instant>,
    armed: ArmedFaults,
    /// A deadline the device kept reporting after it was served; ignored so a
    /// misbehaving model cannot make the shell spin.
    stale_deadline: Option<Instant>,
    stats: WireStats,
    /// Operator controls due later (`pulse`, `chatter`, `after`), by time,
    /// ties in the order they were given.
    scheduled: BTreeMap<(Instant, u64), InputControl>,
    scheduled_count: u64,
}

/// Most changes one `chatter` may make.
pub const MAX_CHATTER_CHANGES: u32 = 10_000;

/// Bytes handed over together at most, unless a message ends first: the
/// receive trigger level Linux sets on a 16550A (8 of its 16 bytes).
pub const HOST_RX_FIFO_TRIGGER: usize = 8;

/// Upper bound on events handled in one `run_until`, against models that
/// generate work without end.
const MAX_EVENTS_PER_RUN: usize = 100_000;

impl Engine {
    pub fn new(device: Box<dyn SimDevice>) -> Self {
        let line = device.line();
        Self {
            device,
            line,
            clock: None,
            last_arrival: None,
            incoming: VecDeque::new(),
            outgoing: VecDeque::new(),
            line_free: None,
            armed: ArmedFaults::default(),
            stale_deadline: None,
            stats: WireStats::default(),
            scheduled: BTreeMap::new(),
            scheduled_count: 0,
        }
    }

    pub fn line(&self) -> LineSettings {
        self.line
    }

    pub fn stats(&self) -> WireStats {
        self.stats
    }

    pub fn armed(&self) -> &ArmedFaults {
        &self.armed
    }

    /// Bytes read from the line at `read_at`.
    pub fn receive(&mut self, bytes: &[u8], read_at: Instant) {
        let byte_time = self.line.byte_time();
        for &b in bytes {
            let start = self.last_arrival.map_or(read_at, |prev| prev.max(read_at));
            let arrival = start + byte_time;
            self.last_arrival = Some(arrival);
            self.incoming.push_back((b, arrival));
        }
        self.stats.bytes_received += bytes.len() as u64;
    }

    /// When `run_until` next has something to do; `None`: nothing pending.
    pub fn next_wake(&self) -> Option<Wake> {
        // The output wake-up hands over a whole receive-FIFO chunk: it is due
        // when the chunk's last byte is, or a message's last byte if sooner.
        let output = self
            .outgoing
            .iter()
            .take(HOST_RX_FIFO_TRIGGER)
            .position(|o| o.ends_message)
            .or_else(|| self.outgoing.len().checked_sub(1))
            .map(|i| i.min(HOST_RX_FIFO_TRIGGER - 1))
            .and_then(|i| self.outgoing.get(i))
            .map(|o| Wake {
                at: o.due,
                exact: o.ends_message,
            });
        let other = [
            self.incoming.front().map(|&(_, t)| t),
            self.pending_deadline(),
            self.next_scheduled(),
        ]
        .into_iter()
        .flatten()
        .min()
        .map(|at| Wake { at, exact: false });
        match (output, other) {
            (Some(o), Some(x)) if x.at < o.at => Some(x),
            (Some(o), _) => Some(o),
            (None, x) => x,
        }
    }

    /// Handle, in time order, every arrival and device deadline up to `now`,
    /// then append to `out` every outgoing byte due by `now`.
    pub fn run_until(&mut self, now: Instant, out: &mut Vec<u8>) {
        for _ in 0..MAX_EVENTS_PER_RUN {
            let arrival = self.incoming.front().map(|&(_, t)| t).filter(|&t| t <= now);
            let deadline = self.pending_deadline().filter(|&d| d <= now);
            let control = self.next_scheduled().filter(|&c| c <= now);
            // An operator control goes before a deadline or an arrival at a
            // later instant, after them at the same instant.
            if let Some(c) = control
                && arrival.is_none_or(|a| c < a)
                && deadline.is_none_or(|d| c < d)
            {
                self.apply_scheduled();
                continue;
            }
            // A deadline at the same instant as an arrival goes first: the
            // model is brought up to date before it sees the byte.
            let arrival_first = match (arrival, deadline) {
                (None, None) => match control {
                    Some(_) => {
                        self.apply_scheduled();
                        continue;
                    }
                    None => break,
                },
                (Some(a), Some(d)) => a < d,
                (Some(_), None) => true,
                (None, Some(_)) => false,
            };
            if arrival_first {
                let Some((byte, at)) = self.incoming.pop_front() else {
                    break;
                };
                let t = self.tick(at);
                self.device.on_byte(byte, t);
                self.advance(t);
            } else if let Some(d) = deadline {
                let t = self.tick(d);
                self.advance(t);
            }
        }
        while let Some(&Outgoing { byte, due, .. }) = self.outgoing.front() {
            if due > now {
                break;
            }
            out.push(byte);
            self.outgoing.pop_front();
            self.stats.bytes_sent += 1;
        }
    }

    /// Apply an operator control at `now`. Call `run_until(now)` first so
    /// the model has seen everything before it.
    pub fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
        let t = self.tick(now);
        let result = self.device.control(control, t);
        self.advance(t);
        result
    }

    /// A timed control given at `now` (call `run_until(now)` first, as for
    /// [`Engine::control`]): what is due at once is applied now (and its
    /// error returned), the rest at its modelled time. The input
    /// must be one with two levels (`SimDevice::input_level`), so that what
    /// comes later cannot fail.
    pub fn timed(&mut self, control: &TimedControl, now: Instant) -> Result<(), String> {
        let start = self.clock.map_or(now, |c| c.max(now)) + control.delay;
        let level_of = |name: &str, what: &str| {
            self.device.input_level(name).ok_or_else(|| {
                format!(
                    "`{what}` needs an input with two levels: expected one of {}",
                    self.device.input_names().join(", ")
                )
            })
        };
        let set = |name: &str, level: bool| InputControl::Set {
            name: name.to_owned(),
            level,
        };
        let steps: Vec<(Instant, InputControl)> = match &control.what {
            Timed::Input(c) => {
                if !control.delay.is_zero() {
                    level_of(c.name(), "after")?;
                }
                vec![(start, c.clone())]
            }
            Timed::Pulse { name, hold } => {
                let level = level_of(name, "pulse")?;
                vec![
                    (start, set(name, !level)),
                    (start + *hold, set(name, level)),
                ]
            }
            Timed::Chatter {
                name,
                changes,
                every,
            } => {
                let level = level_of(name, "chatter")?;
                (0..(*changes).min(MAX_CHATTER_CHANGES))
                    .map(|k| (start + *every * k, set(name, (k % 2 == 0) != level)))
                    .collect()
            }
        };
        for (i, (at, c)) in steps.into_iter().enumerate() {
            if i == 0 && control.delay.is_zero() {
                self.control(&c, now)?;
            } else {
                self.scheduled.insert((at, self.scheduled_count), c);
                self.scheduled_count += 1;
            }
        }
        Ok(())
    }

    /// Operator controls still to come.
    pub fn scheduled(&self) -> usize {
        self.scheduled.len()
    }

    fn next_scheduled(&self) -> Option<Instant> {
        self.scheduled.keys().next().map(|(t, _)| *t)
    }

    fn apply_scheduled(&mut self) {
        if let Some(((at, _), c)) = self.scheduled.pop_first() {
            let t = self.tick(at);
            // Checked when it was scheduled: a device refusing it now has
            // nobody to tell.
            let _ = self.device.control(&c, t);
            self.advance(t);
        }
    }

    /// Arm a message fault, or queue garbage; `Stall` goes to the device.
    /// `Close` concerns the line, not the wire model, and is the shell's;
    /// here it is refused.
    pub fn fault(&mut self, fault: Fault, now: Instant) -> Result<(), String> {
        match fault {
            Fault::DropByte(i) => self.armed.drop = Some(i),
            Fault::CorruptByte(i) => self.armed.corrupt = Some(i),
            Fault::Withhold => self.armed.withhold = true,
            Fault::Delay(d) => self.armed.delay = Some(d),
            Fault::Stream(n) => self.armed.stream = Some(n),
            Fault::Garbage(bytes) => {
                self.stats.garbage_bytes += bytes.len() as u64;
                let t = self.clock.map_or(now, |c| c.max(now));
                let timed = self.place_on_wire(&bytes, t, Duration::ZERO);
                self.enqueue(timed);
            }
            Fault::Close { .. } => return Err("closing the line is up to the shell".to_owned()),
            Fault::Stall => {
                let t = self.tick(now);
                let result = self.device.stall_next(t);
                self.advance(t);
                return result;
            }
        }
        Ok(())
    }

    pub fn describe(&mut self, now: Instant) -> String {
        let t = self.clock.map_or(now, |c| c.max(now));
        self.device.describe(t)
    }

    pub fn input_names(&self) -> Vec<&'static str> {
        self.device.input_names()
    }

    /// Size the device's program store (`SimDevice::set_program_memory`).
    /// Call `run_until(now)` first so the model has seen everything before.
    pub fn set_program_memory(&mut self, commands: usize) -> Result<(), String> {
        self.device.set_program_memory(commands)
    }

    pub fn input_level(&self, name: &str) -> Option<bool> {
        self.device.input_level(name)
    }

    fn pending_deadline(&self) -> Option<Instant> {
        self.device
            .next_deadline()
            .filter(|&d| Some(d) != self.stale_deadline)
    }

    fn tick(&mut self, t: Instant) -> Instant {
        let t = self.clock.map_or(t, |c| c.max(t));
        self.clock = Some(t);
        t
    }

    /// `advance(t)`, then take every message the device has to send.
    fn advance(&mut self, t: Instant) {
        self.device.advance(t);
        self.stale_deadline = self.device.next_deadline().filter(|&d| d <= t);
        while let Some(message) = self.device.poll_output() {
            if message.is_empty() {
                continue;
            }
            let faults = self.armed.take();
            if faults.withhold {
                self.stats.messages_withheld += 1;
                continue;
            }
            // The message is not sent; the stream takes its place.
            let message = match faults.stream {
                Some(n) => {
                    self.stats.messages_withheld += 1;
                    self.stats.garbage_bytes += n as u64;
                    vec![crate::sim::fault::STREAM_BYTE; n]
                }
                None => message,
            };
            // Due times are fixed before drop/corrupt, so a dropped byte
            // leaves its slot silent instead of pulling the rest forward.
            let mut timed = self.place_on_wire(&message, t, faults.delay.unwrap_or_default());
            if faults.corrupt.is_some() {
                self.stats.bytes_corrupted += 1;
            }
            if faults.drop.is_some() {
                self.stats.bytes_dropped += 1;
            }
            faults.apply_to_bytes(&mut timed);
            self.enqueue(timed);
            self.stats.messages_sent += 1;
        }
    }

    fn enqueue(&mut self, timed: Vec<(u8, Instant)>) {
        let last = timed.len().saturating_sub(1);
        self.outgoing.extend(
            timed
                .into_iter()
                .enumerate()
                .map(|(k, (byte, due))| Outgoing {
                    byte,
                    due,
                    ends_message: k == last,
                }),
        );
    }

    /// Book the line for `bytes` after whatever is queued, starting no
    /// earlier than `t + delay`; returns each byte with its due time.
    fn place_on_wire(&mut self, bytes: &[u8], t: Instant, delay: Duration) -> Vec<(u8, Instant)> {
        let start = self.line_free.map_or(t, |free| free.max(t)) + delay;
        self.line_free = Some(start + self.line.transfer_time(bytes.len()));
        bytes
            .iter()
            .enumerate()
            .map(|(k, &b)| (b, start + self.line.transfer_time(k + 1)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fault::ByteIndex;
    use std::sync::{Arc, Mutex};

    /// Answers each CR-ended line with `reply` after `delay`; records when
    /// each byte reached it.
    struct LineDevice {
        line: LineSettings,
        delay: Duration,
        reply: Vec<u8>,
        seen: Seen,
        pending: VecDeque<(Instant, Vec<u8>)>,
        ready: VecDeque<Vec<u8>>,
        replies_per_line: usize,
    }

    impl SimDevice for LineDevice {
        fn line(&self) -> LineSettings {
            self.line
        }
        fn on_byte(&mut self, byte: u8, now: Instant) {
            self.seen.lock().unwrap().push((byte, now));
            if byte == b'\r' {
                for _ in 0..self.replies_per_line {
                    self.pending
                        .push_back((now + self.delay, self.reply.clone()));
                }
            }
        }
        fn advance(&mut self, now: Instant) {
            while self.pending.front().is_some_and(|(t, _)| *t <= now) {
                if let Some((_, m)) = self.pending.pop_front() {
                    self.ready.push_back(m);
                }
            }
        }
        fn next_deadline(&self) -> Option<Instant> {
            self.pending.front().map(|(t, _)| *t)
        }
        fn poll_output(&mut self) -> Option<Vec<u8>> {
            self.ready.pop_front()
        }
        fn control(&mut self, control: &InputControl, _now: Instant) -> Result<(), String> {
            match control {
                InputControl::Set { name, .. } if name == "hood" => Ok(()),
                _ => Err("unknown input: expected hood".into()),
            }
        }
        fn input_names(&self) -> Vec<&'static str> {
            vec!["hood"]
        }
        fn input_level(&self, _name: &str) -> Option<bool> {
            None
        }
        fn describe(&self, _now: Instant) -> String {
            format!("{} lines pending", self.pending.len())
        }
    }

    type Seen = Arc<Mutex<Vec<(u8, Instant)>>>;

    const REPLY: &[u8] = b"0000100002000FFFFFE";

    fn engine(delay: Duration) -> (Engine, Seen) {
        engine_with(delay, 1)
    }

    fn engine_with(delay: Duration, replies_per_line: usize) -> (Engine, Seen) {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let device = LineDevice {
            line: LineSettings::new(19200),
            delay,
            reply: REPLY.to_vec(),
            seen: seen.clone(),
            pending: VecDeque::new(),
            ready: VecDeque::new(),
            replies_per_line,
        };
        (Engine::new(Box::new(device)), seen)
    }

    fn bt(n: usize) -> Duration {
        LineSettings::new(19200).transfer_time(n)
    }

    /// The byte time (counted from the message's start, as `bt`) at which
    /// byte `k` of a `len`-byte message is handed over: when the last byte of
    /// its receive-FIFO chunk is due.
    fn handed(k: usize, len: usize) -> Duration {
        let end = ((k / HOST_RX_FIFO_TRIGGER + 1) * HOST_RX_FIFO_TRIGGER).min(len) - 1;
        bt(end + 1)
    }

    /// Arrivals add one (truncated) byte time per byte.
    fn arr(n: u32) -> Duration {
        bt(1) * n
    }

    /// Step through every wake-up until `until`, recording when each output
    /// byte was handed out.
    fn drive(e: &mut Engine, until: Instant) -> Vec<(u8, Instant)> {
        let mut got = Vec::new();
        while let Some(t) = e.next_wake().map(|w| w.at).filter(|&t| t <= until) {
            let mut out = Vec::new();
            e.run_until(t, &mut out);
            got.extend(out.into_iter().map(|b| (b, t)));
        }
        got
    }

    #[test]
    fn bytes_read_at_once_reach_the_device_one_byte_time_apart() {
        let (mut e, seen) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"@0P\r", t0);
        assert_eq!(e.next_wake().map(|w| w.at), Some(t0 + bt(1)));
        let mut out = Vec::new();
        e.run_until(t0 + bt(1) - Duration::from_nanos(1), &mut out);
        assert!(seen.lock().unwrap().is_empty(), "never before its arrival");
        drive(&mut e, t0 + bt(4));
        let times: Vec<Instant> = seen.lock().unwrap().iter().map(|&(_, t)| t).collect();
        assert_eq!(
            times,
            vec![t0 + arr(1), t0 + arr(2), t0 + arr(3), t0 + arr(4)]
        );
    }

    #[test]
    fn a_byte_read_on_a_quiet_line_arrives_one_byte_time_after_the_read() {
        let (mut e, seen) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"@", t0);
        e.receive(b"0", t0 + Duration::from_micros(100)); // still arriving: queued behind
        e.receive(b"P", t0 + Duration::from_millis(10)); // line was quiet
        drive(&mut e, t0 + Duration::from_millis(20));
        let times: Vec<Instant> = seen.lock().unwrap().iter().map(|&(_, t)| t).collect();
        assert_eq!(
            times,
            vec![
                t0 + arr(1),
                t0 + arr(2),
                t0 + Duration::from_millis(10) + arr(1)
            ]
        );
    }

    #[test]
    fn a_request_reply_cycle_takes_exactly_the_wire_time() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"@0P\r", t0);
        let got = drive(&mut e, t0 + Duration::from_millis(50));
        assert_eq!(got.iter().map(|&(b, _)| b).collect::<Vec<_>>(), REPLY);
        for (k, &(_, at)) in got.iter().enumerate() {
            assert_eq!(at, t0 + arr(4) + handed(k, REPLY.len()), "byte {k}");
        }
        // 4 + 19 bytes at 19200 baud: 11.979 ms, the isel `@0P` wire limit.
        let cycle = got.last().map(|&(_, t)| t - t0).unwrap_or_default();
        assert_eq!(cycle.as_micros(), 11979);
    }

    #[test]
    fn output_is_never_handed_out_early_however_coarsely_polled() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"@0P\r", t0);
        let mut out = Vec::new();
        // Poll every 1 ms instead of at each wake-up: bytes come in batches,
        // each batch holds exactly the bytes due by then.
        for ms in 1..=13 {
            let now = t0 + Duration::from_millis(ms);
            let before = out.len();
            e.run_until(now, &mut out);
            let due = (0..REPLY.len())
                .filter(|&k| t0 + arr(4) + bt(k + 1) <= now)
                .count();
            assert_eq!(out.len(), due, "at {ms} ms (had {before})");
        }
        assert_eq!(out, REPLY);
    }

    #[test]
    fn a_processing_delay_is_served_at_the_device_deadline() {
        let (mut e, _) = engine(Duration::from_millis(2));
        let t0 = Instant::now();
        e.receive(b"@0P\r", t0);
        let got = drive(&mut e, t0 + Duration::from_millis(50));
        assert_eq!(
            got.first().map(|&(_, t)| t),
            Some(t0 + arr(4) + Duration::from_millis(2) + handed(0, REPLY.len()))
        );
    }

    #[test]
    fn messages_produced_together_go_out_back_to_back() {
        let (mut e, _) = engine_with(Duration::ZERO, 2);
        let t0 = Instant::now();
        e.receive(b"\r", t0);
        let got = drive(&mut e, t0 + Duration::from_millis(50));
        assert_eq!(got.len(), 2 * REPLY.len());
        assert_eq!(
            got.last().map(|&(_, t)| t),
            Some(t0 + arr(1) + bt(REPLY.len()) + bt(REPLY.len()))
        );
    }

    fn cycle_with(fault: Fault) -> (Vec<(u8, Instant)>, Instant) {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.fault(fault, t0).expect("armed");
        e.receive(b"@0P\r", t0);
        (drive(&mut e, t0 + Duration::from_millis(100)), t0)
    }

    #[test]
    fn drop_byte_leaves_out_the_middle_byte_and_keeps_the_others_times() {
        let (got, t0) = cycle_with(Fault::DropByte(ByteIndex::Middle));
        // The dropped byte's time slot stays silent: the others keep their
        // due times, and the chunks form around the gap.
        let bytes: Vec<u8> = got.iter().map(|&(b, _)| b).collect();
        let mut expected = REPLY.to_vec();
        expected.remove(9);
        assert_eq!(bytes, expected);
        let last = got.last().map(|&(_, t)| t);
        assert_eq!(last, Some(t0 + arr(4) + bt(REPLY.len())));
        for (k, &(_, at)) in got.iter().enumerate() {
            let slot = if k < 9 { k } else { k + 1 };
            assert!(
                at >= t0 + arr(4) + bt(slot + 1),
                "byte {k} handed out early"
            );
        }
    }

    #[test]
    fn corrupt_byte_flips_bit_seven_of_the_chosen_byte() {
        let (got, _) = cycle_with(Fault::CorruptByte(ByteIndex::At(0)));
        let bytes: Vec<u8> = got.iter().map(|&(b, _)| b).collect();
        let mut expected = REPLY.to_vec();
        expected[0] = b'0' | 0x80;
        assert_eq!(bytes, expected);
    }

    #[test]
    fn withhold_swallows_the_next_message_only() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.fault(Fault::Withhold, t0).expect("armed");
        e.receive(b"@0P\r", t0);
        assert!(drive(&mut e, t0 + Duration::from_millis(20)).is_empty());
        let t1 = t0 + Duration::from_millis(20);
        e.receive(b"@0P\r", t1);
        let got = drive(&mut e, t1 + Duration::from_millis(20));
        assert_eq!(got.len(), REPLY.len());
        assert_eq!(e.stats().messages_withheld, 1);
    }

    #[test]
    fn stream_replaces_the_next_message_with_an_unbroken_run_of_u() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.fault(Fault::Stream(500), t0).expect("armed");
        e.receive(b"@0P\r", t0);
        let got = drive(&mut e, t0 + Duration::from_secs(1));
        assert_eq!(got.len(), 500);
        assert!(got.iter().all(|&(b, _)| b == b'U'));
        // Back to back at line speed, no pause: the whole run within its
        // wire time (handed out in receive-FIFO groups).
        let span = got[499].1 - got[0].1;
        assert!(span <= bt(500) && span >= bt(400), "{span:?}");
        assert_eq!(e.stats().messages_withheld, 1);
        assert_eq!(e.stats().garbage_bytes, 500);
    }

    #[test]
    fn delay_shifts_the_whole_next_message() {
        let (got, t0) = cycle_with(Fault::Delay(Duration::from_millis(30)));
        assert_eq!(
            got.first().map(|&(_, t)| t),
            Some(t0 + arr(4) + Duration::from_millis(30) + handed(0, REPLY.len()))
        );
        assert_eq!(got.len(), REPLY.len());
    }

    #[test]
    fn garbage_goes_out_now_and_the_reply_waits_for_the_line() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"@0P\r", t0);
        let now = t0 + arr(4) + bt(2);
        drive(&mut e, now); // two reply bytes out
        e.fault(Fault::Garbage(vec![0xAA, 0xBB]), now)
            .expect("queued");
        let got = drive(&mut e, now + Duration::from_millis(50));
        let bytes: Vec<u8> = got.iter().map(|&(b, _)| b).collect();
        assert_eq!(
            bytes.get(bytes.len() - 2..),
            Some(&[0xAA, 0xBB][..]),
            "after the message on the wire"
        );
        assert_eq!(
            got.last().map(|&(_, t)| t),
            Some(t0 + arr(4) + bt(REPLY.len()) + bt(2))
        );
    }

    #[test]
    fn a_fault_hits_the_next_message_not_one_already_on_its_way() {
        let (mut e, _) = engine_with(Duration::ZERO, 1);
        let t0 = Instant::now();
        e.receive(b"\r", t0);
        drive(&mut e, t0 + arr(1)); // the reply is queued now
        e.fault(Fault::CorruptByte(ByteIndex::At(0)), t0 + arr(1))
            .expect("armed");
        let first = drive(&mut e, t0 + Duration::from_millis(30));
        assert_eq!(first.iter().map(|&(b, _)| b).collect::<Vec<_>>(), REPLY);
        let t1 = t0 + Duration::from_millis(30);
        e.receive(b"\r", t1);
        let second = drive(&mut e, t1 + Duration::from_millis(30));
        assert_eq!(second.first().map(|&(b, _)| b), Some(b'0' | 0x80));
    }

    #[test]
    fn only_the_last_byte_of_a_message_asks_for_an_exact_wake() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.fault(Fault::DropByte(ByteIndex::At(99)), t0)
            .expect("armed");
        e.receive(b"\r", t0);
        let mut exact = Vec::new();
        while let Some(w) = e.next_wake() {
            let mut out = Vec::new();
            e.run_until(w.at, &mut out);
            if !out.is_empty() {
                exact.push(w.exact);
            }
        }
        // 19 bytes less the dropped last one, in receive-FIFO chunks of
        // 8, 8 and 2: only the chunk with the (new) last byte is exact.
        assert_eq!(exact, vec![false, false, true]);
    }

    #[test]
    fn bytes_are_handed_over_in_fifo_chunks_and_the_message_end_on_time() {
        let (mut e, _) = engine(Duration::ZERO);
        let t0 = Instant::now();
        e.receive(b"\r", t0);
        let mut chunks = Vec::new();
        while let Some(w) = e.next_wake() {
            let mut out = Vec::new();
            e.run_until(w.at, &mut out);
            if !out.is_empty() {
                chunks.push((out.len(), w.at));
            }
        }
        let sizes: Vec<usize> = chunks.iter().map(|c| c.0).collect();
        assert_eq!(sizes, vec![8, 8, 3]);
        // Each chunk goes out when its last byte has crossed the wire: the
        // request's CR arrived one byte time after t0, the reply follows.
        let due = |k: usize| t0 + bt(1) + bt(k + 1);
        let times: Vec<Instant> = chunks.iter().map(|c| c.1).collect();
        assert_eq!(times, vec![due(7), due(15), due(18)]);
    }

    #[test]
    fn close_is_not_the_engines() {
        let (mut e, _) = engine(Duration::ZERO);
        assert!(
            e.fault(Fault::Close { reopen_after: None }, Instant::now())
                .is_err()
        );
    }

    #[test]
    fn a_stall_goes_to_the_device_which_may_have_no_long_actions() {
        let (mut e, _) = engine(Duration::ZERO);
        let err = e.fault(Fault::Stall, Instant::now()).unwrap_err();
        assert!(err.contains("EMP"), "{err}");
        assert!(e.armed().is_empty());
    }

    /// Every level `sw` was set to, and when.
    type SwitchLog = Arc<Mutex<Vec<(Instant, bool)>>>;

    /// One two-level input `sw`; records every level it is set to.
    struct Switch {
        level: bool,
        log: SwitchLog,
    }

    impl SimDevice for Switch {
        fn line(&self) -> LineSettings {
            LineSettings::new(19_200)
        }
        fn on_byte(&mut self, _: u8, _: Instant) {}
        fn advance(&mut self, _: Instant) {}
        fn next_deadline(&self) -> Option<Instant> {
            None
        }
        fn poll_output(&mut self) -> Option<Vec<u8>> {
            None
        }
        fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String> {
            match control {
                InputControl::Set { name, level } if name == "sw" => {
                    self.level = *level;
                    self.log.lock().unwrap().push((now, *level));
                    Ok(())
                }
                _ => Err("unknown input: expected sw".into()),
            }
        }
        fn input_names(&self) -> Vec<&'static str> {
            vec!["sw"]
        }
        fn input_level(&self, name: &str) -> Option<bool> {
            (name == "sw").then_some(self.level)
        }
        fn describe(&self, _now: Instant) -> String {
            String::new()
        }
    }

    fn switch() -> (Engine, SwitchLog) {
        let log = Arc::new(Mutex::new(Vec::new()));
        let device = Switch {
            level: false,
            log: log.clone(),
        };
        (Engine::new(Box::new(device)), log)
    }

    #[test]
    fn a_pulse_lasts_exactly_its_time_on_the_modelled_clock() {
        let (mut e, log) = switch();
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let pulse = TimedControl {
            delay: Duration::ZERO,
            what: Timed::Pulse {
                name: "sw".into(),
                hold: ms(1000),
            },
        };
        assert_eq!(e.timed(&pulse, t0), Ok(()));
        assert_eq!(*log.lock().unwrap(), [(t0, true)], "the first edge at once");
        assert_eq!(e.scheduled(), 1);
        assert_eq!(e.next_wake().map(|w| w.at), Some(t0 + ms(1000)));
        let mut out = Vec::new();
        // Served late by the thread: the device still sees the modelled time.
        e.run_until(t0 + ms(1003), &mut out);
        assert_eq!(*log.lock().unwrap(), [(t0, true), (t0 + ms(1000), false)]);
        assert_eq!(e.scheduled(), 0);
    }

    #[test]
    fn chatter_and_after_follow_their_schedule() {
        let (mut e, log) = switch();
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let chatter = TimedControl {
            delay: ms(30),
            what: Timed::Chatter {
                name: "sw".into(),
                changes: 4,
                every: ms(10),
            },
        };
        assert_eq!(e.timed(&chatter, t0), Ok(()));
        assert!(log.lock().unwrap().is_empty(), "nothing before its delay");
        let mut out = Vec::new();
        e.run_until(t0 + ms(100), &mut out);
        let got: Vec<(Duration, bool)> = log
            .lock()
            .unwrap()
            .iter()
            .map(|(t, l)| (*t - t0, *l))
            .collect();
        assert_eq!(
            got,
            [
                (ms(30), true),
                (ms(40), false),
                (ms(50), true),
                (ms(60), false)
            ]
        );
        let unknown = TimedControl {
            delay: ms(5),
            what: Timed::Input(InputControl::Set {
                name: "door".into(),
                level: true,
            }),
        };
        assert_eq!(
            e.timed(&unknown, t0),
            Err("`after` needs an input with two levels: expected one of sw".into())
        );
        assert_eq!(e.scheduled(), 0, "a refused control leaves nothing behind");
    }

    #[test]
    fn controls_reach_the_device_and_its_errors_come_back() {
        let (mut e, _) = engine(Duration::ZERO);
        let now = Instant::now();
        let set = |name: &str| InputControl::Set {
            name: name.into(),
            level: true,
        };
        assert_eq!(e.control(&set("hood"), now), Ok(()));
        assert_eq!(
            e.control(&set("door"), now),
            Err("unknown input: expected hood".into())
        );
    }

    struct StuckDeadline(Instant);
    impl SimDevice for StuckDeadline {
        fn line(&self) -> LineSettings {
            LineSettings::new(19200)
        }
        fn on_byte(&mut self, _: u8, _: Instant) {}
        fn advance(&mut self, _: Instant) {}
        fn next_deadline(&self) -> Option<Instant> {
            Some(self.0)
        }
        fn poll_output(&mut self) -> Option<Vec<u8>> {
            None
        }
        fn control(&mut self, _: &InputControl, _: Instant) -> Result<(), String> {
            Ok(())
        }
        fn input_names(&self) -> Vec<&'static str> {
            Vec::new()
        }
        fn input_level(&self, _name: &str) -> Option<bool> {
            None
        }
        fn describe(&self, _: Instant) -> String {
            String::new()
        }
    }

    #[test]
    fn a_deadline_the_device_never_clears_does_not_make_the_shell_spin() {
        let t0 = Instant::now();
        let mut e = Engine::new(Box::new(StuckDeadline(t0)));
        assert_eq!(e.next_wake().map(|w| w.at), Some(t0));
        e.run_until(t0 + Duration::from_millis(1), &mut Vec::new());
        assert_eq!(e.next_wake(), None);
    }

    proptest::proptest! {
        /// However the reads are split and however often the shell polls,
        /// each byte reaches the device at max(read, previous) + one byte
        /// time, and never earlier.
        #[test]
        fn arrival_times_do_not_depend_on_polling(
            reads in proptest::collection::vec((0u64..3000, 1usize..6), 1..12),
            poll_us in 50u64..2000,
        ) {
            let (mut e, seen) = engine(Duration::ZERO);
            let t0 = Instant::now();
            let mut expected = Vec::new();
            let mut last: Option<Instant> = None;
            let mut at = t0;
            for &(gap, n) in &reads {
                at += Duration::from_micros(gap);
                e.receive(&vec![b'x'; n], at);
                for _ in 0..n {
                    let arrival = last.map_or(at, |l| l.max(at)) + arr(1);
                    expected.push(arrival);
                    last = Some(arrival);
                }
                // Poll at a coarse period up to this read.
                let mut out = Vec::new();
                e.run_until(at, &mut out);
            }
            let mut now = at;
            while e.next_wake().is_some() && now < at + Duration::from_secs(1) {
                now += Duration::from_micros(poll_us);
                e.run_until(now, &mut Vec::new());
            }
            let got: Vec<Instant> = seen.lock().unwrap().iter().map(|&(_, t)| t).collect();
            proptest::prop_assert_eq!(got, expected);
        }
    }
}
