//! `airglyph-gesture`: the gesture stage process. Follows the drawing hand through the
//! skeleton stream, spots and classifies gestures, publishes each as an event.

use airglyph_gesture::{Hand, Model, Spotter, SpotterConfig};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::wire::Hand as WireHand;
use airglyph_ipc::{shutdown, DecisionMsg, GestureEventMsg, Pipeline, Stage};
use anyhow::Context;
use clap::Parser;
use std::path::PathBuf;
use std::time::Duration;

/// The gesture stage: skeletons in (`airglyph/skeleton`), gesture events out
/// (`airglyph/gesture`).
///
/// The pipeline it joins is set by AIRGLYPH_IPC_ROOT / AIRGLYPH_IPC_PREFIX (or the
/// config file named by AIRGLYPH_CONFIG). Normally started by `airglyph run`.
#[derive(Parser)]
#[command(name = "airglyph-gesture", version)]
struct Args {
    /// The gesture model (from `airglyph train`); default: the shipped 36-symbol model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fault-injection for tests: sleep this long on every skeleton (a slow stage).
    #[arg(long, hide = true, default_value_t = 0)]
    delay_ms: u64,
}

fn main() -> std::process::ExitCode {
    airglyph_ipc::process::main("airglyph-gesture", || run(Args::parse()))
}

fn run(args: Args) -> anyhow::Result<()> {
    let path = args
        .model
        .clone()
        .unwrap_or_else(airglyph_gesture::model::default_model_path);
    let model = Model::load(&path).with_context(|| {
        format!(
            "cannot load the gesture model {} (train one with `airglyph train`, or pass --model)",
            path.display()
        )
    })?;
    let mut spotter = Spotter::new(model, SpotterConfig::default())?;
    let pipeline = Pipeline::join("gesture")?;
    let mut skeletons = pipeline.skeleton_receiver()?;
    let events = pipeline.gesture_publisher()?;
    let decisions = pipeline.decision_publisher()?;
    let mut telemetry = Telemetry::new(&pipeline, Stage::Gesture)?;
    tracing::info!(model = %path.display(), "waiting for skeletons");
    let mut session = None;
    while !shutdown::requested() {
        telemetry.tick();
        // Every skeleton, not only the newest: the trajectory needs them all.
        let received = skeletons.recv(Duration::from_millis(100))?;
        telemetry.set_rejected(skeletons.rejected());
        let Some(r) = received else { continue };
        let msg = r.msg;
        if args.delay_ms > 0 {
            std::thread::sleep(Duration::from_millis(args.delay_ms));
        }
        telemetry.input(r.receive_ns - msg.chain.pose_publish_ns, r.dropped);
        if session.replace(msg.session) != Some(msg.session) {
            // A restarted capture stage: the last trajectory is over.
            spotter.reset();
        }
        let spotted = msg
            .skeleton()
            .and_then(|s| spotter.push(&s, msg.sequence, msg.chain.capture_ns));
        let decided_ns = monotonic_ns();
        let mut decision = DecisionMsg {
            sequence: msg.sequence,
            session: msg.session,
            chain: msg.chain,
            gesture: spotted.is_some() as u8,
            ..DecisionMsg::default()
        };
        decision.chain.gesture_receive_ns = r.receive_ns;
        decision.chain.gesture_publish_ns = decided_ns;
        if let Some(g) = spotted {
            let mut event = GestureEventMsg {
                score: g.score as f32,
                start_sequence: g.start_seq,
                end_sequence: g.end_seq,
                start_ns: g.start_ns,
                end_ns: g.end_ns,
                session: msg.session,
                hand: match g.hand {
                    Hand::Left => WireHand::Left as u8,
                    Hand::Right => WireHand::Right as u8,
                },
                ..GestureEventMsg::default()
            };
            if let Err(e) = event.set_label(&g.label) {
                tracing::warn!(label = %g.label, "label does not fit the wire ({e}); sent cut");
                let cut: String = g.label.chars().take(8).collect();
                event.set_label(&cut)?;
            }
            event.chain = msg.chain;
            event.chain.gesture_receive_ns = r.receive_ns;
            event.chain.gesture_publish_ns = monotonic_ns();
            events.send(event)?;
            tracing::info!(label = %g.label, score = g.score, "gesture");
        }
        decisions.send(decision)?;
        telemetry.output(decided_ns - r.receive_ns, decided_ns - msg.chain.capture_ns);
    }
    Ok(())
}
