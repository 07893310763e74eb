//! Drawing a scene's hands: the body's own hand triangles left out where a posture is
//! asked for, and the procedural hand drawn there instead, every frame.

use super::attach::Placed;
use super::mesh::HandMesh;
use super::shape;
use super::{HandPosture, HandSpec, HandTruth, Hands, SIDES};
use crate::body::{Affine, Body};
use crate::canon::Pose;
use crate::poses::Side;
use crate::raster::Raster;
use airglyph_core::Intrinsics;
use nalgebra::{Point3, Vector3};

/// The hand's length (wrist to middle fingertip) per length of the forearm (elbow to
/// wrist), after anthropometric tables (0.108 and 0.150 of the standing height): the
/// forearm, unlike a rig's hand bone, runs joint to joint on every body.
const HAND_PER_FOREARM: f32 = 0.72;

/// A procedural hand built for a scene, in the hand's frame.
#[derive(Debug, Clone)]
struct Model {
    posture: HandPosture,
    verts: Vec<Vector3<f32>>,
    /// Over `verts`, wound for this side.
    tris: Vec<[u32; 3]>,
    fingertips: [Vector3<f32>; 5],
}

impl Model {
    fn new(side: Side, posture: HandPosture, length_m: f32) -> Self {
        let shape = shape::build(posture, length_m);
        let mesh = HandMesh::of(&shape);
        // The right hand is the left's mirror image: mirroring turns the winding over,
        // and the front of a triangle must stay outside.
        let mirrored = super::attach::tpose_axes(side).determinant() < 0.0;
        let tris = mesh
            .tris
            .iter()
            .map(|t| if mirrored { [t[0], t[2], t[1]] } else { *t })
            .collect();
        Self {
            posture,
            verts: mesh.verts,
            tris,
            fingertips: shape.fingertips,
        }
    }
}

/// One side of the person: its hand bone in the rig, its size, its procedural hands
/// (the one held, and the one taken while drawing, if the pen changes it).
#[derive(Debug, Clone)]
struct SideHand {
    side: Side,
    rig_bone: usize,
    length_m: f32,
    held: Option<Model>,
    drawing: Option<Model>,
}

impl SideHand {
    /// The procedural hand drawn in a frame, if any.
    fn model(&self, drawing: bool) -> Option<&Model> {
        match (drawing, &self.drawing) {
            (true, Some(m)) => Some(m),
            _ => self.held.as_ref(),
        }
    }
}

/// The hands of a scene, ready to draw frame after frame.
#[derive(Debug, Clone)]
pub(crate) struct HandRenderer {
    sides: [SideHand; 2],
    /// The body's triangles and labels without the hands that are replaced; `None`
    /// when no hand is, so that the body draws from its own arrays, untouched.
    body: Option<(Vec<[u32; 3]>, Vec<u8>)>,
    /// Per frame: the procedural hands' vertices in the camera frame, their triangles
    /// and labels.
    verts: Vec<Point3<f32>>,
    tris: Vec<[u32; 3]>,
    labels: Vec<u8>,
}

impl HandRenderer {
    pub fn new(body: &Body, hands: &Hands<HandSpec>) -> Self {
        let sk = body.tpose();
        let sides = SIDES.map(|side| {
            let (_, forearm, hand) = side.bones();
            let length_m = HAND_PER_FOREARM * (sk.tail(forearm) - sk.head(forearm)).norm();
            let rig_bone = body
                .bones
                .iter()
                .position(|b| b.canon == Some(hand))
                .expect("a body's rig drives every canonical bone");
            let spec = hands.get(side);
            let model = |p: Option<HandPosture>| p.map(|p| Model::new(side, p, length_m));
            SideHand {
                side,
                rig_bone,
                length_m,
                held: model(spec.posture),
                drawing: model(spec.drawing.filter(|d| Some(*d) != spec.posture)),
            }
        });
        let replaced: Vec<u8> = sides
            .iter()
            .filter(|s| s.held.is_some() || s.drawing.is_some())
            .map(|s| s.side.bones().2 as u8)
            .collect();
        let body = (!replaced.is_empty()).then(|| {
            body.tris
                .iter()
                .zip(&body.tri_label)
                .filter(|(_, l)| !replaced.contains(l))
                .map(|(t, l)| (*t, *l))
                .unzip()
        });
        Self {
            sides,
            body,
            verts: Vec::new(),
            tris: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// The body's triangles and their labels to draw: all of them unless a hand is
    /// replaced.
    pub fn body_triangles<'a>(&'a self, body: &'a Body) -> (&'a [[u32; 3]], &'a [u8]) {
        match &self.body {
            Some((t, l)) => (t, l),
            None => (&body.tris, &body.tri_label),
        }
    }

    /// Draws the procedural hands of frame `pose` into `depth` and `labels` (nearest
    /// surface wins, as for the body) and returns both hands' truth. `xf` are the
    /// body's bone transforms from rest to the camera frame; `drawing`, whether a
    /// symbol is being drawn in the frame.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        k: &Intrinsics,
        raster: &mut Raster,
        body: &Body,
        pose: &Pose,
        xf: &[Affine],
        camera: &Affine,
        depth: &mut [u16],
        labels: &mut [u8],
        drawing: bool,
    ) -> Hands<HandTruth> {
        self.verts.clear();
        self.tris.clear();
        self.labels.clear();
        let mut truth = [None, None];
        for (t, s) in truth.iter_mut().zip(&self.sides) {
            let wrist = xf[s.rig_bone].apply(&body.bones[s.rig_bone].head);
            let placed = Placed::new(s.side, pose, camera, wrist);
            let model = s.model(drawing);
            if let Some(m) = model {
                let first = self.verts.len() as u32;
                self.verts.extend(m.verts.iter().map(|v| placed.point(v)));
                self.tris
                    .extend(m.tris.iter().map(|t| t.map(|i| i + first)));
                self.labels
                    .extend(std::iter::repeat_n(s.side.bones().2 as u8, m.tris.len()));
            }
            *t = Some(placed.truth(
                model.map(|m| m.posture),
                s.length_m,
                model.map(|m| &m.fingertips),
            ));
        }
        if !self.tris.is_empty() {
            raster.rasterize(
                k,
                &self.verts,
                &self.tris,
                &self.labels,
                true,
                depth,
                Some(labels),
            );
        }
        let [left, right] = truth.map(|t| t.expect("both sides placed"));
        Hands { left, right }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canon::Bone;

    #[test]
    fn only_the_replaced_hand_leaves_the_body() {
        let body = Body::procedural(&Default::default()).unwrap();
        let count = |l: Bone| body.tri_label.iter().filter(|x| **x == l as u8).count();
        let hands = Hands {
            left: HandSpec::default(),
            right: HandSpec {
                posture: Some(HandPosture::Fist),
                ..HandSpec::default()
            },
        };
        let r = HandRenderer::new(&body, &hands);
        let (tris, labels) = r.body_triangles(&body);
        assert_eq!(tris.len(), body.tris.len() - count(Bone::RightHand));
        assert!(!labels.contains(&(Bone::RightHand as u8)));
        assert!(labels.contains(&(Bone::LeftHand as u8)));
        let r = HandRenderer::new(&body, &Hands::default());
        assert_eq!(r.body_triangles(&body).0.as_ptr(), body.tris.as_ptr());
    }
}
