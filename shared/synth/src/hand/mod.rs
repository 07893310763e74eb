//! Hands in static postures: a procedural hand (a palm and five fingers of three
//! phalanges, tapered capsules as triangles) that replaces the body's own hand when a
//! scene asks for a posture, and the hand's ground truth in every frame.
//!
//! The hand is sized from the body's forearm, so it scales with the body, and hangs
//! from the body's hand bone: it follows the forearm and the hand's rotation in the
//! pose, turned further by the scene's roll and pitch about the wrist ([`HandSpec`]).
//! Without a posture the body keeps its own hand, and the frame renders exactly as
//! before hands had postures.
//!
//! Pieces: [`HandPosture`] (the postures and their finger angles), `shape` (the
//! capsules of a posture), `mesh` (their triangles), `attach` (where a hand is in a
//! frame: its frame, the wrist's turn, the truth), `render` (drawing the hands of a
//! scene in place of the body's), `record` (`hands.csv` beside a recording).

mod attach;
mod mesh;
mod posture;
mod record;
mod render;
mod shape;

pub(crate) use attach::turn_wrists;
pub use posture::{Finger, HandPosture};
pub(crate) use record::HandsCsv;
pub use record::HEADER as CSV_HEADER;
pub(crate) use render::HandRenderer;

use crate::poses::Side;
use nalgebra::{Point3, Vector3};

/// One value per hand.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hands<T> {
    /// The person's left hand.
    pub left: T,
    /// The person's right hand.
    pub right: T,
}

impl<T> Hands<T> {
    /// Both hands the same.
    pub fn both(v: T) -> Self
    where
        T: Clone,
    {
        Self {
            left: v.clone(),
            right: v,
        }
    }

    /// The value of one hand.
    pub fn get(&self, side: Side) -> &T {
        match side {
            Side::Left => &self.left,
            Side::Right => &self.right,
        }
    }

    /// The value of one hand, to change.
    pub fn get_mut(&mut self, side: Side) -> &mut T {
        match side {
            Side::Left => &mut self.left,
            Side::Right => &mut self.right,
        }
    }
}

/// Both sides, left first.
pub const SIDES: [Side; 2] = [Side::Left, Side::Right];

/// How a scene shows one hand.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HandSpec {
    /// The posture of the procedural hand; `None` keeps the body's own hand. With
    /// `drawing`, the posture between symbols.
    pub posture: Option<HandPosture>,
    /// The posture while the hand draws a symbol (air-drawing, the right hand), so that
    /// the hand's shape lifts and lowers the pen: e.g. pointing while drawing and
    /// `posture` open between symbols. Needs `posture`; `None` holds `posture` all along.
    pub drawing: Option<HandPosture>,
    /// The hand's turn about the axis along its fingers, degrees, on top of the pose's:
    /// positive turns the palm towards the thumb's side (the same for either hand).
    pub roll_deg: f32,
    /// The hand's bend at the wrist, degrees, on top of the pose's: positive bends the
    /// fingers towards the palm (flexion), negative towards the back of the hand.
    pub pitch_deg: f32,
}

impl HandSpec {
    /// Whether the wrist is turned at all.
    pub fn turns_wrist(&self) -> bool {
        self.roll_deg != 0.0 || self.pitch_deg != 0.0
    }
}

/// The ground truth of one hand in one frame, in the camera frame (metres). For the
/// body's own hand (no posture) the palm centre and length are where and what the
/// procedural hand's would be, on the same bone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandTruth {
    /// The posture rendered; `None` when the body's own hand is drawn.
    pub posture: Option<HandPosture>,
    /// The wrist joint (the head of the body's hand bone).
    pub wrist: Point3<f32>,
    /// The palm's centre: halfway from the wrist to the middle finger's knuckle, on
    /// the hand's mid-plane.
    pub palm_centre: Point3<f32>,
    /// Out of the palm (unit): the way the palm faces.
    pub palm_normal: Vector3<f32>,
    /// From the wrist along the fingers of the flat hand (unit).
    pub finger_dir: Vector3<f32>,
    /// Across the palm towards the thumb's side (unit).
    pub thumb_side: Vector3<f32>,
    /// The hand's length, wrist to the straight middle finger's tip.
    pub length_m: f32,
    /// The outermost point of each finger, thumb first (see [`Finger`]), for a
    /// posture; `None` for the body's own hand.
    pub fingertips: Option<[Point3<f32>; 5]>,
}

/// Reads per-hand values, `left=V`, `right=V` or `both=V`, comma-separated (each hand
/// at most once); a hand not named gets `T::default()`. `what` names the values in
/// messages.
fn parse_per_hand<T: Default + Clone>(
    text: &str,
    what: &str,
    value: impl Fn(&str) -> Result<T, String>,
) -> Result<Hands<T>, String> {
    let mut out = Hands::<T>::default();
    let mut named = Hands::both(false);
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (side, v) = item.split_once('=').ok_or_else(|| {
            format!("{item:?}: expected HAND={what}, HAND one of left, right, both")
        })?;
        let sides: &[Side] = match side.trim() {
            "left" => &[Side::Left],
            "right" => &[Side::Right],
            "both" => &SIDES,
            other => {
                return Err(format!(
                    "{other:?} is not a hand: expected left, right or both"
                ))
            }
        };
        let v = value(v.trim())?;
        for s in sides {
            if std::mem::replace(named.get_mut(*s), true) {
                return Err(format!("{item:?}: that hand was already given"));
            }
            *out.get_mut(*s) = v.clone();
        }
    }
    Ok(out)
}

/// Reads the postures of the hands, e.g. `right=point,left=open` or `both=fist`; a
/// hand not named keeps the body's own hand. A bad value is named in the error with
/// the valid ones.
pub fn parse_postures(text: &str) -> Result<Hands<Option<HandPosture>>, String> {
    parse_per_hand(text, "POSTURE", |v| {
        HandPosture::from_name(v).map(Some).ok_or_else(|| {
            let names: Vec<_> = HandPosture::ALL.iter().map(|p| p.name()).collect();
            format!(
                "{v:?} is not a hand posture: expected one of {}",
                names.join(", ")
            )
        })
    })
}

/// Reads the pen's two postures of the drawing hand, `DRAWING,BETWEEN` (e.g.
/// `point,open`): the posture while a symbol is drawn, then the one between symbols.
pub fn parse_pen_postures(text: &str) -> Result<(HandPosture, HandPosture), String> {
    let one = |v: &str| {
        HandPosture::from_name(v.trim()).ok_or_else(|| {
            let names: Vec<_> = HandPosture::ALL.iter().map(|p| p.name()).collect();
            format!(
                "{v:?} is not a hand posture: expected one of {}",
                names.join(", ")
            )
        })
    };
    match text.split(',').collect::<Vec<_>>()[..] {
        [drawing, between] => Ok((one(drawing)?, one(between)?)),
        _ => Err(format!(
            "{text:?}: expected DRAWING,BETWEEN, two postures, e.g. point,open"
        )),
    }
}

/// Reads angles of the hands in degrees, e.g. `right=30,left=-15` or `both=45`; a hand
/// not named gets 0. Angles must be finite, within ±360.
pub fn parse_angles(text: &str) -> Result<Hands<f32>, String> {
    parse_per_hand(text, "DEGREES", |v| {
        v.parse::<f32>()
            .ok()
            .filter(|a| a.is_finite() && a.abs() <= 360.0)
            .ok_or_else(|| format!("{v:?} is not an angle: expected degrees within ±360"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn postures_are_read_per_hand() {
        let h = parse_postures("right=point, left=open").unwrap();
        assert_eq!(h.right, Some(HandPosture::Point));
        assert_eq!(h.left, Some(HandPosture::Open));
        let h = parse_postures("both=thumb-up").unwrap();
        assert_eq!(h, Hands::both(Some(HandPosture::ThumbUp)));
        let h = parse_postures("left=v").unwrap();
        assert_eq!(h.right, None);
        for p in HandPosture::ALL {
            assert_eq!(HandPosture::from_name(p.name()), Some(p));
        }
    }

    #[test]
    fn a_bad_posture_is_named_with_the_valid_ones() {
        let e = parse_postures("right=peace").unwrap_err();
        assert!(
            e.contains("\"peace\"") && e.contains("open, fist, point, thumb-up, v, pinch"),
            "{e}"
        );
        let e = parse_postures("middle=open").unwrap_err();
        assert!(
            e.contains("\"middle\"") && e.contains("left, right or both"),
            "{e}"
        );
        let e = parse_postures("open").unwrap_err();
        assert!(e.contains("HAND=POSTURE"), "{e}");
        let e = parse_postures("right=open,both=fist").unwrap_err();
        assert!(e.contains("already"), "{e}");
    }

    #[test]
    fn the_pens_postures_are_read_drawing_first() {
        assert_eq!(
            parse_pen_postures("point, open"),
            Ok((HandPosture::Point, HandPosture::Open))
        );
        for (bad, says) in [
            ("point", "DRAWING,BETWEEN"),
            ("point,open,fist", "DRAWING,BETWEEN"),
            ("point,flat", "\"flat\" is not a hand posture"),
        ] {
            let e = parse_pen_postures(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn angles_are_read_per_hand() {
        let h = parse_angles("right=30,left=-15.5").unwrap();
        assert_eq!((h.left, h.right), (-15.5, 30.0));
        assert!(parse_angles("right=inf").unwrap_err().contains("\"inf\""));
        assert!(parse_angles("right=400").is_err());
    }
}
