//! The gesture stage as a library: from skeletons to the drawing hand's body-frame
//! trajectory ([`HandTracker`]), from trajectories to symbols (the seed's Bezier
//! descriptor with discrete HMMs, a linear-chain CRF, and the default network
//! ensemble), and from a continuous stream to spotted gestures ([`Spotter`], with a
//! Lee & Kim threshold model). No IPC here: deterministic given a seed.
//!
//! The stage process uses three calls:
//! ```no_run
//! use airglyph_gesture::{Model, Spotter, SpotterConfig};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = Model::load(std::path::Path::new("models/unipen-36.json"))?;
//! let mut spotter = Spotter::new(model, SpotterConfig::default())?;
//! # let skeleton = airglyph_gesture::tracker::skeleton_with_hand(0.0, 0.0, 2.0);
//! if let Some(g) = spotter.push(&skeleton, 42, 1_000_000) {
//!     println!("{} {:.2} frames {}..{}", g.label, g.score, g.start_seq, g.end_seq);
//! }
//! # Ok(()) }
//! ```

// Numeric code indexes several arrays with one index; iterators would obscure it.
#![allow(clippy::needless_range_loop)]

pub mod bezier;
pub mod body_frame;
pub mod collect;
pub mod crf;
pub mod data;
pub mod dtw;
pub mod eval;
pub mod features;
pub mod hmm;
pub mod limits;
pub mod mlp;
pub mod model;
pub mod spot;
pub mod stream;
pub mod tracker;
pub mod train;

pub use data::{load_jsonl, load_many, Sample, Trajectory};
pub use model::{Classification, Model, ModelError, ModelSource};
pub use spot::{RankBy, SpotError, SpottedGesture, Spotter, SpotterConfig};
pub use tracker::{Hand, HandPoint, HandTracker, OneEuro, TrackerConfig};
pub use train::{train, ClassifierKind, TrainConfig};
