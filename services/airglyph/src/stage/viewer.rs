//! `airglyph stage viewer`: the viewer stage process. Subscribes to the pipeline like any stage
//! and serves a web page of what the camera sees: the depth image, the skeleton, the
//! hand's trail with its Bezier points, the last gestures and each stage's latency.

use airglyph_ipc::{options, shutdown, Pipeline};
use airglyph_viewer::{Feed, ServeConfig, Server, Shared};
use anyhow::Context;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

/// The viewer stage: a web page of the live pipeline.
///
/// It also pushes what the pipeline says to scripts and browsers as server-sent events
/// on /events (gestures with the keys of `run --json`; ?skeletons=HZ, ?state=HZ,
/// ?stats=0: docs/integrating.md).
///
/// Serves on 127.0.0.1 (this machine only) unless --listen says otherwise, e.g.
/// `--listen 0.0.0.0:8080` to watch from another computer: then anyone who reaches the
/// port sees the depth image, the skeletons and the gestures, with no login and in the
/// clear; only on a network you trust. It only reads: nothing the
/// other stages need comes from it, and a slow browser gets fewer pictures rather than
/// slowing anything. The pipeline it joins is set by AIRGLYPH_IPC_ROOT /
/// AIRGLYPH_IPC_PREFIX (or the config file named by AIRGLYPH_CONFIG). Started by
/// `airglyph run --view`, or alone beside a running pipeline.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Address and port to serve the page on (port 0: any free port, logged).
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub listen: SocketAddr,
    /// Most pictures a second sent to browsers, all together; frames between are skipped.
    #[arg(long, default_value_t = 15.0, value_parser = options::within(0.1f64, 120.0), allow_negative_numbers = true)]
    max_fps: f64,
    /// JPEG quality of the pictures (1–100).
    #[arg(long, default_value_t = 80, value_parser = options::within(1u8, 100), allow_negative_numbers = true)]
    quality: u8,
    /// Scheduling niceness of the viewer (0–19): under load the pipeline's stages come
    /// first and the viewer takes what is left.
    #[arg(long, default_value_t = 10, value_parser = options::within(0i32, 19), allow_negative_numbers = true)]
    nice: i32,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // Before any thread starts: Linux applies niceness per thread, and new threads
    // inherit their creator's.
    // SAFETY: setpriority(2) on this process; no memory is touched.
    if unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, args.nice) } != 0 {
        tracing::warn!(nice = args.nice, error = %std::io::Error::last_os_error(), "cannot lower the viewer's priority");
    }
    let pipeline = Pipeline::join("viewer")?;
    let shared = Arc::new(Shared::new(ServeConfig {
        max_fps: args.max_fps,
        quality: args.quality,
    }));
    let server = Server::start(args.listen, shared.clone())
        .context("is another viewer running there? pick another address with --listen")?;
    let mut feed = Feed::new(&pipeline)?.with_push(shared.push().clone());
    tracing::info!("viewer on http://{}/", server.addr());
    let result = (|| {
        while !shutdown::requested() {
            // A server that stopped serving (its thread ended, or its own health check
            // failed three times in a row) ends the process with the reason, so that
            // `airglyph run` or systemd starts a viewer that serves.
            server.health()?;
            if feed
                .poll(shared.scene(), Duration::from_millis(100))?
                .frames
                > 0
            {
                shared.notify();
            }
            shared.push_state();
        }
        Ok(())
    })();
    server.stop();
    result
}
