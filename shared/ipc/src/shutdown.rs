//! SIGINT/SIGTERM as a flag that a process's loops check between two pieces of work (two
//! frames, two repetitions), so it always leaves through its destructors: a stage
//! releases its shared memory, a long command leaves what it wrote whole.

use std::sync::atomic::{AtomicI32, Ordering};

/// The signal that asked this process to stop; 0 while none has.
static SIGNAL: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(sig: libc::c_int) {
    SIGNAL.store(sig, Ordering::SeqCst);
}

/// Installs the handler for SIGINT and SIGTERM. Waits in the ports wake at least every
/// receive timeout, so the flag is seen within one.
pub fn install() {
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
}

/// Whether SIGINT or SIGTERM has arrived.
pub fn requested() -> bool {
    SIGNAL.load(Ordering::SeqCst) != 0
}

/// Asks this process to stop, as SIGTERM would.
pub fn request() {
    let _ = SIGNAL.compare_exchange(0, libc::SIGTERM, Ordering::SeqCst, Ordering::SeqCst);
}

/// Work that SIGINT or SIGTERM stopped before it was done, and what of it is kept.
/// [`crate::process::main`] says so and exits with 128 + the signal, the status a shell
/// gives a command that a signal ended.
#[derive(Debug, thiserror::Error)]
#[error("interrupted by {}: {kept}", signal_name(*.signal))]
pub struct Interrupted {
    /// The signal (SIGINT, SIGTERM).
    pub signal: i32,
    /// What of the work is there: written, printed, or nothing.
    pub kept: String,
}

impl Interrupted {
    /// Stopped by the signal that has arrived, having kept `kept`.
    pub fn new(kept: impl Into<String>) -> Self {
        let signal = SIGNAL.load(Ordering::SeqCst);
        Self {
            signal: if signal == 0 { libc::SIGINT } else { signal },
            kept: kept.into(),
        }
    }

    /// The exit code of a command a signal ended: 128 + the signal.
    pub fn exit_code(&self) -> u8 {
        (128 + self.signal).clamp(0, 255) as u8
    }
}

fn signal_name(signal: i32) -> &'static str {
    match signal {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        _ => "a signal",
    }
}
