//! The limbs' tips (their geodesic maxima) against the tracked body: which are
//! borrowed from another limb, and whether one strayed so far that the geodesic
//! estimate must race the tracked body.

use super::capsules::{place, surface_distance};
use crate::body::{BodyPose, BodyTemplate, Posed};
use nalgebra::Point3;

/// When the seed's estimate races the tracked body, and which tips it keeps (part of
/// [`super::RegisterConfig`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RaceConfig {
    /// Every this many frames the seed's torso registration runs and the geodesic
    /// estimate races the tracked body; in between it races only when a limb tip lies
    /// farther than `gap` from the tracked body's (and off its surface, `off_body`).
    pub redetect_every: usize,
    /// See `redetect_every`.
    pub gap: f32,
    /// A strayed tip races only when it also lies this far off the tracked body's
    /// surface; 0 = wherever it lies.
    pub off_body: f32,
    /// Also race the tracked body with its strayed limbs taken from the geodesic
    /// estimate.
    pub hybrid: bool,
    /// A limb's tip that lies on another limb of the tracked body and at least this much
    /// (metres) farther from its own is dropped. 0 = off.
    pub borrowed_tip_gap: f32,
    /// A person found afresh is also looked for at rest on the torso step's own torso
    /// turned upright (`register::starts`): close up, the arms merged into the torso's
    /// silhouette tilt the torso the other starts are built on.
    pub upright_rest: bool,
}

impl Default for RaceConfig {
    fn default() -> Self {
        Self {
            redetect_every: 10,
            gap: 0.25,
            off_body: 0.05,
            hybrid: false,
            borrowed_tip_gap: 0.1,
            upright_rest: true,
        }
    }
}

/// Whether a limb's tip (its geodesic maximum, as [`drop_borrowed_tips`] left them)
/// strayed from `tracked`, the last frame's body, so that the geodesic estimate must
/// race it: it lies farther than [`RaceConfig::gap`] from its own limb's tip
/// and more than [`RaceConfig::off_body`] off the body's surface. A maximum
/// on the body's surface is one the body explains where it is, whichever limb it was
/// assigned to; sensor noise makes such maxima on a knee or a hip in most frames of a
/// noisy 320×240 image, and racing on them cost every such frame the seed's chains and
/// a second start without finding a better body.
pub fn tips_strayed(
    t: &BodyTemplate,
    tracked: &BodyPose,
    tips: &[Option<Point3<f32>>; 5],
    cfg: &RaceConfig,
) -> bool {
    let posed = Posed::new(t, tracked);
    let mut placed = None;
    tips.iter().zip(&t.tips).any(|(m, (seg, local))| {
        let Some(m) = m else { return false };
        if (posed.point(*seg, local) - m).norm() <= cfg.gap {
            return false;
        }
        cfg.off_body <= 0.0 || {
            let placed = placed.get_or_insert_with(|| place(t, &posed));
            surface_distance(placed.iter(), m) > cfg.off_body
        }
    })
}

/// How near (metres) a tip must lie to another limb's surface to be taken for its point.
const ON_SURFACE: f32 = 0.03;

/// Drops each limb's tip (its geodesic maximum) that lies on another limb of `tracked`,
/// the last frame's body, and well away from its own. The geodesic assignment can give
/// an arm hidden behind the body a maximum of the other arm (a bent elbow before the
/// chest); its tip term then pulled the hidden arm out to that point, and the race kept
/// the arm there for frames.
pub fn drop_borrowed_tips(
    t: &BodyTemplate,
    tracked: &BodyPose,
    tips: &mut [Option<Point3<f32>>; 5],
    cfg: &RaceConfig,
) {
    if cfg.borrowed_tip_gap <= 0.0 || tips.iter().all(Option::is_none) {
        return;
    }
    let placed = place(t, &Posed::new(t, tracked));
    let distance = |limb: crate::Limb, p: &Point3<f32>| {
        let segments = crate::body::limb_segments(limb);
        surface_distance(placed.iter().filter(|c| segments.contains(&c.segment)), p)
    };
    for l in crate::Limb::ALL {
        let Some(m) = tips[l.index()] else { continue };
        let own = distance(l, &m);
        let borrowed = crate::Limb::ALL.iter().any(|&o| {
            o != l && {
                let d = distance(o, &m);
                d < ON_SURFACE && own > d + cfg.borrowed_tip_gap
            }
        });
        if borrowed {
            tips[l.index()] = None;
        }
    }
}
