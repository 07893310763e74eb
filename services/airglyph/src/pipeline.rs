//! The pipeline the commands start (`run`, `demo`, `collect`): which stages, each with
//! which arguments, checked by the stage's own parser before anything starts, and the
//! exporter of `--export`, as a [`Plan`] for the supervisor.

use crate::export::{ExportArgs, Lookup};
use crate::stage::{self, StageArgs};
use airglyph::supervisor::{CrashRule, Plan, StagePlan};
use airglyph_capture::SourceSpec;
use airglyph_ipc::Stage;
use anyhow::bail;
use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

/// The options of a supervised pipeline, as `airglyph run` takes them.
#[derive(clap::Args, Debug, Clone)]
pub struct PipelineArgs {
    /// Where frames come from: synthetic, recording:DIR, v4l2:/dev/videoN, openni2 (the first device) or openni2:URI.
    #[arg(long, default_value = "synthetic")]
    pub source: SourceSpec,
    /// The stages to start, comma-separated (e.g. `capture,pose` to profile pose alone).
    #[arg(long, value_delimiter = ',', default_value = "capture,pose,gesture")]
    pub stages: Vec<String>,
    /// Replay a recording as fast as possible.
    #[arg(long)]
    pub fast: bool,
    /// Replay a recording again and again.
    #[arg(long = "loop")]
    pub looping: bool,
    /// Stop capture after this many frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// The gesture model (from `airglyph train`; default: $AIRGLYPH_MODEL, else the
    /// built-in 36-symbol model).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// The pose stage's posture model: builtin (the default: open, fist, point,
    /// thumb-up, v, pinch), off (skeletons carry no posture) or a posture model FILE,
    /// checked before the pipeline starts (`airglyph stage pose --help`).
    #[arg(long, value_name = "builtin|off|FILE")]
    pub postures: Option<String>,
    /// What puts the gesture stage's pen down: motion (the default: gestures found in
    /// the hand's motion alone), posture[:LABEL] (while the drawing hand holds LABEL,
    /// default point, as the pose stage reads it) or gated[:LABEL] (found by motion,
    /// published only when the drawing hand held LABEL over at least half of it); the
    /// last two not with --postures off or --truth, whose skeletons carry no posture.
    #[arg(long, value_name = "motion|posture[:LABEL]|gated[:LABEL]", value_parser = stage::gesture::parse_pen)]
    pub pen: Option<airglyph_gesture::Pen>,
    /// Extra arguments for one stage, as STAGE=ARGS, split as a shell splits them
    /// (`--stage-args "gesture=--model 'my model.json'"`); repeat it for more stages.
    /// The stages: capture, pose, gesture, viewer; `airglyph stage NAME --help` lists
    /// each one's arguments, which are checked before the pipeline starts.
    #[arg(long = "stage-args", value_name = "STAGE=ARGS")]
    pub stage_args: Vec<StageArgs>,
    /// Restarts of one stage within --crash-window after which it is in a crash loop and
    /// the pipeline gives up (its deaths count whenever they come, not only soon after
    /// a start).
    #[arg(long, default_value_t = CrashRule::default().max_restarts, value_parser = airglyph_ipc::options::within(0usize, 1000), allow_negative_numbers = true)]
    pub max_restarts: usize,
    /// The sliding window of --max-restarts, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = CrashRule::default().window.as_secs_f64(), value_parser = airglyph_ipc::options::seconds(airglyph_ipc::options::MAX_SECONDS), allow_negative_numbers = true)]
    pub crash_window: f64,
    /// Also start the viewer: the live depth image, skeleton, hand trail, gestures and
    /// latencies as a web page.
    #[arg(long)]
    pub view: bool,
    /// With --view: the viewer's address, e.g. 0.0.0.0:8080 to watch from another
    /// computer (default 127.0.0.1:8080, this machine only).
    #[arg(long, value_name = "ADDR", requires = "view")]
    pub listen: Option<std::net::SocketAddr>,
    /// Skip pose estimation: the capture stage publishes the ground-truth skeletons of
    /// a synthetic source or of a recording with joints.csv (to tell pose errors from
    /// gesture errors).
    #[arg(long)]
    pub truth: bool,
    #[command(flatten)]
    pub export: ExportArgs,
}

impl PipelineArgs {
    /// The pipeline from `source` with every other option at its command-line default,
    /// for the commands that run the pipeline themselves (demo, collect).
    pub fn with_source(source: SourceSpec) -> Self {
        #[derive(clap::Parser)]
        struct Run {
            #[command(flatten)]
            args: PipelineArgs,
        }
        let mut args = <Run as clap::Parser>::parse_from(["run"]).args;
        args.source = source;
        args
    }

    /// When a stage that keeps dying is given up.
    fn crash_rule(&self) -> CrashRule {
        CrashRule {
            max_restarts: self.max_restarts,
            window: Duration::from_secs_f64(self.crash_window),
        }
    }

    /// The stages to start, each with its arguments checked by its own parser: a bad
    /// one is refused here, not by a stage dying again and again; and the exporter,
    /// found beside this executable or on PATH, or refused here too.
    pub fn plan(&self) -> anyhow::Result<Plan> {
        self.plan_with(&Lookup::here())
    }

    /// [`Self::plan`], looking for the exporter where `lookup` says.
    fn plan_with(&self, lookup: &Lookup) -> anyhow::Result<Plan> {
        let mut names: Vec<Stage> = Vec::new();
        for name in &self.stages {
            let stage = Stage::from_name(name)
                .filter(|s| Stage::PIPELINE.contains(s))
                .ok_or_else(|| {
                    anyhow::anyhow!("unknown stage {name:?}: expected capture, pose or gesture (the viewer comes with --view)")
                })?;
            if self.truth && stage == Stage::Pose {
                // Capture publishes the skeletons itself.
                continue;
            }
            names.push(stage);
        }
        if self.view {
            names.push(Stage::Viewer);
        }
        for extra in &self.stage_args {
            if !names.contains(&extra.stage) {
                bail!(
                    "--stage-args {}=…: the {} stage does not run here{}",
                    extra.stage.name(),
                    extra.stage.name(),
                    match extra.stage {
                        Stage::Viewer => " (add --view)",
                        Stage::Pose if self.truth => " (--truth runs none)",
                        _ => " (see --stages)",
                    }
                );
            }
        }
        if self.model.is_some() && !names.contains(&Stage::Gesture) {
            bail!("--model: the gesture stage does not run here (see --stages)");
        }
        if self.pen.is_some() && !names.contains(&Stage::Gesture) {
            bail!("--pen: the gesture stage does not run here (see --stages)");
        }
        if let Some(airglyph_gesture::Pen::Posture(_) | airglyph_gesture::Pen::Gated(_)) = self.pen
        {
            if self.truth
                || self.postures.as_deref() == Some("off")
                || !names.contains(&Stage::Pose)
            {
                bail!("--pen posture or gated: the skeletons would carry no posture (the pose stage's posture step reads them; not with --truth, --postures off or without the pose stage)");
            }
        }
        if self.postures.is_some() && !names.contains(&Stage::Pose) {
            bail!(
                "--postures: the pose stage does not run here{}",
                if self.truth {
                    " (--truth runs none)"
                } else {
                    " (see --stages)"
                }
            );
        }
        let stages = names
            .into_iter()
            .map(|stage| {
                let args = self.stage_args(stage);
                stage::check_args(stage, &args).map_err(|e| {
                    anyhow::anyhow!("the arguments of the {} stage: {e}", stage.name())
                })?;
                let health =
                    match stage {
                        Stage::Viewer => Some(stage::viewer_address(&args).map_err(|e| {
                            anyhow::anyhow!("the arguments of the viewer stage: {e}")
                        })?),
                        _ => None,
                    };
                Ok(StagePlan {
                    health,
                    ..StagePlan::own(stage, args)
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        if stages.is_empty() {
            bail!("no stages to run");
        }
        Ok(Plan {
            stages,
            companions: self.export.companion(lookup)?.into_iter().collect(),
            rule: self.crash_rule(),
        })
    }

    /// `--pen` as the gesture stage takes it.
    fn pen_arg(&self) -> Option<String> {
        self.pen.map(|pen| match pen {
            airglyph_gesture::Pen::Motion => "motion".to_owned(),
            airglyph_gesture::Pen::Posture(p) => format!("posture:{}", p.label),
            airglyph_gesture::Pen::Gated(p) => format!("gated:{}", p.label),
        })
    }

    /// The command-line arguments the pipeline gives one stage.
    fn stage_args(&self, stage: Stage) -> Vec<OsString> {
        let mut out: Vec<OsString> = Vec::new();
        match stage {
            Stage::Capture => {
                out.extend(["--source".into(), self.source.to_string().into()]);
                if self.fast {
                    out.push("--fast".into());
                }
                if self.looping {
                    out.push("--loop".into());
                }
                if let Some(n) = self.frames {
                    out.extend(["--frames".into(), n.to_string().into()]);
                }
                if self.truth {
                    // Capture publishes the skeletons itself.
                    out.push("--truth-skeletons".into());
                }
            }
            Stage::Viewer => {
                if let Some(addr) = self.listen {
                    out.extend(["--listen".into(), addr.to_string().into()]);
                }
            }
            Stage::Gesture => {
                if let Some(model) = &self.model {
                    out.extend(["--model".into(), model.into()]);
                }
                if let Some(pen) = &self.pen_arg() {
                    out.extend(["--pen".into(), pen.into()]);
                }
            }
            Stage::Pose => {
                if let Some(postures) = &self.postures {
                    out.extend(["--postures".into(), postures.into()]);
                }
            }
        }
        for extra in self.stage_args.iter().filter(|e| e.stage == stage) {
            out.extend(extra.args.iter().map(OsString::from));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(line: &[&str]) -> PipelineArgs {
        #[derive(clap::Parser)]
        struct Run {
            #[command(flatten)]
            args: PipelineArgs,
        }
        let argv = std::iter::once("run").chain(line.iter().copied());
        <Run as clap::Parser>::try_parse_from(argv).unwrap().args
    }

    fn args_of(plan: &Plan, stage: Stage) -> Vec<String> {
        let s = plan.stages.iter().find(|s| s.stage == stage).unwrap();
        s.args
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect()
    }

    #[test]
    fn each_stage_gets_its_own_options_and_the_viewer_is_probed_where_it_listens() {
        let plan = parse(&[
            "--source",
            "synthetic:draw:12",
            "--loop",
            "--model",
            "m.json",
            "--view",
            "--listen",
            "127.0.0.1:9090",
            "--stage-args",
            "pose=--recording r",
        ])
        .plan()
        .unwrap();
        let stages: Vec<Stage> = plan.stages.iter().map(|s| s.stage).collect();
        assert_eq!(
            stages,
            [Stage::Capture, Stage::Pose, Stage::Gesture, Stage::Viewer]
        );
        assert_eq!(
            args_of(&plan, Stage::Capture),
            [
                "stage",
                "capture",
                "--source",
                "synthetic:draw:12",
                "--loop"
            ]
        );
        assert_eq!(
            args_of(&plan, Stage::Pose),
            ["stage", "pose", "--recording", "r"]
        );
        assert_eq!(
            args_of(&plan, Stage::Gesture),
            ["stage", "gesture", "--model", "m.json"]
        );
        let viewer = &plan.stages[3];
        assert_eq!(viewer.health, Some("127.0.0.1:9090".parse().unwrap()));
        assert!(plan.stages[..3].iter().all(|s| s.health.is_none()));
        assert_eq!(plan.rule, CrashRule::default());
    }

    #[test]
    fn the_pose_stage_gets_the_posture_model() {
        let plan = parse(&["--postures", "off"]).plan().unwrap();
        assert_eq!(
            args_of(&plan, Stage::Pose),
            ["stage", "pose", "--postures", "off"]
        );
        let plan = parse(&[]).plan().unwrap();
        assert_eq!(
            args_of(&plan, Stage::Pose),
            ["stage", "pose"],
            "its default"
        );
    }

    #[test]
    fn the_gesture_stage_gets_the_pen_and_a_posture_pen_needs_postures() {
        let plan = parse(&["--pen", "posture:v"]).plan().unwrap();
        assert_eq!(
            args_of(&plan, Stage::Gesture),
            ["stage", "gesture", "--pen", "posture:v"]
        );
        let plan = parse(&["--pen", "gated"]).plan().unwrap();
        assert_eq!(
            args_of(&plan, Stage::Gesture),
            ["stage", "gesture", "--pen", "gated:point"]
        );
        let plan = parse(&["--pen", "motion", "--truth"]).plan().unwrap();
        assert_eq!(
            args_of(&plan, Stage::Gesture),
            ["stage", "gesture", "--pen", "motion"]
        );
        let err = |line: &[&str]| parse(line).plan().unwrap_err().to_string();
        for line in [
            &["--pen", "posture", "--truth"][..],
            &["--pen", "posture", "--postures", "off"],
            &["--pen", "posture", "--stages", "gesture"],
            &["--pen", "gated", "--truth"],
        ] {
            assert!(err(line).contains("no posture"), "{line:?}");
        }
        assert!(err(&["--pen", "motion", "--stages", "capture,pose"]).contains("--pen"));
        #[derive(clap::Parser)]
        struct Run {
            #[command(flatten)]
            _args: PipelineArgs,
        }
        let bad = <Run as clap::Parser>::try_parse_from(["run", "--pen", "pencil"]);
        assert!(bad.is_err_and(|e| e.to_string().contains("pencil")));
    }

    #[test]
    fn truth_runs_no_pose_stage_and_capture_publishes_the_skeletons() {
        let plan = parse(&["--truth", "--max-restarts", "2"]).plan().unwrap();
        assert!(plan.stages.iter().all(|s| s.stage != Stage::Pose));
        assert!(args_of(&plan, Stage::Capture).contains(&"--truth-skeletons".to_owned()));
        assert_eq!(plan.rule.max_restarts, 2);
    }

    #[test]
    fn options_for_a_stage_that_does_not_run_or_does_not_take_them_are_refused() {
        let err = |line: &[&str]| parse(line).plan().unwrap_err().to_string();
        assert!(err(&["--stage-args", "viewer=--quality 5"]).contains("(add --view)"));
        assert!(
            err(&["--truth", "--stage-args", "pose=--recording r"]).contains("--truth runs none")
        );
        assert!(err(&["--stages", "capture", "--model", "m"]).contains("--model"));
        assert!(err(&["--truth", "--postures", "off"]).contains("--postures"));
        let bad = err(&["--postures", "/no/such/postures.json"]);
        assert!(
            bad.contains("the arguments of the pose stage")
                && bad.contains("/no/such/postures.json"),
            "{bad}"
        );
        assert!(err(&["--stages", "capture,lens"]).contains("unknown stage \"lens\""));
        let bad = err(&["--stage-args", "gesture=--no-such-flag"]);
        assert!(bad.contains("the arguments of the gesture stage"), "{bad}");
        assert!(PipelineArgs::with_source(SourceSpec::Synthetic(None))
            .plan()
            .is_ok());
    }

    #[test]
    fn export_is_planned_after_the_stages_or_refused_before_anything_starts() {
        let empty = tempfile::tempdir().unwrap();
        let nowhere = Lookup {
            beside: Some(empty.path().to_path_buf()),
            path: Some(empty.path().as_os_str().to_owned()),
        };
        let line = ["--export", "zenoh", "--export-listen", "tcp/0.0.0.0:7447"];
        let err = parse(&line).plan_with(&nowhere).unwrap_err().to_string();
        assert!(
            err.contains("cargo build --release -p airglyph-zenoh"),
            "{err}"
        );
        assert!(parse(&[])
            .plan_with(&nowhere)
            .unwrap()
            .companions
            .is_empty());

        let program = empty.path().join(crate::export::PROGRAM);
        std::fs::write(&program, "").unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&program, std::fs::Permissions::from_mode(0o755)).unwrap();
        let plan = parse(&line).plan_with(&nowhere).unwrap();
        assert_eq!(plan.stages.len(), 3);
        assert_eq!(plan.companions.len(), 1);
        assert_eq!(plan.companions[0].program, program);
    }
}
