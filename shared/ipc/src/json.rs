//! The wire messages as JSON lines, one shape a message wherever it is printed: `run
//! --json`, `echo … --json`, `top --json` and the viewer's push stream (README, "JSON
//! output"). A program that reads one reads them all.

use crate::wire::{Hand, Percentiles, PostureMsg};
use crate::{DecisionMsg, GestureEventMsg, SkeletonMsg, Stage, StageStatsMsg};
use airglyph_core::Joint;
use serde::Serialize;
use serde_json::{json, Map, Value};

fn ms(ns: u64) -> f64 {
    ns as f64 * 1e-6
}

/// Milliseconds from `from_ns` to `to_ns`, 0 when the clocks say the other way round.
pub fn latency_ms(from_ns: u64, to_ns: u64) -> f64 {
    ms(to_ns.saturating_sub(from_ns))
}

/// One gesture: `{"event":"gesture","label","score","start_frame","end_frame","hand",
/// "start_ns","end_ns"}`, with `session` (the capture session its frames belong to),
/// `latency_ms` (capture to event) and `posture` (the drawing hand's posture over most
/// of the gesture, or null) when it comes live from the pipeline, and `drawn`
/// (the symbol drawn over its frames, or null) when the drawn symbols are known.
#[derive(Debug, Clone, Serialize)]
pub struct GestureLine<'a> {
    event: &'static str,
    /// The symbol recognized.
    pub label: &'a str,
    /// The classifier's score.
    pub score: f64,
    /// Its first frame: capture's sequence number live, a recording's frame index offline.
    pub start_frame: u64,
    /// Its last frame, counted as `start_frame`.
    pub end_frame: u64,
    /// The drawing hand, "left" or "right" (the person's).
    pub hand: &'static str,
    /// Capture time of its first frame, CLOCK_MONOTONIC nanoseconds.
    pub start_ns: u64,
    /// Capture time of its last frame.
    pub end_ns: u64,
    /// Live only: the capture session of its frames (capture's start time). Frame
    /// numbers start again with each session, so a symbol seen again after capture was
    /// restarted has other frames' numbers in another session; the same session and
    /// frames twice would be the same gesture.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub session: Option<u64>,
    /// Live only: from the capture of the frame that closed it to the event.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency_ms: Option<f64>,
    /// Live, and offline when the hands' postures are known: the posture the drawing
    /// hand held over most of it (None inside: unknown).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub posture: Option<Option<&'a str>>,
    /// The symbol drawn over its frames (None inside: none was), when that is known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drawn: Option<Option<&'a str>>,
}

impl<'a> GestureLine<'a> {
    /// A gesture found offline (from a recording), frames and times as it gives them.
    pub fn offline(label: &'a str, score: f64, frames: [u64; 2], hand: Hand, ns: [u64; 2]) -> Self {
        Self {
            event: "gesture",
            label,
            score,
            start_frame: frames[0],
            end_frame: frames[1],
            hand: hand_name(hand),
            start_ns: ns[0],
            end_ns: ns[1],
            session: None,
            latency_ms: None,
            posture: None,
            drawn: None,
        }
    }

    /// An event of the running pipeline.
    pub fn live(e: &'a GestureEventMsg) -> Self {
        let hand = if e.hand == Hand::Left as u8 {
            Hand::Left
        } else {
            Hand::Right
        };
        Self {
            session: Some(e.session),
            latency_ms: Some(gesture_latency_ms(e)),
            posture: Some(e.posture().ok().flatten()),
            ..Self::offline(
                e.label().unwrap_or("?"),
                e.score.into(),
                [e.start_sequence, e.end_sequence],
                hand,
                [e.start_ns, e.end_ns],
            )
        }
    }

    /// With the posture the drawing hand held over most of it (None: unknown).
    pub fn posture(self, posture: Option<&'a str>) -> Self {
        Self {
            posture: Some(posture),
            ..self
        }
    }

    /// With the symbol drawn over its frames (None: none was).
    pub fn drawn(self, drawn: Option<&'a str>) -> Self {
        Self {
            drawn: Some(drawn),
            ..self
        }
    }

    /// The object as one line of JSON.
    pub fn line(&self) -> String {
        serde_json::to_string(self).expect("a gesture serializes")
    }
}

fn hand_name(hand: Hand) -> &'static str {
    match hand {
        Hand::Left => "left",
        Hand::Right => "right",
    }
}

/// From the capture of the frame that closed the gesture to the event, ms.
pub fn gesture_latency_ms(e: &GestureEventMsg) -> f64 {
    latency_ms(e.chain.capture_ns, e.chain.gesture_publish_ns)
}

/// A skeleton: `{"event":"skeleton","sequence","session","person_found","joints",
/// "confidence","visible","postures","capture_ns","latency_ms"}`, `joints`,
/// `confidence` and `visible` objects keyed by joint name as `airglyph pose --json`
/// writes them, `postures` [`postures`].
pub fn skeleton(m: &SkeletonMsg) -> Value {
    let by_joint = |f: &dyn Fn(usize) -> Value| -> Map<String, Value> {
        Joint::ALL
            .iter()
            .enumerate()
            .map(|(i, j)| (j.name().to_owned(), f(i)))
            .collect()
    };
    json!({
        "event": "skeleton",
        "sequence": m.sequence,
        "session": m.session,
        "person_found": m.person_found != 0,
        "joints": by_joint(&|i| json!(m.joints[i])),
        "confidence": by_joint(&|i| json!(m.confidence[i])),
        "visible": by_joint(&|i| json!(m.visible & (1 << i) != 0)),
        "postures": postures(&m.postures),
        "capture_ns": m.chain.capture_ns,
        "latency_ms": latency_ms(
            m.chain.capture_ns,
            m.chain.pose_publish_ns.max(m.chain.capture_publish_ns)
        ),
    })
}

/// Each hand's posture (a skeleton's, in [`Hand`] order): `{"left": {"label",
/// "confidence"} | null, "right": …}`, null when the hand was not classified.
pub fn postures(p: &[PostureMsg; 2]) -> Value {
    let one = |hand: Hand| match p[hand as usize].get() {
        Ok(Some(p)) => json!({"label": p.label, "confidence": p.confidence}),
        // A receiver has validated the message; what is not a posture is shown as none.
        Ok(None) | Err(_) => Value::Null,
    };
    json!({"left": one(Hand::Left), "right": one(Hand::Right)})
}

/// The gesture stage's decision on one frame: `{"event":"decision","sequence","session",
/// "gesture","latency_ms"}`.
pub fn decision(m: &DecisionMsg) -> Value {
    json!({
        "event": "decision",
        "sequence": m.sequence,
        "session": m.session,
        "gesture": m.gesture != 0,
        "latency_ms": latency_ms(m.chain.capture_ns, m.chain.gesture_publish_ns),
    })
}

fn percentiles(p: &Percentiles) -> Value {
    json!({"count": p.count, "p50_ms": ms(p.p50), "p90_ms": ms(p.p90), "p99_ms": ms(p.p99), "max_ms": ms(p.max)})
}

/// A stage's telemetry as `top --json` lists it under the stage's name: `{"pid","fps",
/// "frames_in","frames_out","frames_dropped","frames_rejected","processing","waiting",
/// "latency"}`, each of the last three `{"count","p50_ms","p90_ms","p99_ms","max_ms"}`.
pub fn stats(s: &StageStatsMsg) -> Value {
    json!({
        "pid": s.pid,
        "fps": s.fps,
        "frames_in": s.frames_in,
        "frames_out": s.frames_out,
        "frames_dropped": s.frames_dropped,
        "frames_rejected": s.frames_rejected,
        "processing": percentiles(&s.processing),
        "waiting": percentiles(&s.waiting),
        "latency": percentiles(&s.latency),
    })
}

/// A stage's telemetry as a line of a stream: [`stats`] with `"event":"stats"` and
/// `"stage"`.
pub fn stats_event(stage: Stage, s: &StageStatsMsg) -> Value {
    let mut v = stats(s);
    v["event"] = "stats".into();
    v["stage"] = stage.name().into();
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_live_gesture_has_the_keys_of_run_json() {
        let mut m = GestureEventMsg {
            score: 0.5,
            start_sequence: 10,
            end_sequence: 40,
            hand: Hand::Left as u8,
            session: 7,
            ..GestureEventMsg::default()
        };
        m.chain.capture_ns = 1_000_000;
        m.chain.gesture_publish_ns = 3_500_000;
        let v: Value = serde_json::from_str(&GestureLine::live(&m).line()).unwrap();
        assert_eq!(v["event"], "gesture");
        assert_eq!(v["hand"], "left");
        assert_eq!(v["start_frame"], 10);
        assert_eq!(v["end_frame"], 40);
        assert_eq!(v["session"], 7);
        assert_eq!(v["latency_ms"], 2.5);
        assert_eq!(v["posture"], Value::Null);
        assert!(v.get("drawn").is_none());
        m.set_posture(Some("fist")).unwrap();
        let v: Value = serde_json::from_str(&GestureLine::live(&m).line()).unwrap();
        assert_eq!(v["posture"], "fist");
        let drawn: Value = serde_json::from_str(&GestureLine::live(&m).drawn(None).line()).unwrap();
        assert_eq!(drawn["drawn"], Value::Null);
    }

    #[test]
    fn an_offline_gesture_has_no_session_or_latency() {
        let g = GestureLine::offline("7", 0.9, [1, 2], Hand::Right, [3, 4]);
        let v: Value = serde_json::from_str(&g.line()).unwrap();
        assert_eq!(v["label"], "7");
        assert_eq!(v["hand"], "right");
        assert!(v.get("session").is_none() && v.get("latency_ms").is_none());
        assert!(v.get("posture").is_none());
    }

    #[test]
    fn a_skeleton_names_its_joints_and_their_visibility() {
        let mut m = SkeletonMsg {
            person_found: 1,
            visible: 1 << Joint::Head.index(),
            ..SkeletonMsg::default()
        };
        m.joints[Joint::Head.index()] = [0.1, 0.2, 2.0];
        let v = skeleton(&m);
        assert_eq!(v["person_found"], true);
        assert_eq!(v["visible"]["head"], true);
        assert_eq!(v["visible"][Joint::ALL[1].name()], false);
        assert_eq!(v["joints"]["head"][2], 2.0);
        assert_eq!(v["joints"].as_object().unwrap().len(), Joint::ALL.len());
        assert_eq!(v["postures"], json!({"left": null, "right": null}));
        m.set_posture(Hand::Right, Some(PostureMsg::new("v", 0.5).unwrap()));
        let v = skeleton(&m);
        assert_eq!(
            v["postures"],
            json!({"left": null, "right": {"label": "v", "confidence": 0.5}})
        );
    }

    #[test]
    fn stats_in_a_stream_say_which_stage() {
        let s = StageStatsMsg {
            fps: 30.0,
            ..StageStatsMsg::default()
        };
        let v = stats_event(Stage::Pose, &s);
        assert_eq!(v["stage"], "pose");
        assert_eq!(v["event"], "stats");
        assert_eq!(v["fps"], 30.0);
        assert!(stats(&s).get("stage").is_none());
    }
}
