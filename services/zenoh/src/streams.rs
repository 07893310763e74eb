//! The services carried, and their messages as bytes.

use airglyph_ipc::port::Message;
use airglyph_ipc::{
    DecisionMsg, GestureEventMsg, IpcError, Pipeline, Publisher, Receiver, SkeletonMsg, Stage,
    StageStatsMsg,
};

/// One service of the pipeline that is carried.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    Gesture,
    Decision,
    Skeleton,
    Stats(Stage),
}

impl Stream {
    /// Every stream carried.
    pub const ALL: [Stream; 6] = [
        Stream::Gesture,
        Stream::Decision,
        Stream::Skeleton,
        Stream::Stats(Stage::Capture),
        Stream::Stats(Stage::Pose),
        Stream::Stats(Stage::Gesture),
    ];

    /// Its name after `airglyph/`, on both sides of the link.
    pub fn name(self) -> String {
        match self {
            Stream::Gesture => "gesture".into(),
            Stream::Decision => "decision".into(),
            Stream::Skeleton => "skeleton".into(),
            Stream::Stats(stage) => format!("stats/{}", stage.name()),
        }
    }

    /// Messages the sending side keeps to send again to a receiver that missed them (a
    /// link that broke and came back): every gesture of the last minutes; skeletons and
    /// decisions are news only while they are new, and come 30 a second.
    pub fn kept(self) -> usize {
        match self {
            Stream::Gesture => 64,
            Stream::Stats(_) => 4,
            Stream::Decision | Stream::Skeleton => 0,
        }
    }
}

/// A message that crosses the link as the bytes it is in shared memory.
///
/// # Safety
///
/// The type is `#[repr(C)]` of integers, floats and arrays of them with no padding the
/// compiler adds (every gap is a named field: `tests/tests/python.rs` checks that the
/// fields lie end to end), so all its bytes are initialized and any bytes of its size
/// are a value of it (one its receiver still checks).
pub unsafe trait Plain: Message {}

// SAFETY: see the trait; the layouts are in shared/ipc/src/wire.rs.
unsafe impl Plain for GestureEventMsg {}
// SAFETY: as above.
unsafe impl Plain for DecisionMsg {}
// SAFETY: as above.
unsafe impl Plain for SkeletonMsg {}
// SAFETY: as above.
unsafe impl Plain for StageStatsMsg {}

pub fn bytes<T: Plain>(m: &T) -> &[u8] {
    // SAFETY: a `Plain` value's bytes are all initialized, and the slice borrows `m`.
    unsafe { std::slice::from_raw_parts((m as *const T).cast::<u8>(), std::mem::size_of::<T>()) }
}

/// The message in `b`, when `b` is one's size.
pub fn from_bytes<T: Plain>(b: &[u8]) -> Option<T> {
    // SAFETY: `b` holds size_of::<T>() bytes, any of which make a `Plain` value; read
    // unaligned, since the network's buffer has no alignment to speak of.
    (b.len() == std::mem::size_of::<T>())
        .then(|| unsafe { std::ptr::read_unaligned(b.as_ptr().cast::<T>()) })
}

/// A stream's iceoryx2 receiver, whatever its message type.
pub trait Inbound {
    /// The next message already received, as bytes.
    fn next(&mut self, timeout: std::time::Duration) -> Result<Option<Vec<u8>>, IpcError>;
}

impl<T: Plain> Inbound for Receiver<T> {
    fn next(&mut self, timeout: std::time::Duration) -> Result<Option<Vec<u8>>, IpcError> {
        Ok(self.recv(timeout)?.map(|r| bytes(&r.msg).to_vec()))
    }
}

/// Why a message from the link was not published.
#[derive(Debug)]
pub enum Refused {
    Size(usize),
    Invalid(airglyph_ipc::wire::MessageError),
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refused::Size(n) => write!(f, "{n} bytes is not the size of the message"),
            Refused::Invalid(e) => write!(f, "{e}"),
        }
    }
}

/// A stream's iceoryx2 publisher, whatever its message type.
pub trait Outbound {
    /// Checks the bytes as any receiver checks a message and publishes them; the
    /// reason when they are not a valid message.
    fn publish(&self, b: &[u8]) -> Result<Result<(), Refused>, IpcError>;
}

impl<T: Plain> Outbound for Publisher<T> {
    fn publish(&self, b: &[u8]) -> Result<Result<(), Refused>, IpcError> {
        let Some(m) = from_bytes::<T>(b) else {
            return Ok(Err(Refused::Size(b.len())));
        };
        if let Err(e) = m.check() {
            return Ok(Err(Refused::Invalid(e)));
        }
        self.send(m)?;
        Ok(Ok(()))
    }
}

impl Stream {
    pub fn receiver(self, pipeline: &Pipeline) -> Result<Box<dyn Inbound>, IpcError> {
        Ok(match self {
            Stream::Gesture => Box::new(pipeline.gesture_receiver()?),
            Stream::Decision => Box::new(pipeline.decision_receiver()?),
            Stream::Skeleton => Box::new(pipeline.skeleton_receiver()?),
            Stream::Stats(stage) => Box::new(pipeline.stats_receiver(stage)?),
        })
    }

    pub fn publisher(self, pipeline: &Pipeline) -> Result<Box<dyn Outbound>, IpcError> {
        Ok(match self {
            Stream::Gesture => Box::new(pipeline.gesture_publisher()?),
            Stream::Decision => Box::new(pipeline.decision_publisher()?),
            Stream::Skeleton => Box::new(pipeline.skeleton_publisher()?),
            Stream::Stats(stage) => Box::new(pipeline.stats_publisher(stage)?),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_crosses_as_its_bytes_and_garbage_does_not() {
        let mut g = GestureEventMsg::default();
        g.set_label("7").unwrap();
        g.end_sequence = 42;
        let b = bytes(&g).to_vec();
        assert_eq!(from_bytes::<GestureEventMsg>(&b), Some(g));
        assert_eq!(from_bytes::<GestureEventMsg>(&b[1..]), None);
        let mut bad = from_bytes::<GestureEventMsg>(&b).unwrap();
        bad.label_len = 200;
        assert!(bad.check().is_err(), "a receiver still checks what came");
    }
}
