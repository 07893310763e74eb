//! The capture stage's logic: depth sources behind one trait, so the process can write
//! each frame once, straight into a loaned shared-memory sample.

#![warn(missing_docs)]

pub mod devices;
pub mod onifile;
#[cfg(feature = "openni2")]
pub mod openni2;
pub mod pixfmt;
pub mod recording;
pub mod source;
pub mod synthetic;
#[cfg(feature = "v4l2")]
pub mod v4l2;

pub use source::{
    open, open_recording_oni, CameraOptions, DepthSource, Frame, IntrinsicsChoice, Pacing,
    SourceError, SourceOptions, SourceSpec,
};
