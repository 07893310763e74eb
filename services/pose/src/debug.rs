//! What the estimator tells of its last frame besides the skeleton: each step's time
//! and intermediate results, for overlays, examples and diagnostics.

use crate::body::{BodyPose, BodyTemplate};
use crate::neck::NeckBase;
use crate::segment::Plane;
use crate::torso::TorsoPose;
use airglyph_core::Skeleton;
use nalgebra::Point3;

/// Time spent in each step of the last frame, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTimes {
    /// Step 1, the person's pixels (with the work image's reduction, when the frame is
    /// wider than [`crate::PoseConfig::work_width`], not counted).
    pub segment: f64,
    /// Step 2, the torso.
    pub torso: f64,
    /// Step 3, the geodesic graph and its root.
    pub graph: f64,
    /// Step 4, the geodesic maxima.
    pub geodesic: f64,
    /// Steps 5 and 6: the maxima given to the limbs, the race's decision, the seed's
    /// chains.
    pub limbs: f64,
    /// Step 7, the articulated registration, with the hands placed.
    pub register: f64,
}

/// Intermediate results of the last frame, for overlays and diagnostics.
#[derive(Debug, Clone, Default)]
pub struct Debug {
    /// Pixels of the geodesic maxima, in the order found (those at a cut left out).
    pub maxima: Vec<u32>,
    /// Pixels of the geodesic maxima where the body is cut from view (the image's edge,
    /// something nearer): no limb ends there.
    pub cut_maxima: Vec<u32>,
    /// For each limb, the maximum assigned to it (index into `maxima`).
    pub assignment: [Option<usize>; 5],
    /// Target points of each limb.
    pub targets: [Vec<Point3<f32>>; 5],
    /// Nodes of the graph.
    pub nodes: usize,
    /// Edges of the graph that bridge occluding foreground.
    pub bridges: usize,
    /// Components of the graph joined to the root's.
    pub joins: usize,
    /// Torso registration residual (m).
    pub torso_residual: f32,
    /// Whether the torso registration was re-initialised from PCA.
    pub torso_reinit: bool,
    /// The floor plane found, if any.
    pub floor: Option<Plane>,
    /// Whether segmentation found the person around the last frame's, without looking
    /// at the whole image ([`crate::steps::Segmentation::windowed`]).
    pub windowed: bool,
    /// Assignment cost of each maximum (rows) for each limb (columns).
    pub cost: Vec<[f32; 5]>,
    /// Geodesic distance of each maximum from the torso centre, metres.
    pub maxima_dist: Vec<f32>,
    /// The registered torso frame (torso frame → camera frame).
    pub torso_pose: Option<TorsoPose>,
    /// Pixels of each maximum's geodesic path back to the torso centre.
    pub paths: Vec<Vec<u32>>,
    /// Size of the image the steps worked on (after reduction).
    pub work_size: (u32, u32),
    /// The registered body and its template, when registration ran.
    pub body: Option<(BodyPose, BodyTemplate)>,
    /// The skeleton of the geodesic steps alone, before registration.
    pub geodesic: Option<Skeleton>,
    /// Person points the registration took.
    pub register_points: usize,
    /// Passes over the points the registration took.
    pub register_passes: usize,
    /// The registration's energy per data point.
    pub register_energy: f32,
    /// Whether the geodesic estimate raced the tracked body this frame.
    pub raced: bool,
    /// The neck's base as the person's outline shows it, when it shows one.
    pub neck_base: Option<NeckBase>,
}
