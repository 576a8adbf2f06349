//! `track --time-offsets`: unsynchronised cameras' offsets, estimated or given; the library's
//! batch run applies them ([`teachcam::pipeline::batch::TimeOffsetsChoice`]).

use std::path::Path;

use anyhow::Context;
use teachcam::camera::Rig;
use teachcam::pipeline::batch::{Synchronised, TimeOffsetsChoice};
use teachcam::sync::{TimeOffsets, parse_time_offsets, read_time_offsets_json};

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

/// The library's choice for `--time-offsets`: a value that is neither `auto`, a list nor a
/// readable JSON file is a usage error, one line naming the camera or the entry.
///
/// # Errors
/// As above.
pub fn resolve(arg: &TimeOffsetsArg, rig: &Rig) -> anyhow::Result<TimeOffsetsChoice> {
    Ok(match arg {
        TimeOffsetsArg::Auto => TimeOffsetsChoice::Auto,
        TimeOffsetsArg::Given(text) => TimeOffsetsChoice::Given(given_offsets(text, rig)?),
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
