//! Replays a recording directory, paced by its `frames.csv` or as fast as possible.

use crate::source::{DepthSource, Frame, Pacing, SourceError, SourceOptions};
use airglyph_core::recording::Recording;
use airglyph_core::{Intrinsics, Skeleton};
use airglyph_ipc::clock::monotonic_ns;
use airglyph_ipc::wire::SourceKind;
use std::path::Path;
use std::time::Duration;

/// Frames from a recording on disk (`recording:DIR`), paced by its own times.
pub struct RecordingSource {
    recording: Recording,
    opts: SourceOptions,
    next: usize,
    /// CLOCK_MONOTONIC at which the first frame of the current pass was released, and
    /// that frame's recorded time: later frames keep their recorded spacing.
    epoch: Option<(u64, u64)>,
    last: Option<usize>,
}

impl RecordingSource {
    /// Opens the recording in `dir`.
    pub fn open(dir: &Path, opts: &SourceOptions) -> Result<Self, SourceError> {
        let recording = Recording::open(dir).map_err(|e| SourceError::Fatal(e.to_string()))?;
        if recording.is_empty() {
            return Err(SourceError::Fatal(format!(
                "{}: the recording has no frames",
                dir.display()
            )));
        }
        Ok(Self {
            recording,
            opts: opts.clone(),
            next: 0,
            epoch: None,
            last: None,
        })
    }

    /// Frames in the recording.
    pub fn len(&self) -> usize {
        self.recording.len()
    }

    /// Whether it has no frame.
    pub fn is_empty(&self) -> bool {
        self.recording.is_empty()
    }

    fn wait_until_due(&mut self, index: usize) {
        let recorded = self.recording.capture_ns(index);
        let now = monotonic_ns();
        let (start, first) = *self.epoch.get_or_insert((now, recorded));
        let due = start + (recorded - first);
        if due > now {
            std::thread::sleep(Duration::from_nanos(due - now));
        }
    }
}

impl DepthSource for RecordingSource {
    fn intrinsics(&self) -> Intrinsics {
        self.recording.intrinsics()
    }

    fn fps(&self) -> f32 {
        self.recording.info().fps
    }

    fn kind(&self) -> SourceKind {
        SourceKind::Recording
    }

    fn describe(&self) -> String {
        format!("recording:{}", self.recording.dir().display())
    }

    fn next_frame(&mut self, out: &mut [u16]) -> Result<Option<Frame>, SourceError> {
        if self.next == self.recording.len() {
            if !self.opts.looping {
                return Ok(None);
            }
            self.next = 0;
            self.epoch = None;
        }
        let index = self.next;
        self.next += 1;
        if self.opts.pacing == Pacing::Realtime {
            self.wait_until_due(index);
        }
        // Decoding is part of capture's latency.
        let capture_ns = monotonic_ns();
        self.recording
            .read_frame_into(index, out)
            .map_err(|e| SourceError::Skipped(e.to_string()))?;
        self.last = Some(index);
        Ok(Some(Frame {
            capture_ns,
            source_ns: self.recording.capture_ns(index),
        }))
    }

    fn last_truth(&self) -> Option<Skeleton> {
        self.last.and_then(|i| self.recording.joints(i).copied())
    }
}
