//! The simulator shell: serves one [`SimDevice`] on one byte stream (a pty
//! master or one end of a socket pair) on its own std thread.
//!
//! The thread waits with `ppoll` (nanosecond timeouts) on the line and a wake
//! socket, and hands everything to the sans-IO [`Engine`], which models wire
//! timing both ways and applies faults. Operators and tests reach it through
//! a [`ShellControl`]; `docs/simulator.md` describes the behaviour.
//!
//! The `*_scaled` variants run the model on a [`TimeScale`]: the engine is
//! handed model time, and the thread sleeps until the wall-clock instant of
//! the model's next event ([`ScaledClock`]); the line stays on the wall
//! clock.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener};
use std::os::fd::{AsFd, OwnedFd};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, TryRecvError};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::Instant;

use rustix::event::{PollFd, PollFlags};

use super::control::run_control_loop;
use super::engine::{Engine, Wake};
use super::fault::Fault;
use super::line::{Line, PtyShared, ReadOutcome};
use super::pty::{self, StableLink};
use super::received::{Received, ReceivedLog};
use super::timescale::{ScaledClock, TimeScale};
use super::{InputControl, SimDevice, TimedControl};
use crate::transport::fd;
use crate::wire::LineSettings;

/// Errors of the simulator shell.
#[derive(Debug, thiserror::Error)]
pub enum ShellError {
    #[error("{action} failed: {source}")]
    Io {
        action: &'static str,
        #[source]
        source: io::Error,
    },
    #[error("{path}: cannot maintain the link: {source}")]
    Link {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The device or the shell refused a control or a fault; says why.
    #[error("{0}")]
    Rejected(String),
    /// The shell's thread has ended.
    #[error("the simulator has stopped")]
    Stopped,
}

/// How to serve on a pseudo-terminal.
#[derive(Debug, Clone, Default)]
pub struct PtyOptions {
    /// Keep a symlink here that points at the current slave device. It is
    /// removed while the line is closed and when the shell ends.
    pub link: Option<PathBuf>,
}

type Reply<T> = mpsc::Sender<T>;

enum Request {
    Input(InputControl, Reply<Result<(), String>>),
    Timed(Vec<TimedControl>, Reply<Result<(), String>>),
    Fault(Fault, Reply<Result<(), String>>),
    Memory(usize, Reply<Result<(), String>>),
    Show(Reply<String>),
    Received(Reply<Received>),
    InputNames(Reply<Vec<&'static str>>),
    InputLevels(Reply<Vec<(&'static str, Option<bool>)>>),
    Shutdown,
}

/// A cloneable, thread-safe way to operate a running shell.
#[derive(Clone)]
pub struct ShellControl {
    requests: mpsc::Sender<Request>,
    waker: Arc<UnixStream>,
}

impl std::fmt::Debug for ShellControl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ShellControl")
    }
}

impl ShellControl {
    /// Flip an input or press a button on the simulated machine.
    pub fn input(&self, control: InputControl) -> Result<(), ShellError> {
        self.ask(|reply| Request::Input(control, reply))?
            .map_err(ShellError::Rejected)
    }

    /// Pulse an input, make it chatter, or set it later (`pulse`,
    /// `chatter`, `after`); several are given at one instant (`;`).
    pub fn timed(&self, controls: Vec<TimedControl>) -> Result<(), ShellError> {
        self.ask(|reply| Request::Timed(controls, reply))?
            .map_err(ShellError::Rejected)
    }

    /// Inject a fault (`docs/simulator.md`, "Faults").
    pub fn fault(&self, fault: Fault) -> Result<(), ShellError> {
        self.ask(|reply| Request::Fault(fault, reply))?
            .map_err(ShellError::Rejected)
    }

    /// Size the controller's program store (`memory <n>`).
    pub fn program_memory(&self, commands: usize) -> Result<(), ShellError> {
        self.ask(|reply| Request::Memory(commands, reply))?
            .map_err(ShellError::Rejected)
    }

    /// The device's state line and the shell's line and wire counters.
    pub fn show(&self) -> Result<String, ShellError> {
        self.ask(Request::Show)
    }

    /// The bytes the device received from the line (`show received`).
    pub fn received(&self) -> Result<Received, ShellError> {
        self.ask(Request::Received)
    }

    /// The input names the device understands.
    pub fn input_names(&self) -> Result<Vec<&'static str>, ShellError> {
        self.ask(Request::InputNames)
    }

    /// Every input name with the level it stands at now (`SimDevice::input_level`).
    pub fn input_levels(&self) -> Result<Vec<(&'static str, Option<bool>)>, ShellError> {
        self.ask(Request::InputLevels)
    }

    fn ask<T>(&self, make: impl FnOnce(Reply<T>) -> Request) -> Result<T, ShellError> {
        let (tx, rx) = mpsc::channel();
        self.send(make(tx))?;
        rx.recv().map_err(|_| ShellError::Stopped)
    }

    fn send(&self, request: Request) -> Result<(), ShellError> {
        self.requests
            .send(request)
            .map_err(|_| ShellError::Stopped)?;
        // A full wake socket already holds a wake-up; nothing else can fail
        // that matters.
        let _ = (&*self.waker).write(&[1]);
        Ok(())
    }
}

/// A running simulator shell. Dropping it (or [`Shell::shutdown`]) stops the
/// thread and closes the line.
#[derive(Debug)]
pub struct Shell {
    control: ShellControl,
    line: LineSettings,
    pty: Option<Arc<PtyShared>>,
    /// The address a TCP line listens on.
    tcp: Option<SocketAddr>,
    thread: Option<JoinHandle<()>>,
}

impl Shell {
    pub fn control(&self) -> ShellControl {
        self.control.clone()
    }

    /// The line settings of the device served (for the client's port).
    pub fn line(&self) -> LineSettings {
        self.line
    }

    /// The current pty slave device, `None` for a socket or while closed.
    pub fn slave_path(&self) -> Option<PathBuf> {
        self.pty.as_ref().and_then(|p| p.slave())
    }

    /// The stable link, if one was asked for.
    pub fn link_path(&self) -> Option<&Path> {
        self.pty
            .as_ref()
            .and_then(|p| p.link.as_ref())
            .map(|l| l.path())
    }

    /// The address a TCP line listens on (`None` for a pty or socket pair).
    pub fn tcp_addr(&self) -> Option<SocketAddr> {
        self.tcp
    }

    /// The path a client should open: the link if there is one, else the slave.
    pub fn client_path(&self) -> Option<PathBuf> {
        self.link_path()
            .map(Path::to_path_buf)
            .or_else(|| self.slave_path())
    }

    /// Stop the thread, close the line, remove the link; waits for the thread.
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        let _ = self.control.send(Request::Shutdown);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for Shell {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Serve `device` in-process: returns the shell and the client's end of a
/// socket pair (for `transport::PortSpec::InProcess`).
pub fn serve_socket(device: Box<dyn SimDevice>) -> Result<(Shell, UnixStream), ShellError> {
    serve_socket_scaled(device, TimeScale::REAL)
}

/// [`serve_socket`] with the model on `time_scale` (`sim::timescale`).
pub fn serve_socket_scaled(
    device: Box<dyn SimDevice>,
    time_scale: TimeScale,
) -> Result<(Shell, UnixStream), ShellError> {
    let (ours, theirs) = UnixStream::pair().map_err(|source| ShellError::Io {
        action: "creating a socket pair",
        source,
    })?;
    let fd = OwnedFd::from(ours);
    fd::set_nonblocking(fd.as_fd()).map_err(|source| ShellError::Io {
        action: "setting the socket non-blocking",
        source,
    })?;
    let shell = spawn(device, Line::socket(fd), None, time_scale)?;
    Ok((shell, theirs))
}

/// Serve `device` on a TCP port, raw, one client at a time (as ser2net's
/// `accepter: tcp,…`); `addr` may give port 0 for any free one. The client
/// connects to [`Shell::tcp_addr`].
pub fn serve_tcp(device: Box<dyn SimDevice>, addr: SocketAddr) -> Result<Shell, ShellError> {
    serve_tcp_scaled(device, addr, TimeScale::REAL)
}

/// [`serve_tcp`] with the model on `time_scale` (`sim::timescale`).
pub fn serve_tcp_scaled(
    device: Box<dyn SimDevice>,
    addr: SocketAddr,
    time_scale: TimeScale,
) -> Result<Shell, ShellError> {
    let listener = TcpListener::bind(addr).map_err(|source| ShellError::Io {
        action: "listening on the TCP port",
        source,
    })?;
    listener
        .set_nonblocking(true)
        .map_err(|source| ShellError::Io {
            action: "setting the listener non-blocking",
            source,
        })?;
    let tcp = listener.local_addr().ok();
    let mut shell = spawn(device, Line::tcp(listener), None, time_scale)?;
    shell.tcp = tcp;
    Ok(shell)
}

/// Serve `device` on a new pseudo-terminal. The client opens
/// [`Shell::client_path`]; clients may close and reopen it at will.
pub fn serve_pty(device: Box<dyn SimDevice>, options: PtyOptions) -> Result<Shell, ShellError> {
    serve_pty_scaled(device, options, TimeScale::REAL)
}

/// [`serve_pty`] with the model on `time_scale` (`sim::timescale`).
pub fn serve_pty_scaled(
    device: Box<dyn SimDevice>,
    options: PtyOptions,
    time_scale: TimeScale,
) -> Result<Shell, ShellError> {
    let master = pty::open_master().map_err(|source| ShellError::Io {
        action: "creating a pseudo-terminal",
        source,
    })?;
    let link = options.link.map(StableLink::new);
    if let Some(link) = &link {
        link.point_to(&master.slave_path)
            .map_err(|source| ShellError::Link {
                path: link.path().to_path_buf(),
                source,
            })?;
    }
    let shared = Arc::new(PtyShared {
        slave: Mutex::new(Some(master.slave_path)),
        link,
    });
    let line = Line::pty(master.fd, shared.clone(), Instant::now());
    spawn(device, line, Some(shared), time_scale)
}

/// What `jogterm sim --pty` runs: serve `device` on a new pty, print the path
/// to open (the link if given, else the slave device) as the first line of
/// stdout, then read control commands from stdin until it closes (or `quit`).
pub fn run_pty_simulator(
    device: Box<dyn SimDevice>,
    options: PtyOptions,
) -> Result<(), ShellError> {
    let stdin = io::stdin();
    let stdout = io::stdout();
    run_pty_simulator_with(
        device,
        options,
        stdin.lock(),
        &mut stdout.lock(),
        &mut io::stderr(),
    )
}

/// [`run_pty_simulator`] on any input and outputs.
pub fn run_pty_simulator_with(
    device: Box<dyn SimDevice>,
    options: PtyOptions,
    input: impl io::BufRead,
    out: &mut impl Write,
    err: &mut impl Write,
) -> Result<(), ShellError> {
    run_simulator_with(
        device,
        Serve::Pty(options),
        TimeScale::REAL,
        input,
        out,
        err,
    )
}

/// Where `jogterm sim` serves.
#[derive(Debug, Clone)]
pub enum Serve {
    Pty(PtyOptions),
    Tcp(SocketAddr),
}

/// What `jogterm sim` runs: serve `device`, print where a client finds it
/// as the first line of stdout (the pty's link or slave path, or
/// `tcp://ADDR:PORT`), then read control commands from `input` until it
/// closes (or `quit`). The model runs on `time_scale` (`jogterm sim
/// --time-scale`).
pub fn run_simulator_with(
    device: Box<dyn SimDevice>,
    serve: Serve,
    time_scale: TimeScale,
    input: impl io::BufRead,
    out: &mut impl Write,
    err: &mut impl Write,
) -> Result<(), ShellError> {
    let (shell, first) = match serve {
        Serve::Pty(options) => {
            let shell = serve_pty_scaled(device, options, time_scale)?;
            let path = shell.client_path().ok_or(ShellError::Stopped)?;
            let first = path.display().to_string();
            (shell, first)
        }
        Serve::Tcp(addr) => {
            let shell = serve_tcp_scaled(device, addr, time_scale)?;
            let addr = shell.tcp_addr().ok_or(ShellError::Stopped)?;
            (shell, format!("tcp://{addr}"))
        }
    };
    writeln!(out, "{first}")
        .and_then(|()| out.flush())
        .map_err(|source| ShellError::Io {
            action: "writing where to connect",
            source,
        })?;
    let result = run_control_loop(input, out, err, &shell.control());
    shell.shutdown();
    result.map_err(|source| ShellError::Io {
        action: "running the control loop",
        source,
    })
}

fn spawn(
    device: Box<dyn SimDevice>,
    line: Line,
    pty: Option<Arc<PtyShared>>,
    time_scale: TimeScale,
) -> Result<Shell, ShellError> {
    let (wake_tx, wake_rx) = UnixStream::pair().map_err(|source| ShellError::Io {
        action: "creating the wake socket",
        source,
    })?;
    for s in [&wake_tx, &wake_rx] {
        s.set_nonblocking(true).map_err(|source| ShellError::Io {
            action: "setting the wake socket non-blocking",
            source,
        })?;
    }
    let (requests, request_rx) = mpsc::channel();
    let engine = Engine::new(device);
    let settings = engine.line();
    let worker = Worker {
        clock: ScaledClock::new(Instant::now(), time_scale),
        engine,
        line,
        requests: request_rx,
        wake: wake_rx,
        out: Vec::new(),
        last_error: None,
        received: ReceivedLog::default(),
    };
    let thread = thread::Builder::new()
        .name("jogterm-sim".into())
        .spawn(move || worker.run())
        .map_err(|source| ShellError::Io {
            action: "starting the simulator thread",
            source,
        })?;
    Ok(Shell {
        control: ShellControl {
            requests,
            waker: Arc::new(wake_tx),
        },
        line: settings,
        pty,
        tcp: None,
        thread: Some(thread),
    })
}

/// How long before the last byte of a message the shell stops sleeping and
/// spins. Covers the usual timer lateness; costs at most this much CPU per
/// message.
const EXACT_SPIN: std::time::Duration = std::time::Duration::from_micros(200);

struct Worker {
    /// Wall clock to model time and back. The engine sees only model time;
    /// the line, `poll` and the spin only wall-clock time.
    clock: ScaledClock,
    engine: Engine,
    line: Line,
    requests: mpsc::Receiver<Request>,
    wake: UnixStream,
    out: Vec<u8>,
    /// The last line error (such as a failed reopen), for `show`.
    last_error: Option<String>,
    /// Everything read from the line, for `show received`.
    received: ReceivedLog,
}

enum Flow {
    Continue,
    Exit,
}

impl Worker {
    fn run(mut self) {
        fd::tighten_timer_slack();
        let mut buf = [0u8; 1024];
        loop {
            loop {
                match self.requests.try_recv() {
                    Ok(request) => {
                        if let Flow::Exit = self.handle(request) {
                            return self.finish();
                        }
                    }
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return self.finish(),
                }
            }
            let now = Instant::now();
            if let Err(e) = self.line.tick(now) {
                self.last_error = Some(format!("the line: {e}"));
            }
            self.catch_up(now);

            // The model's next event, at the wall-clock instant it is due.
            let wake = self.engine.next_wake().map(|w| Wake {
                at: self.clock.real(w.at),
                ..w
            });
            // For the last byte of a message, wake early and spin the rest:
            // the kernel's timer wakes a thread tens of µs late (75 µs is
            // typical in a VM), and that lateness would add to every
            // request/reply cycle a client measures.
            let engine_deadline = wake.map(|w| {
                if w.exact {
                    w.at.checked_sub(EXACT_SPIN).unwrap_or(w.at)
                } else {
                    w.at
                }
            });
            let deadline = [engine_deadline, self.line.timer()]
                .into_iter()
                .flatten()
                .min();
            // The wake socket, the line while a client is on it, and a TCP
            // line's listener. What is ready is read out in this block: the
            // poll entries borrow the line, which is read from below.
            let (ready, wake_ready, line_ready, listener_ready) = {
                let mut fds: [PollFd<'_>; 3] =
                    std::array::from_fn(|_| fd::pollfd(self.wake.as_fd(), PollFlags::IN));
                let mut watched = 1;
                let line_at = self.line.readable_fd().map(|line_fd| {
                    fds[watched] = fd::pollfd(line_fd, PollFlags::IN);
                    watched += 1;
                    watched - 1
                });
                let listener_at = self.line.listener_fd().map(|l| {
                    fds[watched] = fd::pollfd(l, PollFlags::IN);
                    watched += 1;
                    watched - 1
                });
                let ready =
                    match fd::poll_until(fds.get_mut(..watched).unwrap_or_default(), deadline) {
                        Ok(n) => n,
                        Err(_) => {
                            // Cannot wait (should not happen): do not spin at full speed.
                            thread::sleep(std::time::Duration::from_micros(200));
                            continue;
                        }
                    };
                let ready_at = |at: Option<usize>| {
                    at.and_then(|i| fds.get(i))
                        .is_some_and(|p| !p.revents().is_empty())
                };
                (
                    ready,
                    ready_at(Some(0)),
                    ready_at(line_at),
                    ready_at(listener_at),
                )
            };
            if ready == 0
                && let Some(w) = wake.filter(|w| w.exact && Instant::now() + EXACT_SPIN >= w.at)
            {
                while Instant::now() < w.at {
                    std::hint::spin_loop();
                }
                continue;
            }
            // The moment the bytes are known to be there: they arrive one
            // byte time after this at the earliest.
            let read_at = Instant::now();
            if wake_ready {
                let mut sink = [0u8; 64];
                while matches!((&self.wake).read(&mut sink), Ok(n) if n > 0) {}
            }
            if line_ready {
                while let ReadOutcome::Data(n) = self.line.read(&mut buf, read_at) {
                    let bytes = buf.get(..n).unwrap_or_default();
                    self.received.record(bytes);
                    self.engine.receive(bytes, self.clock.model(read_at));
                }
            }
            if listener_ready {
                self.line.accept();
            }
        }
    }

    /// Bring the model up to wall-clock `now` and put every byte due on the
    /// line.
    fn catch_up(&mut self, now: Instant) {
        self.out.clear();
        self.engine.run_until(self.clock.model(now), &mut self.out);
        if !self.out.is_empty() {
            self.line.write(&self.out, now);
        }
    }

    fn handle(&mut self, request: Request) -> Flow {
        let now = Instant::now();
        self.catch_up(now);
        // Controls, faults and the device's state are the model's; closing
        // the line and its status are the wall clock's.
        let model_now = self.clock.model(now);
        match request {
            Request::Input(control, reply) => {
                let _ = reply.send(self.engine.control(&control, model_now));
            }
            Request::Timed(controls, reply) => {
                let result = controls
                    .iter()
                    .try_for_each(|c| self.engine.timed(c, model_now));
                let _ = reply.send(result);
            }
            Request::Fault(Fault::Close { reopen_after }, reply) => {
                let _ = reply.send(self.line.close(reopen_after, now));
            }
            Request::Fault(fault, reply) => {
                let _ = reply.send(self.engine.fault(fault, model_now));
            }
            Request::Memory(commands, reply) => {
                let _ = reply.send(self.engine.set_program_memory(commands));
            }
            Request::Show(reply) => {
                let _ = reply.send(self.show(now));
            }
            Request::Received(reply) => {
                let _ = reply.send(self.received.snapshot());
            }
            Request::InputNames(reply) => {
                let _ = reply.send(self.engine.input_names());
            }
            Request::InputLevels(reply) => {
                let levels = self
                    .engine
                    .input_names()
                    .into_iter()
                    .map(|name| (name, self.engine.input_level(name)))
                    .collect();
                let _ = reply.send(levels);
            }
            Request::Shutdown => return Flow::Exit,
        }
        Flow::Continue
    }

    fn show(&mut self, now: Instant) -> String {
        let s = self.engine.stats();
        let mut text = format!(
            "device: {}\nline: {} baud, {}\nwire: received {} bytes; sent {} bytes in {} messages; \
             withheld {} messages; dropped {}, corrupted {}, garbage {} bytes; \
             lost without a client {}, not taken by the client {} bytes\nfaults armed: {}",
            self.engine.describe(self.clock.model(now)),
            self.engine.line().baud,
            self.line_status(now),
            s.bytes_received,
            s.bytes_sent,
            s.messages_sent,
            s.messages_withheld,
            s.bytes_dropped,
            s.bytes_corrupted,
            s.garbage_bytes,
            self.line.lost_bytes,
            self.line.overrun_bytes,
            self.engine.armed(),
        );
        if let Some(e) = &self.last_error {
            text.push_str("\nlast error: ");
            text.push_str(e);
        }
        text
    }

    /// The line's status, and the time scale when the model is not on the
    /// wall clock.
    fn line_status(&self, now: Instant) -> String {
        let status = self.line.status(now);
        let scale = self.clock.scale();
        if scale.is_real() {
            status
        } else {
            format!("{status}; time scale {scale} (the model runs {scale} times the wall clock)")
        }
    }

    fn finish(mut self) {
        let _ = self.line.close(None, Instant::now());
    }
}
