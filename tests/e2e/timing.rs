//! The one lock of the tests that measure a timing promise (a stop's
//! latency on the wire, a dead-man bound, request/reply cycles against the
//! modelled wire): they hold [`SERIAL`] while they measure, so no two of
//! them ever run at once, and their figures carry the load of at most the
//! tests that only wait on the simulators' time beside them. Every other
//! test in this crate runs in parallel, ptys included: in-process pty pairs
//! are made under a lock of their own (`jogterm::sim::pty::pty_pair`, as
//! `TTYPort::pair()` is not thread-safe), the real binary's under the
//! kernel's. `docs/testing.md` lists which tests hold it and why.

use std::future::Future;

/// Held by such a test for its whole run. A tokio mutex: async tests hold
/// it across `.await` (`SERIAL.lock().await`), plain ones take it with
/// [`serial`]; a test that fails does not poison it for the others.
pub static SERIAL: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Take [`SERIAL`] from a plain (not async) test.
pub fn serial() -> tokio::sync::MutexGuard<'static, ()> {
    SERIAL.blocking_lock()
}

/// Run an async test body on its own runtime while holding [`SERIAL`].
pub fn serialised<F: Future>(body: F) -> F::Output {
    let _serial = serial();
    block_on(body)
}

/// Run an async test body on its own runtime, without the lock: a test
/// that needs a runtime and a pty but measures no timing.
pub fn block_on<F: Future>(body: F) -> F::Output {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
        .block_on(body)
}
