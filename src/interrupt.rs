//! Stopping early: a process-wide request, raised by whoever handles the user's signals (the
//! CLI turns SIGINT and SIGTERM into one), that every long loop polls between bounded pieces
//! of work: a wave of kernel passes, a table origin, a CPU pixel, the final write. They then return
//! [`Error::Interrupted`], and nothing is written.

use std::sync::atomic::{AtomicI32, Ordering};

use crate::error::{Error, Result};

/// The signal that asked to stop, or 0.
static REQUESTED: AtomicI32 = AtomicI32::new(0);

/// Asks every render in this process to stop, because of `signal` (its number).
pub fn request(signal: i32) {
    REQUESTED.store(signal.max(1), Ordering::SeqCst);
}

/// The signal that asked to stop, if one did.
pub fn requested() -> Option<i32> {
    match REQUESTED.load(Ordering::Relaxed) {
        0 => None,
        s => Some(s),
    }
}

/// `Err(Error::Interrupted)` once a stop was asked for.
pub fn check() -> Result<()> {
    match requested() {
        None => Ok(()),
        Some(signal) => Err(Error::Interrupted { signal }),
    }
}

/// Forgets a request (for tests that interrupt on purpose).
pub fn clear() {
    REQUESTED.store(0, Ordering::SeqCst);
}
