//! The device task: the one owner of the port. It feeds the family's
//! sans-IO driver with what happens (bytes read, messages written, requests,
//! time) and carries out what the driver asks for (messages to write,
//! events to publish), on the current tokio runtime.
//!
//! - **Stop** overtakes everything: it has its own channel, checked first
//!   (a biased select), and goes to the paced writer's stop lane, which
//!   puts it between two bytes of a command already on its way.
//! - **Link supervision**: a failed open, a vanished port (read or write),
//!   or a driver that declares the link dead (no reply within its deadline)
//!   is `LinkState::Lost` at once. A port that is still open gets the stop
//!   sequence before it is closed. Then the task reconnects with a backoff
//!   (250 ms doubling to 5 s) and the driver reads the controller's state
//!   back; nothing that was in flight is ever sent again.
//! - **Shutdown** (or the last handle dropped): stop, wait until the stop
//!   bytes are written and drained, close, `LinkState::Closed`.
//! - **Few wakeups**: the paced writer reports every chunk it hands over.
//!   While a message is being written the task does not wait for those
//!   reports (it takes them when it wakes anyway, or when the message should
//!   be done); a stop ends that at once. Received bytes are read as the
//!   kernel delivers them (a reply comes in FIFO-sized chunks). This is what
//!   keeps a 10 Hz poll loop cheap (`docs/performance.md`).
//!
//! See `docs/device.md`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::{mpsc, watch};
use tokio::time::{sleep_until, timeout_at};

use super::api::{Activity, Event, LinkState, MachineState, Request};
use super::common::Polling;
use super::connector::{Backoff, Connector};
use super::driver::{Driver, Outgoing};
use super::emcu::{EmcuDriver, EmcuSettings};
use super::emp::{EmpDriver, EmpSettings};
use super::events::{EventBus, EventReceiver};
use super::handle::{
    DeviceHandle, EmergencyHandle, EmergencySlot, InputLog, StopCall, StopWritten,
};
use super::inputs::{InputRecorder, RecorderConfig};
use super::isel::{IselDriver, IselSettings, SettingsError};
use super::stream_guard::StreamGuard;
use super::traffic_buffer::TrafficBuffer;
use crate::config::Profile;
use crate::proto::Protocol;
use crate::transport::{
    self, EmergencyStop, Interleave, Lane, MessageId, Pace, PacedWriter, PortIdentity, PortParts,
    PortSpec, TransportError, WriterConfig, WriterEvent,
};
use crate::wire::LineSettings;

/// Tuning of the device task.
#[derive(Debug, Clone, Copy)]
pub struct TaskOptions {
    pub writer: WriterConfig,
    /// Lossy events (traffic, positions …) kept per consumer.
    pub lossy_capacity: usize,
    /// Requests waiting for the task.
    pub request_capacity: usize,
    pub backoff: Backoff,
    /// Bound on waiting for stop bytes to be written before a port closes.
    pub stop_flush: Duration,
    /// Whether this session was asked to move, and so whether the task
    /// sends stops of its own (`docs/device.md`, "Sessions that do not
    /// move"). Stops the client asks for go out in every case.
    pub moves: SessionMoves,
}

/// Whether a session moves: what decides the task's own stops (at connect,
/// at close, before a dead link is closed) and the emergency stop armed for
/// the panic hook and a hang-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionMoves {
    /// Asked to move from the start (`upload`, `send` of a move): every
    /// connection opens with the family's stop, the close stops.
    Yes,
    /// Never asked to move (`watch`, `poll`, `send` of reads): no stop of
    /// its own, ever; no emergency stop armed.
    No,
    /// The console: as [`SessionMoves::No`] until the first request that
    /// may move reaches the task, from then on as [`SessionMoves::Yes`] for
    /// the rest of the task (a reconnect after that opens with the stop).
    OnceAsked,
}

impl Default for TaskOptions {
    fn default() -> Self {
        TaskOptions {
            writer: WriterConfig::default(),
            lossy_capacity: 1024,
            request_capacity: 256,
            backoff: Backoff::default(),
            stop_flush: Duration::from_millis(500),
            moves: SessionMoves::Yes,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error("the device task needs a tokio runtime (none is running on this thread)")]
    NoRuntime,
}

/// The driver for a profile's controller family: the one place a family
/// is chosen (the console and every command). It polls as the profile says,
/// or as `polling` asks (a command's own), which each family's settings
/// apply in their own terms.
pub fn driver_for(
    profile: &Profile,
    polling: Option<Polling>,
) -> Result<Box<dyn Driver>, DeviceError> {
    Ok(match profile.connection.protocol {
        Protocol::Isel => {
            let mut s = IselSettings::from_profile(profile)?;
            if let Some(p) = polling {
                s.poll_as(p);
            }
            Box::new(IselDriver::new(s))
        }
        Protocol::Emcu => {
            let mut s = EmcuSettings::from_profile(profile)?;
            if let Some(p) = polling {
                s.poll_as(p);
            }
            Box::new(EmcuDriver::new(s))
        }
        Protocol::Emp => {
            let mut s = EmpSettings::from_profile(profile)?;
            if let Some(p) = polling {
                s.poll_as(p);
            }
            Box::new(EmpDriver::new(s))
        }
    })
}

/// Start the device task for `profile` on `port`. The receiver sees every
/// event from the first one on; inputs are recorded under the profile's
/// names.
pub fn spawn(
    profile: &Profile,
    port: PortSpec,
    options: TaskOptions,
) -> Result<(DeviceHandle, EventReceiver), DeviceError> {
    spawn_recording(
        driver_for(profile, None)?,
        Connector::from(port),
        options,
        RecorderConfig::from_profile(profile),
    )
}

/// Start the device task with any driver and connector (inputs recorded
/// under the driver's names).
pub fn spawn_with(
    driver: Box<dyn Driver>,
    connector: Connector,
    options: TaskOptions,
) -> Result<(DeviceHandle, EventReceiver), DeviceError> {
    spawn_recording(driver, connector, options, RecorderConfig::unnamed())
}

/// [`spawn_with`], its input recorder set up by `inputs`.
pub fn spawn_recording(
    driver: Box<dyn Driver>,
    connector: Connector,
    options: TaskOptions,
    inputs: RecorderConfig,
) -> Result<(DeviceHandle, EventReceiver), DeviceError> {
    let runtime = tokio::runtime::Handle::try_current().map_err(|_| DeviceError::NoRuntime)?;
    let mut driver = driver;
    let moved = options.moves == SessionMoves::Yes;
    driver.set_connect_halt(moved);
    driver.set_reads_only(options.moves == SessionMoves::No);
    let moved_flag = Arc::new(AtomicBool::new(moved));
    let bus = EventBus::new(options.lossy_capacity);
    let first = bus.subscribe();
    let (requests_tx, requests) = mpsc::channel(options.request_capacity.max(1));
    let (stops_tx, stops) = mpsc::unbounded_channel();
    let slot = Arc::new(Mutex::new(EmergencySlot::default()));
    let emergency = EmergencyHandle::new(slot.clone(), driver.emergency_stop().bytes);
    let (done_tx, done) = watch::channel(false);
    let inputs = InputLog::new(InputRecorder::new(inputs));
    let task = Task {
        inputs: inputs.clone(),
        driver,
        connector,
        bus: bus.clone(),
        requests,
        stops,
        slot,
        options,
        last_lost: None,
        identity: None,
        pace: Pace::Tight,
        moved,
        moved_flag: moved_flag.clone(),
        hold: None,
    };
    runtime.spawn(task.run(done_tx));
    Ok((
        DeviceHandle {
            requests: requests_tx,
            stops: stops_tx,
            bus,
            emergency,
            done,
            inputs,
            moved: moved_flag,
        },
        first,
    ))
}

struct Task {
    driver: Box<dyn Driver>,
    /// Fed with every port reading the driver reports, whoever listens.
    inputs: InputLog,
    connector: Connector,
    bus: EventBus,
    requests: mpsc::Receiver<Request>,
    stops: mpsc::UnboundedReceiver<StopCall>,
    slot: Arc<Mutex<EmergencySlot>>,
    options: TaskOptions,
    /// The last loss published, so a retry loop says it once.
    last_lost: Option<String>,
    /// The device the serial port path named when it was first opened: a
    /// reconnect opens it only while the path still names that device.
    identity: Option<PortIdentity>,
    /// How far ahead of the wire the driver's messages may run: bulk while
    /// the driver reports an upload (nothing moves then, motion is refused),
    /// tight otherwise, so that a stop is never more than the writer's
    /// `max_backlog` behind bytes already handed over.
    pace: Pace,
    /// This task was asked to move (`SessionMoves`): its own stops go out.
    moved: bool,
    /// `moved`, for the handles (`DeviceHandle::moved`).
    moved_flag: Arc<AtomicBool>,
    /// A client's hold (`Request::Hold`): when it lapses unless renewed.
    hold: Option<Instant>,
}

/// How a session or a wait ended.
enum End {
    Shutdown,
    Lost,
}

/// Why a session ends.
enum Ending {
    Shutdown,
    /// The driver declared the link dead; the port is still open.
    DeadLink,
    /// The port failed.
    PortGone(String),
}

/// The port of one connection.
struct Session {
    writer: PacedWriter,
    written: mpsc::UnboundedReceiver<WriterEvent>,
    traffic: TrafficBuffer,
    stop_waiters: Vec<(MessageId, Vec<StopCall>)>,
    line: LineSettings,
    /// Do not wait for the writer's reports before this (a message is being
    /// paced out; its last report is due then).
    reports_after: Option<Instant>,
    /// The port's emergency stop, until it is armed (a session that has not
    /// moved arms none).
    emergency: Option<EmergencyStop>,
    /// Bytes that stream and answer nothing end the link (issue 37).
    stream: StreamGuard,
}

/// Bulk pacing only for an upload on a link that is up: storing a program
/// moves nothing, and the drivers refuse motion until it has ended.
fn pace_for(state: &MachineState) -> Pace {
    if state.link_up && state.activity == Activity::Uploading {
        Pace::Bulk
    } else {
        Pace::Tight
    }
}

/// Open and split a port. A serial port server is connected on a blocking
/// thread: a connect and an RFC 2217 negotiation may take seconds when the
/// network is bad, and the runtime's timers and signal handlers must go on
/// meanwhile (a current-thread runtime would stand still).
async fn open_port(
    spec: PortSpec,
    writer: WriterConfig,
) -> Result<(PortParts, LineSettings), TransportError> {
    let open = move |spec: PortSpec| {
        let port = transport::open(spec)?;
        let line = port.line();
        port.split(writer).map(|parts| (parts, line))
    };
    match spec {
        PortSpec::Network { ref target, .. } => {
            let name = target.to_string();
            tokio::task::spawn_blocking(move || open(spec))
                .await
                .unwrap_or_else(|e| {
                    Err(TransportError::Open {
                        port: name,
                        message: format!("connecting ended early: {e}"),
                    })
                })
        }
        _ => open(spec),
    }
}

impl Task {
    async fn run(mut self, done: watch::Sender<bool>) {
        let mut attempt: u32 = 0;
        loop {
            self.bus.publish(Event::Link(LinkState::Connecting));
            let opened = match self.connector.port() {
                Ok(spec) => match self.same_device(&spec) {
                    Ok(()) => open_port(spec, self.options.writer).await,
                    Err(e) => Err(e),
                },
                Err(e) => Err(e),
            };
            match opened {
                Ok((parts, line)) => {
                    attempt = 0;
                    self.last_lost = None;
                    if let End::Shutdown = self.session(parts, line).await {
                        break;
                    }
                }
                Err(e) => self.lost(e.to_string()),
            }
            attempt = attempt.saturating_add(1);
            let retry_in = self.options.backoff.delay(attempt);
            self.bus
                .publish(Event::Link(LinkState::Reconnecting { attempt, retry_in }));
            if let End::Shutdown = self.wait_disconnected(retry_in).await {
                break;
            }
        }
        self.bus.publish(Event::Link(LinkState::Closed));
        self.bus.close();
        // Refuse what comes after, before telling the handles it is over.
        self.requests.close();
        self.stops.close();
        let _ = done.send(true);
    }

    /// Before a serial port is opened (and so before anything is written
    /// to it): the first time, what device its path names; after that,
    /// that it names the same one still (`transport::identity`). A pty's
    /// number handed to another program, an adapter of another machine on
    /// the same `/dev/ttyUSB0`: refused, said, and tried again later.
    fn same_device(&mut self, spec: &PortSpec) -> Result<(), TransportError> {
        let PortSpec::Serial { path, .. } = spec else {
            return Ok(());
        };
        match &self.identity {
            None => {
                // A path that cannot be identified now cannot be opened
                // either: the open says why.
                self.identity = transport::identify(path).ok();
                Ok(())
            }
            Some(first) => {
                transport::still_the_same(path, first).map_err(|message| TransportError::Open {
                    port: path.display().to_string(),
                    message,
                })
            }
        }
    }

    fn lost(&mut self, reason: String) {
        if self.last_lost.as_deref() != Some(reason.as_str()) {
            self.bus.publish(Event::Link(LinkState::Lost {
                reason: reason.clone(),
            }));
            self.last_lost = Some(reason);
        }
    }

    /// A console's first request that may move: from now on the task stops
    /// as a session that moves does (the driver's connect halt on every
    /// reconnect, the stop at close). True when this request made it so,
    /// and the port's emergency stop is to be armed.
    fn asked_to_move(&mut self, request: &Request) -> bool {
        if self.moved
            || self.options.moves != SessionMoves::OnceAsked
            || !self.driver.may_move(request)
        {
            return false;
        }
        self.moved = true;
        self.moved_flag.store(true, Ordering::Relaxed);
        self.driver.set_connect_halt(true);
        true
    }

    fn set_emergency(&self, stop: Option<EmergencyStop>) {
        let mut slot = self.slot.lock().unwrap_or_else(|p| p.into_inner());
        slot.stop = stop;
    }

    /// Hand the driver's messages to the writer and its events to the
    /// clients. `Err` when the driver declared the link dead.
    fn pump(&mut self, s: &mut Session) -> Result<(), ()> {
        let now = Instant::now();
        while let Some(out) = self.driver.poll_transmit(now) {
            let interleave = if out.interruptible {
                Interleave::BetweenBytes
            } else {
                Interleave::WholeMessage
            };
            // Its last byte is handed over about this much later.
            let due = now + s.line.transfer_time(out.bytes.len().saturating_sub(1));
            s.reports_after = Some(s.reports_after.map_or(due, |t| t.max(due)));
            // A writer that has ended reports `Failed`; the loop sees it.
            let sent = match self.pace {
                Pace::Tight => s.writer.send(out.bytes, interleave),
                Pace::Bulk => s.writer.send_bulk(out.bytes, interleave),
            };
            if let Ok(id) = sent {
                s.traffic.sending(id, out.messages);
            }
        }
        self.publish_driver_events()
    }

    /// A report from the writer; `Some` when the port is gone.
    fn writer_event(&mut self, s: &mut Session, event: Option<WriterEvent>) -> Option<Ending> {
        match event {
            Some(WriterEvent::Written(chunk)) => self.written(s, chunk),
            Some(WriterEvent::DrainTimedOut { waited, .. }) => {
                self.bus.publish(Event::Notice(format!(
                    "stop bytes not confirmed on the wire within {} ms",
                    waited.as_millis()
                )))
            }
            // The task never cancels: the driver counts on every message.
            Some(WriterEvent::Cancelled { .. }) => {}
            Some(WriterEvent::Failed(e)) => return Some(Ending::PortGone(e.to_string())),
            None => return Some(Ending::PortGone("the writer has stopped".to_owned())),
        }
        None
    }

    fn publish_driver_events(&mut self) -> Result<(), ()> {
        let mut dead = false;
        while let Some(event) = self.driver.poll_event() {
            if let Event::Link(LinkState::Lost { reason }) = &event {
                dead = true;
                self.last_lost = Some(reason.clone());
            }
            if let Event::State(state) = &event {
                self.pace = pace_for(state);
            }
            // Io events may be dropped for a slow client; the recorder sees
            // every one, here, and its changes are never dropped.
            let changes = match &event {
                Event::Io(snapshot) => self.inputs.with(|r| r.observe(snapshot)),
                _ => Vec::new(),
            };
            self.bus.publish(event);
            for change in changes {
                self.bus.publish(Event::Input(change));
            }
        }
        if dead { Err(()) } else { Ok(()) }
    }

    fn publish_traffic(&self, records: Vec<crate::traffic::TrafficRecord>) {
        for r in records {
            self.bus.publish(Event::Traffic(r));
        }
    }

    /// A chunk the writer reports.
    fn written(&mut self, s: &mut Session, chunk: transport::WrittenChunk) {
        let records = s.traffic.written(&chunk);
        self.publish_traffic(records);
        match chunk.lane {
            Lane::Stop => {
                if let Some(i) = s.stop_waiters.iter().position(|(id, _)| *id == chunk.id) {
                    let (_, calls) = s.stop_waiters.swap_remove(i);
                    for call in calls {
                        let _ = call.done.send(Some(StopWritten {
                            requested: call.requested,
                            wire_start: chunk.wire_start,
                            wire_end: chunk.wire_end,
                        }));
                    }
                }
            }
            // The writer's own time: the report may be taken a little later.
            Lane::Normal if chunk.done => self.driver.transmitted(chunk.at),
            Lane::Normal => {}
        }
    }

    /// Every stop waiting, as one write on the stop lane.
    fn stop_now(&mut self, s: &mut Session, first: StopCall) {
        // A stop ends whatever a hold held.
        self.hold = None;
        let mut calls = vec![first];
        while let Ok(call) = self.stops.try_recv() {
            calls.push(call);
        }
        let out = self.driver.stop(Instant::now());
        // A failed writer has reported `Failed` or will; the calls' senders
        // are dropped with it and their tickets say nothing was written.
        if let Ok(id) = s.writer.stop(out.bytes) {
            s.traffic.sending(id, out.messages);
            s.stop_waiters.push((id, calls));
        }
        // Whatever follows the stop is read and reported at once.
        s.reports_after = None;
    }

    async fn session(&mut self, parts: PortParts, line: LineSettings) -> End {
        let PortParts {
            mut reader,
            writer,
            events,
            emergency,
        } = parts;
        let mut s = Session {
            writer,
            written: events,
            traffic: TrafficBuffer::default(),
            stop_waiters: Vec::new(),
            line,
            reports_after: None,
            emergency: Some(emergency),
            stream: StreamGuard::new(line),
        };
        if self.moved {
            self.set_emergency(s.emergency.take());
        }
        self.bus.publish(Event::Link(LinkState::Connected));
        // A hold of the session before is no hold of this one: its client
        // was told the link went, and a late lapse would stop whatever the
        // new session moves.
        self.hold = None;
        let now = Instant::now();
        self.inputs.with(|r| r.connected(now));
        self.driver.connected(now);
        let mut last_fired: Option<Instant> = None;
        let ending = 'session: loop {
            // Reports that are there already, whether or not the task waits
            // for them.
            while let Ok(event) = s.written.try_recv() {
                if let Some(end) = self.writer_event(&mut s, Some(event)) {
                    break 'session end;
                }
            }
            // A stop asked for while the last event was handled goes before
            // what the driver sends next: a poll line written whole now
            // would otherwise sit on the wire in front of it.
            if let Ok(call) = self.stops.try_recv() {
                self.stop_now(&mut s, call);
            }
            if self.pump(&mut s).is_err() {
                break Ending::DeadLink;
            }
            let now = Instant::now();
            let stopping = !s.stop_waiters.is_empty();
            let reports_later = s.reports_after.filter(|t| *t > now && !stopping);
            let mut wake = [
                self.driver.next_timeout(),
                s.traffic.due(),
                reports_later,
                self.hold,
            ]
            .into_iter()
            .flatten()
            .min();
            // A deadline that handling did not move must not spin the loop.
            if wake.is_some() && wake == last_fired {
                wake = wake.map(|t| t.max(Instant::now() + Duration::from_millis(1)));
            }
            let timer = async {
                match wake {
                    Some(t) => sleep_until(t.into()).await,
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                biased;
                Some(call) = self.stops.recv() => self.stop_now(&mut s, call),
                event = s.written.recv(), if reports_later.is_none() => {
                    if let Some(end) = self.writer_event(&mut s, event) {
                        break end;
                    }
                }
                read = reader.read_chunk() => match read {
                    Ok(chunk) => {
                        let messages = self.driver.received(&chunk.bytes, chunk.at);
                        let answered = messages
                            .iter()
                            .any(|m| m.owner != crate::traffic::Owner::Controller);
                        let streaming = s.stream.read(chunk.bytes.len(), chunk.at, answered);
                        let records = s.traffic.read(&chunk, messages);
                        self.publish_traffic(records);
                        if let Some(reason) = streaming {
                            self.lost(reason);
                            break Ending::DeadLink;
                        }
                    }
                    Err(e) => break Ending::PortGone(e.to_string()),
                },
                request = self.requests.recv() => match request {
                    None | Some(Request::Shutdown) => break Ending::Shutdown,
                    Some(Request::Hold { lease }) => self.hold = Some(Instant::now() + lease),
                    Some(Request::HoldEnd) => self.hold = None,
                    Some(r) => {
                        if self.asked_to_move(&r) {
                            self.set_emergency(s.emergency.take());
                        }
                        self.driver.request(r, Instant::now());
                    }
                },
                () = timer => {
                    let now = Instant::now();
                    last_fired = wake;
                    if self.hold.is_some_and(|t| t <= now) {
                        // The event first: a client that reads on after its
                        // stall sees that the hold lapsed before the idle
                        // state the stop brings, and sends no next move.
                        self.bus.publish(Event::HoldLapsed);
                        let (done, _) = tokio::sync::oneshot::channel();
                        self.stop_now(&mut s, StopCall { requested: now, done });
                    }
                    let records = s.traffic.on_time(now);
                    self.publish_traffic(records);
                    if self.driver.next_timeout().is_some_and(|t| t <= now) {
                        self.driver.handle_timeout(now);
                    }
                }
            }
        };
        self.end_session(s, reader, ending).await
    }

    async fn end_session(
        &mut self,
        mut s: Session,
        reader: transport::PortReader,
        ending: Ending,
    ) -> End {
        let now = Instant::now();
        let (end, reason) = match ending {
            Ending::Shutdown => {
                if self.moved {
                    let out = self.driver.stop(now);
                    self.flush_stop(&mut s, out).await;
                }
                // Else nothing of ours moves and nothing is stopped; the
                // writer's close completes a line partly written.
                (End::Shutdown, "the port was closed".to_owned())
            }
            Ending::DeadLink => {
                // The controller may still be moving: stop it while the port
                // is open (a session that moves nothing leaves it alone).
                if self.moved {
                    let out = self.driver.emergency_stop();
                    self.flush_stop(&mut s, out).await;
                }
                let reason = self.last_lost.clone().unwrap_or_default();
                (End::Lost, reason)
            }
            Ending::PortGone(reason) => (End::Lost, reason),
        };
        drop(reader);
        self.set_emergency(None);
        let records = s.traffic.flush();
        self.publish_traffic(records);
        s.writer.close();
        self.inputs.with(InputRecorder::disconnected);
        self.driver.disconnected(&reason, Instant::now());
        let _ = self.publish_driver_events();
        if let End::Lost = end {
            self.lost(reason);
        }
        end
    }

    /// Write stop bytes on the stop lane and wait (bounded) until the
    /// writer reports them written, which for a terminal includes `tcdrain`.
    async fn flush_stop(&mut self, s: &mut Session, out: Outgoing) {
        let Ok(id) = s.writer.stop(out.bytes) else {
            return;
        };
        s.traffic.sending(id, out.messages);
        let deadline = Instant::now() + self.options.stop_flush;
        loop {
            match timeout_at(deadline.into(), s.written.recv()).await {
                Ok(Some(WriterEvent::Written(chunk))) => {
                    let ours = chunk.id == id;
                    self.written(s, chunk);
                    if ours {
                        return;
                    }
                }
                Ok(Some(WriterEvent::DrainTimedOut { .. } | WriterEvent::Cancelled { .. })) => {}
                Ok(Some(WriterEvent::Failed(_)) | None) | Err(_) => return,
            }
        }
    }

    /// Between connections: requests are answered (refused), stops say that
    /// nothing could be written.
    async fn wait_disconnected(&mut self, delay: Duration) -> End {
        let until = Instant::now() + delay;
        loop {
            let _ = self.publish_driver_events();
            tokio::select! {
                biased;
                Some(call) = self.stops.recv() => {
                    let _ = call.done.send(None);
                }
                request = self.requests.recv() => match request {
                    None | Some(Request::Shutdown) => return End::Shutdown,
                    Some(r) => {
                        self.asked_to_move(&r);
                        self.driver.request(r, Instant::now());
                    }
                },
                () = sleep_until(until.into()) => return End::Lost,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_an_upload_on_a_live_link_is_paced_in_bulk() {
        let mut state = MachineState {
            link_up: true,
            activity: Activity::Uploading,
            ..MachineState::default()
        };
        assert_eq!(pace_for(&state), Pace::Bulk);
        for activity in [Activity::Idle, Activity::Moving, Activity::Jogging] {
            state.activity = activity;
            assert_eq!(pace_for(&state), Pace::Tight, "{activity:?}");
        }
        state.activity = Activity::Uploading;
        state.link_up = false;
        assert_eq!(pace_for(&state), Pace::Tight);
    }
}
