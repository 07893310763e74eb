//! One module a subcommand: its clap `Args` and a `run(args) -> anyhow::Result<()>`.

pub mod collect;
pub mod demo;
pub mod devices;
pub mod eval_gestures;
pub mod eval_pose;
pub mod eval_spotting;
pub mod fetch_assets;
pub mod pose;
pub mod profile;
pub mod record;
pub mod run;
pub mod snapshot;
pub mod spot;
pub mod synth;
pub mod top;
pub mod train;

use airglyph_ipc::GestureEventMsg;

/// Prints a gesture event as a line of text or of JSON. An error is stdout gone (a
/// reader such as `head` that has what it wanted): the caller stops, it does not panic.
pub fn print_gesture(event: &GestureEventMsg, json: bool) -> std::io::Result<()> {
    use std::io::Write;
    let label = event.label().unwrap_or("?");
    let latency_ms = (event
        .chain
        .gesture_publish_ns
        .saturating_sub(event.chain.capture_ns)) as f64
        * 1e-6;
    if json {
        let line = serde_json::json!({
            "event": "gesture",
            "label": label,
            "score": event.score,
            "start_sequence": event.start_sequence,
            "end_sequence": event.end_sequence,
            "start_ns": event.start_ns,
            "end_ns": event.end_ns,
            "hand": if event.hand == 0 { "left" } else { "right" },
            "latency_ms": latency_ms,
        });
        writeln!(std::io::stdout(), "{line}")
    } else {
        writeln!(
            std::io::stdout(),
            "{label}  (score {:.2}, frames {}–{}, {:.1} ms after capture)",
            event.score,
            event.start_sequence,
            event.end_sequence,
            latency_ms
        )
    }
}
