//! Each tracked frame's tip uncertainty (`tip_std_mm`), honest about frames that fit worse
//! than usual: the one σ model of every front end (`track`, `live`, the studio).
//!
//! Model. The first-order tip uncertainty ([`crate::metrology::first_order`]) at the frame's
//! pose for its blobs' predicted centre noise, scaled to the pixel error the recording's
//! triangulation residuals show (the variance factor `σ̂ / σ_blobs`, with `σ̂` from
//! [`crate::metrology::residual_noise_px`] over every identified marker); then inflated by how
//! far this frame's own residuals exceed the recording's typical ones:
//! ```text
//! f = max(1, s_reg / median(s_reg), σ̂_frame / σ̂)      s_reg = rms · sqrt(n / (3n − 6))
//! ```
//! The typical values ([`Typical`]: `σ̂`, `σ_blobs`, `median(s_reg)`) are those of the `ok`
//! frames: of the whole recording for `track`, of the frames the gates were learned from for a
//! stream, which cannot wait for the recording's end.
//! `s_reg` is the registration residual per degree of freedom (`n` markers give `3n` numbers
//! for 6 unknowns), so frames with three and four markers compare; `σ̂_frame` is the residual
//! scale of the frame's own markers. A frame whose markers fit 20 times worse than usual has
//! an error about 20 times the usual one (a merged blob, a reflection), and says so.

use crate::camera::Rig;
use crate::metrology::{first_order, residual_noise_px};
use crate::stats::{median, rms};
use crate::tool::Tool;
use crate::track::FrameTrack;
use crate::trajectory::Status;

/// Registration residual per degree of freedom, `rms · sqrt(n / (3n − 6))`.
fn registration_scale_mm(rms_mm: f64, markers: usize) -> Option<f64> {
    let n = markers as f64;
    (markers >= 3).then(|| rms_mm * (n / (3.0 * n - 6.0)).sqrt())
}

/// What a recording's typical frame shows: the yardstick of every frame's `tip_std_mm`.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Typical {
    /// The pixel error the typical frames' triangulation residuals show, `σ̂`.
    pub shown_px: Option<f64>,
    /// RMS of the predicted centre noise of every blob of the frames measured, `σ_blobs`.
    pub predicted_px: f64,
    /// Median registration residual per degree of freedom of the typical frames, millimetres.
    pub registration_mm: Option<f64>,
}

impl Typical {
    /// Measured from `tracks` and each one's blobs' predicted centre noise per axis
    /// (`blob_noise_px[i]`, pixels, frame `i`'s). The typical frames are the `ok` ones (all
    /// posed ones where none is): outliers, however many, must not make each other look
    /// typical.
    #[must_use]
    pub fn of(tracks: &[FrameTrack], blob_noise_px: &[Vec<f64>]) -> Self {
        let predicted_px = rms(&blob_noise_px.concat());
        let typical: Vec<&FrameTrack> = if tracks.iter().any(|t| t.status() == Status::Ok) {
            tracks.iter().filter(|t| t.status() == Status::Ok).collect()
        } else {
            tracks.iter().collect()
        };
        let shown_px = residual_noise_px(
            typical
                .iter()
                .flat_map(|t| t.labels.values().map(|&p| &t.points[p])),
        );
        let registration: Vec<f64> = typical
            .iter()
            .filter_map(|t| {
                let pose = t.outcome.as_ref().ok()?;
                registration_scale_mm(pose.rms_mm, pose.markers)
            })
            .collect();
        Self {
            shown_px,
            predicted_px,
            registration_mm: median(&registration).filter(|m| *m > 0.0),
        }
    }

    /// The factor from predicted to shown pixel error (1 until both are known).
    #[must_use]
    pub fn noise_scale(&self) -> f64 {
        match self.shown_px {
            Some(shown) if self.predicted_px > 0.0 => shown / self.predicted_px,
            _ => 1.0,
        }
    }

    /// One frame's `tip_std_mm` (`None` without a pose) from its blobs' predicted centre noise
    /// per axis, pixels.
    #[must_use]
    pub fn tip_std_mm(
        &self,
        rig: &Rig,
        tool: &Tool,
        track: &FrameTrack,
        blob_noise_px: &[f64],
    ) -> Option<f64> {
        let pose = track.outcome.as_ref().ok()?;
        let frame_px = self.noise_scale() * rms(blob_noise_px);
        if frame_px <= 0.0 {
            return None;
        }
        let base = first_order(rig, tool, &pose.world_from_tool, frame_px)
            .ok()?
            .tip_rms_mm;
        let by_registration = match (
            registration_scale_mm(pose.rms_mm, pose.markers),
            self.registration_mm,
        ) {
            (Some(s), Some(typical)) => s / typical,
            _ => 1.0,
        };
        let own_px = residual_noise_px(track.labels.values().map(|&p| &track.points[p]));
        let by_residual = match (own_px, self.shown_px) {
            (Some(own), Some(shown)) if shown > 0.0 => own / shown,
            _ => 1.0,
        };
        let inflation = 1_f64.max(by_registration).max(by_residual);
        Some(base * inflation).filter(|v| v.is_finite())
    }
}

/// The `tip_std_mm` of every frame of `tracks` (`None` without a pose), typical values from
/// the tracks themselves ([`Typical::of`]); see the module docs.
#[must_use]
pub fn tip_std_mm(
    rig: &Rig,
    tool: &Tool,
    tracks: &[FrameTrack],
    blob_noise_px: &[Vec<f64>],
) -> Vec<Option<f64>> {
    let typical = Typical::of(tracks, blob_noise_px);
    tracks
        .iter()
        .enumerate()
        .map(|(frame, track)| {
            let noise = blob_noise_px.get(frame).map_or(&[][..], Vec::as_slice);
            typical.tip_std_mm(rig, tool, track, noise)
        })
        .collect()
}
