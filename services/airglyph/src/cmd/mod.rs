//! One module a subcommand: its clap `Args` and a `run(args) -> anyhow::Result<()>`. The
//! lab's commands are in a build with the feature `lab` only.

#[cfg(feature = "lab")]
pub mod collect;
pub mod completions;
pub mod demo;
pub mod devices;
pub mod echo;
#[cfg(feature = "lab")]
pub mod eval_gestures;
#[cfg(feature = "lab")]
pub mod eval_pose;
#[cfg(feature = "lab")]
pub mod eval_spotting;
pub mod fetch_assets;
pub mod man;
pub mod pose;
pub mod profile;
pub mod record;
pub mod run;
pub mod snapshot;
pub mod spot;
pub mod synth;
#[cfg(feature = "lab")]
pub mod synth_gestures;
pub mod top;
#[cfg(feature = "lab")]
pub mod train;

use airglyph_ipc::json::{gesture_latency_ms, GestureLine};
use airglyph_ipc::GestureEventMsg;

/// Prints a gesture event as a line of text or of JSON. An error is stdout gone (a
/// reader such as `head` that has what it wanted): the caller stops, it does not panic.
pub fn print_gesture(event: &GestureEventMsg, json: bool) -> std::io::Result<()> {
    use std::io::Write;
    let g = GestureLine::live(event);
    if json {
        writeln!(std::io::stdout(), "{}", g.line())
    } else {
        writeln!(
            std::io::stdout(),
            "{}  (score {:.2}, frames {}–{}, {:.1} ms after capture)",
            g.label,
            g.score,
            g.start_frame,
            g.end_frame,
            gesture_latency_ms(event)
        )
    }
}
