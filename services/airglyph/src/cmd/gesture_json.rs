//! A gesture as every command prints it: the same keys from `run`, `demo` and `spot`
//! (README, "JSON output").

use airglyph_gesture::{Hand, SpottedGesture};
use airglyph_ipc::wire::Hand as WireHand;
use airglyph_ipc::GestureEventMsg;
use serde::Serialize;

/// One gesture, one JSON object a line: `{"event":"gesture","label":…,"score":…,
/// "start_frame":…,"end_frame":…,"hand":…,"start_ns":…,"end_ns":…}`, with
/// `session` (the capture session its frames belong to) and `latency_ms` (capture to
/// event) when it comes live from the pipeline, and `drawn` (the symbol drawn over its
/// frames, or null) when the drawn symbols are known.
#[derive(Debug, Serialize)]
pub struct GestureJson<'a> {
    event: &'static str,
    pub label: &'a str,
    pub score: f64,
    /// Its first and last frame: capture's sequence numbers live, a recording's frame
    /// indices offline.
    pub start_frame: u64,
    pub end_frame: u64,
    /// The drawing hand, "left" or "right" (the person's).
    pub hand: &'static str,
    /// Capture times of its first and last frame, CLOCK_MONOTONIC nanoseconds.
    pub start_ns: u64,
    pub end_ns: u64,
    /// Live only: the capture session of its frames (capture's start time). Frame
    /// numbers start again with each session, so a symbol seen again after capture was
    /// restarted has other frames' numbers in another session; the same session and
    /// frames twice would be the same gesture.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub session: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drawn: Option<Option<&'a str>>,
}

impl<'a> GestureJson<'a> {
    /// An event of the running pipeline.
    pub fn live(e: &'a GestureEventMsg) -> Self {
        Self {
            event: "gesture",
            label: e.label().unwrap_or("?"),
            score: e.score.into(),
            start_frame: e.start_sequence,
            end_frame: e.end_sequence,
            hand: if e.hand == WireHand::Left as u8 {
                "left"
            } else {
                "right"
            },
            start_ns: e.start_ns,
            end_ns: e.end_ns,
            session: Some(e.session),
            latency_ms: Some(latency_ms(e)),
            drawn: None,
        }
    }

    /// A gesture spotted offline.
    pub fn spotted(g: &'a SpottedGesture) -> Self {
        Self {
            event: "gesture",
            label: &g.label,
            score: g.score,
            start_frame: g.start_seq,
            end_frame: g.end_seq,
            hand: match g.hand {
                Hand::Left => "left",
                Hand::Right => "right",
            },
            start_ns: g.start_ns,
            end_ns: g.end_ns,
            session: None,
            latency_ms: None,
            drawn: None,
        }
    }

    /// With the symbol drawn over its frames (None: none was).
    pub fn drawn(self, drawn: Option<&'a str>) -> Self {
        Self {
            drawn: Some(drawn),
            ..self
        }
    }

    pub fn line(&self) -> String {
        serde_json::to_string(self).expect("a gesture serializes")
    }
}

/// From the capture of the frame that closed the gesture to the event, ms.
pub fn latency_ms(e: &GestureEventMsg) -> f64 {
    e.chain
        .gesture_publish_ns
        .saturating_sub(e.chain.capture_ns) as f64
        * 1e-6
}
