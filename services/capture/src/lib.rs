//! The capture stage: depth sources into shared memory
