//! `airglyph-zenoh export`: the pipeline's messages out to Zenoh.

use crate::link::{self, Endpoints};
use crate::streams::Stream;
use airglyph_ipc::{shutdown, Pipeline};
use anyhow::Context;
use std::time::Duration;
use zenoh::Wait;
use zenoh_ext::{AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

/// Publish this pipeline's gestures, decisions, skeletons and stats on Zenoh.
///
/// Every gesture is numbered and the last 64 are kept: an importer whose link broke
/// gets those it missed again when the link is back, and is told how many it could not
/// get. Decisions and skeletons are not kept (30 a second, news only while new); their
/// losses are counted by the importer all the same.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    link: Endpoints,
}

/// How often an exporter tells importers the number of its last message, so that one
/// that missed the last messages before a quiet spell learns of it.
const HEARTBEAT: Duration = Duration::from_millis(500);
/// How long one wait for a message lasts: a signal is noticed within it.
const ROUND: Duration = Duration::from_millis(100);

pub fn run(args: Args) -> anyhow::Result<()> {
    let session = link::open(&args.link)?;
    tracing::info!(domain = %args.link.domain, listen = ?args.link.listen, connect = ?args.link.connect, "exporting");
    // A thread a stream, each with its own node: a stream waits on its own service's
    // event, so each message leaves as soon as it comes.
    let threads: Vec<_> = Stream::ALL
        .into_iter()
        .map(|stream| {
            let session = session.clone();
            let domain = args.link.domain.clone();
            std::thread::Builder::new()
                .name(format!("export {}", stream.name()))
                .spawn(move || relay(stream, &session, &domain))
        })
        .collect::<Result<_, _>>()
        .context("cannot start the export threads")?;
    let mut result = Ok(());
    for t in threads {
        match t.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => result = Err(e),
            Err(_) => result = Err(anyhow::anyhow!("an export thread panicked")),
        }
    }
    let _ = session.close().wait();
    result
}

fn relay(stream: Stream, session: &zenoh::Session, domain: &str) -> anyhow::Result<()> {
    let name = stream.name();
    let pipeline = Pipeline::join(&format!("export-{}", name.replace('/', "-")))?;
    let mut rx = stream.receiver(&pipeline)?;
    let mut publisher = session
        .declare_publisher(link::key(domain, &name))
        .sample_miss_detection(MissDetectionConfig::default().heartbeat(HEARTBEAT))
        .publisher_detection();
    if stream.kept() > 0 {
        publisher = publisher.cache(CacheConfig::default().max_samples(stream.kept()));
    }
    let publisher = publisher
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("cannot publish {name} on Zenoh"))?;
    while !shutdown::requested() {
        let Some(b) = rx.next(ROUND)? else { continue };
        // Zenoh queues what the link cannot take yet and drops what does not fit, which
        // the importer counts: the pipeline is never held up here.
        if let Err(e) = publisher.put(b).wait() {
            tracing::warn!(stream = %name, error = %e, "cannot send a message to Zenoh");
        }
    }
    Ok(())
}
