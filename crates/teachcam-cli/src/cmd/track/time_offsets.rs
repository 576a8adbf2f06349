//! `track --time-offsets`: unsynchronised cameras' offsets, estimated or given, applied to the
//! blobs before correspondence (the library's `sync`).

use std::path::Path;

use anyhow::Context;
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::sync::{
    ResampleIssue, SyncConfig, SyncEstimate, TimeOffsets, estimate_offsets, parse_time_offsets,
    read_time_offsets_json, resample_views, time_offsets_json,
};

use crate::Rejected;

/// What `--time-offsets` asked for.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeOffsetsArg {
    /// Estimate them from the blobs.
    Auto,
    /// `cam1=0.0093,cam2=-0.0131`, or a JSON file of that form, as given.
    Given(String),
}

impl std::str::FromStr for TimeOffsetsArg {
    type Err = std::convert::Infallible;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Ok(if text == "auto" {
            Self::Auto
        } else {
            Self::Given(text.to_string())
        })
    }
}

/// The blobs moved to common frame times, with what happened.
#[derive(Debug)]
pub struct Synchronised {
    /// Every frame's blobs at the common time.
    pub frames: Vec<Views>,
    /// Per frame, what could not be moved (the frame's status becomes `degraded`).
    pub issues: Vec<Vec<ResampleIssue>>,
    /// The offsets applied, seconds.
    pub offsets: TimeOffsets,
    /// The estimate, when `auto`.
    pub estimate: Option<SyncEstimate>,
}

/// Resolves `--time-offsets` (estimating with `auto`) and moves every camera's blobs to the
/// common frame times. A value that is neither `auto`, a list nor a readable JSON file is a
/// usage error; a recording that cannot determine its offsets is rejected data.
///
/// # Errors
/// As above, one line naming the camera or the entry.
pub fn synchronise(
    arg: &TimeOffsetsArg,
    rig: &Rig,
    frames: Vec<Views>,
    fps: f64,
) -> anyhow::Result<Synchronised> {
    let config = SyncConfig::default();
    let period_s = 1.0 / fps;
    let (offsets, estimate) = match arg {
        TimeOffsetsArg::Auto => {
            let estimate = estimate_offsets(rig, &frames, period_s, &config)
                .context("--time-offsets auto")
                .rejected()?;
            (estimate.time_offsets(), Some(estimate))
        }
        TimeOffsetsArg::Given(text) => (given_offsets(text, rig)?, None),
    };
    let resampled = resample_views(&frames, &offsets, period_s, &config);
    Ok(Synchronised {
        frames: resampled.frames,
        issues: resampled.issues,
        offsets,
        estimate,
    })
}

/// A list `cam1=0.0093,...` or the path of a JSON file `{"cam1": 0.0093, ...}`.
fn given_offsets(text: &str, rig: &Rig) -> anyhow::Result<TimeOffsets> {
    let path = Path::new(text);
    if !text.contains('=') && path.is_file() {
        let json = std::fs::read_to_string(path)
            .with_context(|| format!("--time-offsets: cannot read {}", path.display()))?;
        return read_time_offsets_json(&json, rig)
            .with_context(|| format!("--time-offsets {}", path.display()));
    }
    parse_time_offsets(text, rig)
        .context("--time-offsets (expected auto, NAME=SECONDS,... or a JSON file)")
}

/// The contract's offsets JSON of the offsets applied.
///
/// # Errors
/// When an offset is not finite (never written).
pub fn offsets_json(rig: &Rig, offsets: &TimeOffsets) -> anyhow::Result<String> {
    time_offsets_json(rig, offsets)
        .ok_or_else(|| anyhow::anyhow!("a time offset is not finite; nothing written"))
}

/// One stderr line on the offsets: estimated ones with their σ and the epipolar residual
/// before and after.
#[must_use]
pub fn summary(rig: &Rig, synchronised: &Synchronised) -> String {
    let issues = synchronised.issues.iter().filter(|i| !i.is_empty()).count();
    let Some(estimate) = &synchronised.estimate else {
        let given: Vec<String> = rig
            .iter()
            .map(|(id, c)| {
                let ms = synchronised.offsets.get(&id).copied().unwrap_or(0.0) * 1e3;
                format!("{} {ms:+.3} ms", c.name)
            })
            .collect();
        return format!(
            "time offsets given: {}; {issues} frames degraded by resampling",
            given.join(", ")
        );
    };
    let cameras: Vec<String> = estimate
        .offsets
        .iter()
        .filter(|(id, _)| **id != estimate.reference)
        .filter_map(|(id, o)| {
            Some(format!(
                "{} {:+.3} ms ± {:.3}",
                rig.camera(*id)?.name,
                o.offset_s * 1e3,
                o.sigma_s * 1e3
            ))
        })
        .collect();
    let reference = rig
        .camera(estimate.reference)
        .map_or("camera 0", |c| c.name.as_str());
    format!(
        "time offsets on {reference}'s clock: {}; epipolar RMS {:.3} px unshifted -> {:.3} px over {} matches; {issues} frames degraded by resampling",
        cameras.join(", "),
        estimate.unshifted_residual_rms_px,
        estimate.residual_rms_px,
        estimate.matches
    )
}
