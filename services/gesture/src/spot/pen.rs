//! The hand's posture beside its path: what a posture classifier read of each hand a
//! frame, which posture a gesture was drawn in, and the pen by posture: the pen is down
//! while the drawing hand holds a chosen posture ("point"), so a gesture is the span
//! between pen down and pen up rather than a stretch the motion alone suggests.

use crate::tracker::Hand;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Longest posture label, in UTF-8 bytes: what a skeleton message carries of a hand's
/// posture.
pub const MAX_POSTURE_LABEL_BYTES: usize = 16;

/// A posture's name ("point", "open", …): at most [`MAX_POSTURE_LABEL_BYTES`] bytes,
/// not empty, kept inline so that a frame's postures and the settings stay `Copy`.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct PostureLabel {
    bytes: [u8; MAX_POSTURE_LABEL_BYTES],
    len: u8,
}

/// Why a text is not a posture label.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PostureLabelError {
    /// An empty label: "no posture" is `None`, not a label.
    #[error("a posture label is empty")]
    Empty,
    /// A label longer than [`MAX_POSTURE_LABEL_BYTES`].
    #[error("posture label {0:?} is longer than {MAX_POSTURE_LABEL_BYTES} bytes")]
    TooLong(String),
}

impl PostureLabel {
    /// "point": the pen's posture unless another is named.
    pub const POINT: PostureLabel = PostureLabel::literal("point");

    /// A label known when the code is compiled (checked then).
    const fn literal(s: &str) -> Self {
        let b = s.as_bytes();
        assert!(!b.is_empty() && b.len() <= MAX_POSTURE_LABEL_BYTES);
        let mut bytes = [0; MAX_POSTURE_LABEL_BYTES];
        let mut i = 0;
        while i < b.len() {
            bytes[i] = b[i];
            i += 1;
        }
        Self {
            bytes,
            len: b.len() as u8,
        }
    }

    /// The label `s`, if it is one.
    pub fn new(s: &str) -> Result<Self, PostureLabelError> {
        let b = s.as_bytes();
        if b.is_empty() {
            return Err(PostureLabelError::Empty);
        }
        if b.len() > MAX_POSTURE_LABEL_BYTES {
            return Err(PostureLabelError::TooLong(s.to_owned()));
        }
        let mut bytes = [0; MAX_POSTURE_LABEL_BYTES];
        bytes[..b.len()].copy_from_slice(b);
        Ok(Self {
            bytes,
            len: b.len() as u8,
        })
    }

    /// The label as text.
    pub fn as_str(&self) -> &str {
        // Only `new` fills the bytes, from a whole `&str` that fits.
        std::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or_default()
    }
}

impl std::fmt::Debug for PostureLabel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl std::fmt::Display for PostureLabel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for PostureLabel {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for PostureLabel {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        PostureLabel::new(&s).map_err(serde::de::Error::custom)
    }
}

/// One hand's posture in one frame, as a posture classifier read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPosture {
    /// The posture…
    pub label: PostureLabel,
    /// …and the classifier's confidence in it, in [0, 1].
    pub confidence: f32,
}

/// Both hands' postures in one frame; None for a hand that was not classified.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Postures {
    /// The person's left hand…
    pub left: Option<HandPosture>,
    /// …and right.
    pub right: Option<HandPosture>,
}

impl Postures {
    /// No posture known for either hand: what the spotter goes on without a posture
    /// classifier.
    pub const NONE: Postures = Postures {
        left: None,
        right: None,
    };

    /// The posture of `hand`.
    pub fn of(&self, hand: Hand) -> Option<HandPosture> {
        match hand {
            Hand::Left => self.left,
            Hand::Right => self.right,
        }
    }
}

/// When the pen is down: what decides where a gesture starts and ends.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pen {
    /// From the motion alone: breaks of the hand's speed and rests cut the path, the
    /// verifier and the classifier judge every stretch between them.
    #[default]
    Motion,
    /// While the drawing hand holds a posture.
    Posture(PosturePen),
    /// From the motion, as [`Pen::Motion`], but a stretch is a gesture only when the
    /// drawing hand held a posture over enough of it.
    Gated(GatedPen),
}

/// The gated pen's settings: which stretches of the pen by motion the posture lets
/// through.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GatedPen {
    /// The posture that lets a stretch through.
    pub label: PostureLabel,
    /// A posture read with less confidence counts as not held.
    pub min_confidence: f32,
    /// The least share of a stretch's frames with a posture read in which that posture
    /// was the pen's. Frames with none read count neither way: a hand the classifier
    /// did not see is no evidence, and a stream without postures is spotted as by
    /// motion.
    pub min_share: f32,
}

impl Default for GatedPen {
    fn default() -> Self {
        Self {
            label: PostureLabel::POINT,
            min_confidence: 0.5,
            // Chosen on the training writers' streams (NOTES.md, "The gated pen").
            min_share: 0.5,
        }
    }
}

impl GatedPen {
    /// Whether a frame's posture of the drawing hand holds the pen's.
    pub fn holds(&self, p: &HandPosture) -> bool {
        p.label == self.label && p.confidence >= self.min_confidence
    }
}

/// The pen by posture's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PosturePen {
    /// The posture that puts the pen down.
    pub label: PostureLabel,
    /// A posture read with less confidence counts as not held.
    pub min_confidence: f32,
    /// Frames in a row the posture must be held to put the pen down…
    pub down_frames: u32,
    /// …and not held to lift it: a misread run shorter than this does not cut a
    /// gesture in two (one shorter than `down_frames`, or than `min_seconds`, starts
    /// none).
    pub up_frames: u32,
    /// Whether the verifier must also take the span for a whole gesture, as it must a
    /// stretch the pen by motion finds: a reach made while pointing at something is
    /// then told from a symbol by its motion.
    pub verify: bool,
}

impl Default for PosturePen {
    fn default() -> Self {
        Self {
            label: PostureLabel::POINT,
            min_confidence: 0.5,
            // Chosen on the training writers' streams (NOTES.md, "The pen by posture").
            down_frames: 3,
            up_frames: 12,
            verify: false,
        }
    }
}

/// Why a `--pen` option was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PenParseError {
    /// None of "motion", "posture[:LABEL]", "gated[:LABEL]".
    #[error(
        "{0:?} is none of \"motion\", \"posture\", \"posture:LABEL\", \"gated\", \"gated:LABEL\""
    )]
    Unknown(String),
    /// The label after "posture:" is not one.
    #[error(transparent)]
    Label(#[from] PostureLabelError),
}

impl Pen {
    /// The pen a command line names: "motion", "posture" (the default posture pen,
    /// "point"), "posture:LABEL", "gated" (the default gated pen, "point") or
    /// "gated:LABEL".
    pub fn parse(s: &str) -> Result<Pen, PenParseError> {
        match s.split_once(':') {
            None if s == "motion" => Ok(Pen::Motion),
            None if s == "posture" => Ok(Pen::Posture(PosturePen::default())),
            Some(("posture", label)) => Ok(Pen::Posture(PosturePen {
                label: PostureLabel::new(label)?,
                ..PosturePen::default()
            })),
            None if s == "gated" => Ok(Pen::Gated(GatedPen::default())),
            Some(("gated", label)) => Ok(Pen::Gated(GatedPen {
                label: PostureLabel::new(label)?,
                ..GatedPen::default()
            })),
            _ => Err(PenParseError::Unknown(s.to_owned())),
        }
    }
}

impl PosturePen {
    /// Whether a frame's posture of the drawing hand holds the pen's.
    pub fn holds(&self, p: Option<HandPosture>) -> bool {
        p.is_some_and(|p| p.label == self.label && p.confidence >= self.min_confidence)
    }
}

/// Where the pen is, with the run of frames that may change it (point indices).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PenState {
    /// Up, the posture not held.
    #[default]
    Up,
    /// Up, the posture held from point `held_from` on, not yet long enough.
    Lowering {
        /// The first point of the run.
        held_from: usize,
    },
    /// Down since point `from`.
    Down {
        /// Its first point.
        from: usize,
    },
    /// Down since `from`, the posture not held since `released_at`, not yet long enough.
    Lifting {
        /// The pen's first point…
        from: usize,
        /// …and the first point the posture was not held.
        released_at: usize,
    },
}

impl PenState {
    /// The state after point `i`, at which the posture is `held` or not; with the span
    /// of points drawn with the pen down (inclusive) when the pen was lifted. The pen
    /// goes down at the first point of a run of `down` held points and is lifted after
    /// the last held point before a run of `up` points not held.
    pub fn step(
        self,
        i: usize,
        held: bool,
        (down, up): (u32, u32),
    ) -> (PenState, Option<(usize, usize)>) {
        match self {
            PenState::Up | PenState::Lowering { .. } => {
                if !held {
                    return (PenState::Up, None);
                }
                let from = match self {
                    PenState::Lowering { held_from } => held_from,
                    _ => i,
                };
                if i + 1 - from >= down.max(1) as usize {
                    (PenState::Down { from }, None)
                } else {
                    (PenState::Lowering { held_from: from }, None)
                }
            }
            PenState::Down { from } | PenState::Lifting { from, .. } => {
                if held {
                    return (PenState::Down { from }, None);
                }
                let released_at = match self {
                    PenState::Lifting { released_at, .. } => released_at,
                    _ => i,
                };
                if i + 1 - released_at >= up.max(1) as usize {
                    let last = released_at.saturating_sub(1).max(from);
                    (PenState::Up, Some((from, last)))
                } else {
                    (PenState::Lifting { from, released_at }, None)
                }
            }
        }
    }

    /// The span drawn so far with the pen down, when it is: for the end of a stream.
    pub fn open_span(self, last: usize) -> Option<(usize, usize)> {
        match self {
            PenState::Down { from } => Some((from, last)),
            PenState::Lifting { from, released_at } => {
                Some((from, released_at.saturating_sub(1).max(from)))
            }
            PenState::Up | PenState::Lowering { .. } => None,
        }
    }
}

/// The drawing hand's posture a point, kept as long as its points are: which posture a
/// gesture was drawn in.
#[derive(Debug, Clone, Default)]
pub struct PostureTrack {
    /// Point index of the first element of `labels`.
    base: usize,
    labels: Vec<Option<HandPosture>>,
}

impl PostureTrack {
    /// Adds point `i`'s posture; a gap since the last (points the spotter was not
    /// given a posture for) counts as unknown.
    pub fn push(&mut self, i: usize, label: Option<HandPosture>) {
        if self.labels.is_empty() {
            self.base = i;
        }
        while self.base + self.labels.len() < i {
            self.labels.push(None);
        }
        if self.base + self.labels.len() == i {
            self.labels.push(label);
        }
    }

    /// The posture held over most of points s..=e; None when no posture was known for
    /// more than half of them.
    pub fn most_of(&self, s: usize, e: usize) -> Option<PostureLabel> {
        let from = s.saturating_sub(self.base);
        let to = (e + 1).saturating_sub(self.base).min(self.labels.len());
        let span = e.checked_sub(s)? + 1;
        let mut counts: Vec<(PostureLabel, usize)> = Vec::new();
        for l in self.labels.get(from..to)?.iter().flatten() {
            match counts.iter_mut().find(|(k, _)| *k == l.label) {
                Some((_, n)) => *n += 1,
                None => counts.push((l.label, 1)),
            }
        }
        let (label, n) = counts.into_iter().max_by_key(|&(_, n)| n)?;
        (2 * n > span).then_some(label)
    }

    /// Whether the gated pen lets points s..=e through: the pen's posture held over at
    /// least its share of the points with a posture read (true when none was read).
    pub fn lets_through(&self, s: usize, e: usize, pen: &GatedPen) -> bool {
        let from = s.saturating_sub(self.base).min(self.labels.len());
        let to = (e + 1)
            .saturating_sub(self.base)
            .min(self.labels.len())
            .max(from);
        let read: Vec<&HandPosture> = self.labels[from..to].iter().flatten().collect();
        let held = read.iter().filter(|p| pen.holds(p)).count();
        read.is_empty() || held as f32 >= pen.min_share * read.len() as f32
    }

    /// Forgets the points before `keep_from`.
    pub fn forget_before(&mut self, keep_from: usize) {
        let cut = keep_from.saturating_sub(self.base).min(self.labels.len());
        self.labels.drain(..cut);
        self.base += cut;
    }

    /// Forgets every point.
    pub fn clear(&mut self) {
        self.labels.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(held: &[bool], debounce: (u32, u32)) -> (Vec<(usize, usize)>, PenState) {
        let mut s = PenState::Up;
        let mut spans = Vec::new();
        for (i, &h) in held.iter().enumerate() {
            let (next, span) = s.step(i, h, debounce);
            s = next;
            spans.extend(span);
        }
        (spans, s)
    }

    fn bits(s: &str) -> Vec<bool> {
        s.chars().map(|c| c == '1').collect()
    }

    #[test]
    fn the_pen_spans_the_held_run_and_ignores_flicker_shorter_than_the_debounce() {
        // Held over points 3..=10, one misread point (6) inside, one stray point (14).
        let held = bits("000111011110000100000");
        let (spans, end) = run(&held, (3, 3));
        assert_eq!(spans, vec![(3, 10)]);
        assert_eq!(end, PenState::Up);
        // Without debounce the misread point splits the span and the stray one is a
        // span of its own.
        let (spans, _) = run(&held, (1, 1));
        assert_eq!(spans, vec![(3, 5), (7, 10), (15, 15)]);
        // Two held points in a row do not put the pen down at a debounce of 3.
        let (spans, end) = run(&bits("0110110000"), (3, 3));
        assert!(spans.is_empty() && end == PenState::Up, "{spans:?} {end:?}");
        // Lifting slower than lowering: a misread run of 3 inside is bridged, a gap of
        // 5 between two spans is not.
        let held = bits("0011100011100000111000000");
        assert_eq!(run(&held, (2, 4)).0, vec![(2, 10), (16, 18)]);
        // A stream that ends with the pen down still has its span.
        let (spans, end) = run(&bits("0011111"), (3, 3));
        assert!(spans.is_empty());
        assert_eq!(end.open_span(6), Some((2, 6)));
        let (_, end) = run(&bits("00111110"), (3, 3));
        assert_eq!(end.open_span(7), Some((2, 6)));
    }

    #[test]
    fn labels_are_short_names_and_pens_parse_from_the_command_line() {
        assert_eq!(PostureLabel::new("point").unwrap().as_str(), "point");
        assert_eq!(PostureLabel::new(""), Err(PostureLabelError::Empty));
        assert!(matches!(
            PostureLabel::new("a-very-long-posture-name"),
            Err(PostureLabelError::TooLong(_))
        ));
        assert_eq!(Pen::parse("motion"), Ok(Pen::Motion));
        let Ok(Pen::Posture(p)) = Pen::parse("posture") else {
            panic!("posture")
        };
        assert_eq!(p.label.as_str(), "point");
        let Ok(Pen::Posture(p)) = Pen::parse("posture:v") else {
            panic!("posture:v")
        };
        assert_eq!(p.label.as_str(), "v");
        assert!(Pen::parse("pencil")
            .unwrap_err()
            .to_string()
            .contains("pencil"));
        assert_eq!(
            Pen::parse("posture:"),
            Err(PenParseError::Label(PostureLabelError::Empty))
        );
        // As JSON settings, with the label checked.
        let pen: Pen =
            serde_json::from_str(r#"{"posture":{"label":"fist","up_frames":2}}"#).unwrap();
        let Pen::Posture(p) = pen else {
            panic!("{pen:?}")
        };
        assert_eq!((p.label.as_str(), p.up_frames), ("fist", 2));
        assert!(serde_json::from_str::<Pen>(r#"{"posture":{"label":""}}"#).is_err());
    }

    #[test]
    fn a_gesture_takes_the_posture_held_over_most_of_it() {
        let (point, open) = (
            PostureLabel::new("point").ok(),
            PostureLabel::new("open").ok(),
        );
        let sure = |l: Option<PostureLabel>| {
            l.map(|label| HandPosture {
                label,
                confidence: 1.0,
            })
        };
        let mut t = PostureTrack::default();
        for i in 10..20 {
            t.push(i, sure(if i < 17 { point } else { open }));
        }
        assert_eq!(t.most_of(10, 19), point);
        // Unknown for most of it: none.
        t.push(25, sure(point));
        assert_eq!(t.most_of(15, 25), None);
        t.forget_before(18);
        assert_eq!(t.most_of(18, 19), open);
    }
}
