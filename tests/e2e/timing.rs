//! Tests that time the wire, or open pseudo-terminals, run one at a time
//! across this crate: they share two cores, and a neighbour's load would be
//! in their figures. Before the test crates were folded each file was its
//! own process with its own lock; the files now share a binary, so they
//! share this one lock.

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
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime")
        .block_on(body)
}
