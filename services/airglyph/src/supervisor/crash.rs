//! When a stage that keeps dying is given up.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// When a stage that keeps dying is given up: when it has died more than
/// `max_restarts` times within any `window`, however long each run lasted.
///
/// Deaths count at any age, so a stage that dies a little later each time (a recording
/// damaged 3 s in, a leak that kills it after a while) is not restarted for ever. A
/// stage killed now and then (the OOM killer, an operator) stays below the rule as long
/// as its deaths are spread over more than the window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrashRule {
    /// Deaths within the window that are still restarted; one more gives the stage up.
    pub max_restarts: usize,
    /// The sliding window deaths are counted in.
    pub window: Duration,
}

impl Default for CrashRule {
    /// Five restarts a minute: `airglyph run`'s defaults.
    fn default() -> Self {
        Self {
            max_restarts: 5,
            window: Duration::from_secs(60),
        }
    }
}

/// One stage's deaths within its [`CrashRule`]'s window.
#[derive(Debug)]
pub struct Deaths {
    rule: CrashRule,
    at: VecDeque<Instant>,
}

impl Deaths {
    /// No death yet.
    pub fn new(rule: CrashRule) -> Self {
        Self {
            rule,
            at: VecDeque::new(),
        }
    }

    /// Records a death at `now`; true when the stage is now in a crash loop (died more
    /// than `max_restarts` times within the window ending now) and must be given up.
    pub fn record(&mut self, now: Instant) -> bool {
        self.at.push_back(now);
        while self
            .at
            .front()
            .is_some_and(|t| now.duration_since(*t) > self.rule.window)
        {
            self.at.pop_front();
        }
        self.at.len() > self.rule.max_restarts
    }

    /// Deaths within the window, as of the last one recorded.
    pub fn count(&self) -> usize {
        self.at.len()
    }

    /// The rule the deaths are judged by.
    pub fn rule(&self) -> CrashRule {
        self.rule
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deaths_at_any_age_count_within_the_window() {
        let rule = CrashRule {
            max_restarts: 2,
            window: Duration::from_secs(60),
        };
        // A stage dying 3 s after each start (the old rule counted none of these).
        let t0 = Instant::now();
        let mut d = Deaths::new(rule);
        assert!(!d.record(t0));
        assert!(!d.record(t0 + Duration::from_secs(3)));
        assert!(
            d.record(t0 + Duration::from_secs(6)),
            "the third death gives up"
        );
        assert_eq!(d.count(), 3);
        // Deaths further apart than the window never add up.
        let mut d = Deaths::new(rule);
        for k in 0..10 {
            assert!(!d.record(t0 + Duration::from_secs(31 * k)), "death {k}");
        }
        assert_eq!(d.count(), 2);
    }
}
