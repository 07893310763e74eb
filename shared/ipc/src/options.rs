//! Range checks for the numeric command-line options that size memory or time. A
//! number the parser accepted is not yet a sane one: `top --json --wait 1e300` (or NaN)
//! waited for ever, a count of 10^18 asks for that many of something, and
//! `Duration::from_secs_f64` panics on what does not fit.
//!
//! Each function makes a value parser for clap (`#[arg(long, value_parser =
//! options::seconds(3600.0))]`), so a value out of range is refused while the command
//! line is parsed: one line naming the option and the value (clap's `invalid value
//! '1e300' for '--wait <SECONDS>': …`), before anything starts; and `airglyph run
//! --stage-args`, which parses each stage's arguments first, refuses it too instead of
//! starting a stage that would die of it again and again.

use std::fmt::Display;
use std::str::FromStr;

/// Longest wait any option may ask for: a day.
pub const MAX_SECONDS: f64 = 86_400.0;

/// A value parser: the text of an option's value to a checked number.
pub trait Parser<T>: Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {}
impl<T, F: Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static> Parser<T> for F {}

fn parse<T: FromStr>(text: &str) -> Result<T, String>
where
    T::Err: Display,
{
    text.trim()
        .parse()
        .map_err(|e| format!("not a number ({e})"))
}

/// A number of seconds in `(0, max]`: not zero, not negative, not NaN or infinite.
pub fn seconds(max: f64) -> impl Parser<f64> {
    move |text: &str| {
        let v: f64 = parse(text)?;
        if v.is_finite() && v > 0.0 && v <= max {
            Ok(v)
        } else {
            Err(format!(
                "expected a number of seconds above 0 and up to {max}"
            ))
        }
    }
}

/// A number of seconds in `[0, max]`.
pub fn seconds_or_zero(max: f64) -> impl Parser<f64> {
    move |text: &str| {
        let v: f64 = parse(text)?;
        if v.is_finite() && (0.0..=max).contains(&v) {
            Ok(v)
        } else {
            Err(format!("expected a number of seconds from 0 to {max}"))
        }
    }
}

/// A number (a count, a size, a rate) in `min..=max`; NaN is never within.
pub fn within<T>(min: T, max: T) -> impl Parser<T>
where
    T: FromStr + PartialOrd + Display + Copy + Send + Sync + 'static,
    T::Err: Display,
{
    move |text: &str| {
        let v: T = parse(text)?;
        if min <= v && v <= max {
            Ok(v)
        } else {
            Err(format!("expected a number from {min} to {max}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waits_and_counts_out_of_range_are_refused() {
        let wait = seconds(MAX_SECONDS);
        assert_eq!(wait("2.5"), Ok(2.5));
        for bad in ["1e300", "NaN", "inf", "-1", "0", "x"] {
            assert!(wait(bad).is_err(), "{bad}");
        }
        assert_eq!(seconds_or_zero(60.0)("0"), Ok(0.0));
        assert!(seconds_or_zero(60.0)("61").unwrap_err().contains("0 to 60"));
        let count = within(1usize, 10_000);
        assert_eq!(count("30"), Ok(30));
        for bad in [
            "0",
            "18446744073709551615",
            "99999999999999999999",
            "-3",
            "2.5",
        ] {
            assert!(count(bad).is_err(), "{bad}");
        }
        let fraction = within(0.0f32, 1.0);
        assert!(fraction("NaN").is_err() && fraction("1.5").is_err());
        assert_eq!(fraction("0.25"), Ok(0.25));
    }
}
