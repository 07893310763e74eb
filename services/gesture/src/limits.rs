//! Upper bounds on every size a model file or a training run can ask for.
//!
//! A model's weights are in its file, so their number is bounded by the file; the sizes
//! it only names are not: a feature grid, a Bezier point count or a network width makes
//! the stage allocate what it says when the model runs. Products of such sizes are
//! computed with checked arithmetic: `features.grid = 2^60 + 6` once wrapped around to
//! the expected input size, passed validation and made the gesture stage panic at every
//! start. The bounds are far above anything trained here (the shipped model: 32 points,
//! a 6×6 grid, 192 hidden units, 36 labels, 10 states) and far below what would exhaust
//! a small device.

/// Labels of a vocabulary.
pub const MAX_LABELS: usize = 1024;
/// Points of a resampled trajectory (feature vectors, the verifier's shape).
pub const MAX_FEATURE_POINTS: usize = 1024;
/// Cells per side of the direction feature maps.
pub const MAX_GRID: usize = 64;
/// Points of the seed's Bezier descriptor.
pub const MAX_BEZIER_POINTS: usize = 200;
/// Inputs or outputs of one network layer.
pub const MAX_UNITS: usize = 1 << 16;
/// Hidden units `airglyph train` may give a network (its weights are allocated at
/// once: 4096 × the shipped model's 450 inputs is 7 MiB a network).
pub const MAX_HIDDEN: usize = 4096;
/// Layers of one network.
pub const MAX_LAYERS: usize = 16;
/// Networks of an ensemble or a verifier.
pub const MAX_NETS: usize = 64;
/// States of one HMM.
pub const MAX_STATES: usize = 512;
/// Symbols of one HMM or CRF.
pub const MAX_SYMBOLS: usize = 256;
/// Time bins of the CRF.
pub const MAX_TIME_BINS: usize = 64;
/// Points of the verifier's timing profile.
pub const MAX_TIMING: usize = 1024;
/// Training epochs and iterations (time, not memory, but a typo of a few digits should
/// not mean a week).
pub const MAX_EPOCHS: usize = 100_000;
/// Samples of a training mini-batch.
pub const MAX_BATCH: usize = 1 << 16;
/// Templates of a model's template member (each is matched at every decision).
pub const MAX_TEMPLATES: usize = 1 << 16;

/// `value` in `min..=max`, or a message naming `what`.
pub fn within(what: &str, value: usize, min: usize, max: usize) -> Result<usize, String> {
    if (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(format!("{what} is {value}; it must be in {min}..={max}"))
    }
}

/// `a × b`, or a message naming `what` when it overflows.
pub fn product(what: &str, a: usize, b: usize) -> Result<usize, String> {
    a.checked_mul(b)
        .ok_or_else(|| format!("{what}: {a} × {b} overflows"))
}

/// A finite number in `min..=max`, or a message naming `what`.
pub fn finite_within(what: &str, value: f64, min: f64, max: f64) -> Result<f64, String> {
    if value.is_finite() && (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(format!(
            "{what} is {value}; it must be a number in [{min}, {max}]"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_and_products_name_what_is_wrong() {
        assert_eq!(within("grid", 6, 0, MAX_GRID), Ok(6));
        let err = within("features.grid", 1 << 60, 0, MAX_GRID).unwrap_err();
        assert!(
            err.contains("features.grid") && err.contains("0..=64"),
            "{err}"
        );
        assert!(product("layer", usize::MAX, 2)
            .unwrap_err()
            .contains("overflows"));
        assert!(finite_within("step", f64::NAN, 0.0, 1.0).is_err());
    }
}
