//! `airglyph stage gesture`: the gesture stage process. Follows the drawing hand through the
//! skeleton stream, spots and classifies gestures, publishes each as an event with the
//! Bezier points of its path, and every frame's decision with the hand point the
//! recognizer took from it (what the viewer draws).

use airglyph_core::bezier::bezier_points;
use airglyph_gesture::{
    Hand, HandPosture, ModelSource, Pen, PostureLabel, Postures, SpottedGesture, Spotter,
    SpotterConfig,
};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::stats::Telemetry;
use airglyph_ipc::wire::{Hand as WireHand, BEZIER_CAPACITY};
use airglyph_ipc::{
    shutdown, DecisionMsg, GestureEventMsg, LatencyChain, Pipeline, Received, Receiver,
    SkeletonMsg, Stage,
};
use anyhow::Context;
use std::path::PathBuf;
use std::time::{Duration, Instant};

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
    /// What puts the pen down: motion (gestures found in the hand's motion alone) or
    /// posture (while the drawing hand points, as the pose stage's posture step reads
    /// it: its skeletons must carry postures) or posture:LABEL (while it holds LABEL,
    /// a posture of the pose stage's model) or gated[:LABEL] (found by motion, but
    /// published only when the drawing hand held the posture, default point, over at
    /// least half the frames it was read in). Every gesture event carries the posture
    /// its hand held over most of it, whichever the pen.
    #[arg(long, default_value = "motion", value_name = "motion|posture[:LABEL]|gated[:LABEL]", value_parser = parse_pen)]
    pen: Pen,
    /// Fault-injection for tests: sleep this long on every skeleton (a slow stage).
    #[arg(long, hide = true, default_value_t = 0, value_parser = airglyph_ipc::options::within(0u64, 10_000))]
    delay_ms: u64,
}

/// The last gesture the pipeline's gesture stage reported: its capture session and last
/// frame, kept in a file of the pipeline's own root folder (`<root>/<prefix>gesture.last`,
/// closed to other users like the folder), written after every event.
///
/// A restarted gesture stage is handed the last seconds of skeletons again (the skeleton
/// service's history) and finds again what it had found before it died: whatever it
/// reported then must not be reported twice. The event service cannot tell it: iceoryx2
/// keeps a publisher's history in the publisher's process, which died with the stage.
struct Reported {
    path: PathBuf,
    last: Option<(u64, u64)>,
}

impl Reported {
    fn load(pipeline: &Pipeline) -> Self {
        let cfg = pipeline.config();
        let path = std::path::Path::new(&cfg.root).join(format!("{}gesture.last", cfg.prefix));
        let last = match std::fs::read_to_string(&path) {
            Ok(text) => {
                let mut words = text.split_whitespace().map(str::parse::<u64>);
                match (words.next(), words.next()) {
                    (Some(Ok(session)), Some(Ok(end))) => Some((session, end)),
                    _ => {
                        tracing::warn!(path = %path.display(), "not a last gesture; ignored");
                        None
                    }
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => {
                tracing::warn!(path = %path.display(), error = %e, "cannot read the last gesture reported");
                None
            }
        };
        if let Some((session, end)) = last {
            tracing::debug!(session, end, "the last gesture reported before this start");
        }
        Self { path, last }
    }

    /// Whether a gesture of `session` starting at frame `start` was reported already: it
    /// starts before the last one reported ended. The spotter never starts a gesture
    /// before the end of the last one it published, so only a gesture found again after
    /// a restart does.
    fn already(&self, session: u64, start: u64) -> bool {
        self.last
            .is_some_and(|(s, end)| s == session && start < end)
    }

    /// Remembers a reported gesture, for a stage started after this one dies. Written
    /// whole (a new file renamed over the old): a kill midway leaves the last one.
    fn record(&mut self, session: u64, end: u64) {
        self.last = Some((session, end));
        let tmp = self.path.with_extension("last.new");
        let written = std::fs::write(&tmp, format!("{session} {end}\n"))
            .and_then(|()| std::fs::rename(&tmp, &self.path));
        if let Err(e) = written {
            // The events went out; only a restart could repeat this one.
            tracing::warn!(path = %self.path.display(), error = %e, "cannot remember the last gesture reported");
        }
    }
}

/// `--pen`'s parser.
pub fn parse_pen(s: &str) -> Result<Pen, String> {
    Pen::parse(s).map_err(|e| e.to_string())
}

/// Both hands' postures as a skeleton message carries them, for the spotter. A hand
/// whose posture does not read (the receiver checked it: it does) or whose label the
/// spotter cannot hold counts as not classified.
fn postures_of(msg: &SkeletonMsg) -> Postures {
    let of = |hand: WireHand| {
        let p = msg.posture(hand).ok().flatten()?;
        Some(HandPosture {
            label: PostureLabel::new(p.label).ok()?,
            confidence: p.confidence,
        })
    };
    Postures {
        left: of(WireHand::Left),
        right: of(WireHand::Right),
    }
}

/// The wire's name for the gesture library's hand.
pub fn wire_hand(hand: Hand) -> WireHand {
    match hand {
        Hand::Left => WireHand::Left,
        Hand::Right => WireHand::Right,
    }
}

/// `n` points (at most the wire's capacity) of the Bezier curve of a spotted gesture's
/// path: the gesture descriptor's curve, for others to draw.
fn bezier_of(g: &SpottedGesture, n: usize) -> Vec<[f32; 2]> {
    bezier_points(&g.points, n.min(BEZIER_CAPACITY))
        .into_iter()
        .map(|p| p.map(|v| v as f32))
        .collect()
}

/// Sends one gesture event with `bezier` points of its path, unless it was reported
/// before this stage's start; `chain` is the latency chain of the frame that closed it.
fn publish(
    events: &airglyph_ipc::Publisher<GestureEventMsg>,
    reported: &mut Reported,
    g: &SpottedGesture,
    bezier: usize,
    session: u64,
    chain: LatencyChain,
) -> anyhow::Result<()> {
    if reported.already(session, g.start_seq) {
        tracing::info!(label = %g.label, start = g.start_seq, end = g.end_seq, "found again after a restart; reported before");
        return Ok(());
    }
    let mut event = GestureEventMsg {
        score: g.score as f32,
        start_sequence: g.start_seq,
        end_sequence: g.end_seq,
        start_ns: g.start_ns,
        end_ns: g.end_ns,
        session,
        hand: wire_hand(g.hand) as u8,
        chain,
        ..GestureEventMsg::default()
    };
    event.chain.gesture_publish_ns = monotonic_ns();
    // The model loader refuses labels longer than the wire carries.
    event
        .set_label(&g.label)
        .with_context(|| format!("label {:?}", g.label))?;
    // The spotter's labels are as long as the wire's at most.
    event
        .set_posture(g.posture.as_ref().map(PostureLabel::as_str))
        .with_context(|| format!("posture {:?}", g.posture))?;
    if let Err(e) = event.set_bezier(&bezier_of(g, bezier)) {
        // The gesture matters more than its picture: it goes out without the points.
        tracing::warn!(label = %g.label, error = %e, "the gesture's Bezier points are not sent");
    }
    // Sent first, remembered after: a kill in between repeats the event (which a
    // consumer can tell by its session and frames) rather than losing it.
    events.send(event)?;
    reported.record(session, g.end_seq);
    tracing::info!(label = %g.label, score = g.score, "gesture");
    Ok(())
}

/// How long a starting stage waits for the skeletons' history: it comes with the
/// publisher's next skeleton (33 ms at 30 fps); without a publisher there is none.
const HISTORY_WAIT: Duration = Duration::from_secs(1);
/// How long a starting stage may take to catch up with the stream through the history
/// subscriber's large buffer (256 skeletons took 65–77 ms in a debug build); a stage
/// too slow for that goes on from the newest, as a slow stage does, instead of lagging
/// seconds behind.
const CATCH_UP_LIMIT: Duration = Duration::from_secs(2);

/// Where the skeletons come from: first a subscriber handed the publisher's recent
/// skeletons, read until it has caught up with the stream, then the ordinary one.
struct Skeletons {
    catching_up: Option<Receiver<SkeletonMsg>>,
    got_history: bool,
    since: Instant,
    taken: u64,
    live: Receiver<SkeletonMsg>,
}

impl Skeletons {
    fn new(pipeline: &Pipeline) -> anyhow::Result<Self> {
        // The ordinary subscriber first, so that nothing sent after the history is missed.
        let live = pipeline.skeleton_receiver()?;
        let catching_up = Some(pipeline.skeleton_receiver_with_history()?);
        Ok(Self {
            catching_up,
            got_history: false,
            since: Instant::now(),
            taken: 0,
            live,
        })
    }

    fn recv(&mut self, timeout: Duration) -> anyhow::Result<Option<Received<SkeletonMsg>>> {
        if let Some(history) = self.catching_up.as_mut() {
            let late = self.since.elapsed() >= CATCH_UP_LIMIT;
            let r = if late {
                None
            } else if self.got_history {
                history.try_recv()?
            } else {
                history.recv(timeout.min(Duration::from_millis(50)))?
            };
            if r.is_some() {
                self.got_history = true;
                self.taken += 1;
                return Ok(r);
            }
            if self.got_history || self.since.elapsed() >= HISTORY_WAIT {
                // Caught up (or nothing to catch up with, or too slow to): the large
                // buffer goes, so a slow stage drops skeletons instead of lagging
                // seconds behind.
                self.catching_up = None;
                let ms = self.since.elapsed().as_millis() as u64;
                if late {
                    tracing::warn!(
                        skeletons = self.taken,
                        ms,
                        "could not catch up with the skeleton stream; going on from the newest"
                    );
                } else {
                    tracing::debug!(
                        skeletons = self.taken,
                        ms,
                        "caught up with the skeleton stream"
                    );
                }
            }
            return Ok(None);
        }
        Ok(self.live.recv(timeout)?)
    }

    fn rejected(&self) -> u64 {
        self.live.rejected() + self.catching_up.as_ref().map_or(0, Receiver::rejected)
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let source = ModelSource::choose(args.model.as_deref());
    let model = source.load().with_context(|| {
        format!("cannot load the gesture model {source} (train one with `airglyph train`, or pass --model)")
    })?;
    let cfg = SpotterConfig {
        pen: args.pen,
        ..SpotterConfig::default()
    };
    let mut spotter = Spotter::new(model, cfg)?;
    // As many as the model's descriptor takes.
    let bezier = spotter.model().training.bezier_points;
    let pipeline = Pipeline::join("gesture")?;
    let started_ns = monotonic_ns();
    let mut reported = Reported::load(&pipeline);
    let mut skeletons = Skeletons::new(&pipeline)?;
    let events = pipeline.gesture_publisher()?;
    let decisions = pipeline.decision_publisher()?;
    let mut telemetry = Telemetry::new(&pipeline, Stage::Gesture)?;
    tracing::info!(model = %source, pen = ?args.pen, "waiting for skeletons");
    // The capture session and frame of the last skeleton taken.
    let mut last: Option<(u64, u64)> = None;
    // When the skeletons stop (the camera stopped, the person left), what the spotter
    // still weighs is decided after this long.
    const QUIET: Duration = Duration::from_millis(500);
    let mut last_seen: Option<(Instant, LatencyChain)> = None;
    while !shutdown::requested() {
        telemetry.tick();
        // A subscriber that joined since (`airglyph echo gesture`) gets the last events now.
        events.update_connections();
        // Every skeleton, not only the newest: the trajectory needs them all.
        let received = skeletons.recv(Duration::from_millis(100))?;
        telemetry.set_rejected(skeletons.rejected());
        let Some(r) = received else {
            if let (Some((at, chain)), Some((session, _))) = (last_seen, last) {
                if at.elapsed() >= QUIET {
                    last_seen = None;
                    for g in spotter.finish() {
                        publish(&events, &mut reported, &g, bezier, session, chain)?;
                    }
                }
            }
            continue;
        };
        let msg = r.msg;
        // Frames lost since the last skeleton taken, whichever subscriber had them.
        let dropped = match last {
            Some((session, seq)) if session == msg.session => msg.sequence.saturating_sub(seq + 1),
            _ => r.dropped,
        };
        match last {
            // Both subscribers saw what came while catching up: once is enough.
            Some((session, seq)) if session == msg.session && msg.sequence <= seq => continue,
            Some((session, _)) if session != msg.session => {
                // A restarted capture stage: the last stream is over, and what it left
                // pending is decided as when the skeletons stop.
                if let Some((_, chain)) = last_seen {
                    for g in spotter.finish() {
                        publish(&events, &mut reported, &g, bezier, session, chain)?;
                    }
                }
                spotter.reset();
            }
            _ => {}
        }
        last = Some((msg.session, msg.sequence));
        // A skeleton published before this stage started comes from the history: it
        // rebuilds the trajectory, but its latency and decision were another process's.
        let replayed = msg.chain.pose_publish_ns < started_ns;
        if args.delay_ms > 0 {
            std::thread::sleep(Duration::from_millis(args.delay_ms));
        }
        if !replayed {
            telemetry.input(
                r.receive_ns.saturating_sub(msg.chain.pose_publish_ns),
                dropped,
            );
        }
        let mut chain = msg.chain;
        chain.gesture_receive_ns = r.receive_ns;
        last_seen = Some((Instant::now(), chain));
        let (point, spotted) = match msg.skeleton() {
            Some(s) => {
                let postures = postures_of(&msg);
                spotter.push_posed(&s, &postures, msg.sequence, msg.chain.capture_ns)
            }
            None => (None, spotter.no_hand()),
        };
        if let Some(g) = &spotted {
            publish(&events, &mut reported, g, bezier, msg.session, chain)?;
        }
        if replayed {
            continue;
        }
        let decided_ns = monotonic_ns();
        let mut decision = DecisionMsg {
            sequence: msg.sequence,
            session: msg.session,
            chain,
            gesture: spotted.is_some() as u8,
            ..DecisionMsg::default()
        };
        decision.set_hand_point(
            point
                .filter(|p| p.x.is_finite() && p.y.is_finite())
                .map(|p| (wire_hand(p.hand), [p.x, p.y])),
        );
        decision.chain.gesture_publish_ns = decided_ns;
        decisions.send(decision)?;
        telemetry.output(
            decided_ns - r.receive_ns,
            decided_ns.saturating_sub(msg.chain.capture_ns),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spotter_gets_the_postures_the_skeleton_carries() {
        let mut msg = SkeletonMsg::default();
        assert_eq!(postures_of(&msg), Postures::NONE);
        msg.set_posture(
            WireHand::Right,
            airglyph_ipc::PostureMsg::new("point", 0.8).ok(),
        );
        let p = postures_of(&msg);
        assert_eq!(p.left, None);
        let right = p.right.expect("the right hand's posture");
        assert_eq!((right.label.as_str(), right.confidence), ("point", 0.8));
        // What the stage takes on its command line.
        assert_eq!(parse_pen("motion"), Ok(Pen::Motion));
        assert!(
            matches!(parse_pen("posture:fist"), Ok(Pen::Posture(p)) if p.label.as_str() == "fist")
        );
        assert!(parse_pen("posture:").unwrap_err().contains("empty"));
        assert!(matches!(parse_pen("gated:v"), Ok(Pen::Gated(p)) if p.label.as_str() == "v"));
    }

    #[test]
    fn a_gesture_starting_before_the_last_reported_end_was_reported() {
        let r = Reported {
            path: PathBuf::new(),
            last: Some((7, 100)),
        };
        // Found again after a restart: the same gesture, or one before it.
        assert!(r.already(7, 60) && r.already(7, 99));
        // The next one may start where the last ended (the spotter's barrier).
        assert!(!r.already(7, 100) && !r.already(7, 140));
        // Another capture session: its frames are counted anew.
        assert!(!r.already(8, 60));
    }
}
