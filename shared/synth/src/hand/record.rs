//! `hands.csv`: each hand's ground truth, frame by frame, beside a recording's
//! `joints.csv` (camera frame, metres; a row per hand and frame).

use super::{HandTruth, Hands, SIDES};
use crate::error::SynthError;
use nalgebra::{Point3, Vector3};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The columns: the posture is empty for the body's own hand, and so are its
/// fingertips (thumb, index, middle, ring, little).
pub const HEADER: &str =
    "frame,hand,posture,length_m,wrist_x,wrist_y,wrist_z,palm_x,palm_y,palm_z,\
normal_x,normal_y,normal_z,finger_x,finger_y,finger_z,thumb_side_x,thumb_side_y,thumb_side_z,\
thumb_x,thumb_y,thumb_z,index_x,index_y,index_z,middle_x,middle_y,middle_z,\
ring_x,ring_y,ring_z,little_x,little_y,little_z";

/// Writes `hands.csv` a frame at a time, each frame flushed with it (a recording
/// stopped between two frames keeps whole rows).
pub(crate) struct HandsCsv {
    path: PathBuf,
    out: BufWriter<File>,
}

impl HandsCsv {
    pub fn create(path: &Path) -> Result<Self, SynthError> {
        let file = File::create(path).map_err(|e| SynthError::io(path, e))?;
        let mut me = Self {
            path: path.to_owned(),
            out: BufWriter::new(file),
        };
        me.line(HEADER.to_string())?;
        Ok(me)
    }

    fn line(&mut self, text: String) -> Result<(), SynthError> {
        writeln!(self.out, "{text}")
            .and_then(|_| self.out.flush())
            .map_err(|e| SynthError::io(&self.path, e))
    }

    pub fn write(&mut self, frame: usize, hands: &Hands<HandTruth>) -> Result<(), SynthError> {
        for side in SIDES {
            let h = hands.get(side);
            let p = |p: &Point3<f32>| format!("{:.5},{:.5},{:.5}", p.x, p.y, p.z);
            let v = |v: &Vector3<f32>| format!("{:.5},{:.5},{:.5}", v.x, v.y, v.z);
            let tips = match &h.fingertips {
                Some(t) => t.iter().map(p).collect::<Vec<_>>().join(","),
                None => [",,"; 5].join(","),
            };
            self.line(format!(
                "{frame},{},{},{:.5},{},{},{},{},{},{tips}",
                side.name(),
                h.posture.map_or("", |p| p.name()),
                h.length_m,
                p(&h.wrist),
                p(&h.palm_centre),
                v(&h.palm_normal),
                v(&h.finger_dir),
                v(&h.thumb_side),
            ))?;
        }
        Ok(())
    }
}
