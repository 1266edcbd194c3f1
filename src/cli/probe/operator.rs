//! What `jogterm probe` follows while the machine moves: the device's
//! events, and the operator's ways to stop it (Space or a closed terminal
//! on stdin, Ctrl-C, SIGTERM, a hang-up). A stop is sent at once; the
//! move or probe then ends as stopped, and nothing more is sent.

use tokio::sync::mpsc;

use crate::cli::run::keys::{Key, Keys};
use crate::cli::session::{self, EXIT_LINK, Session};
use crate::cli::upload::{Remedy, refused_in};
use crate::device::api::{
    Activity, Event, Frame, JogId, LinkState, PerAxis, ProbeEnd, ProbeMove, Request,
};

use super::out;

pub struct Operator {
    keys: Keys,
    signals: mpsc::UnboundedReceiver<()>,
    /// A stop was sent: wait for the end, send nothing more.
    pub stopped: bool,
    next_id: u64,
}

impl Operator {
    pub fn new() -> Operator {
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
        }
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
                    session::say_interrupted("probe", session::Moves::Yes);
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
            return Err(lost("the device task ended"));
        }
        let stopper = session.handle.clone();
        loop {
            tokio::select! {
                event = session.next_event() => match event {
                    Some(Event::ProbeEnded { id: ended, end }) if ended == id => return Ok(end),
                    Some(Event::Link(LinkState::Lost { reason })) => return Err(lost(&reason)),
                    Some(_) => {}
                    None => return Err(lost("the device task ended")),
                },
                () = self.stop_asked() => {
                    let _ = stopper.stop().written().await;
                }
            }
        }
    }

    /// A move to `target` (machine steps; axes left out stay) at `hz`
    /// steps/s per axis, followed to its end.
    pub async fn move_to(
        &mut self,
        session: &mut Session,
        target: PerAxis<i64>,
        hz: PerAxis<f64>,
        remedy: &Remedy,
    ) -> Result<(), u8> {
        if self.stopped {
            return Err(stopped());
        }
        let request = Request::MoveTo {
            target,
            frame: Frame::Machine,
            speed_hz: hz,
        };
        if session.handle.request(request).is_err() {
            return Err(lost("the device task ended"));
        }
        let stopper = session.handle.clone();
        let mut moving = false;
        loop {
            tokio::select! {
                event = session.next_event() => match event {
                    Some(Event::State(s)) if s.activity != Activity::Idle => moving = true,
                    Some(Event::State(s)) if moving => {
                        if let Some(f) = s.fault {
                            out::say(format_args!(
                                "jogterm probe: the move ended with `{}`: {}", f.code, f.meaning
                            ));
                            return Err(1);
                        }
                        return if self.stopped { Err(stopped()) } else { Ok(()) };
                    }
                    Some(Event::Refused { reason, .. }) => {
                        return Err(refused_in("probe", "the move", &reason, remedy));
                    }
                    Some(Event::Fault(f)) => {
                        out::say(format_args!(
                            "jogterm probe: the move ended with `{}`: {}", f.code, f.meaning
                        ));
                        return Err(1);
                    }
                    Some(Event::Link(LinkState::Lost { reason })) => return Err(lost(&reason)),
                    Some(_) => {}
                    None => return Err(lost("the device task ended")),
                },
                () = self.stop_asked() => {
                    let _ = stopper.stop().written().await;
                }
            }
        }
    }
}

fn stopped() -> u8 {
    out::say("jogterm probe: stopped; nothing resumes");
    1
}

pub fn lost(reason: &str) -> u8 {
    out::say(format_args!("jogterm probe: link failure: {reason}"));
    EXIT_LINK
}
