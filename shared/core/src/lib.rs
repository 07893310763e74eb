//! The vocabulary every airglyph stage shares: depth images, the pinhole camera model,
//! the 16-joint skeleton, recordings on disk, and the One Euro filter both the pose and
//! the gesture stage smooth with.
//!
//! Nothing here knows about processes or shared memory; `airglyph-ipc` builds the wire
//! types on top of these.

pub mod camera;
pub mod depth;
pub mod file;
pub mod filter;
pub mod recording;
pub mod skeleton;

pub use camera::Intrinsics;
pub use depth::{DepthImage, DepthView};
pub use skeleton::{Joint, Skeleton};
