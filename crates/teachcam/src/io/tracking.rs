//! What `track` writes beside the trajectory: the identified markers per frame and the
//! per-frame diagnostics (CONTRACT.md: `track --markers-out`, `--diagnostics`).

use std::fmt::Write as _;

use crate::sync::ResampleIssue;
use crate::track::FrameTrack;
use crate::trajectory::Status;

/// The identified 3-D markers of every frame:
/// `frame,marker,x_mm,y_mm,z_mm,views,residual_px`.
#[must_use]
pub fn markers_csv(tracks: &[FrameTrack]) -> String {
    let mut out = String::from("frame,marker,x_mm,y_mm,z_mm,views,residual_px\n");
    for (frame, track) in tracks.iter().enumerate() {
        for (marker, point) in &track.labels {
            let p = &track.points[*point];
            let _ = writeln!(
                out,
                "{frame},{},{:.6},{:.6},{:.6},{},{:.4}",
                marker.0,
                p.position.x,
                p.position.y,
                p.position.z,
                p.views.len(),
                p.residual_px
            );
        }
    }
    out
}

/// The per-frame diagnostics; with time offsets, a last column `resampling` lists what could
/// not be moved to the common time, and such a frame's status is `degraded`.
#[must_use]
pub fn diagnostics_csv(tracks: &[FrameTrack], resampling: Option<&[Vec<ResampleIssue>]>) -> String {
    let mut out = String::from(
        "frame,status,reason,points,markers,views_per_marker,max_residual_px,combinations,reflections",
    );
    out.push_str(if resampling.is_some() {
        ",resampling\n"
    } else {
        "\n"
    });
    for (frame, track) in tracks.iter().enumerate() {
        let issues: Vec<String> = resampling
            .and_then(|r| r.get(frame))
            .map(|issues| {
                issues
                    .iter()
                    .map(|i| i.to_string().replace(',', ";"))
                    .collect()
            })
            .unwrap_or_default();
        let status = match track.status() {
            Status::Ok if !issues.is_empty() => Status::Degraded,
            status => status,
        };
        let views: Vec<String> = track
            .views_per_marker()
            .iter()
            .map(|(m, v)| format!("{}:{v}", m.0))
            .collect();
        let max_residual = track
            .points
            .iter()
            .map(|p| p.residual_px)
            .fold(0.0, f64::max);
        let _ = write!(
            out,
            "{frame},{status},{},{},{},{},{max_residual:.4},{},{}",
            track.reason().replace(',', ";"),
            track.points.len(),
            track.labels.len(),
            views.join(" "),
            track.combinations,
            track.reflections
        );
        if resampling.is_some() {
            let _ = write!(out, ",{}", issues.join(" | "));
        }
        out.push('\n');
    }
    out
}
