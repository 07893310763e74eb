//! `airglyph-zenoh import`: another host's messages in from Zenoh, into this host's pipeline.

use crate::link::{self, Endpoints};
use crate::streams::Stream;
use airglyph_ipc::{shutdown, Pipeline};
use anyhow::Context;
use std::io::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
use zenoh::Wait;
use zenoh_ext::{AdvancedSubscriberBuilderExt, HistoryConfig, RecoveryConfig};

/// Republish another host's gestures, decisions, skeletons and stats in this host's
/// pipeline, where `airglyph echo`, `top` and any subscriber read them.
///
/// This host's pipeline must not run stages of its own (each stream has one publisher).
/// Every message is checked as any receiver checks it before it is published; one that
/// fails is dropped and counted. Messages the link lost, and that the exporter could not
/// send again, are counted and reported (a warning, and with --json a line
/// {"event":"missed","stream":…,"count":N}): nothing is lost without a word. Messages
/// keep the other host's times (its CLOCK_MONOTONIC): latencies read from them here are
/// the other host's own.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    link: Endpoints,
    /// Report on stdout as JSON lines: each loss ("missed") and, at the end, the totals.
    #[arg(long)]
    json: bool,
}

const ROUND: Duration = Duration::from_millis(100);

/// What one stream brought and lost.
#[derive(Default)]
struct Counts {
    published: AtomicU64,
    missed: AtomicU64,
    refused: AtomicU64,
}

fn say(json: bool, line: serde_json::Value) {
    if json {
        // Not println!: a reader that went must not panic the importer.
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{line}").and_then(|()| out.flush());
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let session = link::open(&args.link)?;
    tracing::info!(domain = %args.link.domain, listen = ?args.link.listen, connect = ?args.link.connect, "importing");
    let counts: Vec<(Stream, Arc<Counts>)> = Stream::ALL
        .into_iter()
        .map(|s| (s, Arc::new(Counts::default())))
        .collect();
    let threads: Vec<_> = counts
        .iter()
        .map(|(stream, counts)| {
            let (stream, counts, session) = (*stream, counts.clone(), session.clone());
            let (domain, json) = (args.link.domain.clone(), args.json);
            std::thread::Builder::new()
                .name(format!("import {}", stream.name()))
                .spawn(move || relay(stream, &session, &domain, &counts, json))
        })
        .collect::<Result<_, _>>()
        .context("cannot start the import threads")?;
    let mut result = Ok(());
    for t in threads {
        match t.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => result = Err(e),
            Err(_) => result = Err(anyhow::anyhow!("an import thread panicked")),
        }
    }
    for (stream, c) in &counts {
        let (published, missed, refused) = (
            c.published.load(Ordering::Relaxed),
            c.missed.load(Ordering::Relaxed),
            c.refused.load(Ordering::Relaxed),
        );
        tracing::info!(stream = %stream.name(), published, missed, refused, "import totals");
        say(
            args.json,
            serde_json::json!({"event": "totals", "stream": stream.name(),
                               "published": published, "missed": missed, "refused": refused}),
        );
    }
    let _ = session.close().wait();
    result
}

fn relay(
    stream: Stream,
    session: &zenoh::Session,
    domain: &str,
    counts: &Arc<Counts>,
    json: bool,
) -> anyhow::Result<()> {
    let name = stream.name();
    let pipeline = Pipeline::join(&format!("import-{}", name.replace('/', "-")))?;
    let publisher = stream.publisher(&pipeline).with_context(|| {
        format!("cannot publish airglyph/{name} here: does this host run a pipeline of its own?")
    })?;
    let subscriber = session
        .declare_subscriber(link::key(domain, &name))
        .history(HistoryConfig::default().detect_late_publishers())
        .recovery(RecoveryConfig::default().heartbeat())
        .subscriber_detection()
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("cannot subscribe to {name} on Zenoh"))?;
    let missed = {
        let (counts, name) = (counts.clone(), name.clone());
        subscriber
            .sample_miss_listener()
            .callback(move |miss| {
                let n = u64::from(miss.nb());
                counts.missed.fetch_add(n, Ordering::Relaxed);
                tracing::warn!(stream = %name, missed = n, "messages lost on the link and not sent again");
                say(json, serde_json::json!({"event": "missed", "stream": name, "count": n}));
            })
            .wait()
            .map_err(|e| anyhow::anyhow!("{e}"))
            .context("cannot listen for lost messages")?
    };
    while !shutdown::requested() {
        let sample = match subscriber.handler().recv_timeout(ROUND) {
            Ok(Some(s)) => s,
            Ok(None) => continue,
            Err(e) => anyhow::bail!("the Zenoh subscription of {name} ended: {e}"),
        };
        let b = sample.payload().to_bytes();
        match publisher.publish(&b)? {
            Ok(()) => {
                counts.published.fetch_add(1, Ordering::Relaxed);
            }
            Err(why) => {
                counts.refused.fetch_add(1, Ordering::Relaxed);
                tracing::warn!(stream = %name, %why, "dropped a message from the link");
            }
        }
    }
    drop(missed);
    Ok(())
}
