//! The gesture stage as a library: from skeletons to the drawing hand's body-frame
//! trajectory ([`HandTracker`]), from trajectories to symbols (the seed's Bezier
//! descriptor with discrete HMMs, a linear-chain CRF, and the default network
//! ensemble, behind [`Model`]), and from a continuous stream to spotted gestures
//! ([`Spotter`], with a Lee & Kim threshold model and a verifier network). No IPC here:
//! deterministic given a seed.
//!
//! What the stage runs on the device is this crate without its module `lab` (training,
//! evaluation and its plots, synthetic streams, datasets), which sits behind the cargo
//! feature `lab`, on by default: the runtime never uses the lab, so a build without
//! the feature links no plotting or font code.
//!
//! The stage process uses three calls:
//! ```no_run
//! use airglyph_gesture::{Model, Spotter, SpotterConfig};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = Model::load(std::path::Path::new("models/unipen-36.json"))?;
//! let mut spotter = Spotter::new(model, SpotterConfig::default())?;
//! # let skeleton = airglyph_gesture::skeleton_with_hand(0.0, 0.0, 2.0);
//! if let Some(g) = spotter.push(&skeleton, 42, 1_000_000) {
//!     println!("{} {:.2} frames {}..{}", g.label, g.score, g.start_seq, g.end_seq);
//! }
//! # Ok(()) }
//! ```

#![warn(missing_docs)]
// Numeric code indexes several arrays with one index; iterators would obscure it.
#![allow(clippy::needless_range_loop)]

mod bezier;
mod body_frame;
mod crf;
mod dtw;
mod features;
mod features3d;
mod hmm;
pub mod limits;
mod mlp;
pub mod model;
mod spot;
mod templates;
mod tracker;
mod trajectory;

#[cfg(feature = "lab")]
pub mod lab;

pub use bezier::bezier_points;
pub use body_frame::{skeleton_with_hand, FrameSmoothing};
pub use model::{Classification, Model, ModelError, ModelSource, MAX_LABEL_BYTES, MODEL_ENV};
pub use spot::{
    Candidate, GatedPen, HandPosture, Judgement, Pen, PenParseError, PostureLabel,
    PostureLabelError, PosturePen, Postures, RankBy, SettingsError, SpotError, SpottedGesture,
    Spotter, SpotterConfig, MAX_POSTURE_LABEL_BYTES,
};
pub use tracker::{Hand, HandPoint, HandTracker, TrackerConfig};
pub use trajectory::{Point, Point3, Trajectory};
