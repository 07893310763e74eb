//! What surrounds the person: floor, walls and furniture, rendered once per scene into
//! the background every frame starts from.
//!
//! Everything here lives in the room frame: the body frame of the person's start (metres,
//! y up, floor y = 0, the person's hips above the origin, facing +z, towards the camera)
//! without the person's turn, so a person who turns stays at the same desk.

use crate::{camera_from_body, Placement};
use airglyph_core::Intrinsics;
use nalgebra::{Point3, Vector3};

/// The room around the person.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Background {
    /// The person alone, as in the seed paper.
    #[default]
    None,
    /// A floor under the person and a wall [`Placement::wall_behind_m`] behind them.
    FloorAndWall,
    /// A corner of a furnished room: the floor, the wall behind, a wall 1.4 m to the
    /// person's right and a cabinet against the back wall to their left.
    Room,
}

/// A piece of furniture, placed where the person starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Prop {
    /// A table between the person and the camera.
    Table(Table),
    /// A chair under the person, its back behind them.
    Chair(Chair),
    /// A mug beside the right hand's place on the table: something the person touches
    /// that is not the person.
    Mug(Mug),
}

/// A four-legged table in front of the person.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table {
    /// Floor to the top of the table top, metres.
    pub height_m: f32,
    /// Side to side.
    pub width_m: f32,
    /// Front to back (towards the camera).
    pub depth_m: f32,
    /// From the person's hips to the table's near edge, along the floor.
    pub gap_m: f32,
}

impl Default for Table {
    fn default() -> Self {
        Self {
            height_m: TABLE_HEIGHT_M,
            width_m: 1.2,
            depth_m: 0.7,
            gap_m: 0.22,
        }
    }
}

/// The usual desk height, which the hands-on-table rest pose reaches for.
pub const TABLE_HEIGHT_M: f32 = 0.74;

/// A chair with a back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chair {
    /// Floor to the top of the seat, metres.
    pub seat_height_m: f32,
    /// Floor to the top of the back.
    pub back_height_m: f32,
}

impl Default for Chair {
    fn default() -> Self {
        Self {
            seat_height_m: SEAT_HEIGHT_M,
            back_height_m: 1.05,
        }
    }
}

/// The usual chair seat height, which a seated person sits at.
pub const SEAT_HEIGHT_M: f32 = 0.46;

/// A mug standing just outside the right hand as the hands-on-table pose rests it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mug {
    /// Floor to the mug's base: the top of the table it stands on.
    pub base_m: f32,
    /// Floor to its rim.
    pub height_m: f32,
}

impl Default for Mug {
    fn default() -> Self {
        Self {
            base_m: TABLE_HEIGHT_M,
            height_m: 0.1,
        }
    }
}

/// An axis-aligned box in the room frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Block {
    min: Point3<f32>,
    max: Point3<f32>,
}

impl Block {
    fn new(min: [f32; 3], max: [f32; 3]) -> Self {
        Self {
            min: Point3::from(min),
            max: Point3::from(max),
        }
    }
}

impl Prop {
    fn blocks(&self) -> Vec<Block> {
        match *self {
            Prop::Table(t) => {
                let (x, z0, z1) = (t.width_m / 2.0, t.gap_m, t.gap_m + t.depth_m);
                let top = t.height_m;
                let mut v = vec![Block::new([-x, top - 0.03, z0], [x, top, z1])];
                let leg = 0.05;
                for (lx, lz) in [(-x, z0), (x - leg, z0), (-x, z1 - leg), (x - leg, z1 - leg)] {
                    v.push(Block::new([lx, 0.0, lz], [lx + leg, top - 0.03, lz + leg]));
                }
                v
            }
            Prop::Chair(c) => {
                // The seat reaches from behind the hips to under the thighs; the back
                // stands behind the person.
                let (x, z0, z1) = (0.26, -0.25, 0.22);
                let s = c.seat_height_m;
                let mut v = vec![
                    Block::new([-x, s - 0.05, z0], [x, s, z1]),
                    Block::new([-x, s, z0 - 0.04], [x, c.back_height_m, z0]),
                ];
                let leg = 0.035;
                for (lx, lz) in [
                    (-x, z0 - 0.04),
                    (x - leg, z0 - 0.04),
                    (-x, z1 - leg),
                    (x - leg, z1 - leg),
                ] {
                    v.push(Block::new([lx, 0.0, lz], [lx + leg, s - 0.05, lz + leg]));
                }
                v
            }
            Prop::Mug(m) => {
                // The right hand rests at x = -0.17 m, 0.38 m ahead of the hips (a body
                // of 1.75 m): the mug's side 1-2 cm beyond the little finger.
                let (x0, x1, z0, z1) = (-0.31, -0.23, 0.33, 0.41);
                vec![Block::new(
                    [x0, m.base_m, z0],
                    [x1, m.base_m + m.height_m, z1],
                )]
            }
        }
    }

    /// Whether every size is finite, positive and under 5 m.
    pub(crate) fn is_sane(&self) -> bool {
        let sizes: &[f32] = match self {
            Prop::Table(t) => &[t.height_m, t.width_m, t.depth_m, t.gap_m],
            Prop::Chair(c) => &[c.seat_height_m, c.back_height_m],
            Prop::Mug(m) => &[m.base_m, m.height_m],
        };
        sizes.iter().all(|v| v.is_finite() && *v > 0.0 && *v < 5.0)
    }

    /// The farthest this prop reaches towards the camera from the person's hips.
    pub(crate) fn reach_m(&self) -> f32 {
        self.blocks().iter().map(|b| b.max.z).fold(0.0, f32::max)
    }
}

/// The cabinet of [`Background::Room`], against the back wall to the person's left.
fn cabinet(pl: &Placement) -> Block {
    let back = -pl.wall_behind_m;
    Block::new([0.9, 0.0, back], [1.7, 0.85, back + 0.45])
}

/// The static scene's depth (millimetres, 0 = nothing), or `None` when there is none.
pub(crate) fn render(
    k: &Intrinsics,
    pl: &Placement,
    background: Background,
    props: &[Prop],
) -> Option<Vec<u16>> {
    if background == Background::None && props.is_empty() {
        return None;
    }
    let room = Placement {
        yaw_deg: 0.0,
        ..*pl
    };
    let mut depth = match background {
        Background::None => vec![0u16; (k.width * k.height) as usize],
        Background::FloorAndWall => planes(k, &room, false),
        Background::Room => planes(k, &room, true),
    };
    let mut blocks: Vec<Block> = props.iter().flat_map(Prop::blocks).collect();
    if background == Background::Room {
        blocks.push(cabinet(pl));
    }
    let (verts, tris) = mesh(&blocks);
    let c = camera_from_body(&room);
    let verts: Vec<Point3<f32>> = verts.iter().map(|p| c.apply(p)).collect();
    let labels = vec![crate::raster::NO_LABEL; tris.len()];
    crate::raster::Raster::new().rasterize(k, &verts, &tris, &labels, false, &mut depth, None);
    Some(depth)
}

/// The floor (y = 0), the wall behind the person and, for a room, the wall to their
/// right, rendered analytically per pixel.
fn planes(k: &Intrinsics, room: &Placement, side_wall: bool) -> Vec<u16> {
    let c = camera_from_body(room);
    // Camera centre and ray directions in the room frame.
    let rt = c.m.transpose();
    let origin = -(rt * c.t);
    let wall_z = -room.wall_behind_m;
    let side_x = -1.4;
    let mut out = vec![0u16; (k.width * k.height) as usize];
    for v in 0..k.height {
        for u in 0..k.width {
            let ray_cam = Vector3::new((u as f32 - k.cx) / k.fx, (v as f32 - k.cy) / k.fy, 1.0);
            let d = rt * ray_cam;
            let mut best = f32::INFINITY;
            if d.y < -1e-6 {
                best = best.min(-origin.y / d.y);
            }
            if d.z < -1e-6 {
                best = best.min((wall_z - origin.z) / d.z);
            }
            if side_wall && d.x < -1e-6 {
                best = best.min((side_x - origin.x) / d.x);
            }
            if best.is_finite() && best > 0.0 && best < 8.0 {
                out[(v * k.width + u) as usize] = (best * 1000.0).round() as u16;
            }
        }
    }
    out
}

/// The twelve triangles of each box.
fn mesh(blocks: &[Block]) -> (Vec<Point3<f32>>, Vec<[u32; 3]>) {
    let mut verts = Vec::with_capacity(blocks.len() * 8);
    let mut tris = Vec::with_capacity(blocks.len() * 12);
    for b in blocks {
        let base = verts.len() as u32;
        for i in 0..8 {
            verts.push(Point3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            ));
        }
        // Faces by corner bits: x (1), y (2), z (4).
        for [a, b2, c, d] in [
            [0, 1, 3, 2],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 3, 7, 5],
        ] {
            tris.push([base + a, base + b2, base + c]);
            tris.push([base + a, base + c, base + d]);
        }
    }
    (verts, tris)
}
