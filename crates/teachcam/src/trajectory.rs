//! A tool trajectory: one sample per recorded frame, each with the tool's pose or an explicit
//! gap.
//!
//! Model (paper §II-C, §III): tracking queues `world_from_tool` over time; the tip is
//! `world_from_tool * tip_in_tool`. Frames without a pose keep their sample with `pose: None`
//! so that gaps stay visible to every later stage and in every file.

use std::ops::Range;

use crate::geometry::{FrameIndex, Point3, Pose, Quat};

/// The tool's pose in one frame, with how it was measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolPose {
    /// The tool frame in the world (work-object) frame.
    pub world_from_tool: Pose,
    /// The tool centre point in the world frame, millimetres.
    pub tip_in_world: Point3,
    /// How many identified markers the pose used.
    pub markers: usize,
    /// RMS distance between the registered model markers and the measured ones, millimetres.
    pub rms_mm: f64,
}

/// Where a sample's pose came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PoseSource {
    /// Measured (tracked, or smoothed from measurements at this frame).
    #[default]
    Measured,
    /// Filled across a short gap by the smoother: no measurement at this frame.
    Filled,
}

/// How far a frame's pose can be trusted (DESIGN.md, "Status is data"; CONTRACT.md's
/// `status` column). Downstream stages decide what to do with each; the reason is in
/// `track`'s diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Every gate passed with every view and marker the frame offered.
    #[default]
    Ok,
    /// A pose within the gates, made with less than the frame offered: a view dropped, a
    /// merged blob used, fewer markers than the tool has, or a gap filled by smoothing.
    Degraded,
    /// A pose is written, but its residuals are beyond the gate: treat it as a gap unless
    /// told otherwise.
    Outlier,
    /// No pose.
    Lost,
}

impl Status {
    /// Every status, in order of increasing doubt.
    pub const ALL: [Status; 4] = [Status::Ok, Status::Degraded, Status::Outlier, Status::Lost];

    /// The word written in the trajectory CSV.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Ok => "ok",
            Self::Degraded => "degraded",
            Self::Outlier => "outlier",
            Self::Lost => "lost",
        }
    }

    /// The status a CSV word names.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One frame of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Frame number in the recording.
    pub frame: FrameIndex,
    /// Time of the frame, seconds from the recording's start.
    pub time_s: f64,
    /// The pose, `None` for a frame without one (a gap).
    pub pose: Option<ToolPose>,
    /// Whether the pose was measured or filled.
    pub source: PoseSource,
    /// Standard uncertainty of the tip position (RMS over the three axes), millimetres, when
    /// an uncertainty estimate was made.
    pub tip_std_mm: Option<f64>,
    /// How far the pose can be trusted; [`Status::Lost`] exactly when `pose` is `None`.
    pub status: Status,
    /// How many cameras saw the markers the pose used (`None` where no camera measured this
    /// frame's pose: a gap, a filled or smoothed-over frame, the simulator's truth, a file
    /// without the column).
    pub cameras: Option<usize>,
}

impl Sample {
    /// A sample without a pose.
    #[must_use]
    pub fn gap(frame: FrameIndex, time_s: f64) -> Self {
        Self {
            frame,
            time_s,
            pose: None,
            source: PoseSource::Measured,
            tip_std_mm: None,
            status: Status::Lost,
            cameras: None,
        }
    }

    /// A measured sample.
    #[must_use]
    pub fn measured(frame: FrameIndex, time_s: f64, pose: ToolPose) -> Self {
        Self {
            frame,
            time_s,
            pose: Some(pose),
            source: PoseSource::Measured,
            tip_std_mm: None,
            status: Status::Ok,
            cameras: None,
        }
    }
}

/// Samples in frame order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trajectory {
    /// One sample per frame, frames increasing.
    pub samples: Vec<Sample>,
}

impl Trajectory {
    /// Number of samples, gaps included.
    #[must_use]
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Turns every [`Status::Outlier`] sample into a gap ([`Status::Lost`]): what `smooth`,
    /// `check` and `export` do with outliers unless told to keep them. Returns how many.
    pub fn drop_outliers(&mut self) -> usize {
        let mut dropped = 0;
        for s in &mut self.samples {
            if s.status == Status::Outlier {
                *s = Sample {
                    tip_std_mm: None,
                    ..Sample::gap(s.frame, s.time_s)
                };
                dropped += 1;
            }
        }
        dropped
    }

    /// The runs of consecutive samples that have a pose, as index ranges into `samples`.
    #[must_use]
    pub fn segments(&self) -> Vec<Range<usize>> {
        let mut segments = Vec::new();
        let mut start = None;
        for (i, s) in self.samples.iter().enumerate() {
            match (s.pose.is_some(), start) {
                (true, None) => start = Some(i),
                (false, Some(b)) => {
                    segments.push(b..i);
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(b) = start {
            segments.push(b..self.samples.len());
        }
        segments
    }

    /// The sampling rate from the first and last time stamps, `None` with fewer than two
    /// samples or a non-increasing time.
    #[must_use]
    pub fn sample_rate_hz(&self) -> Option<f64> {
        let (first, last) = (self.samples.first()?, self.samples.last()?);
        let span = last.time_s - first.time_s;
        (self.samples.len() > 1 && span > 0.0).then(|| (self.samples.len() - 1) as f64 / span)
    }

    /// The written quaternion of every sample with a pose: `qw >= 0` at the start of each
    /// segment, then the sign that keeps each quaternion on the previous one's hemisphere
    /// (CONTRACT.md, "Conventions").
    #[must_use]
    pub fn continuous_quaternions(&self) -> Vec<Option<Quat>> {
        let mut previous: Option<Quat> = None;
        self.samples
            .iter()
            .map(|s| {
                let Some(pose) = &s.pose else {
                    previous = None;
                    return None;
                };
                let q = Quat::from_rotation(&pose.world_from_tool.rotation);
                let q = previous.map_or(q, |p| q.continuous_with(&p));
                previous = Some(q);
                Some(q)
            })
            .collect()
    }
}

/// Lowest sampling rate accepted, Hz: one frame every 1000 s. Below it frame times leave what
/// a recording of a demonstration means (and at 1e-320 Hz they are infinite).
pub const MIN_SAMPLE_RATE_HZ: f64 = 1e-3;

/// Highest sampling rate accepted, Hz: ten times the fastest motion-capture cameras. The
/// trajectory CSV writes `time_s` to the nanosecond, so a step of 10 µs is held to 5e-5 of
/// itself, well within the smoother's uniformity tolerance of 1e-3.
pub const MAX_SAMPLE_RATE_HZ: f64 = 1e5;

/// A sampling rate outside [`MIN_SAMPLE_RATE_HZ`]`..=`[`MAX_SAMPLE_RATE_HZ`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "{field} = {rate_hz} Hz is outside the accepted {MIN_SAMPLE_RATE_HZ}..={MAX_SAMPLE_RATE_HZ} Hz"
)]
pub struct SampleRateError {
    /// Where the rate came from (`fps`, `--fps`, `the time step`...).
    pub field: &'static str,
    /// The rate, Hz.
    pub rate_hz: f64,
}

/// The one check of a sampling rate (a recording's `fps`, a `--fps` flag, the rate a
/// trajectory's time steps imply): finite and within
/// [`MIN_SAMPLE_RATE_HZ`]`..=`[`MAX_SAMPLE_RATE_HZ`].
///
/// # Errors
/// [`SampleRateError`] naming `field`.
pub fn check_sample_rate_hz(field: &'static str, rate_hz: f64) -> Result<f64, SampleRateError> {
    if (MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&rate_hz) {
        Ok(rate_hz)
    } else {
        Err(SampleRateError { field, rate_hz })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose() -> ToolPose {
        ToolPose {
            world_from_tool: Pose::identity(),
            tip_in_world: Point3::origin(),
            markers: 4,
            rms_mm: 0.0,
        }
    }

    #[test]
    fn segments_split_at_gaps() {
        let mut samples: Vec<Sample> = (0..8)
            .map(|i| Sample::measured(FrameIndex(i), i as f64 / 30.0, pose()))
            .collect();
        samples[0].pose = None;
        samples[3].pose = None;
        samples[4].pose = None;
        let t = Trajectory { samples };
        assert_eq!(t.segments(), vec![1..3, 5..8]);
    }

    #[test]
    fn sample_rates_outside_the_range_are_refused_naming_the_field() {
        for ok in [MIN_SAMPLE_RATE_HZ, 30.0, 2000.0, MAX_SAMPLE_RATE_HZ] {
            assert_eq!(check_sample_rate_hz("fps", ok), Ok(ok));
        }
        for bad in [0.0, -30.0, 1e-320, 1e7, 1e12, f64::NAN, f64::INFINITY] {
            let e = check_sample_rate_hz("fps", bad).unwrap_err();
            assert!(e.to_string().starts_with("fps = "), "{e}");
            assert!(e.to_string().contains("0.001..=100000 Hz"), "{e}");
        }
    }
}
