//! Gaps: which frames the smoother fills and which stay gaps.
//!
//! Model: the measured segments of a trajectory (runs of frames with a pose) are merged across
//! gaps of at most `max_gap_frames` frames into *runs*; a run is smoothed as one uniform series
//! after its inner gaps are filled by cubic-spline interpolation (not-a-knot ends, as scipy's
//! `CubicSpline`) of the positions and of the unrolled rotations. Longer gaps, and the frames
//! before the first and after the last pose, stay gaps: nothing is extrapolated.

use std::ops::Range;

use crate::trajectory::Trajectory;

/// The runs of samples, as index ranges into `trajectory.samples`, that start and end with a
/// pose and contain no gap longer than `max_gap_frames`.
#[must_use]
pub fn runs(trajectory: &Trajectory, max_gap_frames: usize) -> Vec<Range<usize>> {
    let mut runs: Vec<Range<usize>> = Vec::new();
    for segment in trajectory.segments() {
        match runs.last_mut() {
            Some(last) if segment.start - last.end <= max_gap_frames => last.end = segment.end,
            _ => runs.push(segment),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{FrameIndex, Point3, Pose};
    use crate::trajectory::{Sample, ToolPose};

    #[test]
    fn merges_short_gaps_only() {
        let pose = ToolPose {
            world_from_tool: Pose::identity(),
            tip_in_world: Point3::origin(),
            markers: 4,
            rms_mm: 0.0,
        };
        let mut samples: Vec<Sample> = (0..20)
            .map(|i| Sample::measured(FrameIndex(i), i as f64, pose))
            .collect();
        for i in [0, 4, 5, 9, 10, 11, 12, 19] {
            samples[i].pose = None;
        }
        let t = Trajectory { samples };
        assert_eq!(runs(&t, 2), vec![1..9, 13..19]);
        assert_eq!(runs(&t, 4), vec![1..19]);
        assert_eq!(runs(&t, 0), vec![1..4, 6..9, 13..19]);
    }
}
