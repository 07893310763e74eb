//! What the viewer knows of the pipeline, built from its messages: the last depth
//! frames, the newest skeleton, the drawing hand's path as the gesture stage took it
//! (its decisions), the last gestures with their Bezier points and a minute of each
//! stage's telemetry. It picks what one picture shows ([`Scene::picture`])
//! and what the page's panels show ([`Scene::state`]), from the same selection.

use crate::render::{project_joints, GestureLine, HandPosture, Overlay};
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use airglyph_ipc::wire::Hand;
use airglyph_ipc::{DecisionMsg, DepthHeader, GestureEventMsg, SkeletonMsg, Stage, StageStatsMsg};
use serde_json::{json, Value};
use std::collections::VecDeque;

/// Depth frames kept so the skeleton is drawn over the frame it was estimated from
/// (the pose stage answers some tens of milliseconds after the frame): 400 ms at 30 fps.
const FRAME_RING: usize = 12;
/// Hand positions kept for the trail.
const TRAIL_NS: u64 = 3_000_000_000;
/// How long the last gesture's Bezier points are shown after it came: it is decided
/// seconds after it was drawn, so its own frames may have left the trail by then.
const BEZIER_NS: u64 = 3_000_000_000;
/// Gestures listed.
const GESTURES: usize = 8;
/// Telemetry kept per stage.
pub const HISTORY_NS: u64 = 60_000_000_000;
/// A skeleton is drawn over the newest frame only when no frame of its own is kept and it
/// is at most this many frames older (a stopped pose stage must not leave a stale body).
const SKELETON_SLACK: u64 = 3;

/// A depth frame copied out of shared memory.
#[derive(Debug, Clone)]
pub struct Frame {
    /// The frame's header, copied.
    pub header: DepthHeader,
    /// Its pixels, copied.
    pub pixels: Vec<u16>,
}

impl Frame {
    /// The frame as a depth image.
    pub fn view(&self) -> DepthView<'_> {
        DepthView::new(self.header.width, self.header.height, &self.pixels)
            .expect("a frame is only kept when its size matches its header")
    }
}

/// One point of the drawing hand's path as the gesture stage's recognizer took it: body
/// frame, x to the person's right, y down, in shoulder widths.
#[derive(Debug, Clone, Copy)]
struct HandSample {
    sequence: u64,
    capture_ns: u64,
    hand: Hand,
    at: [f32; 2],
}

/// A gesture event and when the viewer received it.
#[derive(Debug, Clone)]
struct Seen {
    msg: GestureEventMsg,
    received_ns: u64,
}

/// What one picture shows.
pub struct Picture {
    /// The frame shown.
    pub frame: Frame,
    /// Its camera's intrinsics.
    pub intrinsics: Intrinsics,
    /// What is drawn over it.
    pub overlay: Overlay,
}

/// The frame a picture shows and the skeleton that goes with it.
struct Selection<'a> {
    frame: &'a Frame,
    skeleton: Option<(&'a SkeletonMsg, Skeleton)>,
}

/// What the viewer knows of the pipeline (see the module's documentation).
pub struct Scene {
    frames: VecDeque<Frame>,
    /// Counts frames taken in: tells the page whether there is anything new.
    frames_in: u64,
    /// Frames lost before the viewer took them (it only ever wants the newest).
    frames_dropped: u64,
    skeleton: Option<SkeletonMsg>,
    /// The capture session of the path, which a new one starts afresh.
    session: Option<u64>,
    /// The sequence of the newest decision taken.
    decided: Option<u64>,
    /// The recognizer's path, oldest first.
    path: VecDeque<HandSample>,
    gestures: VecDeque<Seen>,
    stats: Vec<(Stage, VecDeque<StageStatsMsg>)>,
}

impl Default for Scene {
    fn default() -> Self {
        Self::new()
    }
}

impl Scene {
    /// A scene with nothing in it yet.
    pub fn new() -> Self {
        Self {
            frames: VecDeque::with_capacity(FRAME_RING),
            frames_in: 0,
            frames_dropped: 0,
            skeleton: None,
            session: None,
            decided: None,
            path: VecDeque::new(),
            gestures: VecDeque::new(),
            stats: Stage::PIPELINE
                .iter()
                .map(|&s| (s, VecDeque::new()))
                .collect(),
        }
    }

    /// Frames taken in so far.
    pub fn frames_in(&self) -> u64 {
        self.frames_in
    }

    /// Frames lost before the viewer took them.
    pub fn frames_dropped(&self) -> u64 {
        self.frames_dropped
    }

    /// Whether a frame and the skeleton estimated from it are both kept.
    pub fn has_skeleton_frame(&self) -> bool {
        self.select().is_some_and(|s| s.skeleton.is_some())
    }

    /// Whether any frame is kept.
    pub fn has_frame(&self) -> bool {
        !self.frames.is_empty()
    }

    /// Copies a received frame in (reusing the oldest frame's buffer). A frame whose size
    /// does not match its header is ignored: receivers validate, but the scene does not
    /// rely on it.
    pub fn push_depth(&mut self, header: DepthHeader, pixels: &[u16], dropped: u64) {
        if header.width as u64 * header.height as u64 != pixels.len() as u64 {
            return;
        }
        let mut buf = if self.frames.len() >= FRAME_RING {
            self.frames
                .pop_front()
                .map(|f| f.pixels)
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        buf.clear();
        buf.extend_from_slice(pixels);
        self.frames.push_back(Frame {
            header,
            pixels: buf,
        });
        self.frames_in += 1;
        self.frames_dropped += dropped;
    }

    /// Takes the newest skeleton.
    pub fn push_skeleton(&mut self, msg: SkeletonMsg) {
        self.skeleton = Some(msg);
    }

    /// Takes the gesture stage's decision on one frame: the hand point its recognizer
    /// used, which extends the trail.
    pub fn push_decision(&mut self, msg: DecisionMsg) {
        if self.session.replace(msg.session) != Some(msg.session) {
            // A restarted capture stage: the old path means nothing in the new session.
            self.path.clear();
        }
        self.decided = Some(msg.sequence);
        if let Some((hand, at)) = msg.hand_point() {
            if self.path.back().is_some_and(|h| h.hand != hand) {
                // The recognizer starts the other hand's path afresh.
                self.path.clear();
            }
            self.path.push_back(HandSample {
                sequence: msg.sequence,
                capture_ns: msg.chain.capture_ns,
                hand,
                at,
            });
        }
        while self
            .path
            .front()
            .is_some_and(|h| h.capture_ns + TRAIL_NS < msg.chain.capture_ns)
        {
            self.path.pop_front();
        }
    }

    /// Takes a gesture event, received at `received_ns`.
    pub fn push_gesture(&mut self, msg: GestureEventMsg, received_ns: u64) {
        self.gestures.push_front(Seen { msg, received_ns });
        self.gestures.truncate(GESTURES);
    }

    /// Takes a stage's telemetry report, keeping a minute of them.
    pub fn push_stats(&mut self, stage: Stage, msg: StageStatsMsg) {
        if let Some((_, h)) = self.stats.iter_mut().find(|(s, _)| *s == stage) {
            h.push_back(msg);
            while h
                .front()
                .is_some_and(|f| f.time_ns + HISTORY_NS < msg.time_ns)
            {
                h.pop_front();
            }
        }
    }

    /// The frame of the newest skeleton when it is kept; else the newest frame, with the
    /// skeleton only if it is barely older.
    fn select(&self) -> Option<Selection<'_>> {
        let newest = self.frames.back()?;
        let sk = self
            .skeleton
            .as_ref()
            .and_then(|m| Some((m, m.skeleton()?)));
        if let Some((msg, s)) = sk {
            let own = self
                .frames
                .iter()
                .rev()
                .find(|f| f.header.session == msg.session && f.header.sequence == msg.sequence);
            if let Some(frame) = own {
                return Some(Selection {
                    frame,
                    skeleton: Some((msg, s)),
                });
            }
            let close = newest.header.session == msg.session
                && newest.header.sequence >= msg.sequence
                && newest.header.sequence - msg.sequence <= SKELETON_SLACK;
            if close {
                return Some(Selection {
                    frame: newest,
                    skeleton: Some((msg, s)),
                });
            }
        }
        Some(Selection {
            frame: newest,
            skeleton: None,
        })
    }

    /// The drawing hand's path up to the shown frame as the recognizer took it (body
    /// frame), oldest first, and which hand it is.
    fn trail(&self, sel: &Selection<'_>) -> (Vec<[f32; 2]>, Option<Hand>) {
        let end = sel.frame.header.capture_ns;
        let last_hand = self.path.back().map(|h| h.hand);
        let points = self
            .path
            .iter()
            .filter(|h| {
                sel.frame.header.session == self.session.unwrap_or(0)
                    && h.capture_ns <= end
                    // A gesture stage that stopped must not leave its last trail on new frames.
                    && h.capture_ns + TRAIL_NS >= end
                    && h.sequence <= sel.frame.header.sequence
            })
            .map(|h| h.at)
            .collect();
        (points, last_hand)
    }

    /// The Bezier points of the newest gesture, while it is recent: the curve the
    /// gesture stage described the symbol by (body frame).
    fn bezier(&self, now_ns: u64) -> Vec<[f32; 2]> {
        self.gestures
            .front()
            .filter(|g| g.received_ns + BEZIER_NS >= now_ns)
            .map(|g| g.msg.bezier().to_vec())
            .unwrap_or_default()
    }

    fn gesture_lines(&self, now_ns: u64) -> Vec<GestureLine> {
        self.gestures
            .iter()
            .map(|g| GestureLine {
                label: g.msg.label().unwrap_or("?").to_owned(),
                score: g.msg.score,
                age_s: now_ns.saturating_sub(g.received_ns) as f32 * 1e-9,
            })
            .collect()
    }

    /// The picture to draw now: a copy of the frame and its overlay, so drawing happens
    /// without holding the scene.
    pub fn picture(&self, now_ns: u64) -> Option<Picture> {
        let sel = self.select()?;
        let (trail, _) = self.trail(&sel);
        let bezier = self.bezier(now_ns);
        let h = &sel.frame.header;
        let caption = format!(
            "frame {}  {}x{}  {}",
            h.sequence,
            h.width,
            h.height,
            match (&sel.skeleton, &self.skeleton) {
                (Some(_), _) => "person found",
                (None, Some(m)) if m.person_found == 0 => "no person",
                _ => "no skeleton",
            }
        );
        Some(Picture {
            frame: sel.frame.clone(),
            intrinsics: h.intrinsics(),
            overlay: Overlay {
                skeleton: sel.skeleton.map(|(_, s)| s),
                postures: sel
                    .skeleton
                    .map(|(m, _)| hand_postures(m))
                    .unwrap_or_default(),
                trail,
                bezier,
                gestures: self.gesture_lines(now_ns),
                caption,
            },
        })
    }

    /// The page's panels as JSON: the shown frame and skeleton, trail and Bezier points,
    /// gestures, and each stage's telemetry over the last minute.
    pub fn state(&self, now_ns: u64) -> Value {
        let sel = self.select();
        let frame = sel.as_ref().map(|s| {
            let h = &s.frame.header;
            json!({"sequence": h.sequence, "width": h.width, "height": h.height,
                   "age_ms": now_ns.saturating_sub(h.capture_ns) as f64 * 1e-6})
        });
        let (skeleton, trail) = match &sel {
            Some(s) => {
                let (trail, hand) = self.trail(s);
                (skeleton_json(s, hand), trail)
            }
            None => (json!({"person_found": false}), Vec::new()),
        };
        let newest = self.path.back();
        let recognizer = json!({
            "sequence": self.decided,
            "hand": newest.map(|h| h.hand.name()),
            "newest": newest.map(|h| json!({"sequence": h.sequence, "at": h.at})),
        });
        let gestures: Vec<Value> = self
            .gestures
            .iter()
            .map(|g| {
                let m = &g.msg;
                json!({
                    "label": m.label().unwrap_or("?"),
                    "score": m.score,
                    "start_sequence": m.start_sequence,
                    "end_sequence": m.end_sequence,
                    "hand": Hand::from_u8(m.hand).map(Hand::name),
                    "bezier_points": m.bezier().len(),
                    "age_s": now_ns.saturating_sub(g.received_ns) as f64 * 1e-9,
                    "latency_ms": m.chain.gesture_publish_ns.saturating_sub(m.chain.capture_ns) as f64 * 1e-6,
                })
            })
            .collect();
        let stages: serde_json::Map<String, Value> = self
            .stats
            .iter()
            .map(|(stage, h)| (stage.name().to_owned(), stats_json(h, now_ns)))
            .collect();
        json!({
            "frame": frame,
            "skeleton": skeleton,
            "trail": trail,
            "bezier": self.bezier(now_ns),
            "recognizer": recognizer,
            "gestures": gestures,
            "stages": stages,
            "viewer": {"frames_in": self.frames_in, "frames_dropped": self.frames_dropped},
        })
    }
}

fn skeleton_json(sel: &Selection<'_>, hand: Option<Hand>) -> Value {
    let Some((msg, s)) = &sel.skeleton else {
        return json!({"person_found": false});
    };
    let k = sel.frame.header.intrinsics();
    let at = project_joints(s, &k);
    let joints: Vec<Value> = Joint::ALL
        .iter()
        .map(|j| {
            let p = s[*j];
            json!({
                "name": j.name(),
                "x": p.x, "y": p.y, "z": p.z,
                "u": at[j.index()].map(|a| a[0]),
                "v": at[j.index()].map(|a| a[1]),
                "confidence": s.confidence[j.index()],
            })
        })
        .collect();
    json!({
        "person_found": true,
        "sequence": msg.sequence,
        "joints": joints,
        "hand": hand.map(Hand::name),
        "postures": airglyph_ipc::json::postures(&msg.postures),
    })
}

/// The hands of `m` whose posture was classified, beside which joint to draw each.
fn hand_postures(m: &SkeletonMsg) -> Vec<HandPosture> {
    [
        (Hand::Left, Joint::LeftHand),
        (Hand::Right, Joint::RightHand),
    ]
    .into_iter()
    .filter_map(|(hand, joint)| {
        let p = m.posture(hand).ok().flatten()?;
        Some(HandPosture {
            joint,
            label: p.label.to_owned(),
            confidence: p.confidence,
        })
    })
    .collect()
}

fn ms(ns: u64) -> f64 {
    ns as f64 * 1e-6
}

/// One stage's last minute: per report, seconds before now, frame rate, and the
/// capture→stage latency and processing-time percentiles.
fn stats_json(h: &VecDeque<StageStatsMsg>, now_ns: u64) -> Value {
    let history: Vec<Value> = h
        .iter()
        .filter(|s| s.time_ns + HISTORY_NS >= now_ns)
        .map(|s| {
            json!({
                "t_s": -(now_ns.saturating_sub(s.time_ns) as f64 / 1e9),
                "fps": s.fps,
                "latency_p50_ms": ms(s.latency.p50),
                "latency_p99_ms": ms(s.latency.p99),
                "processing_p50_ms": ms(s.processing.p50),
                "frames_dropped": s.frames_dropped,
            })
        })
        .collect();
    json!({ "history": history })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::tests::person;
    use airglyph_ipc::LatencyChain;

    const SESSION: u64 = 77;

    fn header(seq: u64) -> DepthHeader {
        let mut h = DepthHeader {
            sequence: seq,
            session: SESSION,
            capture_ns: 1_000_000_000 + seq * 33_333_333,
            ..Default::default()
        };
        h.publish_ns = h.capture_ns + 1;
        h.set_intrinsics(&Intrinsics::default().scaled_to(64, 48));
        h
    }

    fn skeleton(seq: u64) -> SkeletonMsg {
        let mut m = SkeletonMsg {
            sequence: seq,
            session: SESSION,
            chain: LatencyChain {
                capture_ns: header(seq).capture_ns,
                ..Default::default()
            },
            ..Default::default()
        };
        m.set_skeleton(Some(&person(2.0)));
        m
    }

    /// The gesture stage's decision on frame `seq`, its recognizer's hand at (x, y).
    fn decision(seq: u64, at: Option<(Hand, [f32; 2])>) -> DecisionMsg {
        // The frame's own numbers, as the skeleton it was decided on carried them.
        let frame = skeleton(seq);
        let mut d = DecisionMsg::default();
        (d.sequence, d.session, d.chain) = (frame.sequence, frame.session, frame.chain);
        d.set_hand_point(at);
        d
    }

    fn pixels(seq: u64) -> Vec<u16> {
        vec![1000 + seq as u16; 64 * 48]
    }

    #[test]
    fn the_skeleton_is_drawn_over_its_own_frame_not_the_newest() {
        let mut scene = Scene::new();
        for seq in 0..5 {
            scene.push_depth(header(seq), &pixels(seq), 0);
        }
        scene.push_skeleton(skeleton(2));
        let p = scene.picture(0).unwrap();
        assert_eq!(p.frame.header.sequence, 2);
        assert_eq!(p.frame.pixels, pixels(2));
        assert!(p.overlay.skeleton.is_some());
        assert!(p.overlay.caption.contains("person found"));
        let state = scene.state(0);
        assert_eq!(state["skeleton"]["person_found"], true);
        assert_eq!(state["skeleton"]["joints"].as_array().unwrap().len(), 16);
        assert_eq!(state["frame"]["sequence"], 2);
        assert_eq!(
            state["skeleton"]["postures"],
            json!({"left": null, "right": null})
        );
        assert!(p.overlay.postures.is_empty());
    }

    #[test]
    fn the_postures_shown_are_those_of_the_skeleton_shown() {
        let mut scene = Scene::new();
        for seq in 0..3 {
            scene.push_depth(header(seq), &pixels(seq), 0);
        }
        let mut m = skeleton(1);
        m.set_posture(
            Hand::Right,
            Some(airglyph_ipc::PostureMsg::new("fist", 0.75).unwrap()),
        );
        scene.push_skeleton(m);
        let p = scene.picture(0).unwrap();
        assert_eq!(p.frame.header.sequence, 1);
        assert_eq!(
            p.overlay.postures,
            [HandPosture {
                joint: Joint::RightHand,
                label: "fist".into(),
                confidence: 0.75
            }]
        );
        let state = scene.state(0);
        assert_eq!(
            state["skeleton"]["postures"],
            json!({"left": null, "right": {"label": "fist", "confidence": 0.75}})
        );
    }

    #[test]
    fn a_stale_skeleton_is_not_drawn_over_a_new_frame() {
        let mut scene = Scene::new();
        scene.push_skeleton(skeleton(1));
        for seq in 0..30 {
            scene.push_depth(header(seq), &pixels(seq), 0);
        }
        let p = scene.picture(0).unwrap();
        assert_eq!(p.frame.header.sequence, 29, "the newest frame");
        assert!(p.overlay.skeleton.is_none(), "skeleton 1 is 28 frames old");
        assert!(!scene.has_skeleton_frame());
        assert_eq!(scene.frames.len(), FRAME_RING, "old frames are released");
    }

    #[test]
    fn the_trail_is_the_recognizers_path_and_the_bezier_points_its_gestures() {
        let mut scene = Scene::new();
        let at = |seq: u64| [seq as f32 * 0.05, -0.5];
        for seq in 0..20 {
            scene.push_depth(header(seq), &pixels(seq), 0);
            scene.push_skeleton(skeleton(seq));
            // The recognizer had no hand point on frame 7 (an unsteady skeleton).
            let point = (seq != 7).then(|| (Hand::Right, at(seq)));
            scene.push_decision(decision(seq, point));
        }
        let p = scene.picture(0).unwrap();
        assert_eq!(
            p.overlay.trail.len(),
            19,
            "one point a decision with a hand point"
        );
        assert_eq!(p.overlay.trail[0], at(0));
        assert_eq!(
            p.overlay.trail[18],
            at(19),
            "exactly as the gesture stage sent it"
        );
        assert!(p.overlay.bezier.is_empty(), "no gesture yet");
        let state = scene.state(0);
        assert_eq!(state["recognizer"]["sequence"], 19);
        assert_eq!(state["recognizer"]["hand"], "right");
        assert_eq!(state["recognizer"]["newest"]["sequence"], 19);
        assert_eq!(state["skeleton"]["hand"], "right");

        // A gesture's Bezier points are shown while it is recent.
        let mut g = GestureEventMsg::default();
        g.set_label("7").unwrap();
        let curve = [[0.0, -0.5], [0.4, -0.5], [0.9, -0.5]];
        g.set_bezier(&curve).unwrap();
        scene.push_gesture(g, 10);
        assert_eq!(scene.picture(10).unwrap().overlay.bezier, curve);
        assert_eq!(scene.state(10)["gestures"][0]["bezier_points"], 3);
        assert!(scene
            .picture(10 + BEZIER_NS + 1)
            .unwrap()
            .overlay
            .bezier
            .is_empty());

        // The other hand starts a path of its own.
        scene.push_decision(decision(20, Some((Hand::Left, [-1.0, 0.0]))));
        scene.push_depth(header(20), &pixels(20), 0);
        scene.push_skeleton(skeleton(20));
        assert_eq!(scene.picture(0).unwrap().overlay.trail, [[-1.0, 0.0]]);

        // A new capture session starts a new trail.
        let mut h = header(0);
        h.session = SESSION + 1;
        scene.push_depth(h, &pixels(0), 0);
        let mut m = skeleton(0);
        m.session = SESSION + 1;
        scene.push_skeleton(m);
        let mut d = decision(0, Some((Hand::Right, at(0))));
        d.session = SESSION + 1;
        scene.push_decision(d);
        assert_eq!(scene.picture(0).unwrap().overlay.trail.len(), 1);
        // Frames long after the last decision (gesture stage stopped) carry no trail,
        // once the skeleton's own frame has left the ring.
        for seq in 200..200 + FRAME_RING as u64 {
            let mut late = header(seq);
            late.session = SESSION + 1;
            scene.push_depth(late, &pixels(seq), 0);
        }
        let p = scene.picture(0).unwrap();
        assert_eq!(p.frame.header.sequence, 200 + FRAME_RING as u64 - 1);
        assert!(p.overlay.trail.is_empty() && p.overlay.skeleton.is_none());
    }

    #[test]
    fn gestures_are_newest_first_and_stats_keep_a_minute() {
        let mut scene = Scene::new();
        for (i, label) in ["3", "7"].iter().enumerate() {
            let mut g = GestureEventMsg {
                score: 0.5 + i as f32 * 0.1,
                start_sequence: 10 * i as u64,
                end_sequence: 10 * i as u64 + 5,
                ..Default::default()
            };
            g.set_label(label).unwrap();
            scene.push_gesture(g, 1_000_000_000 * i as u64);
        }
        for t in 0..90u64 {
            let s = StageStatsMsg {
                time_ns: t * 1_000_000_000,
                fps: 30.0,
                ..Default::default()
            };
            scene.push_stats(Stage::Pose, s);
        }
        let now = 90_000_000_000;
        let st = scene.state(now);
        assert_eq!(st["gestures"][0]["label"], "7");
        assert_eq!(st["gestures"][1]["label"], "3");
        let hist = st["stages"]["pose"]["history"].as_array().unwrap();
        assert_eq!(hist.len(), 60, "the last minute");
        assert!(hist.iter().all(|h| h["t_s"].as_f64().unwrap() >= -60.0));
        assert_eq!(
            st["stages"]["capture"]["history"].as_array().unwrap().len(),
            0
        );
        assert_eq!(st["frame"], Value::Null, "no frame yet");
        assert!(scene.picture(now).is_none());
    }

    #[test]
    fn a_frame_that_does_not_match_its_header_is_ignored() {
        let mut scene = Scene::new();
        scene.push_depth(header(0), &[1, 2, 3], 0);
        assert!(!scene.has_frame());
    }
}
