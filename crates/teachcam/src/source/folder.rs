//! A recording folder as a source: PNG sub-folders and video files, one per camera
//! (CONTRACT.md, "Recording").
//!
//! Frame `i` of every camera belongs to set `i` (the frames of a recording are triggered
//! together, or were paired when recorded), and every camera must have as many frames as the
//! others. When `timestamps.csv` gives each frame's exposure time, the times are carried with
//! the frames (a set's time is their mean), and frame `i` stays set `i` whatever the times say
//! (a camera whose stamps lie apart from the others' is said by
//! [`RecordingClock::stamp_offsets`], not re-paired); only cameras of different lengths are
//! paired by time ([`super::pairing`]).
//! The rate is `--fps`, else `recording.json`, else the videos' common rate, else 30 Hz.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::pairing::{PairBy, Pairer};
use super::video::{VideoReader, probe};
use super::{
    CameraFrame, FrameData, FrameSet, FrameSource, SourceCamera, SourceError, SourceStats,
};
use crate::io::recording::{CameraMedia, DEFAULT_FPS, list_recording};

#[derive(Debug)]
enum Stream {
    Images { files: Vec<PathBuf>, next: usize },
    Video(Box<VideoReader>),
}

/// A recording folder, read frame set by frame set.
#[derive(Debug)]
pub struct FolderSource {
    root: PathBuf,
    cameras: Vec<SourceCamera>,
    streams: Vec<Stream>,
    frames: Vec<usize>,
    ended: Vec<bool>,
    times: Option<BTreeMap<String, Vec<f64>>>,
    pairer: Option<Pairer>,
    fps: f64,
    len_hint: Option<usize>,
    next_index: usize,
    failed: bool,
}

/// The rate: `given` (`--fps`, else recording.json), else the videos' common rate, else
/// [`DEFAULT_FPS`].
fn rate(given: Option<f64>, video_rates: &[f64]) -> f64 {
    let common_video_rate = video_rates.first().copied().filter(|first| {
        video_rates
            .iter()
            .all(|r| (r - first).abs() <= 1e-6 * first)
    });
    given.or(common_video_rate).unwrap_or(DEFAULT_FPS)
}

/// A recording folder's clock, read without decoding a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingClock {
    /// Frames per second, as [`FolderSource`] takes it.
    pub fps: f64,
    /// Frames of the shortest camera, when every camera's length is known.
    pub frames: Option<usize>,
    /// Each camera's frame times from `timestamps.csv`, seconds, when the file is present.
    pub timestamps: Option<BTreeMap<String, Vec<f64>>>,
}

impl RecordingClock {
    /// Frame `frame`'s time: the mean of `cameras`' times in `timestamps.csv`, as a set of
    /// [`FolderSource`] has (cameras without times left out), else `frame / fps`.
    #[must_use]
    pub fn time_s(&self, frame: usize, cameras: &[&str]) -> f64 {
        let times: Vec<f64> = self
            .timestamps
            .iter()
            .flat_map(|t| cameras.iter().filter_map(|c| t.get(*c)?.get(frame)))
            .copied()
            .collect();
        if times.is_empty() {
            frame as f64 / self.fps
        } else {
            times.iter().sum::<f64>() / times.len() as f64
        }
    }

    /// Per camera of `timestamps.csv`, the median over frames of its time minus the frame's
    /// median time over every camera, seconds: how far its stamps lie from the others' (of
    /// three cameras, one stamped half a period late reads `0.5 / fps`). Empty without
    /// timestamps or with one camera.
    #[must_use]
    pub fn stamp_offsets(&self) -> BTreeMap<String, f64> {
        let Some(times) = self.timestamps.as_ref().filter(|t| t.len() > 1) else {
            return BTreeMap::new();
        };
        let frames = times.values().map(Vec::len).min().unwrap_or(0);
        let middle: Vec<f64> = (0..frames)
            .filter_map(|i| {
                crate::stats::median(&times.values().map(|t| t[i]).collect::<Vec<f64>>())
            })
            .collect();
        times
            .iter()
            .filter_map(|(camera, t)| {
                let apart: Vec<f64> = middle.iter().zip(t).map(|(m, t)| t - m).collect();
                Some((camera.clone(), crate::stats::median(&apart)?))
            })
            .collect()
    }
}

/// The clock of a recording folder: its rate, length and frame times (CONTRACT.md,
/// "Recording"), videos probed but not decoded.
///
/// # Errors
/// [`SourceError`] naming the folder, the camera or the video.
pub fn recording_clock(
    root: &Path,
    fps_override: Option<f64>,
) -> Result<RecordingClock, SourceError> {
    let listing = list_recording(root, fps_override)?;
    let mut lengths = Vec::new();
    let mut video_rates = Vec::new();
    for entry in &listing.cameras {
        match &entry.media {
            CameraMedia::Images(files) => lengths.push(Some(files.len())),
            CameraMedia::Video(path) => {
                let info = probe(path, &entry.name)?;
                lengths.push(info.frames);
                video_rates.extend(info.fps);
            }
        }
    }
    Ok(RecordingClock {
        fps: rate(listing.fps, &video_rates),
        frames: lengths
            .into_iter()
            .collect::<Option<Vec<usize>>>()
            .and_then(|l| l.into_iter().min()),
        timestamps: listing.timestamps,
    })
}

impl FolderSource {
    /// Lists a recording folder and starts a decoder for each video camera.
    ///
    /// # Errors
    /// [`SourceError`] naming the folder, the camera or the video.
    pub fn open(root: &Path, fps_override: Option<f64>) -> Result<Self, SourceError> {
        let listing = list_recording(root, fps_override)?;
        let videos = listing
            .cameras
            .iter()
            .filter(|c| matches!(c.media, CameraMedia::Video(_)))
            .count();
        let threads = super::video::decoder_threads(videos);
        let mut cameras = Vec::new();
        let mut streams = Vec::new();
        let mut lengths = Vec::new();
        let mut video_rates = Vec::new();
        for entry in &listing.cameras {
            match &entry.media {
                CameraMedia::Images(files) => {
                    lengths.push(Some(files.len()));
                    cameras.push(SourceCamera {
                        name: entry.name.clone(),
                        size: None,
                    });
                    streams.push(Stream::Images {
                        files: files.clone(),
                        next: 0,
                    });
                }
                CameraMedia::Video(path) => {
                    let info = probe(path, &entry.name)?;
                    lengths.push(info.frames);
                    video_rates.extend(info.fps);
                    cameras.push(SourceCamera {
                        name: entry.name.clone(),
                        size: Some(info.size),
                    });
                    streams.push(Stream::Video(Box::new(VideoReader::start(
                        path, info, threads,
                    )?)));
                }
            }
        }
        let fps = rate(listing.fps, &video_rates);
        let len_hint = lengths
            .iter()
            .copied()
            .collect::<Option<Vec<usize>>>()
            .and_then(|l| l.into_iter().min());
        let equal_lengths = lengths.windows(2).all(|w| w[0].is_some() && w[0] == w[1]);
        let pairer = listing.timestamps.as_ref().map(|_| {
            Pairer::new(
                cameras.len(),
                if equal_lengths {
                    PairBy::Sequence
                } else {
                    PairBy::Timestamp {
                        period_s: 1.0 / fps,
                    }
                },
            )
        });
        let n = cameras.len();
        Ok(Self {
            root: listing.root,
            cameras,
            streams,
            frames: vec![0; n],
            ended: vec![false; n],
            times: listing.timestamps,
            pairer,
            fps,
            len_hint,
            next_index: 0,
            failed: false,
        })
    }

    /// The folder.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Camera `c`'s next frame, `None` at its end.
    fn next_frame(&mut self, c: usize) -> Option<Result<CameraFrame, SourceError>> {
        let frame = self.frames[c];
        let data = match &mut self.streams[c] {
            Stream::Images { files, next } => {
                let file = files.get(*next)?.clone();
                *next += 1;
                FrameData::Png(file)
            }
            Stream::Video(reader) => match reader.next_frame()? {
                Ok(image) => FrameData::Decoded(Arc::new(image)),
                Err(e) => return Some(Err(e)),
            },
        };
        let name = &self.cameras[c].name;
        let time_s = match &self.times {
            Some(times) => match times.get(name).and_then(|t| t.get(frame)) {
                Some(&t) => t,
                None => {
                    return Some(Err(SourceError::Video {
                        path: self.root.join(crate::io::recording::TIMESTAMPS_FILE),
                        message: format!("no time for camera {name}, frame {frame}"),
                    }));
                }
            },
            None => frame as f64 / self.fps,
        };
        self.frames[c] += 1;
        Some(Ok(CameraFrame {
            frame,
            time_s,
            sequence: Some(frame as u64),
            data,
        }))
    }

    fn count_error(&self) -> SourceError {
        let shortest = (0..self.cameras.len())
            .min_by_key(|&c| self.frames[c])
            .unwrap_or(0);
        let longest = (0..self.cameras.len())
            .max_by_key(|&c| self.frames[c])
            .unwrap_or(0);
        SourceError::FrameCount {
            camera: self.cameras[shortest].name.clone(),
            frames: self.frames[shortest],
            other: self.cameras[longest].name.clone(),
            other_frames: self.frames[longest],
        }
    }
}

impl FrameSource for FolderSource {
    fn cameras(&self) -> &[SourceCamera] {
        &self.cameras
    }

    fn fps(&self) -> f64 {
        self.fps
    }

    fn len_hint(&self) -> Option<usize> {
        self.len_hint
    }

    fn is_live(&self) -> bool {
        false
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        self.next_any()
    }

    fn stats(&self) -> SourceStats {
        self.stats_inner()
    }
}

impl FolderSource {
    fn next_any(&mut self) -> Option<Result<FrameSet, SourceError>> {
        if self.failed {
            return None;
        }
        loop {
            if let Some(set) = self.pairer.as_mut().and_then(Pairer::pop) {
                let index = self.next_index;
                self.next_index += 1;
                return Some(Ok(FrameSet::new(index, None, set)));
            }
            if self.ended.iter().all(|e| *e) {
                return None;
            }
            let mut round = Vec::with_capacity(self.cameras.len());
            for c in 0..self.cameras.len() {
                if self.ended[c] {
                    round.push(None);
                    continue;
                }
                match self.next_frame(c) {
                    Some(Ok(frame)) => round.push(Some(frame)),
                    Some(Err(e)) => {
                        self.failed = true;
                        return Some(Err(e));
                    }
                    None => {
                        self.ended[c] = true;
                        round.push(None);
                    }
                }
            }
            match self.pairer.as_mut() {
                Some(pairer) => {
                    for (c, frame) in round.into_iter().enumerate() {
                        match frame {
                            Some(frame) => pairer.push(c, frame),
                            None => pairer.end(c),
                        }
                    }
                }
                None => {
                    let delivered = round.iter().filter(|f| f.is_some()).count();
                    if delivered == 0 {
                        return None;
                    }
                    if delivered < round.len() {
                        self.failed = true;
                        return Some(Err(self.count_error()));
                    }
                    let index = self.next_index;
                    self.next_index += 1;
                    return Some(Ok(FrameSet::new(index, None, round)));
                }
            }
        }
    }

    fn stats_inner(&self) -> SourceStats {
        self.pairer.as_ref().map_or_else(
            || SourceStats {
                unpaired_frames: vec![0; self.cameras.len()],
                ..SourceStats::default()
            },
            |p| p.stats().clone(),
        )
    }
}
