//! What the viewer knows of the pipeline, built from its messages: the last depth
//! frames, the newest skeleton, the drawing hand's path, the last gestures and a
//! minute of each stage's telemetry. It picks what one picture shows ([`Scene::picture`])
//! and what the page's panels show ([`Scene::state`]), from the same selection.

use crate::render::{project_joints, GestureLine, Overlay};
use airglyph_core::{DepthView, Intrinsics, Joint, Skeleton};
use airglyph_gesture::{bezier_points, Hand, HandTracker, SpotterConfig};
use airglyph_ipc::{DepthHeader, GestureEventMsg, SkeletonMsg, Stage, StageStatsMsg};
use nalgebra::Point3;
use serde_json::{json, Value};
use std::collections::VecDeque;

/// Depth frames kept so the skeleton is drawn over the frame it was estimated from
/// (the pose stage answers some tens of milliseconds after the frame): 400 ms at 30 fps.
const FRAME_RING: usize = 12;
/// Hand positions kept for the trail.
const TRAIL_NS: u64 = 3_000_000_000;
/// Gestures listed.
const GESTURES: usize = 8;
/// Telemetry kept per stage.
pub const HISTORY_NS: u64 = 60_000_000_000;
/// Points of the trail's Bezier curve: the gesture descriptor's default N
/// (`TrainConfig::default().bezier_points` in `services/gesture/src/train.rs`).
pub const BEZIER_POINTS: usize = 15;
/// A skeleton is drawn over the newest frame only when no frame of its own is kept and it
/// is at most this many frames older (a stopped pose stage must not leave a stale body).
const SKELETON_SLACK: u64 = 3;

/// A depth frame copied out of shared memory.
#[derive(Debug, Clone)]
pub struct Frame {
    pub header: DepthHeader,
    pub pixels: Vec<u16>,
}

impl Frame {
    pub fn view(&self) -> DepthView<'_> {
        DepthView::new(self.header.width, self.header.height, &self.pixels)
            .expect("a frame is only kept when its size matches its header")
    }
}

/// One position of the drawing hand (camera frame, metres).
#[derive(Debug, Clone, Copy)]
struct HandSample {
    sequence: u64,
    capture_ns: u64,
    hand: Hand,
    at: Point3<f32>,
}

/// A gesture event and when the viewer received it.
#[derive(Debug, Clone)]
struct Seen {
    msg: GestureEventMsg,
    received_ns: u64,
}

/// What one picture shows.
pub struct Picture {
    pub frame: Frame,
    pub intrinsics: Intrinsics,
    pub overlay: Overlay,
}

/// The frame a picture shows and the skeleton that goes with it.
struct Selection<'a> {
    frame: &'a Frame,
    skeleton: Option<(&'a SkeletonMsg, Skeleton)>,
}

pub struct Scene {
    frames: VecDeque<Frame>,
    /// Counts frames taken in: tells the page whether there is anything new.
    frames_in: u64,
    /// Frames lost before the viewer took them (it only ever wants the newest).
    frames_dropped: u64,
    skeleton: Option<SkeletonMsg>,
    tracker: HandTracker,
    session: Option<u64>,
    hand: VecDeque<HandSample>,
    gestures: VecDeque<Seen>,
    stats: Vec<(Stage, VecDeque<StageStatsMsg>)>,
}

impl Default for Scene {
    fn default() -> Self {
        Self::new()
    }
}

impl Scene {
    pub fn new() -> Self {
        Self {
            frames: VecDeque::with_capacity(FRAME_RING),
            frames_in: 0,
            frames_dropped: 0,
            skeleton: None,
            // The gesture stage's own settings, so the viewer follows the same hand.
            tracker: HandTracker::new(SpotterConfig::default().tracker),
            session: None,
            hand: VecDeque::new(),
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

    pub fn frames_dropped(&self) -> u64 {
        self.frames_dropped
    }

    /// Whether a frame and the skeleton estimated from it are both kept.
    pub fn has_skeleton_frame(&self) -> bool {
        self.select().is_some_and(|s| s.skeleton.is_some())
    }

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

    /// Takes the newest skeleton and follows the drawing hand through it.
    pub fn push_skeleton(&mut self, msg: SkeletonMsg) {
        if self.session.replace(msg.session) != Some(msg.session) {
            // A restarted capture stage: the old path means nothing in the new session.
            self.hand.clear();
            self.tracker.reset();
        }
        if let Some(s) = msg.skeleton() {
            if let Some(p) = self.tracker.update(&s, msg.chain.capture_ns) {
                let joint = match p.hand {
                    Hand::Left => Joint::LeftHand,
                    Hand::Right => Joint::RightHand,
                };
                self.hand.push_back(HandSample {
                    sequence: msg.sequence,
                    capture_ns: msg.chain.capture_ns,
                    hand: p.hand,
                    at: s[joint],
                });
            }
        }
        while self
            .hand
            .front()
            .is_some_and(|h| h.capture_ns + TRAIL_NS < msg.chain.capture_ns)
        {
            self.hand.pop_front();
        }
        self.skeleton = Some(msg);
    }

    pub fn push_gesture(&mut self, msg: GestureEventMsg, received_ns: u64) {
        self.gestures.push_front(Seen { msg, received_ns });
        self.gestures.truncate(GESTURES);
    }

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

    /// The drawing hand's positions up to the shown frame, in pixels, oldest first.
    fn trail(&self, sel: &Selection<'_>) -> (Vec<[f32; 2]>, Option<Hand>) {
        let k = sel.frame.header.intrinsics();
        let end = sel.frame.header.capture_ns;
        let last_hand = self.hand.back().map(|h| h.hand);
        let points = self
            .hand
            .iter()
            .filter(|h| {
                sel.frame.header.session == self.session.unwrap_or(0)
                    && Some(h.hand) == last_hand
                    && h.capture_ns <= end
                    // A pose stage that stopped must not leave its last trail on new frames.
                    && h.capture_ns + TRAIL_NS >= end
                    && h.sequence <= sel.frame.header.sequence
            })
            .filter_map(|h| k.project(&h.at).map(|(u, v)| [u, v]))
            .collect();
        (points, last_hand)
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
        let bezier = bezier_of(&trail);
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
        let (skeleton, trail, bezier) = match &sel {
            Some(s) => {
                let (trail, hand) = self.trail(s);
                let bezier = bezier_of(&trail);
                (skeleton_json(s, hand), trail, bezier)
            }
            None => (json!({"person_found": false}), Vec::new(), Vec::new()),
        };
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
                    "hand": if m.hand == airglyph_ipc::wire::Hand::Left as u8 { "left" } else { "right" },
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
            "bezier": bezier,
            "gestures": gestures,
            "stages": stages,
            "viewer": {"frames_in": self.frames_in, "frames_dropped": self.frames_dropped},
        })
    }
}

/// The Bezier points of a trail (none for fewer than three positions).
fn bezier_of(trail: &[[f32; 2]]) -> Vec<[f32; 2]> {
    if trail.len() < 3 {
        return Vec::new();
    }
    bezier_points(trail, BEZIER_POINTS)
        .into_iter()
        .map(|[u, v]| [u as f32, v as f32])
        .collect()
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
    })
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
    use airglyph_gesture::skeleton_with_hand;
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

    fn skeleton(seq: u64, x: f32) -> SkeletonMsg {
        let mut m = SkeletonMsg {
            sequence: seq,
            session: SESSION,
            chain: LatencyChain {
                capture_ns: header(seq).capture_ns,
                ..Default::default()
            },
            ..Default::default()
        };
        m.set_skeleton(Some(&skeleton_with_hand(x, -0.5, 2.0)));
        m
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
        scene.push_skeleton(skeleton(2, 0.0));
        let p = scene.picture(0).unwrap();
        assert_eq!(p.frame.header.sequence, 2);
        assert_eq!(p.frame.pixels, pixels(2));
        assert!(p.overlay.skeleton.is_some());
        assert!(p.overlay.caption.contains("person found"));
        let state = scene.state(0);
        assert_eq!(state["skeleton"]["person_found"], true);
        assert_eq!(state["skeleton"]["joints"].as_array().unwrap().len(), 16);
        assert_eq!(state["frame"]["sequence"], 2);
    }

    #[test]
    fn a_stale_skeleton_is_not_drawn_over_a_new_frame() {
        let mut scene = Scene::new();
        scene.push_skeleton(skeleton(1, 0.0));
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
    fn the_trail_follows_the_drawing_hand_and_has_bezier_points() {
        let mut scene = Scene::new();
        for seq in 0..20 {
            scene.push_depth(header(seq), &pixels(seq), 0);
            scene.push_skeleton(skeleton(seq, seq as f32 * 0.05));
        }
        let p = scene.picture(0).unwrap();
        let trail = &p.overlay.trail;
        assert_eq!(trail.len(), 20, "one point a skeleton");
        // The person's right hand moves to their right: the camera's left (u falls).
        assert!(trail[19][0] < trail[0][0] - 3.0, "{trail:?}");
        let k = p.intrinsics;
        let s = skeleton_with_hand(19.0 * 0.05, -0.5, 2.0);
        let (u, v) = k.project(&s[Joint::RightHand]).unwrap();
        assert!((trail[19][0] - u).abs() < 1e-3 && (trail[19][1] - v).abs() < 1e-3);
        assert_eq!(p.overlay.bezier.len(), BEZIER_POINTS);
        assert_eq!(
            p.overlay.bezier[0], trail[0],
            "a Bezier curve starts at its first control point"
        );
        // A new capture session starts a new trail.
        let mut h = header(0);
        h.session = SESSION + 1;
        scene.push_depth(h, &pixels(0), 0);
        let mut m = skeleton(0, 0.0);
        m.session = SESSION + 1;
        scene.push_skeleton(m);
        assert_eq!(scene.picture(0).unwrap().overlay.trail.len(), 1);
        // Frames long after the last skeleton (pose stopped) carry no trail, once the
        // skeleton's own frame has left the ring.
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
