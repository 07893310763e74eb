//! How the long commands stop on SIGINT and SIGTERM. Those that work frame by frame
//! (synth, record, pose, eval-pose, spot, collect, profile) look at
//! [`airglyph_ipc::shutdown::requested`] between two frames, where what they wrote is
//! whole; those that compute first and write after (train, eval-gestures,
//! eval-spotting) compute through [`unless_interrupted`]. Either way they say what they
//! kept, and exit with 128 + the signal ([`Interrupted`]).

pub use airglyph_ipc::shutdown::Interrupted;
#[cfg(feature = "lab")]
use {
    airglyph_ipc::shutdown,
    std::sync::mpsc::{self, RecvTimeoutError},
    std::time::Duration,
};

/// Runs `work` on a thread of its own and waits for it, or for SIGINT/SIGTERM, whichever
/// comes first. For work that writes nothing until it returns: interrupted, it is left
/// where it is (the process is about to end, taking the thread with it), and `kept` says
/// what there is of it.
#[cfg(feature = "lab")]
pub fn unless_interrupted<T: Send + 'static>(
    kept: &str,
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T, Interrupted> {
    let (done, result) = mpsc::channel();
    let worker = std::thread::spawn(move || {
        let _ = done.send(work());
    });
    loop {
        match result.recv_timeout(Duration::from_millis(50)) {
            Ok(value) => return Ok(value),
            Err(RecvTimeoutError::Timeout) if shutdown::requested() => {
                return Err(Interrupted::new(kept))
            }
            Err(RecvTimeoutError::Timeout) => {}
            // The work panicked before it sent anything: carry its panic on.
            Err(RecvTimeoutError::Disconnected) => match worker.join() {
                Err(panic) => std::panic::resume_unwind(panic),
                Ok(()) => unreachable!("the worker sends before it returns"),
            },
        }
    }
}
