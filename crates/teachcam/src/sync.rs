//! Unsynchronised cameras: each camera's time offset estimated from the blobs, and applied.
//!
//! Model: camera `c`'s frame `k` was exposed at `k·T + δ_c` on the reference camera's clock
//! (the rig's first camera, `δ = 0`), `T` the frame period; `δ_c` is constant over the
//! recording (free-running cameras at one nominal rate, paired frame by frame). A marker's
//! image in camera `c` at the reference's frame time `f·T` lies on its 2-D track at the
//! fractional frame `f − δ_c/T`, which a polynomial through the track's samples around it
//! gives (degree 7 by default), with an estimate of its error ([`tracks`]). The offsets are those for which the blobs of every camera pair satisfy the
//! epipolar constraint `x_bᵀ F_ab x_a = 0` best (Hartley & Zisserman §9.2): a coarse search per
//! camera against the reference on a capped (robust) cost, then Gauss–Newton on all offsets at
//! once over the epipolar residuals of matched blobs ([`estimate`]). The σ is the Gauss–Newton
//! curvature σ, inflated by the scatter of the offsets fitted on segments of the recording when
//! they disagree more than it allows. This is the approach of the "subframe synchronisation"
//! literature (Caspi & Irani 2002, "Spatio-temporal alignment of sequences"; Elhayek et al.
//! 2012, "Spatio-temporal motion tracking with unsynchronized cameras"): temporal alignment
//! from trajectories, no shared trigger.
//!
//! A recording that holds no timing information (a static tool, motion only along epipolar
//! lines) is refused with the σ it would have had, never answered with a guess.
//! [`resample_views`] applies offsets: each camera's blobs are moved to the common frame times
//! before correspondence; the frames where that is not possible are reported.

mod estimate;
mod resample;
pub mod tracks;

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel};
pub use resample::resample_views;

/// Each camera's time offset, seconds: its frame `k` was exposed at `k·T + offset`. A camera
/// that is not listed has offset 0.
pub type TimeOffsets = BTreeMap<CameraId, f64>;

/// Options of the offset estimate and of resampling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncConfig {
    /// Offsets searched, either side of 0, frame periods (1.0: pairing frames by nearest
    /// timestamp leaves at most half a period; the other half is margin, so that an offset
    /// near half a period is found, not clipped).
    pub max_offset_periods: f64,
    /// Step of the coarse grid, periods (0.01: 0.33 ms at 30 Hz, within the refinement's
    /// reach; 200 cost evaluations per camera).
    pub search_step_periods: f64,
    /// Largest epipolar distance of a match and the cap of the coarse cost, ideal pixels
    /// (2.0: twice the correspondence's default tolerance; farther is another marker, not a
    /// timing error, and caps what a stray blob can weigh).
    pub cost_cap_px: f64,
    /// Track linking: the chosen blob must be at least `1 / link_ratio` times nearer to the
    /// prediction than the runner-up (0.5: a marker twice as near as its neighbour).
    pub link_ratio: f64,
    /// Matching across cameras: the nearest blob to an epipolar line must be at least
    /// `1 / ambiguity_ratio` times nearer than the runner-up (0.5, as for linking).
    pub ambiguity_ratio: f64,
    /// Samples each interpolation goes through, at most (8: degree 7; on the paper's stroke
    /// at 2.5× pace, 30 Hz, the tip RMS after moving the blobs was 0.034 mm with 6 against
    /// 0.014 mm synchronised, the interpolation error of 0.02–0.05 px dominating; each two more
    /// points divide it by about five while the noise grows by a few per cent). Tracks shorter
    /// than this use fewer; the estimate uses only samples with all of them.
    pub interpolation_points: usize,
    /// Segments whose separate fits test the σ (6: enough for a scatter, each still holding a
    /// few seconds of a 30 Hz recording).
    pub segments: usize,
    /// Fewest matched blob pairs a camera needs (30: about one per frame over a second).
    pub min_matches: usize,
    /// Largest σ of an accepted offset, periods (0.05: 1.7 ms at 30 Hz; a fast stroke's blobs
    /// move 50 px a period, so an offset known worse than this would leave the blobs pixels
    /// off their epipolar lines, no better than not correcting).
    pub max_sigma_periods: f64,
    /// Smallest ratio of the blobs' motion across epipolar lines per frame period to the
    /// epipolar residual, both RMS over a camera's matches (10: detection noise alone makes
    /// a static tool's interpolated blobs "move" 1–2 residuals per period).
    pub min_motion_ratio: f64,
    /// Interpolation error estimate beyond which a moved blob's frame is reported, pixels
    /// (0.25: a quarter of the correspondence's default epipolar tolerance).
    pub max_interpolation_error_px: f64,
}

impl Default for SyncConfig {
    fn default() -> Self {
        Self {
            max_offset_periods: 1.0,
            search_step_periods: 0.01,
            cost_cap_px: 2.0,
            link_ratio: 0.5,
            ambiguity_ratio: 0.5,
            interpolation_points: 8,
            segments: 6,
            min_matches: 30,
            max_sigma_periods: 0.05,
            min_motion_ratio: 10.0,
            max_interpolation_error_px: 0.25,
        }
    }
}

/// Why offsets could not be estimated (or read).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SyncError {
    /// The frame period is not a positive number.
    #[error("frame period {period_s} s is not a positive number")]
    BadPeriod {
        /// The period given.
        period_s: f64,
    },
    /// The rig has fewer than two cameras.
    #[error("time offsets need at least two cameras; the rig has {cameras}")]
    TooFewCameras {
        /// Cameras in the rig.
        cameras: usize,
    },
    /// A camera shares too few matched blobs with the others.
    #[error(
        "{camera}: {matches} blob pairs match other cameras' epipolar lines, {needed} needed to estimate its time offset"
    )]
    TooFewMatches {
        /// The camera.
        camera: CameraId,
        /// Matched pairs found.
        matches: usize,
        /// Pairs needed.
        needed: usize,
    },
    /// The blobs hold no timing information: the tool barely moves (or only along epipolar
    /// lines), so any offset fits as well.
    #[error(
        "{camera}: the recording holds no timing information (offset σ {sigma_ms:.3} ms, limit {limit_ms:.3} ms): the tool is static or moves too little; film it moving or give the offsets"
    )]
    NoTimingInformation {
        /// The camera.
        camera: CameraId,
        /// The σ it would have had, milliseconds (∞ when undetermined).
        sigma_ms: f64,
        /// The largest accepted σ, milliseconds.
        limit_ms: f64,
    },
    /// The blobs barely move across the epipolar lines: their motion does not rise above
    /// their noise.
    #[error(
        "{camera}: the blobs move {motion_px:.3} px per frame across epipolar lines against an epipolar residual of {residual_px:.3} px: the tool is static or moves too little to time the cameras; film it moving or give the offsets"
    )]
    TooLittleMotion {
        /// The camera.
        camera: CameraId,
        /// RMS motion across epipolar lines per frame period, pixels.
        motion_px: f64,
        /// RMS epipolar residual, pixels.
        residual_px: f64,
    },
    /// The best offset lies at the edge of the searched range.
    #[error(
        "{camera}: best offset {offset_ms:.2} ms lies at the edge of the searched ±{limit_ms:.2} ms; frames may be paired wrongly"
    )]
    AtSearchEdge {
        /// The camera.
        camera: CameraId,
        /// The offset found, milliseconds.
        offset_ms: f64,
        /// The searched range, milliseconds.
        limit_ms: f64,
    },
    /// A camera named in an offsets list or file is not in the rig.
    #[error("time offsets name camera '{name}', which the rig does not have (it has {known})")]
    UnknownCamera {
        /// The name given.
        name: String,
        /// The rig's camera names, comma-separated.
        known: String,
    },
    /// An entry of an offsets list is not `name=seconds`.
    #[error("time offset '{entry}' is not NAME=SECONDS with a finite number (e.g. cam1=0.0093)")]
    BadEntry {
        /// The entry.
        entry: String,
    },
    /// An offsets JSON file is not an object of camera names to seconds.
    #[error("time offsets JSON: {reason}")]
    BadJson {
        /// What is wrong.
        reason: String,
    },
}

/// One camera's estimated offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraOffset {
    /// The offset, seconds (0 for the reference).
    pub offset_s: f64,
    /// Its standard uncertainty, seconds (0 for the reference, which defines the clock).
    pub sigma_s: f64,
    /// Matched blob pairs between this camera and the others.
    pub matches: usize,
}

/// The estimate for a whole rig.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncEstimate {
    /// The camera whose clock the offsets are on.
    pub reference: CameraId,
    /// Every camera's offset, the reference's included.
    pub offsets: BTreeMap<CameraId, CameraOffset>,
    /// RMS epipolar residual of the matched blobs at the estimated offsets, pixels.
    pub residual_rms_px: f64,
    /// RMS epipolar residual of the same matches at zero offsets, pixels.
    pub unshifted_residual_rms_px: f64,
    /// Matched blob pairs over all camera pairs.
    pub matches: usize,
}

impl SyncEstimate {
    /// The offsets alone, seconds.
    #[must_use]
    pub fn time_offsets(&self) -> TimeOffsets {
        self.offsets.iter().map(|(c, o)| (*c, o.offset_s)).collect()
    }
}

/// Estimates each camera's time offset from the blobs of every frame (distorted pixels, as
/// detected), `frame_period_s` apart.
///
/// # Errors
/// [`SyncError`] when the rig or the data cannot determine an offset: fewer than two cameras,
/// too few matched blobs, no motion to time, a best offset at the edge of the search.
pub fn estimate_offsets(
    rig: &Rig,
    frames: &[Views],
    frame_period_s: f64,
    config: &SyncConfig,
) -> Result<SyncEstimate, SyncError> {
    if !(frame_period_s > 0.0 && frame_period_s.is_finite()) {
        return Err(SyncError::BadPeriod {
            period_s: frame_period_s,
        });
    }
    if rig.len() < 2 {
        return Err(SyncError::TooFewCameras { cameras: rig.len() });
    }
    let cameras: BTreeMap<CameraId, estimate::CameraTracks> = rig
        .iter()
        .map(|(id, camera)| {
            let blobs: Vec<Vec<Pixel>> = frames
                .iter()
                .map(|v| v.get(&id).cloned().unwrap_or_default())
                .collect();
            let tracks = tracks::link_tracks(&blobs, config.link_ratio)
                .into_iter()
                .filter_map(|mut track| {
                    track.positions = track
                        .positions
                        .iter()
                        .map(|p| camera.ideal_pixel(p).ok())
                        .collect::<Option<_>>()?;
                    Some(track)
                })
                .collect();
            (
                id,
                estimate::CameraTracks::new(tracks, frames.len(), config.interpolation_points),
            )
        })
        .collect();
    let problem = estimate::Problem {
        cameras: &cameras,
        fundamental: rig.fundamental_matrices(),
        frame_count: frames.len(),
        reference: CameraId(0),
        config,
    };
    estimate::estimate(&problem, frame_period_s)
}

/// What resampling could not do in one frame.
#[derive(Debug, Clone, PartialEq)]
pub enum ResampleIssue {
    /// Blobs whose tracks do not reach the common time (a track's end, a broken link).
    NotMoved {
        /// The camera.
        camera: CameraId,
        /// Blobs left out.
        blobs: usize,
    },
    /// A moved blob whose interpolation error estimate exceeds the limit (fast motion, or a
    /// lower order near a track's end).
    Uncertain {
        /// The camera.
        camera: CameraId,
        /// The largest error estimate in the frame, pixels.
        error_px: f64,
    },
}

impl std::fmt::Display for ResampleIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotMoved { camera, blobs } => write!(
                f,
                "{camera}: {blobs} blob(s) at a track's end could not be moved to the common time"
            ),
            Self::Uncertain { camera, error_px } => write!(
                f,
                "{camera}: blobs moved to the common time are uncertain by up to {error_px:.2} px (fast motion or a track's end)"
            ),
        }
    }
}

/// Views moved to the common frame times.
#[derive(Debug, Clone, PartialEq)]
pub struct Resampled {
    /// Every frame's blobs at the common time.
    pub frames: Vec<Views>,
    /// Per frame, what could not be done (empty where all went well).
    pub issues: Vec<Vec<ResampleIssue>>,
}

/// Parses `cam1=0.0093,cam2=-0.0131` (seconds) against a rig; cameras not named get 0.
///
/// # Errors
/// [`SyncError::BadEntry`] for an entry that is not `NAME=SECONDS` with a finite number,
/// [`SyncError::UnknownCamera`] for a name the rig lacks.
pub fn parse_time_offsets(text: &str, rig: &Rig) -> Result<TimeOffsets, SyncError> {
    let mut offsets = TimeOffsets::new();
    for entry in text.split(',').map(str::trim).filter(|e| !e.is_empty()) {
        let bad = || SyncError::BadEntry {
            entry: entry.to_string(),
        };
        let (name, value) = entry.split_once('=').ok_or_else(bad)?;
        let seconds: f64 = value.trim().parse().map_err(|_| bad())?;
        if !seconds.is_finite() {
            return Err(bad());
        }
        offsets.insert(camera_named(rig, name.trim())?, seconds);
    }
    Ok(offsets)
}

/// Reads the JSON written by [`time_offsets_json`] (`{"cam0": 0.0, "cam1": 0.0093}`) against
/// a rig; cameras not named get 0.
///
/// # Errors
/// [`SyncError::BadJson`] for text that is not an object of finite numbers,
/// [`SyncError::UnknownCamera`] for a name the rig lacks.
pub fn read_time_offsets_json(text: &str, rig: &Rig) -> Result<TimeOffsets, SyncError> {
    let map: BTreeMap<String, f64> =
        serde_json::from_str(text).map_err(|e| SyncError::BadJson {
            reason: e.to_string(),
        })?;
    let mut offsets = TimeOffsets::new();
    for (name, seconds) in map {
        if !seconds.is_finite() {
            return Err(SyncError::BadJson {
                reason: format!("offset of '{name}' is not a finite number"),
            });
        }
        offsets.insert(camera_named(rig, &name)?, seconds);
    }
    Ok(offsets)
}

fn camera_named(rig: &Rig, name: &str) -> Result<CameraId, SyncError> {
    rig.id_of(name).ok_or_else(|| SyncError::UnknownCamera {
        name: name.to_string(),
        known: rig
            .cameras
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
    })
}

/// The contract's offsets JSON, every rig camera in rig order, seconds:
/// `{"cam0": 0.0, "cam1": 0.0093, ...}`; `None` when an offset is not finite.
#[must_use]
pub fn time_offsets_json(rig: &Rig, offsets: &TimeOffsets) -> Option<String> {
    let mut out = String::from("{");
    for (i, (id, camera)) in rig.iter().enumerate() {
        let seconds = offsets.get(&id).copied().unwrap_or(0.0);
        if !seconds.is_finite() {
            return None;
        }
        let name = serde_json::to_string(&camera.name).ok()?;
        let separator = if i == 0 { "" } else { ", " };
        let _ = write!(out, "{separator}{name}: {seconds:?}");
    }
    out.push_str("}\n");
    Some(out)
}
