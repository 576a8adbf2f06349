//! The pipeline thread: the source's frames through the library's conductor
//! ([`TrackStream`]), each tracked frame counted, added to the take, handed to a recording in
//! progress and, downscaled, to the live view.
//!
//! A recording folder plays at its own rate (paced here, as a camera would deliver it) and
//! starts again at its end; the simulator and cameras run on their own clocks. A change of
//! threshold rebuilds the stream (the tracker's state starts afresh); a change of a camera's
//! exposure reopens the cameras. An error on a frame (a threshold so low that the detector
//! refuses the image) is shown in the status and the stream restarts with the next frame.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use std::collections::VecDeque;

use teachcam::detect::{DetectConfig, Threshold};
use teachcam::pipeline::recording::DetectOptions;
use teachcam::pipeline::{DetectStream, PipelineError, StreamOptions, TrackStream};
use teachcam::source::sim::{SimConfig, SimSource};
use teachcam::source::{
    CameraFrame, FrameData, FrameSet, FrameSource, SourceCamera, SourceError, SourceSpec,
    SourceStats, open_source,
};
use teachcam::track::gates::GateOverrides;

use super::preview::{live_message, view_message};
use super::state::{CameraCounts, ExposureControl, Studio};
use super::{StudioConfig, StudioError};

/// Frames per second of the studio's simulator: a camera rate, so that the live view, not
/// the renderer, sets the pace (`teachcam live` defaults to 60).
pub const SIM_FPS: f64 = 30.0;

/// A source opened, with how its exposure is controlled.
#[derive(Debug)]
pub struct Opened {
    /// The source.
    pub source: Box<dyn FrameSource>,
    /// Its exposure control.
    pub exposure: ExposureControl,
}

/// Opens the configured source (the simulator at [`SIM_FPS`] unless a rate is given).
///
/// # Errors
/// [`StudioError::Pipeline`] naming the folder, file or device that cannot be opened.
pub fn open(config: &StudioConfig) -> Result<Opened, StudioError> {
    let source_error = |e: SourceError| StudioError::Pipeline(PipelineError::Source(e));
    match &config.source {
        SourceSpec::Sim(scenario) => {
            let sim = SimConfig {
                fps: config.source_config.fps.unwrap_or(SIM_FPS),
                max_sets: config.source_config.max_sets,
                ..config.source_config.sim.clone()
            };
            let source = SimSource::start(*scenario, &sim).map_err(source_error)?;
            let exposure = ExposureControl::Sim(source.exposure());
            Ok(Opened {
                source: Box::new(source),
                exposure,
            })
        }
        SourceSpec::V4l2(_) => Ok(Opened {
            source: open_source(&config.source, &config.source_config).map_err(source_error)?,
            exposure: ExposureControl::Camera,
        }),
        SourceSpec::Folder(_) => Ok(Opened {
            source: open_source(&config.source, &config.source_config).map_err(source_error)?,
            exposure: ExposureControl::Unsupported,
        }),
    }
}

/// Sets the feed keeps for the live view and the recorder: the stream emits a set once its
/// status is final, up to its lag (and a batch) after the feed delivered it.
const KEPT_SETS: usize = 64;

/// The source as the stream reads it: a finite source paced at its rate and decoded here (so
/// that the live view has the pixels detection saw, decoded once), the latest sets kept for
/// the live view and the recorder.
#[derive(Debug)]
struct Feed {
    source: Box<dyn FrameSource>,
    cameras: Vec<SourceCamera>,
    /// For a finite source: when its first set was due.
    paced_from: Option<Instant>,
    delivered: usize,
    last: Arc<Mutex<VecDeque<FrameSet>>>,
}

impl Feed {
    fn new(source: Box<dyn FrameSource>, last: Arc<Mutex<VecDeque<FrameSet>>>) -> Self {
        Self {
            cameras: source.cameras().to_vec(),
            paced_from: None,
            delivered: 0,
            source,
            last,
        }
    }
}

impl FrameSource for Feed {
    fn cameras(&self) -> &[SourceCamera] {
        &self.cameras
    }

    fn fps(&self) -> f64 {
        self.source.fps()
    }

    fn len_hint(&self) -> Option<usize> {
        self.source.len_hint()
    }

    fn is_live(&self) -> bool {
        true
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        let mut set = match self.source.next_set()? {
            Ok(set) => set,
            Err(e) => return Some(Err(e)),
        };
        if !self.source.is_live() {
            let start = *self.paced_from.get_or_insert_with(Instant::now);
            let due = start + Duration::from_secs_f64(self.delivered as f64 / self.fps());
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            for (camera, frame) in self.cameras.iter().zip(set.cameras.iter_mut()) {
                if let Some(frame) = frame
                    && matches!(frame.data, FrameData::Png(_))
                {
                    match frame.decode(&camera.name, None) {
                        Ok(image) => frame.data = FrameData::Decoded(image),
                        Err(e) => return Some(Err(e)),
                    }
                }
            }
            set.exposed_at = Some(due);
        }
        self.delivered += 1;
        let mut last = self
            .last
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        last.push_back(set.clone());
        while last.len() > KEPT_SETS {
            last.pop_front();
        }
        drop(last);
        Some(Ok(set))
    }

    fn stats(&self) -> SourceStats {
        self.source.stats()
    }
}

/// The stream's options under the page's threshold: for a recording, its gates learned from
/// its sample as `track` measures them (learned once per threshold and kept across passes);
/// for cameras and the simulator, from their first seconds.
fn stream_options(
    studio: &Studio,
    fps: f64,
    threshold: Option<u32>,
    learned: &mut Option<(Option<u32>, StreamOptions)>,
) -> Result<StreamOptions, PipelineError> {
    if let Some((at, options)) = learned.as_ref()
        && *at == threshold
    {
        return Ok(options.clone());
    }
    let config = studio.config();
    let (rig, tool) = config
        .tracking()
        .ok_or_else(|| PipelineError::Config("a view-only studio tracks nothing".into()))?;
    let detect = DetectOptions {
        fps: config.source_config.fps,
        threshold,
        ..DetectOptions::default()
    };
    let options = StreamOptions::for_source(
        &config.source,
        fps,
        rig,
        tool,
        detect,
        GateOverrides::default(),
    )?;
    *learned = Some((threshold, options.clone()));
    Ok(options)
}

/// Runs until the studio shuts down.
pub fn run(studio: &Studio, opened: Opened) {
    let config = studio.config().clone();
    let last = Arc::new(Mutex::new(VecDeque::new()));
    let mut learned = None;
    let mut feed = Some(Feed::new(opened.source, Arc::clone(&last)));
    let mut exposure_ms = config.source_config.v4l2.exposure_ms;
    while !studio.is_shutting_down() {
        let controls = studio.live().controls.clone();
        if matches!(studio.exposure(), ExposureControl::Camera)
            && controls.exposure_ms != exposure_ms
        {
            // A camera is opened once at a time: close them, then open them anew.
            drop(feed.take());
            let mut source_config = config.source_config.clone();
            source_config.v4l2.exposure_ms = controls.exposure_ms;
            let reopened = open_source(&config.source, &source_config).or_else(|e| {
                let mut live = studio.live();
                live.error = Some(format!("exposure {:?} ms: {e}", controls.exposure_ms));
                live.controls.exposure_ms = exposure_ms;
                drop(live);
                source_config.v4l2.exposure_ms = exposure_ms;
                open_source(&config.source, &source_config)
            });
            match reopened {
                Ok(source) => {
                    exposure_ms = source_config.v4l2.exposure_ms;
                    feed = Some(Feed::new(source, Arc::clone(&last)));
                }
                Err(e) => {
                    studio.live().error = Some(format!("cannot reopen the cameras: {e}"));
                    return;
                }
            }
        }
        let Some(current) = feed.as_mut() else { return };
        let ended = if config.tracking().is_some() {
            track(studio, current, &last, &controls, &mut learned)
        } else {
            view(studio, current, &last, &controls)
        };
        match ended {
            Ended::Restart => {}
            Ended::Error(message) => {
                studio.live().error = Some(message);
                std::thread::sleep(Duration::from_millis(200));
            }
            Ended::Exhausted if !current.source.is_live() => {
                // A recording played to its end: its pass is the take; play it again.
                {
                    let mut live = studio.live();
                    live.passes += 1;
                    if live.recorder.is_none() {
                        live.take.frozen = true;
                    }
                }
                match open_source(&config.source, &config.source_config) {
                    Ok(source) => feed = Some(Feed::new(source, Arc::clone(&last))),
                    Err(e) => {
                        studio.live().error = Some(e.to_string());
                        return;
                    }
                }
            }
            Ended::Exhausted => {
                // A live source that reached its set limit stays ended.
                while !studio.is_shutting_down() {
                    std::thread::sleep(Duration::from_millis(100));
                }
            }
        }
    }
}

/// Why one stream ended.
enum Ended {
    /// The controls changed, or the studio is stopping.
    Restart,
    /// The source has no more sets.
    Exhausted,
    /// A frame was refused.
    Error(String),
}

/// Tracks the feed until the controls change, the source ends or a frame fails.
fn track(
    studio: &Studio,
    feed: &mut Feed,
    last: &Arc<Mutex<VecDeque<FrameSet>>>,
    controls: &super::state::Controls,
    learned: &mut Option<(Option<u32>, StreamOptions)>,
) -> Ended {
    let config = studio.config();
    let Some((rig, tool)) = config.tracking() else {
        return Ended::Error("a view-only studio tracks nothing".into());
    };
    let fps = feed.fps();
    let options = match stream_options(studio, fps, controls.threshold, learned) {
        Ok(options) => options,
        Err(e) => return Ended::Error(e.to_string()),
    };
    // Each rig camera's place among the source's cameras (the rig's order is the stream's).
    let positions: Vec<Option<usize>> = rig
        .iter()
        .map(|(_, c)| feed.cameras.iter().position(|s| s.name == c.name))
        .collect();
    let mut stream = match TrackStream::new(feed, rig, tool, options) {
        Ok(stream) => stream,
        Err(e) => return Ended::Error(e.to_string()),
    };
    studio.live().source_fps = fps;
    while !studio.is_shutting_down() {
        let Some(frame) = stream.next() else {
            return Ended::Exhausted;
        };
        let frame = match frame {
            Ok(frame) => frame,
            Err(e) => return Ended::Error(e.to_string()),
        };
        let set = kept_set(last, frame.detections.index);
        let images: Vec<Option<&CameraFrame>> = match &set {
            Some(set) => positions
                .iter()
                .map(|p| set.cameras.get((*p)?)?.as_ref())
                .collect(),
            None => vec![None; positions.len()],
        };
        let now = Instant::now();
        let stats = stream.stats();
        {
            let mut live = studio.live();
            live.frames += 1;
            if frame.track.outcome.is_ok() {
                live.posed += 1;
            }
            live.tick(now);
            live.dropped = stats.dropped_sets;
            live.error = None;
            let reason = frame.reason();
            if let Some(recorder) = live.recorder.as_mut() {
                recorder.track(frame.sample, reason.clone());
            }
            live.status = Some((frame.status().name().to_string(), reason));
            live.cameras = rig
                .iter()
                .map(|(_, camera)| CameraCounts {
                    name: camera.name.clone(),
                    width: camera.image_size.width,
                    height: camera.image_size.height,
                    blobs: frame
                        .detections
                        .of(&camera.name)
                        .map_or(0, |d| d.blobs.len()),
                })
                .collect();
            live.take.push(frame.sample, fps);
            if let (Some(recorder), Some(set)) = (live.recorder.as_mut(), set.as_ref()) {
                recorder.push(set, &positions);
            }
        }
        if studio.frames().receiver_count() > 0 {
            let fps_now = studio.live().fps();
            let message = live_message(rig, &frame, &images, fps_now);
            studio.frames().send_replace(Some(message));
        }
        if studio.live().controls.generation != controls.generation {
            return Ended::Restart;
        }
    }
    Ended::Restart
}

/// The set the feed kept with this index (the frames the detector saw), dropping the ones
/// kept before it (a recording played again starts its indices afresh after its last sets).
fn kept_set(last: &Arc<Mutex<VecDeque<FrameSet>>>, index: usize) -> Option<FrameSet> {
    let mut kept = last
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let at = kept.iter().position(|s| s.index == index)?;
    kept.drain(..at);
    kept.front().cloned()
}

/// Without a rig: detects every camera of the feed with the detector's defaults (the page's
/// threshold), as `teachcam detect` does without `--rig`, and shows the frames, the blobs and
/// what the detector measured of each image; nothing is tracked, the take stays empty.
fn view(
    studio: &Studio,
    feed: &mut Feed,
    last: &Arc<Mutex<VecDeque<FrameSet>>>,
    controls: &super::state::Controls,
) -> Ended {
    let config = studio.config();
    let reason = config.view_only().unwrap_or_default().to_string();
    let detect = DetectConfig {
        threshold: controls.threshold.map_or(Threshold::Auto, Threshold::Fixed),
        ..DetectConfig::default()
    };
    let fps = feed.fps();
    let names: Vec<String> = feed.cameras.iter().map(|c| c.name.clone()).collect();
    let mut stream = match DetectStream::all_cameras(feed, &detect) {
        Ok(stream) => stream,
        Err(e) => return Ended::Error(e.to_string()),
    };
    studio.live().source_fps = fps;
    while !studio.is_shutting_down() {
        let Some(set) = stream.next() else {
            return Ended::Exhausted;
        };
        let set = match set {
            Ok(set) => set,
            Err(e) => return Ended::Error(e.to_string()),
        };
        let frames = kept_set(last, set.index);
        let images: Vec<Option<&CameraFrame>> = match &frames {
            Some(frames) => (0..names.len())
                .map(|k| frames.cameras.get(k)?.as_ref())
                .collect(),
            None => vec![None; names.len()],
        };
        {
            let mut live = studio.live();
            live.frames += 1;
            live.tick(Instant::now());
            live.error = None;
            live.status = Some(("view-only".to_string(), reason.clone()));
            live.cameras = names
                .iter()
                .zip(&set.cameras)
                .zip(&images)
                .map(|((name, detections), image)| {
                    let (width, height) = image
                        .and_then(|f| f.decode(name, None).ok())
                        .map_or((0, 0), |i| i.dimensions());
                    CameraCounts {
                        name: name.clone(),
                        width,
                        height,
                        blobs: detections.as_ref().map_or(0, |d| d.blobs.len()),
                    }
                })
                .collect();
        }
        if studio.frames().receiver_count() > 0 {
            let fps_now = studio.live().fps();
            let message = view_message(&names, &set, &images, &detect, &reason, fps_now);
            studio.frames().send_replace(Some(message));
        }
        if studio.live().controls.generation != controls.generation {
            return Ended::Restart;
        }
    }
    Ended::Restart
}
