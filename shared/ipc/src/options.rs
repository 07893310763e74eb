//! Range checks for the numeric command-line options of every airglyph binary that
//! size memory or time. A number the parser accepted is not yet a sane one: `top
//! --wait 1e300` (or NaN) waited for ever, a count of 10^18 asks for that many of
//! something, and `Duration::from_secs_f64` panics on what does not fit.

use std::fmt::Display;
use std::time::Duration;

/// An option's value out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{option} {value}: {expected}")]
pub struct OptionError {
    pub option: String,
    pub value: String,
    pub expected: String,
}

/// Longest wait any option may ask for: a day.
pub const MAX_SECONDS: f64 = 86_400.0;

/// A number of seconds in `(0, max]` (`[0, max]` when `zero_ok`), as a [`Duration`].
pub fn seconds(option: &str, value: f64, max: f64, zero_ok: bool) -> Result<Duration, OptionError> {
    let low_ok = if zero_ok { value >= 0.0 } else { value > 0.0 };
    if value.is_finite() && low_ok && value <= max {
        return Ok(Duration::from_secs_f64(value));
    }
    Err(OptionError {
        option: option.into(),
        value: value.to_string(),
        expected: format!(
            "expected a number of seconds in {}0, {max}]",
            if zero_ok { "[" } else { "(" }
        ),
    })
}

/// A count in `min..=max`.
pub fn count<T: Copy + Into<u64> + Display>(
    option: &str,
    value: T,
    min: u64,
    max: u64,
) -> Result<T, OptionError> {
    if (min..=max).contains(&value.into()) {
        return Ok(value);
    }
    Err(OptionError {
        option: option.into(),
        value: value.to_string(),
        expected: format!("expected a whole number in {min}..={max}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waits_and_counts_out_of_range_are_named() {
        assert_eq!(
            seconds("--wait", 2.5, MAX_SECONDS, false),
            Ok(Duration::from_millis(2500))
        );
        for bad in [1e300, f64::NAN, f64::INFINITY, -1.0, 0.0] {
            let err = seconds("--wait", bad, MAX_SECONDS, false).unwrap_err();
            assert!(err.to_string().starts_with("--wait "), "{err}");
        }
        assert!(seconds("--warmup", 0.0, 60.0, true).is_ok());
        assert_eq!(count("--count", 30usize as u64, 1, 10_000), Ok(30));
        let err = count("--count", u64::MAX, 1, 10_000).unwrap_err();
        assert!(err.to_string().contains("1..=10000"), "{err}");
    }
}
