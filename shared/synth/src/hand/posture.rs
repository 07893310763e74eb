//! The static hand postures and the finger joint angles that make each one.

use std::fmt;

/// A static posture of the hand, as the procedural hand ([`super`]) renders it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum HandPosture {
    /// Fingers straight and spread, the thumb out to the side.
    Open,
    /// Every finger curled into the palm, the thumb across them.
    Fist,
    /// The index finger straight, the others curled, the thumb across them.
    Point,
    /// A fist with the thumb straight out along the hand's side.
    ThumbUp,
    /// Index and middle finger straight and apart, the others curled.
    V,
    /// The tips of thumb and index finger together, the other fingers loosely bent.
    Pinch,
}

/// The fingers, thumb first; the index of each in per-finger arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Finger {
    /// The thumb.
    Thumb,
    /// The index finger.
    Index,
    /// The middle finger.
    Middle,
    /// The ring finger.
    Ring,
    /// The little finger.
    Little,
}

impl Finger {
    /// Every finger, thumb first.
    pub const ALL: [Finger; 5] = [
        Finger::Thumb,
        Finger::Index,
        Finger::Middle,
        Finger::Ring,
        Finger::Little,
    ];
}

/// The angles of one long finger, degrees: `spread` turns it in the palm's plane
/// towards the thumb; `mcp`, `pip` and `dip` bend its three joints (knuckle to tip)
/// towards the palm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FingerAngles {
    pub spread: f32,
    pub mcp: f32,
    pub pip: f32,
    pub dip: f32,
}

/// The thumb's angles, degrees: at its base, `spread` turns it away from the index
/// finger in the palm's plane and `lift` raises it out of that plane towards the palm
/// side (opposition); `mcp` and `ip` bend its two outer joints towards its pad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ThumbAngles {
    pub spread: f32,
    pub lift: f32,
    pub mcp: f32,
    pub ip: f32,
}

/// How the thumb of a posture is placed: by its angles, or touching a place on the
/// other fingers (solved when the hand is built, since where that place is depends on
/// their angles and the hand's proportions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ThumbPlacement {
    Angles(ThumbAngles),
    OnIndexTip {
        mcp: f32,
        ip: f32,
    },
    /// Folded over the curled index and middle fingers, as in a fist.
    OverFingers {
        mcp: f32,
        ip: f32,
    },
}

/// The joint angles of a posture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PostureAngles {
    pub thumb: ThumbPlacement,
    /// Index, middle, ring, little.
    pub fingers: [FingerAngles; 4],
}

const fn f(spread: f32, mcp: f32, pip: f32, dip: f32) -> FingerAngles {
    FingerAngles {
        spread,
        mcp,
        pip,
        dip,
    }
}

const fn thumb(spread: f32, lift: f32, mcp: f32, ip: f32) -> ThumbPlacement {
    ThumbPlacement::Angles(ThumbAngles {
        spread,
        lift,
        mcp,
        ip,
    })
}

/// A finger curled into the palm, as in a fist.
const CURLED: FingerAngles = f(0.0, 88.0, 100.0, 60.0);
/// The thumb folded over the curled fingers' middle phalanges.
const THUMB_ACROSS: ThumbPlacement = ThumbPlacement::OverFingers {
    mcp: 30.0,
    ip: 30.0,
};

impl HandPosture {
    /// Every posture, in the order `--help` lists them.
    pub const ALL: [HandPosture; 6] = [
        HandPosture::Open,
        HandPosture::Fist,
        HandPosture::Point,
        HandPosture::ThumbUp,
        HandPosture::V,
        HandPosture::Pinch,
    ];

    /// The posture's name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            HandPosture::Open => "open",
            HandPosture::Fist => "fist",
            HandPosture::Point => "point",
            HandPosture::ThumbUp => "thumb-up",
            HandPosture::V => "v",
            HandPosture::Pinch => "pinch",
        }
    }

    /// The posture named `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Which fingers are straight (thumb first), as a fingertip count would see them.
    pub fn extended(self) -> [bool; 5] {
        match self {
            HandPosture::Open => [true; 5],
            HandPosture::Fist | HandPosture::Pinch => [false; 5],
            HandPosture::Point => [false, true, false, false, false],
            HandPosture::ThumbUp => [true, false, false, false, false],
            HandPosture::V => [false, true, true, false, false],
        }
    }

    pub(crate) fn angles(self) -> PostureAngles {
        match self {
            HandPosture::Open => PostureAngles {
                thumb: thumb(38.0, 12.0, -12.0, -8.0),
                fingers: [
                    f(9.0, 0.0, 0.0, 0.0),
                    f(0.0, 0.0, 0.0, 0.0),
                    f(-8.0, 0.0, 0.0, 0.0),
                    f(-17.0, 0.0, 0.0, 0.0),
                ],
            },
            HandPosture::Fist => PostureAngles {
                thumb: THUMB_ACROSS,
                fingers: [CURLED; 4],
            },
            HandPosture::Point => PostureAngles {
                thumb: THUMB_ACROSS,
                fingers: [f(2.0, 0.0, 0.0, 0.0), CURLED, CURLED, CURLED],
            },
            HandPosture::ThumbUp => PostureAngles {
                thumb: thumb(70.0, 5.0, 0.0, 0.0),
                fingers: [CURLED; 4],
            },
            HandPosture::V => PostureAngles {
                thumb: THUMB_ACROSS,
                fingers: [
                    f(12.0, 0.0, 0.0, 0.0),
                    f(-10.0, 0.0, 0.0, 0.0),
                    CURLED,
                    CURLED,
                ],
            },
            HandPosture::Pinch => PostureAngles {
                thumb: ThumbPlacement::OnIndexTip {
                    mcp: 15.0,
                    ip: 15.0,
                },
                fingers: [
                    f(4.0, 38.0, 48.0, 22.0),
                    f(0.0, 25.0, 35.0, 15.0),
                    f(-6.0, 30.0, 40.0, 15.0),
                    f(-12.0, 35.0, 45.0, 15.0),
                ],
            },
        }
    }
}

impl fmt::Display for HandPosture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
