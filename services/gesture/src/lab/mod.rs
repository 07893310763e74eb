//! The lab: what trains and measures the gesture stage, and what the stage never runs.
//! Trajectory datasets, the training of every classifier and of the spotting part,
//! synthetic continuous streams, scoring and evaluation with their pictures, the DTW
//! baseline, and cutting repetitions out of a recording session for a vocabulary of
//! one's own.
//!
//! Behind the cargo feature `lab` (on by default). The runtime never uses it, so a
//! build without it (`default-features = false`) leaves out all of this and the
//! plotting and font code the evaluation's pictures need.

mod augment;
mod collect;
mod data;
mod dtw;
mod dtw3d;
mod eval;
mod everyday;
mod movement;
mod posture_signal;
mod scoring;
mod stream;
mod train;
mod user_dependent;

pub use crate::features::{resample, Resampled};
pub use collect::{Repetition, RepetitionConfig, RepetitionSegmenter};
pub use data::{
    folds_by_subject, labels_of, load_jsonl, load_many, parse_jsonl, DataError, Sample,
};
pub use dtw::DtwClassifier;
pub use dtw3d::Dtw3dClassifier;
pub use eval::{plot_timeline, Confusion, Span};
pub use everyday::{everyday_movement, everyday_stream};
pub use movement::Generator;
pub use posture_signal::{
    measured_error_rate, posture_signal, read as read_postures, true_postures, PostureNoise,
    CONFUSION, POINT, POSTURES,
};
pub use scoring::{matched, score, Matching, SpottingScore};
pub use stream::{
    build_stream, drawn_in_stream, random_movement, training_stream, Body, StreamConfig,
    SyntheticStream, TruthGesture,
};
pub use train::{
    calibrate_label_bars, few_shot_plan, look_alikes, recalibrate, retrain_spotting, train,
    ClassifierKind, CrfTrainConfig, FewShotConfig, FewShotPlan, HmmTrainConfig, LookAlike,
    MlpTrainConfig, Progress, Recalibrated, TrainConfig, TrainError, BAR_STEPS, CALIBRATION_SEED,
    LOOK_ALIKE_THRESHOLD,
};
pub use user_dependent::{writer_hash, writer_splits, WriterGroup, WriterSplit};
