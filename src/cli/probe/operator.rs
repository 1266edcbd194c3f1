//! What `jogterm probe` (and `jogterm frame`) follows while the machine moves: the device's
//! events, and the operator's ways to stop it (Space or a closed terminal
//! on stdin, Ctrl-C, SIGTERM, a hang-up). A stop is sent at once; the
//! move or probe then ends as stopped, and nothing more is sent.

use tokio::sync::mpsc;

use crate::cli::run::keys::{Key, Keys};
use crate::cli::session::{self, EXIT_LINK, Session};
use crate::cli::upload::{Remedy, refused_in};
use crate::device::api::{
    Activity, Event, JogId, LinkState, PerAxis, PositionSource, ProbeEnd, ProbeMove, Request,
};

use super::out;

pub struct Operator {
    keys: Keys,
    signals: mpsc::UnboundedReceiver<()>,
    /// A stop was sent: wait for the end, send nothing more.
    pub stopped: bool,
    next_id: u64,
    /// Where the axes stand, as last measured (machine steps).
    here: Option<PerAxis<i64>>,
    /// The command whose messages these are (`jogterm <command>: …`).
    command: &'static str,
}

impl Operator {
    /// `here`: the position measured when the session was set up.
    pub fn new(here: Option<PerAxis<i64>>) -> Operator {
        Operator::of_command(here, "probe")
    }

    /// [`Operator::new`] for another command that moves this way (`frame`).
    pub fn of_command(here: Option<PerAxis<i64>>, command: &'static str) -> Operator {
        let (tx, signals) = mpsc::unbounded_channel();
        tokio::spawn(async move {
            session::interrupted().await;
            let _ = tx.send(());
        });
        Operator {
            keys: Keys::from_stdin(),
            signals,
            stopped: false,
            next_id: 0,
            here,
            command,
        }
    }

    /// An operator on keys read already (`jogterm run`'s, lent for a
    /// measure between two pieces of a job): the run watches the signals
    /// itself.
    pub fn with_keys(keys: Keys, here: Option<PerAxis<i64>>) -> Operator {
        let (_, signals) = mpsc::unbounded_channel();
        Operator {
            keys,
            signals,
            stopped: false,
            next_id: 0,
            here,
            command: "run",
        }
    }

    /// The keys back (after [`Operator::with_keys`]).
    pub fn into_keys(self) -> Keys {
        self.keys
    }

    /// Where the axes stand, as last measured.
    pub fn here(&self) -> Option<PerAxis<i64>> {
        self.here
    }

    /// Resolves when the operator stops (once).
    async fn stop_asked(&mut self) {
        if self.stopped {
            return std::future::pending().await;
        }
        loop {
            tokio::select! {
                key = self.keys.next() => if matches!(key, Key::Stop | Key::Gone) {
                    break;
                },
                Some(()) = self.signals.recv() => {
                    session::say_interrupted(self.command, session::Moves::Yes);
                    break;
                }
            }
        }
        self.stopped = true;
    }

    /// `probe` sent and followed to its end.
    pub async fn probe(&mut self, session: &mut Session, probe: ProbeMove) -> Result<ProbeEnd, u8> {
        if self.stopped {
            return Ok(ProbeEnd::Stopped);
        }
        self.next_id += 1;
        let id = JogId(self.next_id);
        if session
            .handle
            .request(Request::Probe { id, probe })
            .is_err()
        {
            return Err(lost(self.command, "the device task ended"));
        }
        let stopper = session.handle.clone();
        loop {
            tokio::select! {
                event = session.next_event() => match event {
                    Some(Event::ProbeEnded { id: ended, end }) if ended == id => return Ok(end),
                    Some(Event::Position(p)) if p.source == PositionSource::Measured => {
                        self.here = Some(p.steps);
                    }
                    Some(Event::Link(LinkState::Lost { reason })) => return Err(lost(self.command, &reason)),
                    Some(_) => {}
                    None => return Err(lost(self.command, "the device task ended")),
                },
                () = self.stop_asked() => {
                    let _ = stopper.stop().written().await;
                }
            }
        }
    }

    /// A move to `target` (machine steps; axes left out stay) at `hz`
    /// steps/s per axis, followed to its end. Relative from where the axes
    /// were measured (isel `@0A`): an absolute isel move counts from the
    /// controller's own zero, which a session does not know (manual
    /// 2.2.19, `docs/protocols.md`).
    pub async fn move_to(
        &mut self,
        session: &mut Session,
        target: PerAxis<i64>,
        hz: PerAxis<f64>,
        remedy: &Remedy,
    ) -> Result<(), u8> {
        if self.stopped {
            return Err(stopped(self.command));
        }
        let Some(here) = self.here else {
            out::say(format_args!(
                "jogterm {}: the controller reported no position: nothing moved",
                self.command
            ));
            return Err(1);
        };
        let mut delta = PerAxis::new();
        for (axis, to) in target.iter() {
            let d = to - here.get(axis).unwrap_or(to);
            if d != 0 {
                delta.set(axis, d);
            }
        }
        if delta.axes().is_empty() {
            return Ok(());
        }
        let request = Request::Step {
            delta,
            speed_hz: hz,
        };
        if session.handle.request(request).is_err() {
            return Err(lost(self.command, "the device task ended"));
        }
        let stopper = session.handle.clone();
        let mut moving = false;
        loop {
            tokio::select! {
                event = session.next_event() => match event {
                    Some(Event::Position(p)) if p.source == PositionSource::Measured => {
                        self.here = Some(p.steps);
                    }
                    Some(Event::State(s)) if s.activity != Activity::Idle => moving = true,
                    Some(Event::State(s)) if moving => {
                        if let Some(f) = s.fault {
                            out::say(format_args!(
                                "jogterm {}: the move ended with `{}`: {}",
                                self.command, f.code, f.meaning
                            ));
                            return Err(1);
                        }
                        if self.stopped {
                            return Err(stopped(self.command));
                        }
                        return self.measured_after(session, here, &delta).await;
                    }
                    Some(Event::Refused { reason, .. }) => {
                        return Err(refused_in(self.command, "the move", &reason, remedy));
                    }
                    Some(Event::Fault(f)) => {
                        out::say(format_args!(
                            "jogterm {}: the move ended with `{}`: {}",
                            self.command, f.code, f.meaning
                        ));
                        return Err(1);
                    }
                    Some(Event::Link(LinkState::Lost { reason })) => return Err(lost(self.command, &reason)),
                    Some(_) => {}
                    None => return Err(lost(self.command, "the device task ended")),
                },
                () = self.stop_asked() => {
                    let _ = stopper.stop().written().await;
                }
            }
        }
    }

    /// The position read after a move (it follows the move's end at
    /// once); without one within a moment, where the move ends.
    async fn measured_after(
        &mut self,
        session: &mut Session,
        from: PerAxis<i64>,
        delta: &PerAxis<i64>,
    ) -> Result<(), u8> {
        let settle = tokio::time::Instant::now() + SETTLE;
        loop {
            match tokio::time::timeout_at(settle, session.next_event()).await {
                Ok(Some(Event::Position(p))) if p.source == PositionSource::Measured => {
                    self.here = Some(p.steps);
                    return Ok(());
                }
                Ok(Some(Event::Link(LinkState::Lost { reason }))) => {
                    return Err(lost(self.command, &reason));
                }
                Ok(Some(_)) => {}
                Ok(None) => return Err(lost(self.command, "the device task ended")),
                Err(_) => {
                    self.here = Some(from.map(|axis, v| v + delta.get(axis).unwrap_or(0)));
                    return Ok(());
                }
            }
        }
    }
}

/// How long the position read after a move may take to arrive.
const SETTLE: std::time::Duration = std::time::Duration::from_millis(500);

fn stopped(command: &str) -> u8 {
    out::say(format_args!("jogterm {command}: stopped; nothing resumes"));
    1
}

pub fn lost(command: &str, reason: &str) -> u8 {
    out::say(format_args!("jogterm {command}: link failure: {reason}"));
    EXIT_LINK
}
