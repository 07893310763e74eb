//! Air-drawing.

use crate::canon::{Pose, TposeSkeleton};
use crate::error::SynthError;
use crate::motion::{DrawSpec, GestureTruth};

pub(crate) struct Drawing {}

impl Drawing {
    pub(crate) fn new(
        _d: &DrawSpec,
        _sk: &TposeSkeleton,
        _fps: f32,
        _seed: u64,
    ) -> Result<Self, SynthError> {
        Err(SynthError::Config("air-drawing not implemented yet".into()))
    }
    pub(crate) fn len(&self) -> Option<usize> {
        None
    }
    pub(crate) fn pose(&self, _f: usize) -> Pose {
        unreachable!()
    }
    pub(crate) fn gesture(&self, _f: usize) -> Option<GestureTruth> {
        None
    }
    pub(crate) fn gestures(&self) -> Vec<GestureTruth> {
        Vec::new()
    }
}
