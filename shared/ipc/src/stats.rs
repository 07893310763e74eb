//! Stage telemetry: counts, and latency percentiles from hdrhistogram, published once a
//! second on `airglyph/stats/<stage>`.

use crate::clock::monotonic_ns;
use crate::port::{Pipeline, Publisher, Stage};
use crate::wire::{Percentiles, StageStatsMsg};
use crate::IpcError;
use hdrhistogram::Histogram;

/// Counts frames lost between a publisher and this receiver from sequence gaps. A new
/// capture session (a restarted capture stage) starts counting afresh.
#[derive(Debug, Clone)]
pub struct SequenceTracker {
    /// When the receiver was made: sessions that started later owe it every frame.
    since_ns: u64,
    last: Option<(u64, u64)>,
}

impl Default for SequenceTracker {
    fn default() -> Self {
        Self::since(monotonic_ns())
    }
}

impl SequenceTracker {
    /// A tracker for a receiver that exists since `since_ns` (CLOCK_MONOTONIC).
    pub fn since(since_ns: u64) -> Self {
        Self {
            since_ns,
            last: None,
        }
    }

    /// Notes a frame of a session (identified by its start time); returns how many
    /// frames were lost just before it.
    pub fn observe(&mut self, session: u64, sequence: u64) -> u64 {
        let dropped = match self.last {
            Some((s, prev)) if s == session => sequence.saturating_sub(prev + 1),
            // A session that started after we subscribed: every frame was meant for us.
            _ if session >= self.since_ns => sequence,
            // A session we joined late: frames before we subscribed were never ours.
            _ => 0,
        };
        if self
            .last
            .is_none_or(|(s, prev)| s != session || sequence > prev)
        {
            self.last = Some((session, sequence));
        }
        dropped
    }
}

/// How often stats are published.
pub const REPORT_PERIOD_NS: u64 = 1_000_000_000;

fn histogram() -> Histogram<u64> {
    // 1 µs to 60 s at 3 significant digits.
    Histogram::new_with_bounds(1_000, 60_000_000_000, 3).expect("static bounds are valid")
}

fn percentiles(h: &Histogram<u64>) -> Percentiles {
    if h.is_empty() {
        return Percentiles::default();
    }
    Percentiles {
        count: h.len(),
        p50: h.value_at_quantile(0.50),
        p90: h.value_at_quantile(0.90),
        p99: h.value_at_quantile(0.99),
        max: h.max(),
    }
}

fn record(h: &mut Histogram<u64>, ns: u64) {
    h.saturating_record(ns.max(1_000));
}

/// A stage's counters and latency histograms, reported once a second.
pub struct Telemetry {
    stage: Stage,
    publisher: Publisher<StageStatsMsg>,
    window_start_ns: u64,
    window_out: u64,
    totals: StageStatsMsg,
    processing: Histogram<u64>,
    waiting: Histogram<u64>,
    latency: Histogram<u64>,
}

impl Telemetry {
    /// Telemetry of `stage`, published on its stats service once a second.
    pub fn new(pipeline: &Pipeline, stage: Stage) -> Result<Self, IpcError> {
        Ok(Self {
            stage,
            publisher: pipeline.stats_publisher(stage)?,
            window_start_ns: monotonic_ns(),
            window_out: 0,
            totals: StageStatsMsg {
                stage: stage as u32,
                pid: std::process::id(),
                ..Default::default()
            },
            processing: histogram(),
            waiting: histogram(),
            latency: histogram(),
        })
    }

    /// An input arrived after waiting `waiting_ns` in shared memory, with `dropped` lost
    /// before it.
    pub fn input(&mut self, waiting_ns: u64, dropped: u64) {
        self.totals.frames_in += 1;
        self.totals.frames_dropped += dropped;
        record(&mut self.waiting, waiting_ns);
    }

    /// Inputs refused as malformed, as counted by the receiver.
    pub fn set_rejected(&mut self, rejected: u64) {
        self.totals.frames_rejected = rejected;
    }

    /// An output was published `processing_ns` after its input arrived and
    /// `latency_ns` after its frame was captured.
    pub fn output(&mut self, processing_ns: u64, latency_ns: u64) {
        self.totals.frames_out += 1;
        self.window_out += 1;
        record(&mut self.processing, processing_ns);
        record(&mut self.latency, latency_ns);
    }

    /// Publishes the report if a second has passed; returns it when it did.
    pub fn tick(&mut self) -> Option<StageStatsMsg> {
        let now = monotonic_ns();
        let window = now - self.window_start_ns;
        if window < REPORT_PERIOD_NS {
            return None;
        }
        let msg = StageStatsMsg {
            time_ns: now,
            window_ns: window,
            fps: self.window_out as f32 / (window as f32 * 1e-9),
            processing: percentiles(&self.processing),
            waiting: percentiles(&self.waiting),
            latency: percentiles(&self.latency),
            ..self.totals
        };
        if let Err(e) = self.publisher.send(msg) {
            tracing::warn!(stage = self.stage.name(), error = %e, "cannot publish stats");
        }
        self.window_start_ns = now;
        self.window_out = 0;
        self.processing.reset();
        self.waiting.reset();
        self.latency.reset();
        Some(msg)
    }
}

/// A stage's totals, logged when it stops: a run that went wrong (a stage that fell
/// behind and dropped frames, inputs refused as malformed) leaves a trace in the log
/// even when nobody watched its stats.
impl Drop for Telemetry {
    fn drop(&mut self) {
        let t = &self.totals;
        tracing::info!(
            stage = self.stage.name(),
            frames_in = t.frames_in,
            dropped = t.frames_dropped,
            rejected = t.frames_rejected,
            frames_out = t.frames_out,
            "stage totals"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_count_as_drops_and_a_new_session_starts_afresh() {
        let mut t = SequenceTracker::since(2);
        assert_eq!(t.observe(1, 5), 0, "joined session 1 late");
        assert_eq!(t.observe(1, 6), 0);
        assert_eq!(t.observe(1, 9), 2);
        assert_eq!(t.observe(1, 3), 0, "a late duplicate is no drop");
        assert_eq!(t.observe(1, 10), 0);
        assert_eq!(t.observe(2, 0), 0);
        assert_eq!(t.observe(2, 4), 3);
        assert_eq!(t.observe(7, 2), 2, "session 7 began after we subscribed");
    }

    #[test]
    fn percentiles_of_a_known_distribution() {
        let mut h = histogram();
        for v in 1..=100u64 {
            record(&mut h, v * 1_000_000);
        }
        let p = percentiles(&h);
        assert_eq!(p.count, 100);
        assert!((p.p50 as f64 / 50e6 - 1.0).abs() < 0.01, "{p:?}");
        assert!((p.p99 as f64 / 99e6 - 1.0).abs() < 0.01, "{p:?}");
        assert!((p.max as f64 / 100e6 - 1.0).abs() < 0.01, "{p:?}");
    }
}
