//! `airglyph stage gesture`: the gesture stage process. Follows the drawing hand through the
//! skeleton stream, spots and classifies gestures, publishes each as an event.

use airglyph_gesture::{Hand, ModelSource, SpottedGesture, Spotter, SpotterConfig};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::wire::Hand as WireHand;
use airglyph_ipc::{shutdown, DecisionMsg, GestureEventMsg, LatencyChain, Pipeline, Stage};
use anyhow::Context;
use std::path::PathBuf;
use std::time::Duration;

/// The gesture stage: skeletons in (`airglyph/skeleton`), gesture events out
/// (`airglyph/gesture`).
///
/// The pipeline it joins is set by AIRGLYPH_IPC_ROOT / AIRGLYPH_IPC_PREFIX (or the
/// config file named by AIRGLYPH_CONFIG). Normally started by `airglyph run`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The gesture model (from `airglyph train`); default: $AIRGLYPH_MODEL, else the
    /// built-in 36-symbol model.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fault-injection for tests: sleep this long on every skeleton (a slow stage).
    #[arg(long, hide = true, default_value_t = 0, value_parser = airglyph_ipc::options::within(0u64, 10_000))]
    delay_ms: u64,
}

/// Sends one gesture event; `chain` is the latency chain of the frame that closed it.
fn publish(
    events: &airglyph_ipc::Publisher<GestureEventMsg>,
    g: &SpottedGesture,
    session: u64,
    chain: LatencyChain,
    publish_ns: u64,
) -> anyhow::Result<()> {
    let mut event = GestureEventMsg {
        score: g.score as f32,
        start_sequence: g.start_seq,
        end_sequence: g.end_seq,
        start_ns: g.start_ns,
        end_ns: g.end_ns,
        session,
        hand: match g.hand {
            Hand::Left => WireHand::Left as u8,
            Hand::Right => WireHand::Right as u8,
        },
        chain,
        ..GestureEventMsg::default()
    };
    event.chain.gesture_publish_ns = publish_ns;
    // The model loader refuses labels longer than the wire carries.
    event
        .set_label(&g.label)
        .with_context(|| format!("label {:?}", g.label))?;
    events.send(event)?;
    tracing::info!(label = %g.label, score = g.score, "gesture");
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let source = ModelSource::choose(args.model.as_deref());
    let model = source.load().with_context(|| {
        format!("cannot load the gesture model {source} (train one with `airglyph train`, or pass --model)")
    })?;
    let mut spotter = Spotter::new(model, SpotterConfig::default())?;
    let pipeline = Pipeline::join("gesture")?;
    let mut skeletons = pipeline.skeleton_receiver()?;
    let events = pipeline.gesture_publisher()?;
    let decisions = pipeline.decision_publisher()?;
    let mut telemetry = Telemetry::new(&pipeline, Stage::Gesture)?;
    tracing::info!(model = %source, "waiting for skeletons");
    let mut session = None;
    // When the skeletons stop (the camera stopped, the person left), what the spotter
    // still weighs is decided after this long.
    const QUIET: Duration = Duration::from_millis(500);
    let mut last_seen: Option<(std::time::Instant, LatencyChain, u64)> = None;
    while !shutdown::requested() {
        telemetry.tick();
        // Every skeleton, not only the newest: the trajectory needs them all.
        let received = skeletons.recv(Duration::from_millis(100))?;
        telemetry.set_rejected(skeletons.rejected());
        let Some(r) = received else {
            if let Some((at, chain, session)) = last_seen {
                if at.elapsed() >= QUIET {
                    last_seen = None;
                    for g in spotter.finish() {
                        publish(&events, &g, session, chain, monotonic_ns())?;
                    }
                }
            }
            continue;
        };
        let msg = r.msg;
        if args.delay_ms > 0 {
            std::thread::sleep(Duration::from_millis(args.delay_ms));
        }
        telemetry.input(r.receive_ns - msg.chain.pose_publish_ns, r.dropped);
        if session.replace(msg.session) != Some(msg.session) {
            // A restarted capture stage: the last trajectory is over.
            spotter.reset();
        }
        let mut chain = msg.chain;
        chain.gesture_receive_ns = r.receive_ns;
        last_seen = Some((std::time::Instant::now(), chain, msg.session));
        let spotted = msg
            .skeleton()
            .and_then(|s| spotter.push(&s, msg.sequence, msg.chain.capture_ns));
        let decided_ns = monotonic_ns();
        let mut decision = DecisionMsg {
            sequence: msg.sequence,
            session: msg.session,
            chain,
            gesture: spotted.is_some() as u8,
            ..DecisionMsg::default()
        };
        decision.chain.gesture_publish_ns = decided_ns;
        if let Some(g) = spotted {
            publish(&events, &g, msg.session, chain, monotonic_ns())?;
        }
        decisions.send(decision)?;
        telemetry.output(decided_ns - r.receive_ns, decided_ns - msg.chain.capture_ns);
    }
    Ok(())
}
