//! The gesture stage: hand trajectory to Bezier descriptors, HMM/CRF classification and spotting
