//! The loop that drives the model: messages in (keys from the input thread,
//! device events, ticks, signals, simulator answers), `update`, effects out
//! to the device and the simulator, and a redraw when something changed, at
//! most once per frame interval.
//!
//! A stop never waits: input is looked at first, and the `Stop` effect goes
//! to the device's stop lane as soon as `update` returns it.
//!
//! Terminating signals (HUP, TERM, INT) are watched by a task of their own,
//! which writes the stop bytes through the emergency handle the moment a
//! signal arrives, whatever this loop is doing (drawing to a terminal that
//! has stopped reading, say), and then tells the loop to stop and leave.

use std::future::Future;
use std::time::{Duration, Instant};

use ratatui::Terminal;
use ratatui::backend::Backend;
use tokio::signal::unix::{SignalKind, signal};
use tokio::sync::mpsc::{self, UnboundedReceiver, UnboundedSender};

use crate::device::api::{Event, LinkState, Request};
use crate::device::describe::describe;
use crate::sim::InputControl;
use crate::sim::shell::ShellControl;

use super::editor::worker::EditorWorker;
use super::model::Model;
use super::msg::{Effect, Msg};
use super::terminal::run_emergency;
use super::update::update;
use super::view::Screen;
use crate::offsets::store::Writer;

/// The device task as the UI needs it. Implemented for the real device
/// handle and for test doubles.
pub trait DeviceLink {
    /// Hand a request to the device task.
    fn request(&mut self, request: Request) -> Result<(), NotSent>;
    /// Stop all motion, ahead of everything queued.
    fn stop(&mut self);
    /// The stop of a way out the operator did not ask to stop by (a
    /// hang-up, a signal): only when this session was asked to move
    /// (`docs/device.md`, "Sessions that do not move").
    fn stop_on_exit(&mut self) {
        self.stop();
    }
    /// The next event; `None` once the device task has ended.
    fn next_event(&mut self) -> impl Future<Output = Option<Event>> + Send;
}

/// Why a request did not reach the device task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum NotSent {
    #[error("too many requests are waiting for the device task")]
    Busy,
    #[error("the device task has ended")]
    Gone,
}

impl From<crate::device::RequestError> for NotSent {
    fn from(e: crate::device::RequestError) -> Self {
        match e {
            crate::device::RequestError::Full => NotSent::Busy,
            crate::device::RequestError::Closed => NotSent::Gone,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("drawing the screen failed: {0}")]
    Draw(String),
    #[error("cannot watch for signals: {0}")]
    Signals(#[source] std::io::Error),
    #[error("cannot start the editor's file and lint threads or the offsets writer: {0}")]
    Worker(#[source] std::io::Error),
}

#[derive(Debug, Clone, Copy)]
pub struct RunOptions {
    /// Least time between two frames (20 frames/s at 50 ms).
    pub frame_interval: Duration,
    /// How long to wait for the device to close after `Quit`.
    pub shutdown_timeout: Duration,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            frame_interval: Duration::from_millis(50),
            shutdown_timeout: Duration::from_secs(2),
        }
    }
}

/// Run until the operator quits, a terminating signal arrives or the
/// terminal hangs up. The device is stopped and shut down on every way out.
pub async fn run<B: Backend, D: DeviceLink>(
    terminal: &mut Terminal<B>,
    model: &mut Model,
    device: &mut D,
    input: &mut UnboundedReceiver<Msg>,
    simulator: Option<ShellControl>,
    options: RunOptions,
) -> Result<(), RunError> {
    let (signal_tx, mut signals) = mpsc::unbounded_channel::<Msg>();
    let watcher = watch_signals(signal_tx)?;
    let (sim_tx, mut sim_rx) = mpsc::unbounded_channel::<Msg>();
    let (editor_tx, mut editor_rx) = mpsc::unbounded_channel::<Msg>();
    let worker = EditorWorker::spawn(editor_tx.clone()).map_err(RunError::Worker)?;
    // The work offsets file is written on a thread of its own; how it went
    // comes back on the editor's channel, which is only a channel of `Msg`.
    let offsets = Writer::spawn(move |what, saved| {
        let _ = editor_tx.send(Msg::OffsetsSaved(what, saved));
    })
    .map_err(RunError::Worker)?;
    let mut ticks = tokio::time::interval(options.frame_interval);
    ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut last_draw: Option<Instant> = None;
    let mut device_open = true;
    // A frame that could not be drawn: the terminal is gone (a hang-up's
    // EIO can beat its SIGHUP and POLLHUP to this loop). The way out is the
    // one a `Terminate` takes, so the last edits still reach the recovery
    // file, and the error is returned once that is done.
    let mut failed: Option<RunError> = None;
    let mut next: Option<Msg> = None;
    loop {
        let msg = if let Some(msg) = next.take() {
            msg
        } else {
            tokio::select! {
            biased;
            msg = input.recv() => msg.unwrap_or(Msg::Terminate {
                reason: "terminal input ended".into(),
            }),
            Some(msg) = signals.recv() => msg,
            event = device.next_event(), if device_open => match event {
                Some(e) => Msg::Device(e),
                None => {
                    device_open = false;
                    Msg::Device(Event::Link(LinkState::Lost {
                        reason: "the device task has ended".into(),
                    }))
                }
            },
            Some(msg) = sim_rx.recv() => msg,
            Some(msg) = editor_rx.recv() => msg,
            _ = ticks.tick() => Msg::Tick(Instant::now()),
            }
        };
        if matches!(msg, Msg::Terminate { .. }) {
            // The way out may be a dead terminal: the stop bytes go first,
            // on the reserved handle, before anything else can block.
            run_emergency();
            device.stop_on_exit();
            late_edits(model, input, &worker).await;
        }
        let effects = update(model, msg);
        let leaving = effects.iter().any(|e| matches!(e, Effect::Quit));
        let mut quit = false;
        for effect in effects {
            match effect {
                // The stop of a quit (or of a signal's way out) goes out only
                // when this session moved; Space alone always stops.
                Effect::Stop if leaving => device.stop_on_exit(),
                Effect::Stop => device.stop(),
                Effect::Request(request) => {
                    let what = describe(&request);
                    if let Err(reason) = device.request(request) {
                        device_open &= reason != NotSent::Gone;
                        // Said at once; the model never waits for an answer.
                        update(
                            model,
                            Msg::NotSent {
                                request: what,
                                reason: reason.to_string(),
                            },
                        );
                    }
                }
                Effect::Simulator(control) => simulate(simulator.clone(), control, sim_tx.clone()),
                // On the way out no lint is started; files go through the
                // file thread like every other request, so they are done in
                // the order asked (`finish_files` waits for them).
                Effect::Editor(crate::ui::editor::io::EditorIo::Lint(_)) if leaving => {}
                Effect::Editor(io) => worker.submit(io),
                Effect::SaveOffsets(job) => offsets.submit(job),
                Effect::ReadJobLog => read_job_log(sim_tx.clone()),
                Effect::Quit => quit = true,
            }
        }
        if quit {
            if failed.is_none() {
                // One last frame so the screen says what is happening.
                let _ = draw(terminal, model);
            }
            // The stop bytes went out already; the device closes while the
            // files are written, so neither waits on the other.
            tokio::join!(
                finish_files(worker),
                finish_offsets(offsets),
                shutdown(device, options.shutdown_timeout)
            );
            watcher.abort();
            return failed.map_or(Ok(()), Err);
        }
        let due = last_draw.is_none_or(|t| t.elapsed() >= options.frame_interval);
        if model.dirty && due {
            if let Err(e) = draw(terminal, model) {
                next = Some(Msg::Terminate {
                    reason: e.to_string(),
                });
                failed = Some(e);
                continue;
            }
            last_draw = Some(Instant::now());
        }
    }
}

/// How long a `Terminate` waits for keys the input thread read before the
/// hang-up and has not handed over yet.
const LATE_INPUT: Duration = Duration::from_millis(200);

/// The job log read off the loop (`jogterm log`'s table, newest last) and
/// handed back as `Msg::JobLog`.
fn read_job_log(tx: mpsc::UnboundedSender<Msg>) {
    tokio::task::spawn_blocking(move || {
        let lines = match crate::joblog::file::dir() {
            Some(dir) => {
                let folded = crate::joblog::file::read(&dir);
                let mut lines = vec![format!(
                    "job log {}:",
                    dir.join(crate::joblog::file::FILE_NAME).display()
                )];
                lines.extend(crate::joblog::table::table(&folded.runs, JOB_LOG_RUNS));
                lines.extend(folded.notes);
                lines
            }
            None => vec!["no state directory: no job log".to_owned()],
        };
        let _ = tx.send(Msg::JobLog(lines));
    });
}

/// How many runs the console shows of the job log.
const JOB_LOG_RUNS: usize = 10;

/// Keys typed before a hang-up can still be on their way when the
/// `Terminate` of the hang-up watcher or of SIGHUP is taken: read by
/// crossterm, not yet sent (or, for a signal, behind it in the select).
/// Their edits must reach the recovery file, so the input thread gets a
/// moment to hand them over, until it ends (its own `Terminate`, or the
/// channel closed) or `LATE_INPUT` has passed. The machine is stopped
/// already: only their file effects are carried out, never a request to
/// the device.
async fn late_edits(model: &mut Model, input: &mut UnboundedReceiver<Msg>, worker: &EditorWorker) {
    let until = tokio::time::Instant::now() + LATE_INPUT;
    loop {
        let msg = match tokio::time::timeout_at(until, input.recv()).await {
            Ok(Some(msg @ (Msg::Key(_) | Msg::KeyAt(..) | Msg::KeysAt(_) | Msg::Paste(_)))) => msg,
            Ok(Some(Msg::Terminate { .. }) | None) | Err(_) => return,
            Ok(Some(_)) => continue,
        };
        for effect in update(model, msg) {
            match effect {
                Effect::Editor(crate::ui::editor::io::EditorIo::Lint(_)) => {}
                Effect::Editor(io) => worker.submit(io),
                _ => {}
            }
        }
    }
}

/// How long the way out waits for the file thread. Bounded, so a dead
/// disk cannot keep the process alive, but generous: a recovery write is
/// two `fsync`s, which on a busy disk take seconds, and the process ending
/// first would lose the edits it carries.
const FILES_BOUND: Duration = Duration::from_secs(10);

/// Let the editor's file thread finish what it was handed (bounded).
async fn finish_files(worker: EditorWorker) {
    let _ = tokio::task::spawn_blocking(move || worker.finish(FILES_BOUND)).await;
}

/// Let the work offsets' writer finish what it was handed (bounded).
async fn finish_offsets(writer: Writer) {
    let _ = tokio::task::spawn_blocking(move || writer.finish(FILES_BOUND)).await;
}

/// Watch HUP, TERM and INT on a task of their own. Their default action
/// ends the process without a stop (and SIGHUP is what a vanishing
/// terminal sends), so they are caught from here on: each writes the stop
/// bytes through the emergency handle at once, then asks the loop to stop
/// and leave (`docs/field-notes.md`, "SIGHUP's default action").
fn watch_signals(tx: UnboundedSender<Msg>) -> Result<tokio::task::JoinHandle<()>, RunError> {
    let mut hangup = signal(SignalKind::hangup()).map_err(RunError::Signals)?;
    let mut terminate = signal(SignalKind::terminate()).map_err(RunError::Signals)?;
    let mut interrupt = signal(SignalKind::interrupt()).map_err(RunError::Signals)?;
    Ok(tokio::spawn(async move {
        loop {
            let reason = tokio::select! {
                _ = hangup.recv() => "hang-up signal",
                _ = terminate.recv() => "terminate signal",
                _ = interrupt.recv() => "interrupt signal",
            };
            run_emergency();
            if tx
                .send(Msg::Terminate {
                    reason: reason.into(),
                })
                .is_err()
            {
                return;
            }
        }
    }))
}

fn draw<B: Backend>(terminal: &mut Terminal<B>, model: &mut Model) -> Result<(), RunError> {
    terminal
        .draw(|frame| {
            let area = frame.area();
            frame.render_widget(Screen(&*model), area);
            // Shown only where typing lands; ratatui hides it otherwise.
            if let Some(at) = super::view::cursor(model, area) {
                frame.set_cursor_position(at);
            }
        })
        .map_err(|e| RunError::Draw(e.to_string()))?;
    model.dirty = false;
    Ok(())
}

/// Ask the device to close and wait (bounded) until it says it has.
async fn shutdown<D: DeviceLink>(device: &mut D, timeout: Duration) {
    if device.request(Request::Shutdown).is_err() {
        return;
    }
    let _ = tokio::time::timeout(timeout, async {
        while let Some(event) = device.next_event().await {
            if matches!(event, Event::Link(LinkState::Closed)) {
                break;
            }
        }
    })
    .await;
}

/// Carry out a simulator control off the loop (the shell answers over a
/// channel) and report the outcome as a message.
fn simulate(shell: Option<ShellControl>, control: InputControl, tx: UnboundedSender<Msg>) {
    let Some(shell) = shell else {
        let _ = tx.send(Msg::Simulator {
            control,
            result: Err("this session is not on the built-in simulator".into()),
        });
        return;
    };
    tokio::task::spawn_blocking(move || {
        let result = shell.input(control.clone()).map_err(|e| e.to_string());
        let _ = tx.send(Msg::Simulator { control, result });
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile, load_theme};
    use crate::ui::keymap::Keymap;
    use crate::ui::model::Setup;
    use crate::ui::palette::Palette;
    use ratatui::backend::TestBackend;
    use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

    /// Records what the UI asked for; answers `Shutdown` with `Closed`;
    /// refuses other requests as busy when told to.
    struct FakeDevice {
        calls: Vec<String>,
        events: UnboundedReceiver<Event>,
        events_tx: UnboundedSender<Event>,
        busy: bool,
    }

    impl FakeDevice {
        fn new(busy: bool) -> Self {
            let (events_tx, events) = mpsc::unbounded_channel();
            FakeDevice {
                calls: Vec::new(),
                events,
                events_tx,
                busy,
            }
        }
    }

    impl DeviceLink for FakeDevice {
        fn request(&mut self, request: Request) -> Result<(), NotSent> {
            if self.busy && request != Request::Shutdown {
                return Err(NotSent::Busy);
            }
            if request == Request::Shutdown {
                let _ = self.events_tx.send(Event::Link(LinkState::Closed));
            }
            self.calls.push(format!("{request:?}"));
            Ok(())
        }

        fn stop(&mut self) {
            self.calls.push("stop".into());
        }

        fn next_event(&mut self) -> impl Future<Output = Option<Event>> + Send {
            self.events.recv()
        }
    }

    fn model() -> Model {
        let dirs = ConfigDirs::builtin_only();
        let profile = load_profile("default", &dirs).expect("profile");
        let theme = load_theme("dark", &dirs).expect("theme");
        Model::new(
            Setup::from_profile(&profile, None),
            Keymap::builtin().expect("built-in keys"),
            Palette::from(&theme),
            Instant::now(),
        )
    }

    fn key(c: char) -> Msg {
        Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
    }

    #[tokio::test]
    async fn space_stops_and_quit_shuts_the_device_down() {
        let mut device = FakeDevice::new(false);
        let events_tx = device.events_tx.clone();
        let (tx, mut rx) = mpsc::unbounded_channel();
        events_tx
            .send(Event::Link(LinkState::Connected))
            .expect("event");
        tx.send(key(' ')).expect("key");
        tx.send(key('q')).expect("key");
        let mut terminal = Terminal::new(TestBackend::new(80, 24)).expect("terminal");
        let mut model = model();
        run(
            &mut terminal,
            &mut model,
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await
        .expect("run");
        assert_eq!(device.calls, ["stop", "stop", "Shutdown"]);
        assert!(model.quitting);
    }

    /// A test backend that counts the frames written.
    struct Frames {
        inner: TestBackend,
        flushes: usize,
    }

    impl Backend for Frames {
        type Error = <TestBackend as Backend>::Error;

        fn draw<'a, I>(&mut self, content: I) -> Result<(), Self::Error>
        where
            I: Iterator<Item = (u16, u16, &'a ratatui::buffer::Cell)>,
        {
            self.inner.draw(content)
        }

        fn hide_cursor(&mut self) -> Result<(), Self::Error> {
            self.inner.hide_cursor()
        }

        fn show_cursor(&mut self) -> Result<(), Self::Error> {
            self.inner.show_cursor()
        }

        fn get_cursor_position(&mut self) -> Result<ratatui::layout::Position, Self::Error> {
            self.inner.get_cursor_position()
        }

        fn set_cursor_position<P: Into<ratatui::layout::Position>>(
            &mut self,
            position: P,
        ) -> Result<(), Self::Error> {
            self.inner.set_cursor_position(position)
        }

        fn clear(&mut self) -> Result<(), Self::Error> {
            self.inner.clear()
        }

        fn clear_region(
            &mut self,
            clear_type: ratatui::backend::ClearType,
        ) -> Result<(), Self::Error> {
            self.inner.clear_region(clear_type)
        }

        fn size(&self) -> Result<ratatui::layout::Size, Self::Error> {
            self.inner.size()
        }

        fn window_size(&mut self) -> Result<ratatui::backend::WindowSize, Self::Error> {
            self.inner.window_size()
        }

        fn flush(&mut self) -> Result<(), Self::Error> {
            self.flushes += 1;
            self.inner.flush()
        }
    }

    #[tokio::test]
    async fn a_flood_of_events_is_drawn_at_the_frame_rate() {
        let mut device = FakeDevice::new(false);
        let events_tx = device.events_tx.clone();
        for i in 0..500 {
            let sample = crate::device::api::PositionSample {
                at: Instant::now(),
                steps: crate::device::api::PerAxis::new().with(crate::axis::Axis::X, i),
                source: crate::device::api::PositionSource::Measured,
            };
            events_tx.send(Event::Position(sample)).expect("event");
        }
        let (tx, mut rx) = mpsc::unbounded_channel();
        let quit_later = tokio::spawn(async move {
            tokio::time::sleep(Duration::from_millis(300)).await;
            let _ = tx.send(key('q'));
            tx
        });
        let mut terminal = Terminal::new(Frames {
            inner: TestBackend::new(80, 24),
            flushes: 0,
        })
        .expect("terminal");
        let started = Instant::now();
        run(
            &mut terminal,
            &mut model(),
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await
        .expect("run");
        let _ = quit_later.await;
        let frames = terminal.backend().flushes;
        let allowed = started.elapsed().as_millis() as usize / 50 + 3;
        assert!(frames >= 1, "drawn at least once");
        assert!(
            frames <= allowed,
            "{frames} frames for 500 events (at most {allowed})"
        );
    }

    /// A terminal that has gone: every flush fails as a hung-up pty does.
    struct HungUp(TestBackend);

    fn never(e: core::convert::Infallible) -> std::io::Error {
        match e {}
    }

    impl Backend for HungUp {
        type Error = std::io::Error;

        fn draw<'a, I>(&mut self, content: I) -> Result<(), Self::Error>
        where
            I: Iterator<Item = (u16, u16, &'a ratatui::buffer::Cell)>,
        {
            self.0.draw(content).map_err(never)
        }

        fn hide_cursor(&mut self) -> Result<(), Self::Error> {
            self.0.hide_cursor().map_err(never)
        }

        fn show_cursor(&mut self) -> Result<(), Self::Error> {
            self.0.show_cursor().map_err(never)
        }

        fn get_cursor_position(&mut self) -> Result<ratatui::layout::Position, Self::Error> {
            self.0.get_cursor_position().map_err(never)
        }

        fn set_cursor_position<P: Into<ratatui::layout::Position>>(
            &mut self,
            position: P,
        ) -> Result<(), Self::Error> {
            self.0.set_cursor_position(position).map_err(never)
        }

        fn clear(&mut self) -> Result<(), Self::Error> {
            self.0.clear().map_err(never)
        }

        fn clear_region(
            &mut self,
            clear_type: ratatui::backend::ClearType,
        ) -> Result<(), Self::Error> {
            self.0.clear_region(clear_type).map_err(never)
        }

        fn size(&self) -> Result<ratatui::layout::Size, Self::Error> {
            self.0.size().map_err(never)
        }

        fn window_size(&mut self) -> Result<ratatui::backend::WindowSize, Self::Error> {
            self.0.window_size().map_err(never)
        }

        fn flush(&mut self) -> Result<(), Self::Error> {
            Err(std::io::Error::from(rustix::io::Errno::IO))
        }
    }

    /// The model with its editor keeping recovery files in `dir`.
    fn model_keeping_recoveries(
        dir: &std::path::Path,
    ) -> (Model, crate::program::store::RecoveryStore) {
        let store = crate::program::store::RecoveryStore::new(dir);
        let mut model = model();
        model.editor.keep_recoveries(store.clone(), "test");
        (model, store)
    }

    /// The terminal hangs up and the next frame fails before any hang-up
    /// message arrives: the way out still writes the unsaved edits to the
    /// recovery file (the autosave is not due for an hour).
    #[tokio::test]
    async fn a_frame_that_cannot_be_drawn_still_keeps_the_edits() {
        let dir = tempfile::tempdir().expect("tempdir");
        let (mut model, store) = model_keeping_recoveries(dir.path());
        let mut device = FakeDevice::new(false);
        for c in "; last-words".chars() {
            model.editor.buffer.insert_char(c);
        }
        model.editor.after_edit(model.now);
        model.editor.file.recovery_due = Some(Instant::now() + Duration::from_secs(3600));
        model.dirty = true;
        // The input stays open: no `Terminate` but the failed frame's.
        let (_tx, mut rx) = mpsc::unbounded_channel::<Msg>();
        let mut terminal = Terminal::new(HungUp(TestBackend::new(80, 24))).expect("terminal");
        let result = run(
            &mut terminal,
            &mut model,
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await;
        assert!(matches!(result, Err(RunError::Draw(_))), "{result:?}");
        assert_eq!(device.calls.first().map(String::as_str), Some("stop"));
        assert!(device.calls.iter().any(|c| c == "Shutdown"));
        let kept = store
            .read(&model.editor.origin())
            .expect("read the recovery")
            .map(|r| r.text)
            .unwrap_or_default();
        assert!(kept.contains("; last-words"), "{kept:?}");
    }

    /// The hang-up watcher's `Terminate` is taken before keys the input
    /// thread read just ahead of the hang-up: their edits still reach the
    /// recovery file, and they ask the device for nothing.
    #[tokio::test]
    async fn keys_behind_a_hang_up_still_reach_the_recovery_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let (mut model, store) = model_keeping_recoveries(dir.path());
        let mut device = FakeDevice::new(false);
        model.focus = crate::ui::model::PanelId::Editor;
        model.editor.file.recovery_due = Some(Instant::now() + Duration::from_secs(3600));
        let (tx, mut rx) = mpsc::unbounded_channel::<Msg>();
        tx.send(Msg::Terminate {
            reason: "the terminal hung up".into(),
        })
        .expect("send");
        for c in "late".chars() {
            tx.send(key(c)).expect("key");
        }
        // The input thread's own end, as on EOF.
        tx.send(Msg::Terminate {
            reason: "terminal input ended".into(),
        })
        .expect("send");
        let mut terminal = Terminal::new(TestBackend::new(80, 24)).expect("terminal");
        run(
            &mut terminal,
            &mut model,
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await
        .expect("run");
        assert_eq!(model.editor.buffer.text().trim_end(), "late");
        let kept = store
            .read(&model.editor.origin())
            .expect("read the recovery")
            .map(|r| r.text)
            .unwrap_or_default();
        assert_eq!(kept.trim_end(), "late");
        assert!(
            device.calls.iter().all(|c| c == "stop" || c == "Shutdown"),
            "{:?}",
            device.calls
        );
    }

    #[tokio::test]
    async fn a_closed_input_stops_and_leaves() {
        let mut device = FakeDevice::new(false);
        let (tx, mut rx) = mpsc::unbounded_channel::<Msg>();
        drop(tx);
        let mut terminal = Terminal::new(TestBackend::new(80, 24)).expect("terminal");
        run(
            &mut terminal,
            &mut model(),
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await
        .expect("run");
        // The stop goes out as the `Terminate` is taken, before late keys
        // are waited for, and once more from `update`.
        assert_eq!(device.calls, ["stop", "stop", "Shutdown"]);
    }

    #[tokio::test]
    async fn a_request_the_device_cannot_take_is_said_at_once() {
        let mut device = FakeDevice::new(true);
        let (tx, mut rx) = mpsc::unbounded_channel();
        tx.send(key('i')).expect("key");
        tx.send(key('q')).expect("key");
        let mut terminal = Terminal::new(TestBackend::new(80, 24)).expect("terminal");
        let mut model = model();
        run(
            &mut terminal,
            &mut model,
            &mut device,
            &mut rx,
            None,
            RunOptions::default(),
        )
        .await
        .expect("run");
        let text = model.message.map(|m| m.text).unwrap_or_default();
        assert!(
            model.console.traffic.tail(50).iter().any(|l| l.text
                == "not sent: initialise: too many requests are waiting for the device task"),
            "{text}"
        );
    }
}
