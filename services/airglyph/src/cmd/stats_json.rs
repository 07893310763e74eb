//! A stage's telemetry as every command prints it: the same keys from `top --json` and
//! `echo stats --json`.

use airglyph_ipc::wire::Percentiles;
use airglyph_ipc::StageStatsMsg;

fn ms(ns: u64) -> f64 {
    ns as f64 * 1e-6
}

fn percentiles_json(p: &Percentiles) -> serde_json::Value {
    serde_json::json!({"count": p.count, "p50_ms": ms(p.p50), "p90_ms": ms(p.p90), "p99_ms": ms(p.p99), "max_ms": ms(p.max)})
}

/// `{"pid","fps","frames_in","frames_out","frames_dropped","frames_rejected",
/// "processing","waiting","latency"}`, each of the last three `{"count","p50_ms",
/// "p90_ms","p99_ms","max_ms"}`.
pub fn stats_json(s: &StageStatsMsg) -> serde_json::Value {
    serde_json::json!({
        "pid": s.pid,
        "fps": s.fps,
        "frames_in": s.frames_in,
        "frames_out": s.frames_out,
        "frames_dropped": s.frames_dropped,
        "frames_rejected": s.frames_rejected,
        "processing": percentiles_json(&s.processing),
        "waiting": percentiles_json(&s.waiting),
        "latency": percentiles_json(&s.latency),
    })
}
