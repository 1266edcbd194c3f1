//! The clients' side of the device task: requests in, a stop path that
//! overtakes everything, events out, an emergency handle for the panic hook
//! and the hang-up path, and an orderly shutdown.

use std::sync::{Arc, Mutex, TryLockError};
use std::time::{Duration, Instant};

use tokio::sync::{mpsc, oneshot, watch};

use super::api::Request;
use super::events::{EventBus, EventReceiver};
use super::inputs::InputRecorder;
use crate::transport::{EmergencyStop, TransportError};

/// A stop as it went out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StopWritten {
    /// When [`DeviceHandle::stop`] was called.
    pub requested: Instant,
    /// Modelled: when the first stop byte started on the wire.
    pub wire_start: Instant,
    /// Modelled: when the last stop byte had left the wire.
    pub wire_end: Instant,
}

impl StopWritten {
    /// Stop request to the first stop byte on the wire.
    pub fn latency(&self) -> Duration {
        self.wire_start.saturating_duration_since(self.requested)
    }
}

/// A stop on its way to the device task.
#[derive(Debug)]
pub(crate) struct StopCall {
    pub requested: Instant,
    pub done: oneshot::Sender<Option<StopWritten>>,
}

/// Await it to learn when the stop went out; dropping it changes nothing.
#[derive(Debug)]
pub struct StopTicket {
    done: oneshot::Receiver<Option<StopWritten>>,
}

impl StopTicket {
    /// `None` when nothing could be written: no port was open, or the task
    /// has ended.
    pub async fn written(self) -> Option<StopWritten> {
        self.done.await.ok().flatten()
    }
}

/// Why a request was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    #[error("too many requests are waiting for the device task")]
    Full,
    #[error("the device task has ended")]
    Closed,
}

/// The port's reserved emergency fd, as far as a port is open.
#[derive(Debug, Default)]
pub(crate) struct EmergencySlot {
    pub stop: Option<EmergencyStop>,
}

/// Writes the stop bytes synchronously through whatever port the task has
/// open now (it changes on every reconnect). For the panic hook and the
/// hang-up path, where the async machinery may be gone. Never panics, never
/// blocks longer than the transport's bound.
#[derive(Debug, Clone)]
pub struct EmergencyHandle {
    slot: Arc<Mutex<EmergencySlot>>,
    bytes: Arc<Vec<u8>>,
}

impl EmergencyHandle {
    pub(crate) fn new(slot: Arc<Mutex<EmergencySlot>>, bytes: Vec<u8>) -> EmergencyHandle {
        EmergencyHandle {
            slot,
            bytes: Arc::new(bytes),
        }
    }

    /// The transport's handle on the port open now, if any.
    pub fn current(&self) -> Option<EmergencyStop> {
        // A panicking thread may hold the lock: wait a little, then give up
        // rather than hang the panic hook.
        let deadline = Instant::now() + Duration::from_millis(50);
        loop {
            match self.slot.try_lock() {
                Ok(slot) => return slot.stop.clone(),
                Err(TryLockError::Poisoned(p)) => return p.into_inner().stop.clone(),
                Err(TryLockError::WouldBlock) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_micros(100));
                }
                Err(TryLockError::WouldBlock) => return None,
            }
        }
    }

    /// The family's stop sequence (isel: 0xFD 0xFF).
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// Write the stop sequence now. `Ok(false)` when no port is open.
    pub fn fire(&self) -> Result<bool, TransportError> {
        match self.current() {
            Some(stop) => stop.write_now(&self.bytes).map(|()| true),
            None => Ok(false),
        }
    }
}

/// The device task's input recorder, for a client that wants what it saw
/// before the client subscribed (the changes themselves come as
/// `Event::Input`), or how often the inputs are read.
#[derive(Debug, Clone)]
pub struct InputLog(pub(crate) Arc<Mutex<InputRecorder>>);

impl InputLog {
    pub(crate) fn new(recorder: InputRecorder) -> InputLog {
        InputLog(Arc::new(Mutex::new(recorder)))
    }

    /// Look at the recorder. The device task waits meanwhile: keep it short.
    pub fn read<R>(&self, f: impl FnOnce(&InputRecorder) -> R) -> R {
        let recorder = self.0.lock().unwrap_or_else(|p| p.into_inner());
        f(&recorder)
    }

    pub(crate) fn with<R>(&self, f: impl FnOnce(&mut InputRecorder) -> R) -> R {
        let mut recorder = self.0.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut recorder)
    }
}

/// What a client holds. Cheap to clone; the task ends (stopping motion
/// first) when every handle is gone or [`DeviceHandle::shutdown`] is called.
#[derive(Debug, Clone)]
pub struct DeviceHandle {
    pub(crate) requests: mpsc::Sender<Request>,
    pub(crate) stops: mpsc::UnboundedSender<StopCall>,
    pub(crate) bus: EventBus,
    pub(crate) emergency: EmergencyHandle,
    pub(crate) done: watch::Receiver<bool>,
    pub(crate) inputs: InputLog,
    /// The task was asked to move (`TaskOptions::moves`).
    pub(crate) moved: Arc<std::sync::atomic::AtomicBool>,
}

impl DeviceHandle {
    /// Whether this task was asked to move (`SessionMoves`): a way out that
    /// is not a stop the operator asked for (a quit, a hang-up, a signal)
    /// stops only then (`docs/device.md`, "Sessions that do not move").
    pub fn moved(&self) -> bool {
        self.moved.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Queue a request. Never waits: a full queue is refused at once.
    pub fn request(&self, request: Request) -> Result<(), RequestError> {
        self.requests.try_send(request).map_err(|e| match e {
            mpsc::error::TrySendError::Full(_) => RequestError::Full,
            mpsc::error::TrySendError::Closed(_) => RequestError::Closed,
        })
    }

    /// Stop all motion, now. Goes on its own path, ahead of every request.
    pub fn stop(&self) -> StopTicket {
        let (done, rx) = oneshot::channel();
        let call = StopCall {
            requested: Instant::now(),
            done,
        };
        // A task that has ended has nothing to stop; the ticket says so.
        let _ = self.stops.send(call);
        StopTicket { done: rx }
    }

    /// A new consumer of events (from now on).
    pub fn subscribe(&self) -> EventReceiver {
        self.bus.subscribe()
    }

    pub fn emergency(&self) -> EmergencyHandle {
        self.emergency.clone()
    }

    /// The input recorder the task feeds with every port reading.
    pub fn inputs(&self) -> &InputLog {
        &self.inputs
    }

    /// Stop motion, wait until the stop bytes have left, close the port and
    /// end the task; returns when it has ended.
    pub async fn shutdown(&self) {
        let _ = self.requests.send(Request::Shutdown).await;
        self.closed().await;
    }

    /// Returns once the task has ended.
    pub async fn closed(&self) {
        let mut done = self.done.clone();
        let _ = done.wait_for(|d| *d).await;
    }

    pub fn is_closed(&self) -> bool {
        *self.done.borrow()
    }
}
