//! BVH motion capture: reading, naming conventions, resampling and retargeting.

use crate::canon::{Pose, TposeSkeleton};
use crate::error::SynthError;
use std::path::Path;

/// A parsed BVH clip.
pub struct BvhClip {}

impl BvhClip {
    pub fn load(path: &Path) -> Result<Self, SynthError> {
        Err(SynthError::Config(format!(
            "{}: BVH not implemented yet",
            path.display()
        )))
    }

    pub fn retarget(&self, _sk: &TposeSkeleton, _fps: f32) -> Vec<Pose> {
        Vec::new()
    }
}
