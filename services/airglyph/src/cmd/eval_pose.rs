//! `airglyph eval-pose DIR [--json] [--plots OUTDIR]`: the pose estimator against a
//! recording's ground truth (joints.csv): e_m, e_h, e_j (seed Eq. 16.20–16.22), share
//! within 10 cm, mAP at 10 cm, frames/s; plots like the seed's Fig. 16.10 and 16.11.
//! Every frame is scored on the joints the truth has in view; the seed's figure, over
//! the frames that hold the whole body, is given beside it.

use crate::interrupt::Interrupted;
use airglyph_core::recording::Recording;
use airglyph_core::Joint;
use airglyph_ipc::shutdown;
use airglyph_plot::PlotError;
use airglyph_pose::metrics::{PoseEval, Summary};
use airglyph_pose::{overlay, PoseConfig, PoseEstimator};
use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Recording directory with ground truth (joints.csv).
    pub dir: PathBuf,
    /// Print one JSON object: {"frames":N,"mean_error_cm":…,"max_error_cm":…,
    /// "mean_error_whole_cm":…,"frames_whole":N,"per_joint_cm":{…},"within_10cm":…,
    /// "map_10cm":…,"out_of_view_reported":…,"lower_hidden_frames":…,"in_view_reported":…,
    /// "visible_outside_image":N,"fps":…} (errors over the joints the truth has in view;
    /// `mean_error_whole_cm` over the frames that hold all 16, the seed's setting).
    #[arg(long)]
    pub json: bool,
    /// Write per-frame error (Fig. 16.10) and per-joint error (Fig. 16.11) plots here.
    #[arg(long, value_name = "OUTDIR")]
    pub plots: Option<PathBuf>,
    /// Also write overlays (ground truth green, estimate red) of every Nth frame into
    /// the plots directory.
    #[arg(long, value_name = "N", value_parser = airglyph_ipc::options::within(1usize, 1_000_000), allow_negative_numbers = true)]
    pub overlay_every: Option<usize>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let rec = Recording::open(&args.dir)?;
    if !rec.has_joints() {
        bail!(
            "{}: has no joints.csv, so there is no ground truth to evaluate against",
            args.dir.display()
        );
    }
    let k = rec.intrinsics();
    let mut est = PoseEstimator::new(k, PoseConfig::default());
    let mut ev = PoseEval::default();
    let mut px = vec![0u16; (k.width * k.height) as usize];
    if let Some(d) = &args.plots {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    let bar = ProgressBar::new(rec.len() as u64).with_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} frames {per_sec} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    // An overlay that cannot be written stops the overlays, not the measurement.
    let mut overlay_failed: Option<anyhow::Error> = None;
    for i in 0..rec.len() {
        if shutdown::requested() {
            bar.finish_and_clear();
            let overlays = match (&args.plots, args.overlay_every) {
                (Some(d), Some(n)) if n > 0 => {
                    format!("; the overlays in {} are whole", d.display())
                }
                _ => String::new(),
            };
            return Err(Interrupted::new(format!(
                "stopped after {i} of {} frames: no figures{overlays}",
                rec.len()
            ))
            .into());
        }
        rec.read_frame_into(i, &mut px)?;
        let view = airglyph_core::DepthView::new(k.width, k.height, &px)?;
        let t = Instant::now();
        let r = est.estimate(view);
        let dt = t.elapsed().as_secs_f64();
        let truth = rec.joints(i).expect("checked above");
        ev.seconds += dt;
        ev.add(&r, truth, &k);
        if let (Some(d), Some(n)) = (&args.plots, args.overlay_every) {
            if n > 0 && i % n == 0 && overlay_failed.is_none() {
                let mut im = overlay::depth_image(&view, Some(est.mask()));
                overlay::skeleton(&mut im, &k, truth, overlay::GREEN);
                if r.person_found {
                    overlay::skeleton(&mut im, &k, &r.skeleton, overlay::RED);
                }
                let p = d.join(format!("overlay_{i:06}.png"));
                if let Err(e) = im.save(&p) {
                    overlay_failed =
                        Some(anyhow::Error::new(e).context(format!("writing {}", p.display())));
                }
            }
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let s = ev.summary();
    // The figures first: a picture that fails below loses none of them.
    if args.json {
        println!("{}", serde_json::to_string(&s)?);
    } else {
        print_human(&s);
    }
    if let Some(d) = &args.plots {
        plot_frames(&ev, &d.join("error_per_frame.png"))?;
        plot_joints(&s, &d.join("error_per_joint.png"))?;
    }
    match overlay_failed {
        Some(e) => Err(e.context("no overlay was written after it; the figures are complete")),
        None => Ok(()),
    }
}

fn print_human(s: &Summary) {
    println!(
        "{} frames, joints in view: mean error e_m {:.2} cm, max error e_h {:.2} cm, {:.1} % within 10 cm, mAP@10cm {:.3}, {:.0} frames/s",
        s.frames,
        s.mean_error_cm,
        s.max_error_cm,
        s.within_10cm * 100.0,
        s.map_10cm,
        s.fps
    );
    if let Some(e) = s.mean_error_whole_cm {
        println!(
            "  the {} frames with the whole body in view (the seed's setting): e_m {e:.2} cm",
            s.frames_whole
        );
    }
    println!(
        "  visibility: {:.1} % of the joints in view reported visible{}; {} reported visible outside the image",
        s.in_view_reported * 100.0,
        s.out_of_view_reported
            .map(|r| format!(", {:.1} % of those out of view reported not visible", r * 100.0))
            .unwrap_or_default(),
        s.visible_outside_image
    );
    if let Some(r) = s.lower_hidden_frames {
        println!(
            "  {:.1} % of the frames with lower joints out of view report all of those not visible",
            r * 100.0
        );
    }
    for j in Joint::ALL {
        match s.per_joint_cm[j.name()] {
            Some(e) => println!("  {:15} {e:6.2} cm", j.name()),
            None => println!("  {:15}  never in view", j.name()),
        }
    }
}

/// Fig. 16.10: mean and largest joint error of each frame.
fn plot_frames(ev: &PoseEval, path: &Path) -> Result<(), PlotError> {
    let mean: Vec<(f64, f64)> = ev
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.person_found)
        .map(|(i, f)| (i as f64, f.mean() as f64 * 100.0))
        .collect();
    let max: Vec<(f64, f64)> = ev
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.person_found)
        .map(|(i, f)| (i as f64, f.max() as f64 * 100.0))
        .collect();
    let top = max.iter().map(|p| p.1).fold(10.0, f64::max).min(200.0) * 1.05;
    airglyph_plot::png(path, (1000, 500), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("Joint error per frame", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0f64..(ev.frames.len().max(1) as f64), 0f64..top)?;
        chart
            .configure_mesh()
            .x_desc("frame (of those in view)")
            .y_desc("error (cm)")
            .draw()?;
        chart
            .draw_series(LineSeries::new(mean, &BLUE))?
            .label("mean e_m")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
        chart
            .draw_series(LineSeries::new(max, &RED))?
            .label("max e_h")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    })
}

/// The seed's per-joint error on its own data (e_j ≤ 4.1 cm, §16.5).
const SEED_JOINT_CM: f64 = 4.1;

/// Fig. 16.11: mean error of each joint.
fn plot_joints(s: &Summary, path: &Path) -> Result<(), PlotError> {
    let vals: Vec<f64> = Joint::ALL
        .iter()
        .map(|j| s.per_joint_cm[j.name()].unwrap_or(0.0).max(0.0))
        .collect();
    let top = vals.iter().copied().fold(5.0, f64::max) * 1.1;
    // Bars across, one a row, the head at the top: the joints' names read level
    // beside them.
    let row = |i: usize| Joint::COUNT - 1 - i;
    airglyph_plot::png(path, (800, 560), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("Mean error per joint", ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(110)
            .build_cartesian_2d(0f64..top, (0..Joint::COUNT).into_segmented())?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .x_desc("error (cm)")
            .y_labels(Joint::COUNT)
            .y_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) if *i < Joint::COUNT => {
                    Joint::ALL[row(*i)].name().to_string()
                }
                _ => String::new(),
            })
            .y_label_style(("sans-serif", 13))
            .draw()?;
        chart.draw_series(
            Histogram::horizontal(&chart)
                .style(BLUE.mix(0.7).filled())
                .margin(4)
                .data(vals.iter().enumerate().map(|(i, v)| (row(i), *v))),
        )?;
        // The seed's own figure for every joint.
        chart
            .draw_series(LineSeries::new(
                [
                    (SEED_JOINT_CM, SegmentValue::Exact(0)),
                    (SEED_JOINT_CM, SegmentValue::Last),
                ],
                RED.stroke_width(2),
            ))?
            .label(format!("seed: every joint within {SEED_JOINT_CM} cm"))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()?;
        Ok(())
    })
}
