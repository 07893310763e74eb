//! The fixed-size `#[repr(C)]` types that cross process boundaries. Each carries an
//! explicit, versioned iceoryx2 type name: change a layout, bump the version, and old and
//! new processes refuse to connect instead of misreading each other.

use airglyph_core::{Intrinsics, Joint, Skeleton};
use iceoryx2::prelude::ZeroCopySend;
use nalgebra::Point3;

/// The user header of a depth frame; the payload is `width × height` `u16` millimetres.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("airglyph.DepthHeader.v1")]
#[repr(C)]
pub struct DepthHeader {
    /// Counts frames of one capture session from 0; a gap means frames were dropped.
    pub sequence: u64,
    /// Identifies the capture session (its start time); sequences restart with a new one.
    pub session: u64,
    /// When the frame entered the pipeline, CLOCK_MONOTONIC ns.
    pub capture_ns: u64,
    /// When capture sent it, CLOCK_MONOTONIC ns.
    pub publish_ns: u64,
    /// The source's own timestamp (a recording's frames.csv time; else `capture_ns`).
    pub source_ns: u64,
    pub width: u32,
    pub height: u32,
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    /// Which kind of source produced the frame ([`SourceKind`] as u32).
    pub source_kind: u32,
    /// [`DepthHeader::FROM_ANOTHER_HOST`], or 0. (Was `_reserved`, always 0: the layout
    /// and type name are those of before.)
    pub flags: u32,
}

/// The kind of depth source, as carried in [`DepthHeader::source_kind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum SourceKind {
    Synthetic = 1,
    Recording = 2,
    V4l2 = 3,
    OpenNi2 = 4,
}

/// Why a received depth header was dropped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeaderError {
    #[error("header says {width}x{height} = {} pixels but the payload holds {len}", *width as u64 * *height as u64)]
    SizeMismatch { width: u32, height: u32, len: usize },
    #[error("intrinsics: {0}")]
    Intrinsics(#[from] airglyph_core::camera::IntrinsicsError),
    #[error("timestamps out of order: capture {capture_ns} ns, publish {publish_ns} ns, received {now_ns} ns")]
    Timestamps {
        capture_ns: u64,
        publish_ns: u64,
        now_ns: u64,
    },
}

/// How far into the future a timestamp may be (clock reads race between processes).
const CLOCK_SLACK_NS: u64 = 5_000_000;

fn check_times(capture_ns: u64, publish_ns: u64, now_ns: u64) -> Result<(), HeaderError> {
    if capture_ns == 0 || capture_ns > publish_ns || publish_ns > now_ns + CLOCK_SLACK_NS {
        return Err(HeaderError::Timestamps {
            capture_ns,
            publish_ns,
            now_ns,
        });
    }
    Ok(())
}

impl DepthHeader {
    /// In [`DepthHeader::flags`]: the frame was captured on another host and carried
    /// here (`airglyph import`). Its times are that host's CLOCK_MONOTONIC, which says
    /// nothing about this host's: they are checked for order, never against our clock.
    pub const FROM_ANOTHER_HOST: u32 = 1;

    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics::new(self.width, self.height, self.fx, self.fy, self.cx, self.cy)
    }

    pub fn set_intrinsics(&mut self, k: &Intrinsics) {
        (self.width, self.height, self.fx, self.fy, self.cx, self.cy) =
            (k.width, k.height, k.fx, k.fy, k.cx, k.cy);
    }

    /// The header with its times on this host's clock, given when it was received: a
    /// frame from another host ([`DepthHeader::FROM_ANOTHER_HOST`]) is moved so that it
    /// was published as it was received (the time in transit cannot be known without a
    /// shared clock), its capture as long before that as it was there; a frame of this
    /// host is as it is. What a stage makes of it (a skeleton's latency chain) is then
    /// in one clock and in order.
    pub fn on_this_host(&self, received_ns: u64) -> Self {
        if self.flags & Self::FROM_ANOTHER_HOST == 0 {
            return *self;
        }
        let back = |t: u64| received_ns.saturating_sub(self.publish_ns.saturating_sub(t));
        Self {
            capture_ns: back(self.capture_ns).max(1),
            source_ns: back(self.source_ns),
            publish_ns: received_ns,
            ..*self
        }
    }

    /// Checks a received header against its payload and the receiver's clock. Shared
    /// memory is written by another process: nothing in it is trusted before this.
    pub fn validate(&self, payload_len: usize, now_ns: u64) -> Result<(), HeaderError> {
        if self.width as u64 * self.height as u64 != payload_len as u64 {
            return Err(HeaderError::SizeMismatch {
                width: self.width,
                height: self.height,
                len: payload_len,
            });
        }
        self.intrinsics().validate()?;
        // Another host's clock is not ours: a frame from there may come from our future.
        let now_ns = if self.flags & Self::FROM_ANOTHER_HOST != 0 {
            u64::MAX - CLOCK_SLACK_NS
        } else {
            now_ns
        };
        check_times(self.capture_ns, self.publish_ns, now_ns)
    }
}

/// Each stage's in and out times for one frame, CLOCK_MONOTONIC ns; 0 = not reached.
/// Carried along so every consumer can split end-to-end latency by stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("airglyph.LatencyChain.v1")]
#[repr(C)]
pub struct LatencyChain {
    pub capture_ns: u64,
    pub capture_publish_ns: u64,
    pub pose_receive_ns: u64,
    pub pose_publish_ns: u64,
    pub gesture_receive_ns: u64,
    pub gesture_publish_ns: u64,
}

impl LatencyChain {
    /// The chain of a depth frame as it leaves capture.
    pub fn of_frame(h: &DepthHeader) -> Self {
        Self {
            capture_ns: h.capture_ns,
            capture_publish_ns: h.publish_ns,
            ..Self::default()
        }
    }

    fn is_ordered(&self) -> bool {
        let times = [
            self.capture_ns,
            self.capture_publish_ns,
            self.pose_receive_ns,
            self.pose_publish_ns,
            self.gesture_receive_ns,
            self.gesture_publish_ns,
        ];
        let reached: Vec<u64> = times.into_iter().take_while(|&t| t != 0).collect();
        !reached.is_empty() && reached.windows(2).all(|w| w[0] <= w[1])
    }
}

/// The skeleton of one depth frame.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("airglyph.SkeletonMsg.v2")]
#[repr(C)]
pub struct SkeletonMsg {
    pub sequence: u64,
    pub session: u64,
    pub chain: LatencyChain,
    /// x, y, z in metres, camera frame, in [`Joint::ALL`] order.
    pub joints: [[f32; 3]; Joint::COUNT],
    pub confidence: [f32; Joint::COUNT],
    /// 1 when a person was found; the joints are meaningless otherwise.
    pub person_found: u8,
    pub _pad: u8,
    /// Bit `i` set: joint `i` ([`Joint::ALL`] order) is in the camera's view
    /// ([`Skeleton::visible`]).
    pub visible: u16,
    pub _reserved: [u8; 4],
}

impl Default for SkeletonMsg {
    fn default() -> Self {
        Self {
            sequence: 0,
            session: 0,
            chain: LatencyChain::default(),
            joints: [[0.0; 3]; Joint::COUNT],
            confidence: [0.0; Joint::COUNT],
            person_found: 0,
            _pad: 0,
            visible: 0,
            _reserved: [0; 4],
        }
    }
}

/// Why a received message was dropped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MessageError {
    #[error("a joint coordinate or confidence is not a finite number")]
    NotFinite,
    #[error("the latency chain's timestamps are missing or out of order")]
    Chain,
    #[error("label is not UTF-8 or longer than {} bytes", LABEL_CAPACITY)]
    Label,
}

impl SkeletonMsg {
    pub fn skeleton(&self) -> Option<Skeleton> {
        (self.person_found != 0).then(|| Skeleton {
            joints: self.joints.map(|[x, y, z]| Point3::new(x, y, z)),
            confidence: self.confidence,
            visible: std::array::from_fn(|i| self.visible & (1 << i) != 0),
        })
    }

    pub fn set_skeleton(&mut self, s: Option<&Skeleton>) {
        match s {
            Some(s) => {
                self.joints = s.joints.map(|p| [p.x, p.y, p.z]);
                self.confidence = s.confidence;
                self.visible = s
                    .visible
                    .iter()
                    .enumerate()
                    .fold(0, |m, (i, v)| m | (u16::from(*v) << i));
                self.person_found = 1;
            }
            None => {
                self.joints = [[0.0; 3]; Joint::COUNT];
                self.confidence = [0.0; Joint::COUNT];
                self.visible = 0;
                self.person_found = 0;
            }
        }
    }

    pub fn validate(&self) -> Result<(), MessageError> {
        if !self
            .joints
            .iter()
            .flatten()
            .chain(&self.confidence)
            .all(|v| v.is_finite())
        {
            return Err(MessageError::NotFinite);
        }
        if !self.chain.is_ordered() {
            return Err(MessageError::Chain);
        }
        Ok(())
    }
}

/// The iceoryx2 type name of a wire type: what a program in another language must give
/// its copy of the type (`python/airglyph/wire.py`).
pub fn type_name<T: ZeroCopySend>() -> &'static str {
    // SAFETY: only reads the name. The trait's contract (the same layout wherever the
    // name is used) is what the caller checks with it.
    unsafe { <T as ZeroCopySend>::type_name() }
}

/// Longest gesture label on the wire, in UTF-8 bytes.
pub const LABEL_CAPACITY: usize = 32;

/// A spotted and classified gesture.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("airglyph.GestureEventMsg.v1")]
#[repr(C)]
pub struct GestureEventMsg {
    pub label: [u8; LABEL_CAPACITY],
    pub label_len: u32,
    pub score: f32,
    pub start_sequence: u64,
    pub end_sequence: u64,
    pub start_ns: u64,
    pub end_ns: u64,
    pub session: u64,
    /// The latency chain of the frame that closed the gesture.
    pub chain: LatencyChain,
    /// Which hand drew it ([`Hand`] as u8).
    pub hand: u8,
    pub _reserved: [u8; 7],
}

/// The hand that drew a gesture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Hand {
    Left = 0,
    Right = 1,
}

impl Default for GestureEventMsg {
    fn default() -> Self {
        Self {
            label: [0; LABEL_CAPACITY],
            label_len: 0,
            score: 0.0,
            start_sequence: 0,
            end_sequence: 0,
            start_ns: 0,
            end_ns: 0,
            session: 0,
            chain: LatencyChain::default(),
            hand: Hand::Right as u8,
            _reserved: [0; 7],
        }
    }
}

impl GestureEventMsg {
    /// Sets the label; refuses labels longer than [`LABEL_CAPACITY`] bytes.
    pub fn set_label(&mut self, label: &str) -> Result<(), MessageError> {
        let bytes = label.as_bytes();
        if bytes.len() > LABEL_CAPACITY {
            return Err(MessageError::Label);
        }
        self.label = [0; LABEL_CAPACITY];
        self.label[..bytes.len()].copy_from_slice(bytes);
        self.label_len = bytes.len() as u32;
        Ok(())
    }

    pub fn label(&self) -> Result<&str, MessageError> {
        let len = self.label_len as usize;
        if len > LABEL_CAPACITY {
            return Err(MessageError::Label);
        }
        std::str::from_utf8(&self.label[..len]).map_err(|_| MessageError::Label)
    }

    pub fn validate(&self) -> Result<(), MessageError> {
        self.label()?;
        if !self.score.is_finite() {
            return Err(MessageError::NotFinite);
        }
        if !self.chain.is_ordered() {
            return Err(MessageError::Chain);
        }
        Ok(())
    }
}

/// The gesture stage's decision on one skeleton: sent for every frame it processes, so
/// capture→decision latency can be profiled frame by frame, gesture or not.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("airglyph.DecisionMsg.v1")]
#[repr(C)]
pub struct DecisionMsg {
    pub sequence: u64,
    pub session: u64,
    pub chain: LatencyChain,
    /// 1 when this frame closed a gesture (an event was published for it).
    pub gesture: u8,
    pub _reserved: [u8; 7],
}

impl DecisionMsg {
    pub fn validate(&self) -> Result<(), MessageError> {
        if self.chain.is_ordered() {
            Ok(())
        } else {
            Err(MessageError::Chain)
        }
    }
}

/// Percentiles of one latency distribution over the last reporting window, in ns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("airglyph.Percentiles.v1")]
#[repr(C)]
pub struct Percentiles {
    pub count: u64,
    pub p50: u64,
    pub p90: u64,
    pub p99: u64,
    pub max: u64,
}

/// One stage's telemetry, published once a second on `airglyph/stats/<stage>`.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("airglyph.StageStatsMsg.v1")]
#[repr(C)]
pub struct StageStatsMsg {
    /// The stage ([`crate::Stage`] as u32).
    pub stage: u32,
    pub pid: u32,
    /// CLOCK_MONOTONIC ns when this report was made.
    pub time_ns: u64,
    /// Length of the window the rates and percentiles cover.
    pub window_ns: u64,
    /// Totals since the stage started.
    pub frames_in: u64,
    pub frames_out: u64,
    /// Frames lost upstream of this stage, counted from sequence gaps.
    pub frames_dropped: u64,
    /// Received messages refused as malformed.
    pub frames_rejected: u64,
    /// Output frames per second over the window.
    pub fps: f32,
    pub _reserved: u32,
    /// Time from receiving an input to publishing the output.
    pub processing: Percentiles,
    /// Time an input waited in shared memory before this stage took it.
    pub waiting: Percentiles,
    /// Time from capture to this stage's publish.
    pub latency: Percentiles,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> DepthHeader {
        let mut h = DepthHeader {
            capture_ns: 10,
            publish_ns: 20,
            ..Default::default()
        };
        h.set_intrinsics(&Intrinsics::default());
        h
    }

    #[test]
    fn a_header_that_does_not_match_its_payload_is_refused() {
        let h = header();
        assert!(h.validate(640 * 480, 30).is_ok());
        let err = h.validate(640 * 479, 30).unwrap_err();
        assert!(matches!(err, HeaderError::SizeMismatch { len: 306560, .. }));
        assert!(err.to_string().contains("307200"), "{err}");
    }

    #[test]
    fn insane_intrinsics_and_timestamps_are_refused() {
        let mut h = header();
        h.fx = f32::INFINITY;
        assert!(matches!(
            h.validate(640 * 480, 30),
            Err(HeaderError::Intrinsics(_))
        ));
        let mut h = header();
        h.capture_ns = 25;
        assert!(matches!(
            h.validate(640 * 480, 30),
            Err(HeaderError::Timestamps { .. })
        ));
        let h = header();
        assert!(
            matches!(h.validate(640 * 480, 1), Ok(())),
            "5 ms of clock slack"
        );
        let mut h = header();
        h.publish_ns = 1_000_000_000;
        assert!(matches!(
            h.validate(640 * 480, 30),
            Err(HeaderError::Timestamps { .. })
        ));
    }

    #[test]
    fn a_frame_from_another_host_is_not_held_to_our_clock() {
        let mut h = header();
        (h.capture_ns, h.publish_ns) = (5_000_000_000, 6_000_000_000);
        // Published "in our future": another host's clock runs ahead of ours.
        assert!(matches!(
            h.validate(640 * 480, 30),
            Err(HeaderError::Timestamps { .. })
        ));
        h.flags = DepthHeader::FROM_ANOTHER_HOST;
        assert!(h.validate(640 * 480, 30).is_ok());
        // On this host's clock: published when received, captured as long before.
        let here = h.on_this_host(100_000);
        assert_eq!((here.capture_ns, here.publish_ns), (1, 100_000));
        let here = h.on_this_host(2_000_000_000);
        assert_eq!(
            (here.capture_ns, here.publish_ns),
            (1_000_000_000, 2_000_000_000)
        );
        assert_eq!(header().on_this_host(7), header());
        // Its times must still be in order.
        h.capture_ns = 7_000_000_000;
        assert!(matches!(
            h.validate(640 * 480, 30),
            Err(HeaderError::Timestamps { .. })
        ));
    }

    #[test]
    fn skeleton_round_trips_and_nan_is_refused() {
        let mut s = Skeleton::new([Point3::new(0.1, 0.2, 2.0); Joint::COUNT]);
        s.confidence[3] = 0.5;
        s.visible[11] = false;
        s.visible[15] = false;
        let mut m = SkeletonMsg {
            chain: LatencyChain {
                capture_ns: 1,
                ..Default::default()
            },
            ..Default::default()
        };
        m.set_skeleton(Some(&s));
        m.validate().unwrap();
        assert_eq!(m.skeleton(), Some(s));
        m.joints[5][1] = f32::NAN;
        assert_eq!(m.validate(), Err(MessageError::NotFinite));
        m.set_skeleton(None);
        assert_eq!(m.skeleton(), None);
    }

    #[test]
    fn gesture_labels_are_bounded_utf8() {
        let mut g = GestureEventMsg::default();
        g.set_label("Ω7").unwrap();
        assert_eq!(g.label().unwrap(), "Ω7");
        assert!(g.set_label(&"x".repeat(33)).is_err());
        g.label_len = 200;
        assert_eq!(g.label(), Err(MessageError::Label));
    }

    #[test]
    fn chains_must_be_ordered() {
        let ok = LatencyChain {
            capture_ns: 1,
            capture_publish_ns: 2,
            pose_receive_ns: 3,
            ..Default::default()
        };
        assert!(ok.is_ordered());
        let bad = LatencyChain {
            capture_ns: 5,
            capture_publish_ns: 2,
            ..Default::default()
        };
        assert!(!bad.is_ordered());
        assert!(!LatencyChain::default().is_ordered());
    }
}
