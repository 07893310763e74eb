//! The capture stage's logic: depth sources behind one trait, so the process can write
//! each frame once, straight into a loaned shared-memory sample.

pub mod recording;
pub mod source;
pub mod synthetic;

pub use source::{open, DepthSource, Frame, Pacing, SourceError, SourceOptions, SourceSpec};
