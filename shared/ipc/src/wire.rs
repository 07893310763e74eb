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
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// Horizontal focal length, pixels.
    pub fx: f32,
    /// Vertical focal length, pixels.
    pub fy: f32,
    /// Principal point's column, pixels.
    pub cx: f32,
    /// Principal point's row, pixels.
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
    /// The synthetic person.
    Synthetic = 1,
    /// A recording on disk.
    Recording = 2,
    /// A V4L2 camera.
    V4l2 = 3,
    /// An OpenNI2 camera or `.oni` file.
    OpenNi2 = 4,
}

/// Why a received depth header was dropped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HeaderError {
    /// The header's size does not match the payload's length.
    #[error("header says {width}x{height} = {} pixels but the payload holds {len}", *width as u64 * *height as u64)]
    SizeMismatch {
        /// The width the header claims.
        width: u32,
        /// The height the header claims.
        height: u32,
        /// The payload's pixels.
        len: usize,
    },
    /// The intrinsics cannot describe a camera.
    #[error("intrinsics: {0}")]
    Intrinsics(#[from] airglyph_core::camera::IntrinsicsError),
    /// The timestamps are missing, out of order or in the future.
    #[error("timestamps out of order: capture {capture_ns} ns, publish {publish_ns} ns, received {now_ns} ns")]
    Timestamps {
        /// When the frame entered the pipeline.
        capture_ns: u64,
        /// When capture sent it.
        publish_ns: u64,
        /// The receiver's clock.
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

    /// The camera's intrinsics at the frame's size.
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics::new(self.width, self.height, self.fx, self.fy, self.cx, self.cy)
    }

    /// Sets the size and intrinsics fields from `k`.
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
    /// When the frame entered the pipeline.
    pub capture_ns: u64,
    /// When capture sent it.
    pub capture_publish_ns: u64,
    /// When the pose stage took it.
    pub pose_receive_ns: u64,
    /// When the pose stage sent its skeleton.
    pub pose_publish_ns: u64,
    /// When the gesture stage took the skeleton.
    pub gesture_receive_ns: u64,
    /// When the gesture stage sent its decision or event.
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

/// Longest posture label on the wire, in UTF-8 bytes (a posture model's labels are held
/// to it: `airglyph_posture::MAX_POSTURE_LABEL_BYTES`).
pub const POSTURE_LABEL_CAPACITY: usize = 16;

/// One hand's static posture in a skeleton, as the pose stage's posture step classified
/// it; "none" (`label_len` 0) when the hand was not classified (not visible, the step
/// switched off, no hand found in the depth image).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("airglyph.PostureMsg.v1")]
#[repr(C)]
pub struct PostureMsg {
    /// The label's UTF-8 bytes, zero-padded.
    pub label: [u8; POSTURE_LABEL_CAPACITY],
    /// How many of `label`'s bytes are the label; 0: none.
    pub label_len: u32,
    /// The classifier's confidence in [0, 1]; 0 when none.
    pub confidence: f32,
}

/// A posture as read from a message: its label and the classifier's confidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Posture<'a> {
    /// The posture model's label.
    pub label: &'a str,
    /// The classifier's confidence in [0, 1].
    pub confidence: f32,
}

impl PostureMsg {
    /// A classified posture; refuses an empty label (that is "none"), one longer than
    /// [`POSTURE_LABEL_CAPACITY`] bytes, and a confidence outside [0, 1].
    pub fn new(label: &str, confidence: f32) -> Result<Self, MessageError> {
        if label.is_empty() {
            return Err(MessageError::PostureLabel);
        }
        let mut m = Self {
            confidence,
            ..Self::default()
        };
        m.label_len = write_bounded(&mut m.label, label).ok_or(MessageError::PostureLabel)?;
        m.check_confidence()?;
        Ok(m)
    }

    /// The posture, None when the hand was not classified; an error when what another
    /// process wrote is not a posture ([`PostureMsg::validate`]).
    pub fn get(&self) -> Result<Option<Posture<'_>>, MessageError> {
        self.check_confidence()?;
        if self.label_len == 0 {
            return Ok(None);
        }
        let label = read_bounded(&self.label, self.label_len).ok_or(MessageError::PostureLabel)?;
        Ok(Some(Posture {
            label,
            confidence: self.confidence,
        }))
    }

    /// Checks a received posture: a UTF-8 label of at most [`POSTURE_LABEL_CAPACITY`]
    /// bytes, a finite confidence in [0, 1].
    pub fn validate(&self) -> Result<(), MessageError> {
        self.get().map(drop)
    }

    fn check_confidence(&self) -> Result<(), MessageError> {
        if !(0.0..=1.0).contains(&self.confidence) {
            return Err(MessageError::PostureConfidence(self.confidence));
        }
        Ok(())
    }
}

/// Copies `s` into `dst`, zero-padded: its length, or None when it does not fit.
fn write_bounded(dst: &mut [u8], s: &str) -> Option<u32> {
    let bytes = s.as_bytes();
    if bytes.len() > dst.len() {
        return None;
    }
    dst.fill(0);
    dst[..bytes.len()].copy_from_slice(bytes);
    Some(bytes.len() as u32)
}

/// The first `len` bytes of `src` as text; None when `len` claims more than `src` holds
/// or the bytes are not UTF-8 (another process wrote them).
fn read_bounded(src: &[u8], len: u32) -> Option<&str> {
    let bytes = src.get(..usize::try_from(len).ok()?)?;
    std::str::from_utf8(bytes).ok()
}

/// The skeleton of one depth frame.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("airglyph.SkeletonMsg.v3")]
#[repr(C)]
pub struct SkeletonMsg {
    /// The depth frame's sequence number in its capture session.
    pub sequence: u64,
    /// The depth frame's capture session.
    pub session: u64,
    /// The frame's latency chain up to the skeleton's publication.
    pub chain: LatencyChain,
    /// x, y, z in metres, camera frame, in [`Joint::ALL`] order.
    pub joints: [[f32; 3]; Joint::COUNT],
    /// Each joint's confidence in [0, 1], in [`Joint::ALL`] order.
    pub confidence: [f32; Joint::COUNT],
    /// 1 when a person was found; the joints are meaningless otherwise.
    pub person_found: u8,
    /// Padding, written as 0.
    pub _pad: u8,
    /// Bit `i` set: joint `i` ([`Joint::ALL`] order) is in the camera's view
    /// ([`Skeleton::visible`]).
    pub visible: u16,
    /// Padding to 8 bytes, written as 0.
    pub _reserved: [u8; 4],
    /// Each hand's posture, in [`Hand`] order (left, right).
    pub postures: [PostureMsg; 2],
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
            postures: [PostureMsg::default(); 2],
        }
    }
}

/// Why a received message was dropped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MessageError {
    /// A coordinate, confidence or score is not a finite number.
    #[error("a joint coordinate or confidence is not a finite number")]
    NotFinite,
    /// The latency chain's timestamps are missing or out of order.
    #[error("the latency chain's timestamps are missing or out of order")]
    Chain,
    /// The label is not UTF-8 or longer than [`LABEL_CAPACITY`].
    #[error("label is not UTF-8 or longer than {} bytes", LABEL_CAPACITY)]
    Label,
    /// More Bezier points than a gesture event holds.
    #[error("more than {} Bezier points", BEZIER_CAPACITY)]
    Bezier,
    /// A hand that is neither left (0) nor right (1).
    #[error("hand {0} is neither left (0) nor right (1)")]
    Hand(u8),
    /// A posture label that is empty where one is set, not UTF-8, or longer than
    /// [`POSTURE_LABEL_CAPACITY`].
    #[error(
        "posture label is empty, not UTF-8 or longer than {} bytes",
        POSTURE_LABEL_CAPACITY
    )]
    PostureLabel,
    /// A posture's confidence that is not a number in [0, 1].
    #[error("posture confidence {0} is not a number in [0, 1]")]
    PostureConfidence(f32),
}

impl SkeletonMsg {
    /// The skeleton, or None when no person was found.
    pub fn skeleton(&self) -> Option<Skeleton> {
        (self.person_found != 0).then(|| Skeleton {
            joints: self.joints.map(|[x, y, z]| Point3::new(x, y, z)),
            confidence: self.confidence,
            visible: std::array::from_fn(|i| self.visible & (1 << i) != 0),
        })
    }

    /// The posture of `hand`, None when it was not classified.
    pub fn posture(&self, hand: Hand) -> Result<Option<Posture<'_>>, MessageError> {
        self.postures[hand as usize].get()
    }

    /// Sets the posture of `hand` (None: not classified).
    pub fn set_posture(&mut self, hand: Hand, posture: Option<PostureMsg>) {
        self.postures[hand as usize] = posture.unwrap_or_default();
    }

    /// Sets the joints, confidences and visibility, or marks no person found (and then
    /// no posture either).
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
                self.postures = [PostureMsg::default(); 2];
            }
        }
    }

    /// Checks a received skeleton: finite joints and confidences, an ordered chain,
    /// postures with UTF-8 labels that fit and confidences in [0, 1].
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
        self.postures.iter().try_for_each(PostureMsg::validate)
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

/// Most Bezier points a gesture event carries: more than a gesture descriptor uses
/// (15 by default); a model asking for more is sent that many points of the same curve.
pub const BEZIER_CAPACITY: usize = 64;

/// A spotted and classified gesture, with the Bezier points of the path it was
/// recognized from.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("airglyph.GestureEventMsg.v3")]
#[repr(C)]
pub struct GestureEventMsg {
    /// The label's UTF-8 bytes, zero-padded.
    pub label: [u8; LABEL_CAPACITY],
    /// How many of `label`'s bytes are the label.
    pub label_len: u32,
    /// The classifier's confidence in [0, 1].
    pub score: f32,
    /// Its first frame's sequence number.
    pub start_sequence: u64,
    /// Its last frame's sequence number.
    pub end_sequence: u64,
    /// Its first frame's capture time, CLOCK_MONOTONIC ns.
    pub start_ns: u64,
    /// Its last frame's capture time, CLOCK_MONOTONIC ns.
    pub end_ns: u64,
    /// The capture session its frames belong to.
    pub session: u64,
    /// The latency chain of the frame that closed the gesture.
    pub chain: LatencyChain,
    /// Which hand drew it ([`Hand`] as u8).
    pub hand: u8,
    /// Padding, written as 0.
    pub _reserved: [u8; 3],
    /// How many of `bezier` are the gesture's.
    pub bezier_len: u32,
    /// Points of the Bezier curve whose control points are the hand's path over the
    /// gesture, as the gesture stage measured it (body frame: x to the person's right,
    /// y down, shoulder widths), from its start to its end.
    pub bezier: [[f32; 2]; BEZIER_CAPACITY],
    /// The posture label the drawing hand held over most of the gesture, UTF-8,
    /// zero-padded.
    pub posture: [u8; POSTURE_LABEL_CAPACITY],
    /// How many of `posture`'s bytes are the label; 0: unknown.
    pub posture_len: u32,
    /// Padding to 8 bytes, written as 0.
    pub _reserved_end: [u8; 4],
}

/// The hand that drew a gesture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Hand {
    /// The person's left hand.
    Left = 0,
    /// The person's right hand.
    Right = 1,
}

impl Hand {
    /// The hand a message's `u8` names, if any.
    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Hand::Left),
            1 => Some(Hand::Right),
            _ => None,
        }
    }

    /// `"left"` or `"right"`, as JSON and the page name it.
    pub fn name(self) -> &'static str {
        match self {
            Hand::Left => "left",
            Hand::Right => "right",
        }
    }
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
            _reserved: [0; 3],
            bezier_len: 0,
            bezier: [[0.0; 2]; BEZIER_CAPACITY],
            posture: [0; POSTURE_LABEL_CAPACITY],
            posture_len: 0,
            _reserved_end: [0; 4],
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

    /// The label; an error when the bytes are not UTF-8 or claim more than fits.
    pub fn label(&self) -> Result<&str, MessageError> {
        let len = self.label_len as usize;
        if len > LABEL_CAPACITY {
            return Err(MessageError::Label);
        }
        std::str::from_utf8(&self.label[..len]).map_err(|_| MessageError::Label)
    }

    /// Sets the Bezier points; refuses more than [`BEZIER_CAPACITY`] or a coordinate
    /// that is not finite.
    pub fn set_bezier(&mut self, points: &[[f32; 2]]) -> Result<(), MessageError> {
        if points.len() > BEZIER_CAPACITY {
            return Err(MessageError::Bezier);
        }
        if !points.iter().flatten().all(|v| v.is_finite()) {
            return Err(MessageError::NotFinite);
        }
        self.bezier = [[0.0; 2]; BEZIER_CAPACITY];
        self.bezier[..points.len()].copy_from_slice(points);
        self.bezier_len = points.len() as u32;
        Ok(())
    }

    /// The Bezier points the gesture carries (as many as fit, whatever the length says).
    pub fn bezier(&self) -> &[[f32; 2]] {
        &self.bezier[..(self.bezier_len as usize).min(BEZIER_CAPACITY)]
    }

    /// Sets the posture the drawing hand held over most of the gesture (None: unknown);
    /// refuses an empty label or one longer than [`POSTURE_LABEL_CAPACITY`] bytes.
    pub fn set_posture(&mut self, posture: Option<&str>) -> Result<(), MessageError> {
        match posture {
            Some("") => Err(MessageError::PostureLabel),
            Some(label) => {
                self.posture_len =
                    write_bounded(&mut self.posture, label).ok_or(MessageError::PostureLabel)?;
                Ok(())
            }
            None => {
                (self.posture, self.posture_len) = ([0; POSTURE_LABEL_CAPACITY], 0);
                Ok(())
            }
        }
    }

    /// The posture the drawing hand held over most of the gesture, None when unknown;
    /// an error when the bytes are not UTF-8 or claim more than fits.
    pub fn posture(&self) -> Result<Option<&str>, MessageError> {
        if self.posture_len == 0 {
            return Ok(None);
        }
        read_bounded(&self.posture, self.posture_len)
            .map(Some)
            .ok_or(MessageError::PostureLabel)
    }

    /// Checks a received event: its label and posture, finite score and Bezier points,
    /// an ordered chain.
    pub fn validate(&self) -> Result<(), MessageError> {
        self.label()?;
        self.posture()?;
        if !self.score.is_finite() {
            return Err(MessageError::NotFinite);
        }
        if self.bezier_len as usize > BEZIER_CAPACITY {
            return Err(MessageError::Bezier);
        }
        if !self.bezier().iter().flatten().all(|v| v.is_finite()) {
            return Err(MessageError::NotFinite);
        }
        if !self.chain.is_ordered() {
            return Err(MessageError::Chain);
        }
        Ok(())
    }
}

/// The gesture stage's decision on one skeleton: sent for every frame it processes, so
/// capture→decision latency can be profiled frame by frame, gesture or not; and the
/// drawing hand's point its recognizer took from that skeleton, so a viewer draws the
/// path the gesture stage followed rather than one of its own.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("airglyph.DecisionMsg.v2")]
#[repr(C)]
pub struct DecisionMsg {
    /// The frame's sequence number.
    pub sequence: u64,
    /// The frame's capture session.
    pub session: u64,
    /// The frame's latency chain up to the decision.
    pub chain: LatencyChain,
    /// The drawing hand in the body frame the gesture stage measures in: x to the
    /// person's right, y down, shoulder widths from between the shoulders; meaningful
    /// when `hand_found` is 1.
    pub hand_point: [f32; 2],
    /// 1 when this frame closed a gesture (an event was published for it).
    pub gesture: u8,
    /// 1 when the skeleton gave the recognizer a hand point (a person, steady joints).
    pub hand_found: u8,
    /// Which hand `hand_point` is ([`Hand`] as u8).
    pub hand: u8,
    /// Padding to 8 bytes, written as 0.
    pub _reserved: [u8; 5],
}

impl DecisionMsg {
    /// Sets the hand point the recognizer took, or none.
    pub fn set_hand_point(&mut self, point: Option<(Hand, [f32; 2])>) {
        (self.hand_found, self.hand, self.hand_point) = match point {
            Some((hand, at)) => (1, hand as u8, at),
            None => (0, 0, [0.0; 2]),
        };
    }

    /// The hand point the recognizer took from this frame's skeleton, if any.
    pub fn hand_point(&self) -> Option<(Hand, [f32; 2])> {
        if self.hand_found == 0 {
            return None;
        }
        Some((Hand::from_u8(self.hand)?, self.hand_point))
    }

    /// Checks a received decision: an ordered chain, a known hand and a finite point.
    pub fn validate(&self) -> Result<(), MessageError> {
        if !self.chain.is_ordered() {
            return Err(MessageError::Chain);
        }
        if self.hand_found != 0 {
            Hand::from_u8(self.hand).ok_or(MessageError::Hand(self.hand))?;
            if !self.hand_point.iter().all(|v| v.is_finite()) {
                return Err(MessageError::NotFinite);
            }
        }
        Ok(())
    }
}

/// Percentiles of one latency distribution over the last reporting window, in ns.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[type_name("airglyph.Percentiles.v1")]
#[repr(C)]
pub struct Percentiles {
    /// How many values the window had.
    pub count: u64,
    /// The median.
    pub p50: u64,
    /// The 90th percentile.
    pub p90: u64,
    /// The 99th percentile.
    pub p99: u64,
    /// The largest.
    pub max: u64,
}

/// One stage's telemetry, published once a second on `airglyph/stats/<stage>`.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[type_name("airglyph.StageStatsMsg.v1")]
#[repr(C)]
pub struct StageStatsMsg {
    /// The stage ([`crate::Stage`] as u32).
    pub stage: u32,
    /// The stage's process id.
    pub pid: u32,
    /// CLOCK_MONOTONIC ns when this report was made.
    pub time_ns: u64,
    /// Length of the window the rates and percentiles cover.
    pub window_ns: u64,
    /// Totals since the stage started.
    pub frames_in: u64,
    /// Outputs published.
    pub frames_out: u64,
    /// Frames lost upstream of this stage, counted from sequence gaps.
    pub frames_dropped: u64,
    /// Received messages refused as malformed.
    pub frames_rejected: u64,
    /// Output frames per second over the window.
    pub fps: f32,
    /// Padding to 8 bytes, written as 0.
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
    fn skeletons_carry_each_hands_posture() {
        let mut m = SkeletonMsg {
            chain: captured(),
            ..Default::default()
        };
        m.set_skeleton(Some(&Skeleton::new(
            [Point3::new(0.1, 0.2, 2.0); Joint::COUNT],
        )));
        assert_eq!(m.posture(Hand::Left), Ok(None));
        m.set_posture(
            Hand::Right,
            Some(PostureMsg::new("thumb_up", 0.75).unwrap()),
        );
        m.validate().unwrap();
        assert_eq!(m.posture(Hand::Left), Ok(None));
        let p = m.posture(Hand::Right).unwrap().unwrap();
        assert_eq!((p.label, p.confidence), ("thumb_up", 0.75));
        // Sixteen bytes fit, whatever their characters; seventeen do not.
        assert_eq!(
            PostureMsg::new("ΩΩΩΩΩΩΩΩ", 1.0)
                .unwrap()
                .get()
                .unwrap()
                .unwrap()
                .label,
            "ΩΩΩΩΩΩΩΩ"
        );
        assert_eq!(
            PostureMsg::new(&"x".repeat(17), 0.5),
            Err(MessageError::PostureLabel)
        );
        assert_eq!(PostureMsg::new("", 0.5), Err(MessageError::PostureLabel));
        assert!(matches!(
            PostureMsg::new("fist", 1.5),
            Err(MessageError::PostureConfidence(_))
        ));
        // No person, no posture.
        m.set_skeleton(None);
        assert_eq!(m.posture(Hand::Right), Ok(None));
    }

    #[test]
    fn a_hostile_posture_is_refused_not_read() {
        let mut good = SkeletonMsg {
            chain: captured(),
            ..Default::default()
        };
        good.set_posture(Hand::Left, Some(PostureMsg::new("open", 0.5).unwrap()));
        let refused = |f: &dyn Fn(&mut PostureMsg)| {
            let mut m = good;
            f(&mut m.postures[Hand::Left as usize]);
            let err = m.validate().unwrap_err();
            // (Debug: a NaN confidence is not equal to itself.)
            let read = m.posture(Hand::Left).unwrap_err();
            assert_eq!(format!("{read:?}"), format!("{err:?}"));
            err
        };
        assert_eq!(refused(&|p| p.label_len = 17), MessageError::PostureLabel);
        assert_eq!(
            refused(&|p| p.label_len = u32::MAX),
            MessageError::PostureLabel
        );
        // Half of a two-byte character.
        assert_eq!(
            refused(&|p| {
                p.label[..2].copy_from_slice("Ω".as_bytes());
                p.label_len = 1;
            }),
            MessageError::PostureLabel
        );
        assert_eq!(refused(&|p| p.label[0] = 0xff), MessageError::PostureLabel);
        for bad in [f32::NAN, f32::INFINITY, -0.1, 1.01] {
            assert!(matches!(
                refused(&|p| p.confidence = bad),
                MessageError::PostureConfidence(_)
            ));
        }
        // A "none" with garbage confidence is refused too: nothing on the wire is unread.
        let mut m = good;
        m.postures[Hand::Right as usize].confidence = f32::NAN;
        assert!(m.validate().is_err());
        good.validate().unwrap();
    }

    #[test]
    fn gesture_events_carry_the_drawing_hands_posture() {
        let mut g = GestureEventMsg {
            chain: captured(),
            ..Default::default()
        };
        assert_eq!(g.posture(), Ok(None));
        g.set_posture(Some("point")).unwrap();
        assert_eq!(g.posture(), Ok(Some("point")));
        g.validate().unwrap();
        assert_eq!(
            g.set_posture(Some(&"p".repeat(17))),
            Err(MessageError::PostureLabel)
        );
        assert_eq!(g.set_posture(Some("")), Err(MessageError::PostureLabel));
        assert_eq!(
            g.posture(),
            Ok(Some("point")),
            "a refused label leaves the last"
        );
        g.set_posture(None).unwrap();
        assert_eq!(g.posture(), Ok(None));
        g.posture_len = 40;
        assert_eq!(g.validate(), Err(MessageError::PostureLabel));
        g.posture = [0xc3; POSTURE_LABEL_CAPACITY];
        g.posture_len = 3;
        assert_eq!(g.validate(), Err(MessageError::PostureLabel));
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

    /// The chain of a frame that has only been captured.
    fn captured() -> LatencyChain {
        LatencyChain {
            capture_ns: 1,
            ..Default::default()
        }
    }

    #[test]
    fn gesture_events_carry_bounded_finite_bezier_points() {
        let mut g = GestureEventMsg {
            chain: captured(),
            ..Default::default()
        };
        let curve: Vec<[f32; 2]> = (0..15).map(|i| [i as f32 * 0.1, -0.5]).collect();
        g.set_bezier(&curve).unwrap();
        assert_eq!(g.bezier(), &curve[..]);
        g.validate().unwrap();
        assert_eq!(
            g.set_bezier(&vec![[0.0; 2]; BEZIER_CAPACITY + 1]),
            Err(MessageError::Bezier)
        );
        assert_eq!(
            g.set_bezier(&[[f32::NAN, 0.0]]),
            Err(MessageError::NotFinite)
        );
        // What another process wrote is checked, and never read past the array.
        g.bezier_len = 1000;
        assert_eq!(g.bezier().len(), BEZIER_CAPACITY);
        assert_eq!(g.validate(), Err(MessageError::Bezier));
        g.bezier_len = 2;
        g.bezier[1][0] = f32::INFINITY;
        assert_eq!(g.validate(), Err(MessageError::NotFinite));
    }

    #[test]
    fn decisions_carry_the_recognizers_hand_point() {
        let mut d = DecisionMsg {
            chain: captured(),
            ..Default::default()
        };
        assert_eq!(d.hand_point(), None);
        d.set_hand_point(Some((Hand::Left, [0.25, -0.5])));
        assert_eq!(d.hand_point(), Some((Hand::Left, [0.25, -0.5])));
        d.validate().unwrap();
        d.hand = 7;
        assert_eq!(d.validate(), Err(MessageError::Hand(7)));
        assert_eq!(d.hand_point(), None);
        d.set_hand_point(Some((Hand::Right, [f32::NAN, 0.0])));
        assert_eq!(d.validate(), Err(MessageError::NotFinite));
        d.set_hand_point(None);
        d.validate().unwrap();
    }

    /// The layouts other processes read: a change here is a change of the type's
    /// version in its name (and of every process that speaks it).
    #[test]
    fn layouts_are_as_their_versions_say() {
        use std::mem::{align_of, offset_of, size_of};
        assert_eq!(size_of::<LatencyChain>(), 48);
        assert_eq!(
            (size_of::<DepthHeader>(), align_of::<DepthHeader>()),
            (72, 8)
        );
        assert_eq!(size_of::<PostureMsg>(), 24);
        assert_eq!(offset_of!(PostureMsg, label_len), 16);
        assert_eq!(offset_of!(PostureMsg, confidence), 20);
        assert_eq!(size_of::<SkeletonMsg>(), 376);
        assert_eq!(offset_of!(SkeletonMsg, visible), 322);
        assert_eq!(offset_of!(SkeletonMsg, postures), 328);
        assert_eq!(size_of::<GestureEventMsg>(), 672);
        assert_eq!(offset_of!(GestureEventMsg, posture), 648);
        assert_eq!(offset_of!(GestureEventMsg, posture_len), 664);
        assert_eq!(offset_of!(GestureEventMsg, chain), 80);
        assert_eq!(offset_of!(GestureEventMsg, hand), 128);
        assert_eq!(offset_of!(GestureEventMsg, bezier_len), 132);
        assert_eq!(offset_of!(GestureEventMsg, bezier), 136);
        assert_eq!(size_of::<DecisionMsg>(), 80);
        assert_eq!(offset_of!(DecisionMsg, hand_point), 64);
        assert_eq!(offset_of!(DecisionMsg, gesture), 72);
        assert_eq!(offset_of!(DecisionMsg, hand_found), 73);
        assert_eq!(offset_of!(DecisionMsg, hand), 74);
        assert_eq!(size_of::<Percentiles>(), 40);
        assert_eq!(size_of::<StageStatsMsg>(), 184);
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
