//! A recording folder written set by set, all or nothing: what `teachcam record` and the
//! studio's Record button write, in the layout every command reads (`CONTRACT.md`,
//! "Recording"):
//!
//! ```text
//! REC/cam0/000000.png ...   one PNG per camera and set, 8- or 16-bit gray as the camera gives
//! REC/timestamps.csv        camera,frame,time_s: each frame's exposure time from the first one
//! REC/recording.json        {"fps": ...}
//! ```
//! Everything goes into a staging folder beside `REC` ([`StagedFolder`]) and is put in place by
//! [`RecordingWriter::finish`]; dropped unfinished (an error, a crash), the writer leaves
//! nothing. A set is written whole or not at all: every camera has the same frames.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::recording::{
    GrayFrame, TIMESTAMPS_FILE, frame_file_name, timestamps_text, write_frame_png,
    write_recording_info,
};
use super::{FileError, StagedFolder, create_folder, write_atomically};

/// A recording folder being written.
#[derive(Debug)]
pub struct RecordingWriter {
    staged: StagedFolder,
    /// Camera names, in the order each set's frames come.
    names: Vec<String>,
    /// Per camera, its frames' times from the recording's first exposure, seconds.
    times: BTreeMap<String, Vec<f64>>,
    /// The first set's earliest exposure time, seconds (the source's clock).
    origin_s: Option<f64>,
    /// Sets written.
    sets: usize,
}

impl RecordingWriter {
    /// Starts a recording into `target` with one sub-folder per camera of `names`.
    ///
    /// # Errors
    /// [`FileError::Write`] when the staging folder or a camera's folder cannot be made.
    pub fn create(target: &Path, names: &[String]) -> Result<Self, FileError> {
        let staged = StagedFolder::new(target)?;
        for name in names {
            create_folder(&staged.path().join(name))?;
        }
        Ok(Self {
            staged,
            names: names.to_vec(),
            times: names.iter().map(|n| (n.clone(), Vec::new())).collect(),
            origin_s: None,
            sets: 0,
        })
    }

    /// The staging folder: where files that go beside the frames (`rig.json`, `tool.json`)
    /// are written before [`RecordingWriter::finish`] puts everything in place.
    #[must_use]
    pub fn staging(&self) -> &Path {
        self.staged.path()
    }

    /// Sets written so far.
    #[must_use]
    pub fn sets(&self) -> usize {
        self.sets
    }

    /// Writes one set: each camera's frame with its exposure time (seconds, the source's
    /// clock), in the order of the names given to [`RecordingWriter::create`]; cameras in
    /// parallel.
    ///
    /// # Errors
    /// [`FileError::Invalid`] when the set does not hold one frame per camera;
    /// [`FileError::Write`] when a frame cannot be written.
    pub fn push(&mut self, frames: &[(&GrayFrame, f64)]) -> Result<(), FileError> {
        if frames.len() != self.names.len() {
            return Err(FileError::Invalid {
                path: self.staged.path().to_path_buf(),
                message: format!(
                    "set {}: {} frames for {} cameras",
                    self.sets,
                    frames.len(),
                    self.names.len()
                ),
            });
        }
        let file = frame_file_name(self.sets);
        let root = self.staged.path();
        frames
            .par_iter()
            .zip(&self.names)
            .try_for_each(|((image, _), name)| {
                write_frame_png(&root.join(name).join(&file), image)
            })?;
        let origin_s = *self
            .origin_s
            .get_or_insert_with(|| frames.iter().map(|(_, t)| *t).fold(f64::INFINITY, f64::min));
        for ((_, time_s), name) in frames.iter().zip(&self.names) {
            if let Some(times) = self.times.get_mut(name) {
                times.push(time_s - origin_s);
            }
        }
        self.sets += 1;
        Ok(())
    }

    /// Writes the timestamps and the rate and puts the folder in place; returns it.
    ///
    /// # Errors
    /// [`FileError::Write`]; nothing is left in place then.
    pub fn finish(self, fps: f64) -> Result<PathBuf, FileError> {
        let root = self.staged.path();
        write_atomically(
            &root.join(TIMESTAMPS_FILE),
            timestamps_text(&self.times).as_bytes(),
        )?;
        write_recording_info(root, fps)?;
        self.staged.commit()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::io::recording::open_recording;

    fn frame(level: u8) -> GrayFrame {
        GrayFrame::Eight(image::GrayImage::from_pixel(8, 6, image::Luma([level])))
    }

    #[test]
    fn a_finished_recording_reads_back_with_its_times_and_rate() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        let names = vec!["cam0".to_string(), "cam1".to_string()];
        let mut writer = RecordingWriter::create(&target, &names).unwrap();
        assert!(!target.exists(), "nothing in place before finish");
        for set in 0..3u8 {
            let (a, b) = (frame(set), frame(100 + set));
            let t = 10.0 + f64::from(set) / 30.0;
            writer.push(&[(&a, t), (&b, t + 0.001)]).unwrap();
        }
        assert!(
            writer.push(&[(&frame(0), 0.0)]).is_err(),
            "a set missing a camera"
        );
        assert_eq!(writer.sets(), 3);
        assert_eq!(writer.finish(30.0).unwrap(), target);
        let recording = open_recording(&target, None).unwrap();
        assert_eq!(recording.frame_count(), 3);
        assert_eq!(recording.cameras.len(), 2);
        assert_eq!(recording.fps, 30.0);
        let times = std::fs::read_to_string(target.join(TIMESTAMPS_FILE)).unwrap();
        assert!(
            times.starts_with("camera,frame,time_s\ncam0,0,0"),
            "{times}"
        );
        assert!(times.contains("cam1,2,0.0676"), "{times}");
    }

    #[test]
    fn an_unfinished_recording_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        let mut writer = RecordingWriter::create(&target, &["cam0".to_string()]).unwrap();
        writer.push(&[(&frame(7), 0.0)]).unwrap();
        drop(writer);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
