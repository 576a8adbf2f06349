//! The simulator as a live source: a scenario's frames delivered at a fixed rate, as a rig of
//! triggered cameras would deliver them.
//!
//! Ray-casting a 1280×1024 view costs far more than tracking it, so the scenario's first
//! [`SimConfig::cached_frames`] frames are rendered before the clock starts and then played
//! forwards and backwards (a continuous back-and-forth stroke): the source measures the
//! pipeline, not the renderer. A clock thread exposes set `k` at `start + k / fps` and hands it
//! to a queue of [`SimConfig::queue_sets`] sets (a camera driver's buffers); when the queue is
//! full the set is dropped and counted, so a consumer that cannot keep up shows drops instead of
//! slowing the cameras down. The rendered exposure can be scaled while the source runs
//! ([`SimExposure`]): every level is multiplied by the scale and clipped at full scale, as a
//! longer exposure of the same scene collects proportionally more light.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, TrySendError, sync_channel};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::{
    CameraFrame, FrameData, FrameSet, FrameSource, SourceCamera, SourceError, SourceStats,
};
use crate::io::recording::GrayFrame;
use crate::sim::{Scenario, Scene, build_scene, render_frame};

/// Options of the simulated live source.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Frames per second delivered (60: the acceptance rate of `teachcam live`).
    pub fps: f64,
    /// Frames rendered ahead and played back and forth (60: a second of frames at 60 Hz,
    /// ≈ 236 MB for the paper's three 1280×1024 cameras).
    pub cached_frames: usize,
    /// Sets the queue holds before new ones are dropped (4, as a camera driver's buffers).
    pub queue_sets: usize,
    /// Seed of the scene's glints and the images' noise.
    pub seed: u64,
    /// Stop after this many sets (`None`: until the consumer stops).
    pub max_sets: Option<usize>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            fps: 60.0,
            cached_frames: 60,
            queue_sets: 4,
            seed: 1,
            max_sets: None,
        }
    }
}

/// The scenario's scene as the source renders it (its rig and tool are the ones to track with).
#[must_use]
pub fn scene(scenario: Scenario, config: &SimConfig) -> Scene {
    build_scene(scenario, config.seed)
}

/// The simulated rig, delivering frames on its own clock.
#[derive(Debug)]
pub struct SimSource {
    cameras: Vec<SourceCamera>,
    fps: f64,
    sets: Receiver<FrameSet>,
    dropped: Arc<AtomicUsize>,
    exposure: SimExposure,
}

/// A handle on a running [`SimSource`]'s exposure: a scale of the rendered levels (1: as
/// rendered), applied to the sets exposed after it is set.
#[derive(Debug, Clone)]
pub struct SimExposure {
    scale_bits: Arc<AtomicU64>,
}

impl SimExposure {
    /// The largest scale accepted: beyond it every marker and most of the background saturate.
    pub const MAX_SCALE: f64 = 16.0;

    fn new() -> Self {
        Self {
            scale_bits: Arc::new(AtomicU64::new(1.0_f64.to_bits())),
        }
    }

    /// The current scale.
    #[must_use]
    pub fn scale(&self) -> f64 {
        f64::from_bits(self.scale_bits.load(Ordering::Relaxed))
    }

    /// Sets the scale; `None` (unchanged) unless it is finite and within `(0, MAX_SCALE]`.
    pub fn set_scale(&self, scale: f64) -> Option<f64> {
        (scale.is_finite() && scale > 0.0 && scale <= Self::MAX_SCALE).then(|| {
            self.scale_bits.store(scale.to_bits(), Ordering::Relaxed);
            scale
        })
    }
}

/// The frame with every level times `scale`, rounded and clipped at full scale.
#[must_use]
pub fn scale_levels(frame: &GrayFrame, scale: f64) -> GrayFrame {
    match frame {
        GrayFrame::Eight(image) => {
            let mut image = image.clone();
            for p in image.iter_mut() {
                *p = (f64::from(*p) * scale + 0.5).min(255.0) as u8;
            }
            GrayFrame::Eight(image)
        }
        GrayFrame::Sixteen(image) => {
            let mut image = image.clone();
            for p in image.iter_mut() {
                *p = (f64::from(*p) * scale + 0.5).min(65535.0) as u16;
            }
            GrayFrame::Sixteen(image)
        }
    }
}

/// Which cached frame set `k` shows: forwards, then backwards, so the motion never jumps.
fn ping_pong(k: usize, cached: usize) -> usize {
    if cached <= 1 {
        return 0;
    }
    let period = 2 * cached - 2;
    let m = k % period;
    if m < cached { m } else { period - m }
}

impl SimSource {
    /// Renders the cached frames (in parallel), then starts the clock.
    ///
    /// # Errors
    /// [`SourceError::Spec`] for a rate that is not positive or a scenario without frames.
    pub fn start(scenario: Scenario, config: &SimConfig) -> Result<Self, SourceError> {
        let spec_error = |reason: String| SourceError::Spec {
            given: format!("sim:{}", scenario.name()),
            reason,
        };
        if !(config.fps.is_finite() && config.fps > 0.0 && config.fps <= 10_000.0) {
            return Err(spec_error(format!(
                "frame rate must be within 0..10000 Hz, got {}",
                config.fps
            )));
        }
        let scene = scene(scenario, config);
        let cached = config.cached_frames.clamp(1, scene.truth.len().max(1));
        let frames: Vec<Vec<Arc<GrayFrame>>> = (0..cached)
            .into_par_iter()
            .map(|f| {
                render_frame(&scene, f, config.seed)
                    .into_iter()
                    .map(|view| Arc::new(GrayFrame::Eight(view.image)))
                    .collect()
            })
            .collect();
        if frames.iter().any(|f| f.len() != scene.rig.cameras.len()) {
            return Err(spec_error("the scenario's truth has a gap".to_string()));
        }
        let cameras = scene
            .rig
            .cameras
            .iter()
            .map(|c| SourceCamera {
                name: c.name.clone(),
                size: Some((c.image_size.width, c.image_size.height)),
            })
            .collect();
        let (sender, sets) = sync_channel(config.queue_sets.max(1));
        let dropped = Arc::new(AtomicUsize::new(0));
        let counter = Arc::clone(&dropped);
        let fps = config.fps;
        let max_sets = config.max_sets;
        let exposure = SimExposure::new();
        let scale = exposure.clone();
        std::thread::spawn(move || {
            let period = Duration::from_secs_f64(1.0 / fps);
            let start = Instant::now();
            for k in 0.. {
                if max_sets.is_some_and(|m| k >= m) {
                    break;
                }
                let due = start + period.mul_f64(k as f64);
                if let Some(wait) = due.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
                let cached_frame = &frames[ping_pong(k, frames.len())];
                let exposure_scale = scale.scale();
                let time_s = k as f64 / fps;
                let set = FrameSet::new(
                    k,
                    Some(due),
                    cached_frame
                        .iter()
                        .map(|image| {
                            Some(CameraFrame {
                                frame: k,
                                time_s,
                                sequence: Some(k as u64),
                                data: FrameData::Decoded(if exposure_scale == 1.0 {
                                    Arc::clone(image)
                                } else {
                                    Arc::new(scale_levels(image, exposure_scale))
                                }),
                            })
                        })
                        .collect(),
                );
                match sender.try_send(set) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => {
                        counter.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(TrySendError::Disconnected(_)) => break,
                }
            }
        });
        Ok(Self {
            cameras,
            fps,
            sets,
            dropped,
            exposure,
        })
    }

    /// The handle that scales the exposure of the sets to come.
    #[must_use]
    pub fn exposure(&self) -> SimExposure {
        self.exposure.clone()
    }
}

impl FrameSource for SimSource {
    fn cameras(&self) -> &[SourceCamera] {
        &self.cameras
    }

    fn fps(&self) -> f64 {
        self.fps
    }

    fn len_hint(&self) -> Option<usize> {
        None
    }

    fn is_live(&self) -> bool {
        true
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        self.sets.recv().ok().map(Ok)
    }

    fn stats(&self) -> SourceStats {
        SourceStats {
            dropped_sets: self.dropped.load(Ordering::Relaxed),
            unpaired_frames: vec![0; self.cameras.len()],
            max_pair_spread_s: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn playback_goes_back_and_forth_without_jumps() {
        let shown: Vec<usize> = (0..9).map(|k| ping_pong(k, 4)).collect();
        assert_eq!(shown, vec![0, 1, 2, 3, 2, 1, 0, 1, 2]);
        assert_eq!(ping_pong(5, 1), 0);
    }

    #[test]
    fn exposure_scales_levels_and_clips_at_full_scale() {
        let image = image::GrayImage::from_raw(3, 1, vec![10, 100, 200]).unwrap();
        let GrayFrame::Eight(scaled) = scale_levels(&GrayFrame::Eight(image), 2.0) else {
            panic!("8-bit in, 8-bit out");
        };
        assert_eq!(scaled.as_raw(), &vec![20, 200, 255]);
        let exposure = SimExposure::new();
        assert_eq!(exposure.scale(), 1.0);
        assert_eq!(exposure.set_scale(0.5), Some(0.5));
        assert_eq!(exposure.set_scale(0.0), None);
        assert_eq!(exposure.set_scale(f64::NAN), None);
        assert_eq!(exposure.set_scale(100.0), None);
        assert_eq!(exposure.scale(), 0.5);
    }
}
