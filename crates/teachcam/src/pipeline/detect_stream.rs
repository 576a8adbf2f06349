//! Detection over a source's frames, set by set: decode, size check and detect, every camera
//! of a batch of sets in parallel (a file source is read a few sets per core ahead, a live
//! source one set at a time so that no set waits for the next).

use std::collections::VecDeque;
use std::sync::Arc;

use rayon::prelude::*;

use super::{CameraSetup, PipelineError};
use crate::detect::learn::FrameSample;
use crate::detect::sketch::Sketch;
use crate::detect::{
    Blob, CameraDetections, DetectConfig, DetectError, DetectedSet, GrayView, RoundnessChoices,
    detect, detect_choices,
};
use crate::io::recording::GrayFrame;
use crate::source::{CameraFrame, FrameSet, FrameSource, SourceError, SourceStats};

/// What a stream finds in one camera's frame: its blobs ([`Vec<Blob>`], by [`detect`]) or its
/// blobs for every roundness floor from the configuration's up ([`RoundnessChoices`], by
/// [`detect_choices`]).
pub trait FrameDetections: Sized + Send {
    /// Detects `image` with `config`.
    ///
    /// # Errors
    /// As [`detect`].
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError>;
}

/// What can be detected from a frame's [`Sketch`] as from the frame itself.
pub trait FromSketch: FrameDetections {
    /// What [`FrameDetections::detect_frame`] gives on the sketched frame.
    ///
    /// # Errors
    /// As [`FrameDetections::detect_frame`]; [`DetectError::Sketch`] when `config` reads
    /// pixels the sketch did not keep.
    fn from_sketch(sketch: &Sketch, config: &DetectConfig) -> Result<Self, DetectError>;
}

impl FrameDetections for Vec<Blob> {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        match image {
            GrayFrame::Eight(i) => detect(i, config),
            GrayFrame::Sixteen(i) => detect(i, config),
        }
    }
}

impl FromSketch for Vec<Blob> {
    fn from_sketch(sketch: &Sketch, config: &DetectConfig) -> Result<Self, DetectError> {
        sketch.detect(config)
    }
}

impl FrameDetections for FrameSample {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        match image {
            GrayFrame::Eight(i) => FrameSample::detect(GrayView::new(i), config),
            GrayFrame::Sixteen(i) => FrameSample::detect(GrayView::new(i), config),
        }
    }
}

impl FromSketch for FrameSample {
    fn from_sketch(sketch: &Sketch, config: &DetectConfig) -> Result<Self, DetectError> {
        sketch.sample(config)
    }
}

impl FrameDetections for RoundnessChoices {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        match image {
            GrayFrame::Eight(i) => detect_choices(GrayView::new(i), config),
            GrayFrame::Sixteen(i) => detect_choices(GrayView::new(i), config),
        }
    }
}

impl FromSketch for RoundnessChoices {
    fn from_sketch(sketch: &Sketch, config: &DetectConfig) -> Result<Self, DetectError> {
        sketch.detect_choices(config)
    }
}

impl FrameDetections for Sketch {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        Ok(Sketch::of(image, config))
    }
}

/// One camera's frame detected: its size and blobs, or nothing when it had no frame.
type DetectedFrame<B> = Result<Option<((u32, u32), CameraDetections<B>)>, PipelineError>;

/// Detection over a source's frames, set by set; `B` is what each camera's frame gives
/// ([`FrameDetections`]).
#[derive(Debug)]
pub struct DetectStream<'s, B = Vec<Blob>> {
    source: &'s mut dyn FrameSource,
    /// For each detected camera: its position among the source's cameras, its configuration.
    cameras: Vec<(usize, DetectConfig)>,
    sizes: Vec<Option<(u32, u32)>>,
    batch: usize,
    ready: VecDeque<DetectedSet<B>>,
    done: bool,
}

impl<'s> DetectStream<'s> {
    /// Detects these cameras of `source`, in this order.
    ///
    /// # Errors
    /// [`PipelineError::MissingCamera`] when a name is not among the source's cameras.
    pub fn new(
        source: &'s mut dyn FrameSource,
        cameras: Vec<CameraSetup>,
    ) -> Result<Self, PipelineError> {
        Self::detecting(source, cameras)
    }

    /// Every camera of the source, each with the same configuration and its first frame's size.
    ///
    /// # Errors
    /// Never in practice (every name is the source's own); kept for one signature.
    pub fn all_cameras(
        source: &'s mut dyn FrameSource,
        config: &DetectConfig,
    ) -> Result<Self, PipelineError> {
        let cameras = source
            .cameras()
            .iter()
            .map(|c| CameraSetup {
                name: c.name.clone(),
                detect: config.clone(),
                size: None,
            })
            .collect();
        Self::new(source, cameras)
    }
}

impl<'s, B: FrameDetections> DetectStream<'s, B> {
    /// Detects these cameras of `source`, in this order, each frame into a `B`.
    ///
    /// # Errors
    /// [`PipelineError::MissingCamera`] when a name is not among the source's cameras.
    pub fn detecting(
        source: &'s mut dyn FrameSource,
        cameras: Vec<CameraSetup>,
    ) -> Result<Self, PipelineError> {
        let names: Vec<String> = source.cameras().iter().map(|c| c.name.clone()).collect();
        let mut detected = Vec::new();
        let mut sizes = Vec::new();
        for CameraSetup {
            name,
            detect: config,
            size,
        } in cameras
        {
            let Some(position) = names.iter().position(|n| *n == name) else {
                return Err(PipelineError::MissingCamera {
                    camera: name,
                    found: names.join(", "),
                });
            };
            let known = source.cameras()[position].size;
            if let (Some(expected), Some(known)) = (size, known)
                && expected != known
            {
                return Err(SourceError::FrameSize {
                    camera: name,
                    frame: 0,
                    size: known,
                    expected,
                }
                .into());
            }
            detected.push((position, config));
            sizes.push(size.or(known));
        }
        let batch = if source.is_live() {
            1
        } else {
            4 * rayon::current_num_threads()
        };
        Ok(Self {
            source,
            cameras: detected,
            sizes,
            batch,
            ready: VecDeque::new(),
            done: false,
        })
    }

    /// The source's nominal rate.
    #[must_use]
    pub fn fps(&self) -> f64 {
        self.source.fps()
    }

    /// The number of sets when the source knows it.
    #[must_use]
    pub fn len_hint(&self) -> Option<usize> {
        self.source.len_hint()
    }

    /// What the source dropped or left unpaired so far.
    #[must_use]
    pub fn stats(&self) -> SourceStats {
        self.source.stats()
    }

    /// The names of the detected cameras, in the order of [`DetectedSet::cameras`].
    #[must_use]
    pub fn camera_names(&self) -> Vec<String> {
        self.cameras
            .iter()
            .map(|(p, _)| self.source.cameras()[*p].name.clone())
            .collect()
    }

    /// The sets detected and not yet taken (the rest of the batch the last [`Iterator::next`]
    /// read), in order.
    pub(crate) fn take_ready(&mut self) -> Vec<DetectedSet<B>> {
        self.ready.drain(..).collect()
    }

    /// Reads, decodes and detects the next batch of sets, in order.
    fn next_batch(&mut self) -> Result<Vec<DetectedSet<B>>, PipelineError> {
        let mut sets: Vec<FrameSet> = Vec::with_capacity(self.batch);
        while sets.len() < self.batch {
            match self.source.next_set() {
                Some(set) => sets.push(set?),
                None => {
                    self.done = true;
                    break;
                }
            }
        }
        let names: Vec<String> = self.camera_names();
        let jobs: Vec<(usize, usize)> = (0..sets.len())
            .flat_map(|s| (0..self.cameras.len()).map(move |c| (s, c)))
            .collect();
        let sizes = &self.sizes;
        let cameras = &self.cameras;
        let frame_of =
            |(s, c): (usize, usize)| sets[s].cameras.get(cameras[c].0).and_then(Option::as_ref);
        let detect = |(_, c): (usize, usize),
                      frame: &CameraFrame,
                      image: Result<Arc<GrayFrame>, SourceError>|
         -> DetectedFrame<B> {
            let name = &names[c];
            let image = image?;
            let size = image.dimensions();
            let blobs =
                B::detect_frame(&image, &cameras[c].1).map_err(|source| PipelineError::Detect {
                    camera: name.clone(),
                    frame: frame.frame,
                    source,
                })?;
            // Its memory kept by this thread for the next frame decoded here.
            if let Ok(image) = Arc::try_unwrap(image) {
                image.recycle();
            }
            Ok(Some((
                size,
                CameraDetections {
                    camera: name.clone(),
                    frame: frame.frame,
                    time_s: frame.time_s,
                    blobs,
                },
            )))
        };
        // Frames two at a time: two PNG files are decoded side by side (their inflates'
        // look-up chains fill each other's waits: 1.2 times one at a time on OpenCV's
        // frames).
        let results: Vec<DetectedFrame<B>> = jobs
            .par_chunks(2)
            .flat_map_iter(|pair| {
                let frames: Vec<Option<&CameraFrame>> =
                    pair.iter().map(|&job| frame_of(job)).collect();
                let images: Vec<Option<Result<Arc<GrayFrame>, SourceError>>> =
                    match (pair, frames.as_slice()) {
                        (&[(_, c_a), (_, c_b)], &[Some(a), Some(b)]) => CameraFrame::decode_pair([
                            (a, &names[c_a], sizes[c_a]),
                            (b, &names[c_b], sizes[c_b]),
                        ])
                        .map(Some)
                        .into(),
                        _ => pair
                            .iter()
                            .zip(&frames)
                            .map(|(&(_, c), frame)| frame.map(|f| f.decode(&names[c], sizes[c])))
                            .collect(),
                    };
                pair.iter()
                    .zip(frames)
                    .zip(images)
                    .map(|((&job, frame), image)| match (frame, image) {
                        (Some(frame), Some(image)) => detect(job, frame, image),
                        _ => Ok(None),
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut results = results.into_iter();
        let mut detected = Vec::with_capacity(sets.len());
        for set in &sets {
            let mut cameras = Vec::with_capacity(self.cameras.len());
            for c in 0..self.cameras.len() {
                let result = results.next().ok_or_else(|| {
                    PipelineError::Config("internal: a detection went missing".into())
                })??;
                let Some((size, detections)) = result else {
                    cameras.push(None);
                    continue;
                };
                // Without a rig the camera's first frame sets its size: later frames must agree.
                match self.sizes[c] {
                    Some(expected) if expected != size => {
                        return Err(SourceError::FrameSize {
                            camera: detections.camera,
                            frame: detections.frame,
                            size,
                            expected,
                        }
                        .into());
                    }
                    Some(_) => {}
                    None => self.sizes[c] = Some(size),
                }
                cameras.push(Some(detections));
            }
            detected.push(DetectedSet {
                index: set.index,
                time_s: set.time_s,
                exposed_at: set.exposed_at,
                cameras,
            });
        }
        Ok(detected)
    }
}

impl<B: FrameDetections> Iterator for DetectStream<'_, B> {
    type Item = Result<DetectedSet<B>, PipelineError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.ready.is_empty() && !self.done {
            match self.next_batch() {
                Ok(sets) => self.ready.extend(sets),
                Err(e) => {
                    self.done = true;
                    self.ready.clear();
                    return Some(Err(e));
                }
            }
        }
        self.ready.pop_front().map(Ok)
    }
}
