//! `airglyph pose DIR [--json]`: the pose estimator over a recording, one line a frame,
//! with each visible hand's posture as the pose stage classifies it.

use crate::interrupt::Interrupted;
use crate::stage::postures::{self, Postures};
use airglyph_core::recording::Recording;
use airglyph_core::{Joint, Skeleton};
use airglyph_ipc::wire::Hand;
use airglyph_ipc::{shutdown, PostureMsg};
use airglyph_pose::{PoseConfig, PoseEstimator};
use anyhow::Context;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Recording directory (recording.toml, depth/*.png).
    pub dir: PathBuf,
    /// One JSON object a frame: {"frame":i,"person_found":…,"joints":{…},"confidence":{…},
    /// "visible":{…},"postures":{"left":{"label","confidence"} or null,"right":…}}
    /// (joints in metres, camera frame; a joint not visible is out of the camera's view,
    /// its confidence 0 and its place a guess; a posture null where the hand was not
    /// classified; no "postures" with --postures off).
    #[arg(long)]
    pub json: bool,
    #[arg(long, value_name = "builtin|off|FILE", default_value = "builtin", value_parser = Postures::parse, help = postures::HELP)]
    pub postures: Postures,
}

/// The JSON line of one frame (joints in metres, camera frame; keys in joint order),
/// with the hands' postures when they were classified (in `Hand` order).
pub fn frame_json(
    frame: usize,
    person_found: bool,
    s: &Skeleton,
    postures: Option<&[PostureMsg; 2]>,
) -> String {
    let num = |x: f32| {
        if x.is_finite() {
            format!("{}", (x as f64 * 1e5).round() / 1e5)
        } else {
            "0".into()
        }
    };
    let mut out = format!("{{\"frame\":{frame},\"person_found\":{person_found},\"joints\":{{");
    for (i, j) in Joint::ALL.iter().enumerate() {
        let p = s.get(*j);
        if i > 0 {
            out.push(',');
        }
        out += &format!("\"{}\":[{},{},{}]", j.name(), num(p.x), num(p.y), num(p.z));
    }
    out += "},\"confidence\":{";
    for (i, j) in Joint::ALL.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        out += &format!("\"{}\":{}", j.name(), num(s.confidence[j.index()]));
    }
    out += "},\"visible\":{";
    for (i, j) in Joint::ALL.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        out += &format!("\"{}\":{}", j.name(), s.visible[j.index()]);
    }
    out += "}";
    if let Some(p) = postures {
        out += &format!(",\"postures\":{}", airglyph_ipc::json::postures(p));
    }
    out += "}";
    out
}

/// " fist 0.93" when `hand` was classified, else "".
fn posture_text(classified: &Option<[PostureMsg; 2]>, hand: Hand) -> String {
    match classified
        .map(|c| c[hand as usize])
        .as_ref()
        .map(PostureMsg::get)
    {
        Some(Ok(Some(p))) => format!(" {} {:.2}", p.label, p.confidence),
        _ => String::new(),
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let rec = Recording::open(&args.dir)?;
    let k = rec.intrinsics();
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let model = args.postures.model();
    let mut px = vec![0u16; (k.width * k.height) as usize];
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for i in 0..rec.len() {
        if shutdown::requested() {
            out.flush().context("writing to stdout")?;
            return Err(Interrupted::new(format!(
                "the lines of the first {i} of {} frames are written, each whole",
                rec.len()
            ))
            .into());
        }
        rec.read_frame_into(i, &mut px)?;
        let view = airglyph_core::DepthView::new(k.width, k.height, &px)?;
        let r = est.estimate(view);
        let classified = model.filter(|_| r.person_found).map(|m| {
            postures::classify_hands(m, view, &k, &r.skeleton).map(Option::unwrap_or_default)
        });
        if args.json {
            let none = [PostureMsg::default(); 2];
            let p = model.map(|_| classified.as_ref().unwrap_or(&none));
            writeln!(out, "{}", frame_json(i, r.person_found, &r.skeleton, p))?;
        } else if r.person_found {
            let h = r.skeleton[Joint::Head];
            let rh = r.skeleton[Joint::RightHand];
            let lh = r.skeleton[Joint::LeftHand];
            writeln!(
                out,
                "frame {i}: head ({:.2}, {:.2}, {:.2})  right hand ({:.2}, {:.2}, {:.2}){}  left hand ({:.2}, {:.2}, {:.2}){}",
                h.x, h.y, h.z, rh.x, rh.y, rh.z, posture_text(&classified, Hand::Right),
                lh.x, lh.y, lh.z, posture_text(&classified, Hand::Left)
            )?;
        } else {
            writeln!(out, "frame {i}: no person")?;
        }
    }
    out.flush().context("writing to stdout")?;
    Ok(())
}
