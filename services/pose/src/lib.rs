//! The pose stage: a 16-joint skeleton from each depth frame by geodesic distances
//! (Handrich, Rashid & Al-Hamadi, seed §16.3). A plain, deterministic library: no IPC.
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
//!   state between frames (torso registration, last limb fits): one estimator per
//!   camera stream; [`PoseEstimator::reset`] after a gap. Frames whose size differs
//!   from the intrinsics are handled with the intrinsics scaled to them. It takes the
//!   frames to be [`PoseConfig::nominal_fps`] apart; with capture times, use
//! * [`PoseEstimator::estimate_at`]`(&mut self, depth, time_s: f64) -> PoseResult`.
//! * [`PoseEstimator::step_times`] gives the time of each step of the last frame.
//!
//! # Method, in the order of the steps
//!
//! 1. [`segment`]: back-projection (airglyph-core), depth band, floor plane by RANSAC
//!    removed, blobs split at depth jumps, the largest person-shaped blob kept (planar,
//!    too small or too large blobs are walls, tables, noise). While a person is
//!    tracked, only a window around the last frame's is looked at; the whole image
//!    only when the person found there is not the tracked one or may reach beyond it,
//!    so the person's pixels are the whole image's either way.
//! 2. [`torso`]: distance transform of the mask ([`dt`]); the torso region is where it
//!    is at least half its maximum; PCA of its points gives a first frame; a torso model
//!    is registered by mutual closest points (< 0.1 m) and Horn's quaternion closed form
//!    ([`geom`]), started from the last frame's pose and redone from PCA when the
//!    residual is too large. Neck, shoulders, pelvis and hips are fixed points of the
//!    torso frame.
//! 3. [`graph`]: 8-neighbours joined when closer than a threshold scaled by the pixel
//!    footprint z/f; edges bridging occluding foreground along rows and columns; stray
//!    components joined to the rest, nearest first.
//! 4. [`dijkstra`]: geodesic distances from the torso centre with a radix heap; five
//!    (and spare) maxima, each joined to the root by a zero-weight edge and the search continued
//!    incrementally.
//! 5. [`limbs`]: maxima assigned to the five limb roots by least total cost (geodesic
//!    cost from the limb root, distance to the limb's last extremity, side of the body);
//!    a limb without a maximum keeps its last fit with lowered confidence. Target points
//!    within d_e (5 cm arms, 10 cm legs and head) of the geodesic path (Eq. 16.10); a
//!    two-joint chain fitted by weighted closed-form rotations (ω_succ = 0.05) until the
//!    error stops falling.
//! 6. [`register`] (beyond the seed): an articulated body ([`body`]: fourteen rigid
//!    segments carrying tapered capsules, the shape measured on the MakeHuman body) is
//!    fitted to the person's points by Gauss–Newton — points on the nearest capsule,
//!    the body's front inside the silhouette and never before a surface the camera
//!    sees, limb tips at their geodesic maxima, spine, neck and hinge-joint priors —
//!    from the last frame's fit and, when a limb tip strays or every tenth frame, from
//!    the seed's estimate too; the start that explains the frame better wins. Its 16
//!    joints are the skeleton.
//!
//! # Beyond the seed (and why)
//!
//! * The registration (step 6) exists because the seed's estimate is made of parts
//!   fitted apart: a rigid torso model that turns a few degrees when an arm is raised
//!   before the chest or slides along its own axis carries every key point with it,
//!   and each chain knows nothing of the others. Fitted as one body, MakeHuman's CMU
//!   01_01 and 01_03 fall from 7.6 / 14.4 cm mean error to under 5 cm. While it tracks
//!   the body, the seed's torso registration and chains are skipped (the registered
//!   body gives the torso frame for the geodesic steps); every tenth frame, and whenever
//!   a geodesic maximum lies 25 cm from the tracked body's limb tip and 5 cm off its
//!   surface ([`register::tips_strayed`]), the seed's steps run in full and race the
//!   tracked body, so a lost limb is found again. A maximum on the body's surface (noise
//!   makes them on knees and hips) is explained where the body is: racing on those cost
//!   most frames of a noisy 320×240 image the chains and a second start, and sometimes
//!   the race went to the wrong start (CMU 01_03 with noise 3.94 → 3.81 cm without).
//! * A person found afresh whose torso core is narrow (half width under 0.125 m,
//!   [`PoseConfig::side_on_half_width`]; 0.15–0.16 m facing the camera, 0.09–0.11 m
//!   side-on) may be side-on, where the seed's torso step fits its frontal model to a
//!   flank. The registration then also races a standing body turned a quarter either
//!   way, for every step and without the tips (assigned to the frontal body's limbs).
//!   Side-on scenes before floor and wall with noise fall from 29 to 20 cm mean error
//!   (MakeHuman, seven poses, both sides; `examples/turning.rs`). Of 22 such people
//!   turning to the camera, none instead of 4 stays lost once facing it. Frontal
//!   detections are unchanged.
//! * Upper arms and thighs the camera did not see last frame are pulled weakly towards
//!   hanging down ([`config::RegisterConfig::limb_rest_prior`], 0.3): a limb behind the
//!   body has no data to hold it, and "hanging" is a better guess for it than wherever
//!   a wrong start left it. It brings CMU 01_01 / 01_03 with sensor noise from 94.9 /
//!   93.3 % of joints within 10 cm to 96.8 / 95.5 %.
//! * A limb's geodesic maximum that lies on another limb of the last frame's body is
//!   not that limb's end ([`register::drop_borrowed_tips`]): the assignment could give
//!   an arm hidden behind the body a point of the other arm, which then pulled the
//!   hidden arm out to it for frames. With it, all five evaluation sequences improve
//!   (CMU 01_03 with sensor noise: 96.9 → 97.4 % within 10 cm).
//! * Joint confidence is the share of the joint's segment that the camera sees where
//!   the fitted body puts it (a hand whose fingertips are seen: 0.9 at least).
//! * Frames wider than [`PoseConfig::work_width`] (320) are reduced by an integer factor,
//!   each pixel the nearest depth of its block: 640×480 then costs what 320×240 does.
//! * Up to eight geodesic maxima are taken, not five: the middle of a long leg can lie
//!   geodesically farther from every source than the top of the head, so the fifth
//!   maximum is often a thigh. The assignment leaves the spares out.
//! * Assignment cost: |geodesic length from the limb root − the limb's expected length|
//!   (a limb's geodesic length hardly depends on how it is bent), plus the gap between
//!   the limb root and the path, the side of the body, feet below the hips, and the
//!   distance to the limb's last extremity.
//! * A cylinder-like torso model slides along its axis under closest-point registration;
//!   tracking therefore starts where the torso region is now, and the head's geodesic
//!   maximum, when assigned and plausible, fixes the torso's height.
//! * Target points are pushed back along their viewing ray by a per-limb surface offset
//!   (the seen surface lies in front of the bone), and targets beyond the chain's end
//!   (fingers, toes) weigh 0.1.
//! * Key points and bone lengths in [`PoseConfig::default`] were measured on the
//!   MakeHuman body of airglyph-synth standing still. Arm and leg lengths are then
//!   learned for the person in view ([`calibrate`]): from the registration (each frame
//!   that sees a limb pair well asks for a length; the median of recent frames' is
//!   taken), or without it from the limbs' geodesic lengths. Optionally
//!   ([`config::RegisterConfig::bone_evidence`], off by default), the arms' upper arm
//!   and forearm are learned apart, from frames whose bent elbow tells them apart: with
//!   one ratio for the whole reach the elbow of the procedural body comes out 1.7 cm
//!   short, and the registered chest turns with the drawing arm (2.8° per shoulder
//!   width the hand goes down; 1.6° with the split), bending the strokes. It stays off
//!   because the split it learns is biased and CMU 01_03 with noise loses a leg with it.
//! * Segmentation keeps the person's own parts that meet the body only across depth
//!   jumps (an arm raised before the chest hides its shoulder); points of a limb before
//!   the chest stay out of the torso's PCA; the geodesic root is a torso node even when
//!   a forearm covers the torso centre's projection.
//! * A maximum beside a farther one's path (a bent elbow or knee) is no limb's end; a
//!   head candidate out on a shoulder costs more; an arm whose path misses its shoulder
//!   (a hand against the hip) is judged by reach, not geodesic length.
//! * The hand is placed a palm behind the fingertips seen, towards the elbow, not at
//!   the chain's end (nor the registered forearm's, which cannot bend at the wrist), so
//!   an arm length a little off does not shrink the strokes drawn.
//! * Then [`hands`] moves each hand across its forearm to the centre of the points the
//!   fitted body gives to that forearm near it, set back by half a hand's thickness:
//!   the body model has no wrist, and a real hand turns there. Only the published
//!   joints move; the tracker keeps the fit's.
//! * Joints are smoothed over time by the One Euro filter (airglyph-core): still joints
//!   stop jittering with the sensor's noise, moving ones keep up (its speed estimate
//!   follows at 5 Hz, so the filter opens within a frame or two of a jump's start).
//!
//! [`metrics`] holds the evaluation against ground truth (Eq. 16.20–16.22, share within
//! 10 cm, mAP at 10 cm), [`overlay`] draws skeletons on depth images.

pub mod body;
pub mod calibrate;
pub mod config;
pub mod dijkstra;
pub mod dt;
mod estimator;
pub mod geom;
pub mod graph;
pub mod hands;
pub mod limbs;
pub mod metrics;
pub mod overlay;
pub mod register;
pub mod segment;
pub mod torso;

pub use config::{Limb, PoseConfig};
pub use estimator::{Debug, OfferedStart, PoseEstimator, PoseResult, StepTimes};
