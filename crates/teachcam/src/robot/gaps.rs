//! Gaps in a path of targets: runs of frames without a pose (lost, or outliers dropped) that a
//! program would cross with one straight move, and whether that straight move stays within
//! the path tolerance.
//!
//! Model: across a gap from target `a` (time `t_a`) to target `b` (`t_b`, `T = t_b − t_a`),
//! the smoothest path the data allows is the cubic Hermite curve with the positions and
//! velocities measured on either side (velocities: the derivative of the quadratic through the
//! last three frames before the gap and the first three after it, or a difference over two
//! frames where only two are there). A straight move is the chord `a → b`; the gap is
//! bridgeable when the Hermite curve stays within the path tolerance of the chord (sampled at
//! 1/32 of the gap). A stroke going straight through a gap bridges at any length; an arc whose
//! bend is `κ v²` bridges for `T ≲ √(8 · tolerance / (κ v²))` (the chord-to-arc sagitta).
//! A side with a single frame has no velocity: the gap cannot be judged and is not
//! bridgeable. `--max-gap-s` replaces the criterion by a plain duration.

use crate::geometry::{FrameIndex, Vec3};
use crate::robot::TcpTarget;

/// Options of [`find_gaps`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GapConfig {
    /// How far, millimetres, a straight move may leave the smoothest path across a gap (the
    /// program's path tolerance).
    pub tolerance_mm: f64,
    /// When given, a gap is bridgeable when it lasts at most this long, seconds, whatever its
    /// shape.
    pub max_gap_s: Option<f64>,
}

/// One gap between two targets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// The last frame with a pose before the gap.
    pub after: FrameIndex,
    /// The first frame with a pose after it.
    pub before: FrameIndex,
    /// Time from `after` to `before`, seconds (recorded, before any time scale).
    pub duration_s: f64,
    /// How far the smoothest path across the gap leaves the straight move, millimetres;
    /// `None` when a side has a single frame (no velocity to judge by).
    pub deviation_mm: Option<f64>,
    /// True when a straight move may cross it ([`GapConfig`]).
    pub bridgeable: bool,
}

impl Gap {
    /// Frames without a pose in the gap.
    #[must_use]
    pub fn missing(&self) -> usize {
        self.before.0.saturating_sub(self.after.0 + 1)
    }

    /// True when a move from frame `from` to frame `to` crosses the gap.
    #[must_use]
    pub fn spans(&self, from: FrameIndex, to: FrameIndex) -> bool {
        from.0 <= self.after.0 && to.0 >= self.before.0
    }
}

impl std::fmt::Display for Gap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frames {}-{} without a pose ({} frames, {:.3} s)",
            self.after.0 + 1,
            self.before.0 - 1,
            self.missing(),
            self.duration_s
        )?;
        match self.deviation_mm {
            Some(d) => write!(
                f,
                ": a straight move across leaves the smoothest path by about {d:.1} mm"
            ),
            None => write!(
                f,
                ": a single frame on one side, no speed to judge the path by"
            ),
        }
    }
}

/// The gaps of a path: each pair of consecutive targets whose frames are not consecutive.
#[must_use]
pub fn find_gaps(targets: &[TcpTarget], config: &GapConfig) -> Vec<Gap> {
    let mut out = Vec::new();
    for k in 1..targets.len() {
        let (a, b) = (&targets[k - 1], &targets[k]);
        if b.frame.0 <= a.frame.0 + 1 {
            continue;
        }
        let duration_s = b.time_s - a.time_s;
        let consecutive = |i: usize, j: usize| targets[i].frame.0 + 1 == targets[j].frame.0;
        let before = if k >= 3 && consecutive(k - 2, k - 1) && consecutive(k - 3, k - 2) {
            Some(end_velocity(a, &targets[k - 2], &targets[k - 3]))
        } else {
            (k >= 2 && consecutive(k - 2, k - 1)).then(|| velocity(&targets[k - 2], a))
        };
        let after = if k + 2 < targets.len() && consecutive(k, k + 1) && consecutive(k + 1, k + 2) {
            Some(end_velocity(b, &targets[k + 1], &targets[k + 2]))
        } else {
            (k + 1 < targets.len() && consecutive(k, k + 1)).then(|| velocity(b, &targets[k + 1]))
        };
        let deviation_mm = match (before, after) {
            (Some(Some(v0)), Some(Some(v1))) if duration_s > 0.0 => {
                Some(hermite_deviation(a, b, v0, v1, duration_s))
            }
            _ => None,
        };
        let bridgeable = match config.max_gap_s {
            Some(max) => duration_s <= max,
            None => deviation_mm.is_some_and(|d| d <= config.tolerance_mm),
        };
        out.push(Gap {
            after: a.frame,
            before: b.frame,
            duration_s,
            deviation_mm,
            bridgeable,
        });
    }
    out
}

/// Velocity at `end`, mm/s, from it and the two frames beside it (`near`, then `far`, either
/// side of `end` in time): the derivative at `end` of the quadratic through the three
/// positions, exact for a quadratic and second order otherwise (a one-sided difference over
/// the last frame would lag by half a frame and tilt the tangent on a curve). `None` when the
/// times do not increase away from `end`.
fn end_velocity(end: &TcpTarget, near: &TcpTarget, far: &TcpTarget) -> Option<Vec3> {
    let (t0, t1, t2) = (end.time_s, near.time_s, far.time_s);
    let (d01, d02, d12) = (t0 - t1, t0 - t2, t1 - t2);
    let apart = d01 != 0.0 && d02 != 0.0 && d12 != 0.0 && (d01 > 0.0) == (d02 > 0.0);
    if !(apart && d01.is_finite() && d02.is_finite()) {
        return None;
    }
    let p = |t: &TcpTarget| t.wobj_from_tcp.translation.vector;
    let w0 = 1.0 / d01 + 1.0 / d02;
    let w1 = -d02 / (d01 * d12);
    let w2 = d01 / (d02 * d12);
    Some(p(end) * w0 + p(near) * w1 + p(far) * w2)
}

/// Velocity from `a` to `b`, mm/s (`None` for a non-increasing time).
fn velocity(a: &TcpTarget, b: &TcpTarget) -> Option<Vec3> {
    let dt = b.time_s - a.time_s;
    (dt > 0.0)
        .then(|| (b.wobj_from_tcp.translation.vector - a.wobj_from_tcp.translation.vector) / dt)
}

/// The largest distance from the chord `a → b` of the cubic Hermite curve with end velocities
/// `v0`, `v1` over `duration` seconds, sampled at 33 points.
fn hermite_deviation(a: &TcpTarget, b: &TcpTarget, v0: Vec3, v1: Vec3, duration: f64) -> f64 {
    let p0 = a.wobj_from_tcp.translation.vector;
    let p1 = b.wobj_from_tcp.translation.vector;
    let m0 = v0 * duration;
    let m1 = v1 * duration;
    let chord = p1 - p0;
    let length = chord.norm();
    (0..=32)
        .map(|i| {
            let s = f64::from(i) / 32.0;
            let (s2, s3) = (s * s, s * s * s);
            let p = p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                + m0 * (s3 - 2.0 * s2 + s)
                + p1 * (-2.0 * s3 + 3.0 * s2)
                + m1 * (s3 - s2);
            let d = p - p0;
            if length < 1e-9 {
                return d.norm();
            }
            // Distance to the segment (clamped projection).
            let along = (d.dot(&chord) / (length * length)).clamp(0.0, 1.0);
            (d - chord * along).norm()
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;

    fn target(frame: usize, time_s: f64, p: Vec3) -> TcpTarget {
        TcpTarget {
            frame: FrameIndex(frame),
            time_s,
            wobj_from_tcp: Pose::from_parts(p.into(), nalgebra::UnitQuaternion::identity()),
        }
    }

    /// Frames of a circle of radius `r` mm at `w` rad/s, 30 Hz, frames `lost` taken out.
    fn circle(r: f64, w: f64, frames: usize, lost: std::ops::Range<usize>) -> Vec<TcpTarget> {
        (0..frames)
            .filter(|k| !lost.contains(k))
            .map(|k| {
                let t = k as f64 / 30.0;
                target(k, t, Vec3::new(r * (w * t).cos(), r * (w * t).sin(), 0.0))
            })
            .collect()
    }

    #[test]
    fn an_arc_across_a_long_gap_is_not_bridgeable_a_short_one_is() {
        let config = GapConfig {
            tolerance_mm: 0.5,
            max_gap_s: None,
        };
        // 100 mm radius at 1 rad/s (100 mm/s): the sagitta of a 1 s chord is r(1 − cos 0.5)
        // = 12.2 mm; of a 2-frame gap (0.1 s), r(1 − cos 0.05) = 0.125 mm.
        let long = find_gaps(&circle(100.0, 1.0, 90, 30..59), &config);
        assert_eq!(long.len(), 1);
        assert_eq!(long[0].missing(), 29);
        let d = long[0].deviation_mm.unwrap();
        assert!((d - 12.2).abs() < 0.2 * 12.2, "{d}");
        assert!(!long[0].bridgeable);
        let short = find_gaps(&circle(100.0, 1.0, 90, 30..32), &config);
        let d = short[0].deviation_mm.unwrap();
        assert!((d - 0.125).abs() < 0.02, "{d}");
        assert!(short[0].bridgeable);
        // A fixed duration replaces the criterion.
        let fixed = GapConfig {
            max_gap_s: Some(2.0),
            ..config
        };
        assert!(find_gaps(&circle(100.0, 1.0, 90, 30..59), &fixed)[0].bridgeable);
    }

    #[test]
    fn a_straight_stroke_bridges_and_a_lone_frame_cannot_be_judged() {
        let config = GapConfig {
            tolerance_mm: 0.5,
            max_gap_s: None,
        };
        let line: Vec<TcpTarget> = (0..60)
            .filter(|k| !(10..40).contains(k))
            .map(|k| target(k, k as f64 / 30.0, Vec3::new(k as f64, 0.0, 0.0)))
            .collect();
        let gaps = find_gaps(&line, &config);
        assert!(gaps[0].deviation_mm.unwrap() < 1e-9);
        assert!(gaps[0].bridgeable);
        let lone = circle(100.0, 1.0, 60, 1..30);
        let gaps = find_gaps(&lone, &config);
        assert_eq!(gaps[0].deviation_mm, None);
        assert!(!gaps[0].bridgeable);
    }
}
