//! What the supervisor does with the pipeline's output while the stages run.

use airglyph_ipc::{GestureEventMsg, IpcError, Pipeline, Receiver};
use std::time::Duration;

/// A listener's own failure, handed back unchanged as
/// [`SupervisorError::Listener`](super::SupervisorError::Listener).
pub type ListenerError = Box<dyn std::error::Error + Send + Sync>;

/// Handles the pipeline's output between the supervisor's looks at the stages.
pub trait Listener {
    /// Waits up to `timeout` for one message and handles it.
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError>;
}

/// What one [`Listener::poll`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Poll {
    /// Nothing came.
    Idle,
    /// A message came and was handled.
    Handled,
    /// The listener has what it wanted: stop the pipeline.
    Done,
}

/// Hands each gesture event to a closure; stops the pipeline when the closure's reader
/// has gone (a broken pipe), as a command piped into `head` should.
pub struct Gestures<F> {
    rx: Receiver<GestureEventMsg>,
    on_event: F,
}

impl<F: FnMut(&GestureEventMsg) -> std::io::Result<()>> Gestures<F> {
    /// Subscribes to the gesture events of `pipeline`.
    pub fn new(pipeline: &Pipeline, on_event: F) -> Result<Self, IpcError> {
        Ok(Self {
            rx: pipeline.gesture_receiver()?,
            on_event,
        })
    }
}

impl<F: FnMut(&GestureEventMsg) -> std::io::Result<()>> Listener for Gestures<F> {
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
        let Some(event) = self.rx.recv(timeout)? else {
            return Ok(Poll::Idle);
        };
        match (self.on_event)(&event.msg) {
            Ok(()) => Ok(Poll::Handled),
            // Whoever read the events has gone: stop the stages cleanly, not by a panic.
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                tracing::info!("the reader of the events has gone; stopping");
                Ok(Poll::Done)
            }
            Err(e) => Err(Box::new(HandOn(e))),
        }
    }
}

/// A gesture event that could not be handed on.
#[derive(Debug, thiserror::Error)]
#[error("cannot hand on a gesture event")]
struct HandOn(#[source] std::io::Error);

/// Listens to nothing: the stages run until stopped.
pub struct Idle;

impl Listener for Idle {
    fn poll(&mut self, timeout: Duration) -> Result<Poll, ListenerError> {
        std::thread::sleep(timeout);
        Ok(Poll::Idle)
    }
}

/// A listener after the run, with the supervisor's place in the pipeline. The listener's
/// ports keep the supervisor's node alive, so the pipeline must be left after them (the
/// last node out removes iceoryx2's per-domain files): fields drop in this order.
pub struct Listening<L> {
    listener: L,
    _pipeline: Pipeline,
}

impl<L> Listening<L> {
    pub(super) fn new(listener: L, pipeline: Pipeline) -> Self {
        Self {
            listener,
            _pipeline: pipeline,
        }
    }
}

impl<L> std::ops::Deref for Listening<L> {
    type Target = L;
    fn deref(&self) -> &L {
        &self.listener
    }
}

impl<L> std::ops::DerefMut for Listening<L> {
    fn deref_mut(&mut self) -> &mut L {
        &mut self.listener
    }
}
