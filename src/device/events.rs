//! Events from the device task to any number of consumers (the TUI, the
//! traffic log, a CLI command), without letting a slow consumer stall the
//! port owner.
//!
//! Every subscriber has its own queue. Publishing never waits:
//! - **lossy** events (traffic, positions, port snapshots, poll statistics,
//!   upload progress) are bounded per subscriber: when a queue holds
//!   `capacity` of them, the oldest lossy one is dropped (the newest
//!   position is the one worth showing) and counted
//!   ([`EventReceiver::dropped`]);
//! - every other event (faults, refusals, link and machine state, jog ends,
//!   replies, notices, upload results) is never dropped. They are rare, so a
//!   consumer that stops reading grows its queue slowly; dropping its
//!   receiver removes the queue.
//!
//! Events keep their order within each queue.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard, Weak};

use tokio::sync::Notify;

use super::api::{Event, UploadEvent};

/// Whether an event may be dropped for a slow consumer.
pub fn is_lossy(event: &Event) -> bool {
    matches!(
        event,
        Event::Traffic(_)
            | Event::Position(_)
            | Event::Io(_)
            | Event::Stats(_)
            | Event::Upload(UploadEvent::Progress { .. })
    )
}

#[derive(Debug, Default)]
struct QueueState {
    events: VecDeque<Event>,
    lossy: usize,
    dropped: u64,
    closed: bool,
}

#[derive(Debug)]
struct Queue {
    state: Mutex<QueueState>,
    notify: Notify,
    capacity: usize,
}

impl Queue {
    /// A poisoned lock only means a publisher panicked mid-push; the queue
    /// itself is still consistent enough to read.
    fn lock(&self) -> MutexGuard<'_, QueueState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn push(&self, event: Event) {
        {
            let mut s = self.lock();
            if is_lossy(&event) {
                if s.lossy >= self.capacity
                    && let Some(i) = s.events.iter().position(is_lossy)
                {
                    s.events.remove(i);
                    s.lossy -= 1;
                    s.dropped += 1;
                }
                s.lossy += 1;
            }
            s.events.push_back(event);
        }
        self.notify.notify_one();
    }

    fn pop(&self) -> Result<Event, TryRecvError> {
        let mut s = self.lock();
        match s.events.pop_front() {
            Some(e) => {
                if is_lossy(&e) {
                    s.lossy = s.lossy.saturating_sub(1);
                }
                Ok(e)
            }
            None if s.closed => Err(TryRecvError::Closed),
            None => Err(TryRecvError::Empty),
        }
    }
}

/// The publishing side, owned by the device task.
#[derive(Debug, Clone)]
pub struct EventBus {
    inner: Arc<BusInner>,
}

#[derive(Debug)]
struct BusInner {
    subscribers: Mutex<Vec<Weak<Queue>>>,
    capacity: usize,
    closed: Mutex<bool>,
}

impl EventBus {
    /// `capacity`: lossy events kept per subscriber (at least 1).
    pub fn new(capacity: usize) -> EventBus {
        EventBus {
            inner: Arc::new(BusInner {
                subscribers: Mutex::new(Vec::new()),
                capacity: capacity.max(1),
                closed: Mutex::new(false),
            }),
        }
    }

    fn subscribers(&self) -> MutexGuard<'_, Vec<Weak<Queue>>> {
        self.inner
            .subscribers
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// A new consumer; it sees the events published from now on.
    pub fn subscribe(&self) -> EventReceiver {
        let queue = Arc::new(Queue {
            state: Mutex::new(QueueState::default()),
            notify: Notify::new(),
            capacity: self.inner.capacity,
        });
        if *self.inner.closed.lock().unwrap_or_else(|p| p.into_inner()) {
            queue.lock().closed = true;
        }
        self.subscribers().push(Arc::downgrade(&queue));
        EventReceiver { queue }
    }

    /// Hand an event to every consumer. Never blocks on a consumer.
    pub fn publish(&self, event: Event) {
        let mut subs = self.subscribers();
        subs.retain(|w| w.strong_count() > 0);
        let live: Vec<Arc<Queue>> = subs.iter().filter_map(Weak::upgrade).collect();
        drop(subs);
        if let Some((last, rest)) = live.split_last() {
            for q in rest {
                q.push(event.clone());
            }
            last.push(event);
        }
    }

    /// No more events: receivers end after what they hold.
    pub fn close(&self) {
        *self.inner.closed.lock().unwrap_or_else(|p| p.into_inner()) = true;
        let live: Vec<Arc<Queue>> = self
            .subscribers()
            .iter()
            .filter_map(Weak::upgrade)
            .collect();
        for q in live {
            q.lock().closed = true;
            q.notify.notify_one();
        }
    }
}

/// Why [`EventReceiver::try_recv`] has nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TryRecvError {
    #[error("no event waiting")]
    Empty,
    #[error("the device task has ended")]
    Closed,
}

/// One consumer's queue of events.
#[derive(Debug)]
pub struct EventReceiver {
    queue: Arc<Queue>,
}

impl EventReceiver {
    /// The next event; `None` once the device task has ended and every event
    /// was read.
    pub async fn recv(&mut self) -> Option<Event> {
        loop {
            match self.queue.pop() {
                Ok(e) => return Some(e),
                Err(TryRecvError::Closed) => return None,
                Err(TryRecvError::Empty) => self.queue.notify.notified().await,
            }
        }
    }

    pub fn try_recv(&mut self) -> Result<Event, TryRecvError> {
        self.queue.pop()
    }

    /// Lossy events dropped for this consumer so far.
    pub fn dropped(&self) -> u64 {
        self.queue.lock().dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::api::{LinkState, PerAxis, PositionSample, PositionSource};
    use std::time::Instant;

    fn position(x: i64) -> Event {
        Event::Position(PositionSample {
            at: Instant::now(),
            steps: PerAxis::new().with(crate::axis::Axis::X, x),
            source: PositionSource::Measured,
        })
    }

    fn x_of(e: &Event) -> Option<i64> {
        match e {
            Event::Position(p) => p.steps.get(crate::axis::Axis::X),
            _ => None,
        }
    }

    #[test]
    fn a_slow_consumer_loses_the_oldest_positions_never_the_link_state() {
        let bus = EventBus::new(3);
        let mut rx = bus.subscribe();
        bus.publish(position(1));
        bus.publish(Event::Link(LinkState::Connected));
        for x in 2..=6 {
            bus.publish(position(x));
        }
        bus.publish(Event::Notice("kept".into()));
        let mut got = Vec::new();
        while let Ok(e) = rx.try_recv() {
            got.push(e);
        }
        assert_eq!(got.len(), 5);
        assert_eq!(got[0], Event::Link(LinkState::Connected));
        let xs: Vec<_> = got.iter().filter_map(x_of).collect();
        assert_eq!(xs, [4, 5, 6]);
        assert_eq!(got[4], Event::Notice("kept".into()));
        assert_eq!(rx.dropped(), 3);
    }

    #[test]
    fn every_consumer_gets_every_event_in_order() {
        let bus = EventBus::new(100);
        let mut a = bus.subscribe();
        let mut b = bus.subscribe();
        for x in 0..10 {
            bus.publish(position(x));
        }
        for rx in [&mut a, &mut b] {
            let xs: Vec<_> = std::iter::from_fn(|| rx.try_recv().ok())
                .filter_map(|e| x_of(&e))
                .collect();
            assert_eq!(xs, (0..10).collect::<Vec<_>>());
        }
    }

    #[test]
    fn a_dropped_receiver_is_forgotten_and_close_ends_the_others() {
        let bus = EventBus::new(4);
        let gone = bus.subscribe();
        let mut rx = bus.subscribe();
        drop(gone);
        bus.publish(Event::Notice("a".into()));
        assert_eq!(bus.subscribers().len(), 1);
        bus.close();
        assert_eq!(rx.try_recv(), Ok(Event::Notice("a".into())));
        assert_eq!(rx.try_recv(), Err(TryRecvError::Closed));
        let mut late = bus.subscribe();
        assert_eq!(late.try_recv(), Err(TryRecvError::Closed));
    }

    #[tokio::test]
    async fn recv_waits_for_the_next_event() {
        let bus = EventBus::new(4);
        let mut rx = bus.subscribe();
        let publisher = bus.clone();
        let task = tokio::spawn(async move {
            tokio::task::yield_now().await;
            publisher.publish(Event::Notice("late".into()));
            publisher.close();
        });
        assert_eq!(rx.recv().await, Some(Event::Notice("late".into())));
        assert_eq!(rx.recv().await, None);
        task.await.expect("publisher");
    }
}
