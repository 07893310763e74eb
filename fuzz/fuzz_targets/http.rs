//! The viewer's HTTP handling on arbitrary bytes from a client: whatever arrives (a
//! broken request line, endless headers, a body, pipelined requests), the server
//! answers or closes, never panics, and sends back no more than its answers.
#![no_main]

use airglyph_core::Intrinsics;
use airglyph_ipc::DepthHeader;
use airglyph_viewer::{server, ServeConfig, Shared};
use libfuzzer_sys::fuzz_target;
use std::sync::{Arc, OnceLock};

/// A viewer with two frames, so pictures are drawn; made once.
fn shared() -> Arc<Shared> {
    static SHARED: OnceLock<Arc<Shared>> = OnceLock::new();
    SHARED
        .get_or_init(|| {
            let shared = Shared::new(ServeConfig {
                max_fps: 1e6,
                quality: 50,
            });
            for seq in 0..2 {
                let mut h = DepthHeader {
                    sequence: seq,
                    session: 1,
                    capture_ns: 1 + seq,
                    publish_ns: 2 + seq,
                    ..Default::default()
                };
                h.set_intrinsics(&Intrinsics::default().scaled_to(32, 24));
                shared
                    .scene()
                    .lock()
                    .unwrap()
                    .push_depth(h, &vec![1500; 32 * 24], 0);
            }
            Arc::new(shared)
        })
        .clone()
}

fuzz_target!(|data: &[u8]| {
    // Paused time: a request waiting for a newer frame, or a client that sent half a
    // head, costs no wall-clock second here.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    let reply = runtime.block_on(server::answer(shared(), data));
    // Every answer starts with a status line.
    assert!(reply.is_empty() || reply.starts_with(b"HTTP/1."), "{reply:?}");
});
