//! The vocabulary every airglyph stage shares: depth images, the pinhole camera model,
//! the 16-joint skeleton, recordings on disk with the symbols drawn in them, the One
//! Euro filter both the pose and the gesture stage smooth with, and the Bezier points
//! the gesture stage describes a symbol by and the viewer draws.
//!
//! Nothing here knows about processes or shared memory; `airglyph-ipc` builds the wire
//! types on top of these.

#![warn(missing_docs)]

pub mod bezier;
pub mod camera;
pub mod depth;
pub mod file;
pub mod filter;
pub mod gestures;
pub mod recording;
pub mod skeleton;

pub use camera::Intrinsics;
pub use depth::{DepthImage, DepthView};
pub use skeleton::{Joint, Skeleton};
