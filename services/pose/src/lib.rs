//! The pose stage: a 16-joint skeleton from each depth frame by geodesic distances
//! (Handrich, Rashid & Al-Hamadi, seed §16.3) and an articulated body registered to the
//! person's points. A plain, deterministic library: no IPC.
//!
//! How it works and how well: `services/pose/README.md`; what was tried, round by round,
//! with its figures: `services/pose/NOTES.md`.
//!
//! # Use
//!
//! ```no_run
//! use airglyph_core::{DepthImage, Intrinsics, Joint};
//! use airglyph_pose::{PoseConfig, PoseEstimator};
//!
//! let k = Intrinsics::default(); // Kinect v1, 640×480
//! let mut est = PoseEstimator::new(k, PoseConfig::default());
//! let frame = DepthImage::empty(640, 480);
//! let r = est.estimate(frame.view()); // one call a frame, in order
//! if r.person_found {
//!     let hand = r.skeleton[Joint::RightHand]; // metres, camera frame
//!     let c = r.skeleton.confidence[Joint::RightHand.index()];
//!     println!("{hand:?} {c}");
//! }
//! ```
//!
//! * [`PoseEstimator::new`]`(intrinsics: Intrinsics, config: PoseConfig) -> PoseEstimator`
//! * [`PoseEstimator::estimate`]`(&mut self, depth: DepthView<'_>) -> PoseResult`:
//!   `PoseResult { person_found: bool, skeleton: Skeleton }`. Never panics, never NaN;
//!   with no person the skeleton is all zeros with confidence 0. The estimator keeps
//!   state between frames (torso registration, last limb fits, the registered body, the
//!   person's limb lengths): one estimator per camera stream; [`PoseEstimator::reset`]
//!   after a gap. Frames whose size differs from the intrinsics are handled with the
//!   intrinsics scaled to them. It takes the frames to be [`PoseConfig::nominal_fps`]
//!   apart; with capture times, use
//! * [`PoseEstimator::estimate_at`]`(&mut self, depth, time_s: f64) -> PoseResult`.
//! * [`PoseEstimator::step_times`] gives the time of each step of the last frame,
//!   [`PoseEstimator::debug`] its intermediate results ([`struct@Debug`]).
//!
//! Public beside the estimator: [`config`] (the settings, one section a step), [`body`]
//! (the articulated body model, for examples and overlays), [`metrics`] (the evaluation
//! against ground truth: Eq. 16.20–16.22, share within 10 cm, mAP at 10 cm), [`overlay`]
//! (skeletons drawn on depth images) and [`steps`] (single steps, for the benches).
//!
//! # The steps of a frame
//!
//! Frames wider than [`PoseConfig::work_width`] are first reduced by an integer factor,
//! each pixel the nearest depth of its block. Then, in `estimate_at`'s order (each step
//! a module of its own, its settings a section of [`PoseConfig`]):
//!
//! 1. Segmentation (`segment.rs`, [`config::SegmentConfig`]): back-projection, depth
//!    band, floor plane by RANSAC removed, blobs split at depth jumps, the largest
//!    person-shaped blob kept with the parts of the body that meet it only across depth
//!    jumps. While a person is tracked, only a window around the last frame's is looked
//!    at; the whole image only when the person found there is not the tracked one or may
//!    reach beyond it, so the person's pixels are the whole image's either way.
//! 2. Torso (`torso.rs`, [`config::TorsoConfig`]): distance transform of the mask
//!    (`dt.rs`); the torso region is where it is at least half its maximum; PCA of its
//!    points gives a first frame; a torso model is registered by mutual closest points
//!    and Horn's closed form (`geom.rs`), started from the last frame's pose and redone
//!    from PCA when the residual is too large. While the registration tracks the body,
//!    the torso is the tracked body's instead. The key points (neck, shoulders, pelvis,
//!    hips, torso) are fixed points of the torso frame ([`config::TorsoPoints`]).
//! 3. Geodesic graph (`graph.rs`, [`config::GraphConfig`]): 8-neighbours joined when
//!    closer than a threshold scaled by the pixel footprint; edges bridging occluding
//!    foreground; stray components joined to the rest, nearest first.
//! 4. Geodesic maxima (`geodesic.rs`, [`config::GeodesicConfig`]): distances from the
//!    torso centre (`dijkstra.rs`, a radix heap), then up to eight maxima, each joined
//!    to the root by a zero-weight edge and the search continued. The torso is turned
//!    to face where the toes point when the feet say so.
//! 5. Assignment (`assign.rs`, [`config::AssignConfig`]): maxima given to the five
//!    limbs by least total cost; the head's maximum holds the torso's height. Then the
//!    limbs' tips are checked against the tracked body (`register/tips.rs`): a tip on
//!    another limb is dropped, and only a tip off the tracked body's surface makes the
//!    seed's estimate race the tracked body.
//! 6. Chains (`chains.rs`, [`config::ChainConfig`]), when the seed's estimate races:
//!    target points within d_e of each limb's geodesic path, a two-joint chain fitted
//!    by weighted closed-form rotations.
//! 7. Body registration (`register/`, [`config::RegisterConfig`]; beyond the seed): an
//!    articulated body ([`body`]: fourteen rigid segments carrying tapered capsules) is
//!    fitted to the person's points by Gauss–Newton — points on the nearest capsule, the
//!    body's front inside the silhouette and never before a surface the camera sees,
//!    limb tips at their geodesic maxima, spine, neck and hinge-joint priors — from the
//!    last frame's body and, when the seed's estimate races, from it too; the start
//!    that explains the frame better wins. Its joints are the skeleton; the hands are
//!    then placed behind the fingertips seen and across the forearm onto the hand's own
//!    points (`hands.rs`, [`config::HandsConfig`]), and the head at the height of the
//!    head's own top (`head_top.rs`, [`config::HeadConfig`]). The arms' and legs' lengths are
//!    learned from the fits (`calibrate.rs`, [`config::CalibrateConfig`]).
//! 8. Smoothing (`smooth.rs`, [`config::SmoothingConfig`]): the One Euro filter per
//!    joint coordinate.
//!
//! What a frame carries to the next is one struct in `estimator.rs` (`Tracking`:
//! segmentation's window and floor, the torso, each limb's chain, the registered body,
//! the filters); losing the person resets it whole. The person's learned size is kept
//! apart, and the steps' buffers are a third struct, reused frame to frame.
//!
//! # Beyond the seed (and why)
//!
//! * The registration exists because the seed's estimate is made of parts fitted
//!   apart: a rigid torso model that turns a few degrees when an arm is raised before
//!   the chest or slides along its own axis carries every key point with it, and each
//!   chain knows nothing of the others. While it tracks the body, the seed's torso
//!   registration and chains are skipped; every tenth frame, and whenever a geodesic
//!   maximum lies far from the tracked body's limb tip and off its surface, the seed's
//!   steps run in full and race the tracked body, so a lost limb is found again. A
//!   maximum on the body's surface (noise makes them on knees and hips) is explained
//!   where the body is.
//! * A person found afresh whose torso core is narrow may be side-on, where the seed's
//!   torso step fits its frontal model to a flank: the registration then also races a
//!   standing body turned a quarter either way.
//! * Upper arms and thighs the camera did not see last frame are pulled weakly towards
//!   hanging down: a limb behind the body has no data to hold it, and "hanging" is a
//!   better guess for it than wherever a wrong start left it.
//! * A limb's geodesic maximum that lies on another limb of the last frame's body is
//!   not that limb's end: the assignment could give an arm hidden behind the body a
//!   point of the other arm, which then pulled the hidden arm out to it for frames.
//! * Joint confidence is the share of the joint's segment that the camera sees where
//!   the fitted body puts it (a hand whose fingertips are seen: 0.9 at least).
//! * Up to eight geodesic maxima are taken, not five: the middle of a long leg can lie
//!   geodesically farther from every source than the top of the head.
//! * Assignment cost: |geodesic length from the limb root − the limb's expected length|
//!   (a limb's geodesic length hardly depends on how it is bent), plus the gap between
//!   the limb root and the path, the side of the body, feet below the hips, and the
//!   distance to the limb's last extremity. A maximum beside a farther one's path (a
//!   bent elbow or knee) is no limb's end; an arm whose path misses its shoulder (a hand
//!   against the hip) is judged by reach.
//! * A cylinder-like torso model slides along its axis under closest-point
//!   registration: tracking starts where the torso region is now, and the head's
//!   geodesic maximum fixes the torso's height.
//! * Target points are pushed back along their viewing ray (the seen surface lies in
//!   front of the bone), and targets beyond the chain's end (fingers, toes) weigh 0.1.
//! * Key points, bone lengths and the body's shape were measured on the MakeHuman body
//!   of airglyph-synth standing still; arm and leg lengths are learned for the person
//!   in view (from the registration, or without it from the limbs' geodesic lengths).
//! * Segmentation keeps the person's own parts that meet the body only across depth
//!   jumps (an arm raised before the chest hides its shoulder); points of a limb before
//!   the chest stay out of the torso's PCA.
//! * The body model has no wrist: the hand is placed behind the fingertips seen, then
//!   across the forearm onto the hand's own points. Only the published joints move;
//!   the tracker keeps the fit's.
//! * Joints are smoothed over time: still joints stop jittering with the sensor's noise,
//!   moving ones keep up.

#![warn(missing_docs)]

mod assign;
pub mod body;
mod calibrate;
mod cells;
mod chains;
pub mod config;
mod debug;
mod dijkstra;
mod dt;
mod estimator;
mod geodesic;
mod geom;
mod graph;
mod hands;
mod head_top;
mod legs_seen;
mod limb;
pub mod metrics;
mod neck;
pub mod overlay;
mod register;
mod segment;
mod smooth;
mod torso;
mod view;

pub use config::PoseConfig;
pub use debug::{Debug, StepTimes};
pub use estimator::{PoseEstimator, PoseResult};
pub use limb::Limb;
pub use neck::NeckBase;
pub use register::OfferedStart;

/// The steps one at a time, for the benches and diagnostics (`benches/pose.rs` times
/// each): not needed to estimate a pose, which [`PoseEstimator`] does.
pub mod steps {
    pub use crate::dijkstra::{Dijkstra, Graph, INF};
    pub use crate::dt::DistanceTransform;
    pub use crate::geom::Rigid;
    pub use crate::graph::{GeoGraph, NONE};
    pub use crate::segment::{Plane, Segmentation, Segmenter};
    pub use crate::torso::{TorsoEstimator, TorsoFit, TorsoPose, TorsoStart};
}
