//! Synthetic people: bodies, skinning, motion, depth rendering and exact ground truth
