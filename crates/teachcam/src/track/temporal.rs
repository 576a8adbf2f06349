//! The temporal guard: a pose farther from its neighbours than the recording's own motion
//! allows is an outlier — a second line behind [`crate::track::reflections`] for a ghost that
//! is never seen beside the tool.
//!
//! Model. A hand or a robot moves the tool smoothly: between consecutive frames its tip moves
//! by a step whose scale the recording shows. The gate is `g = median + 4σ̂` of the tip steps
//! between consecutive confident (`ok`) frames (σ̂ the normal-consistent MAD, as every gate of
//! [`crate::track::gates`]), with a floor of 6 times the frames' median `tip_std_mm` (a
//! static tool's steps are noise). The posed frames (outliers left out) are cut into
//! *segments* wherever the tip moves more than `g` per frame between posed frames. A segment
//! is a ghost when
//! - it is shorter than the segments on both sides of it, and
//! - those two agree with each other: the last tip before it and the first after it are
//!   within `g` per frame of each other;
//!
//! and each of its frames whose tip is more than `g` off the straight path between those two
//! tips is an outlier.
//!
//! Real fast motion cannot pass: where the tool moves faster than `g` every frame is its own
//! segment and the tips around each are more than `g` per frame apart. A segment at the start
//! or the end of the recording has one neighbour and is never flagged.

use crate::geometry::Point3;
use crate::stats::{median, robust_scale};
use crate::track::gates::Gate;

/// Tip steps needed to measure the gate; with fewer there is no guard.
pub const MIN_STEPS: usize = 10;

/// How many σ̂ above the median tip step the gate lies.
const K: f64 = 4.0;

/// The gate's floor in units of the frames' median tip uncertainty.
const NOISE_FLOOR: f64 = 6.0;

/// One frame as the guard sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipFrame {
    /// The tip, world frame; `None` without a pose or for a frame already an outlier.
    pub tip_in_world: Option<Point3>,
    /// Whether the frame is `ok` (its steps measure the gate).
    pub confident: bool,
    /// The frame's `tip_std_mm`, if any.
    pub tip_std_mm: Option<f64>,
}

impl TipFrame {
    /// A frame the guard cannot use: no pose (or not in the stream).
    #[must_use]
    pub fn absent() -> Self {
        Self {
            tip_in_world: None,
            confident: false,
            tip_std_mm: None,
        }
    }
}

/// The guard's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct TemporalCheck {
    /// Largest tip step per frame of the tool's own motion, millimetres; `None` when too few
    /// steps were measured (nothing flagged then).
    pub gate: Option<Gate>,
    /// The frames flagged, each with its tip's distance from the path between the tips around
    /// its segment, millimetres.
    pub outliers: Vec<(usize, f64)>,
}

/// Measures the step gate from `frames` and flags the ghost segments (module docs).
#[must_use]
pub fn temporal_outliers(frames: &[TipFrame]) -> TemporalCheck {
    let Some(gate) = step_gate(frames) else {
        return TemporalCheck {
            gate: None,
            outliers: Vec::new(),
        };
    };
    let outliers = ghosts(frames, gate.value);
    TemporalCheck {
        gate: Some(gate),
        outliers,
    }
}

/// The tip steps between consecutive confident frames of `frames`, millimetres.
#[must_use]
pub fn confident_steps(frames: &[TipFrame]) -> Vec<f64> {
    frames
        .windows(2)
        .filter(|w| w[0].confident && w[1].confident)
        .filter_map(|w| Some((w[1].tip_in_world? - w[0].tip_in_world?).norm()))
        .collect()
}

/// The step gate of `frames` (module docs); `None` with fewer than [`MIN_STEPS`] steps.
#[must_use]
pub fn step_gate(frames: &[TipFrame]) -> Option<Gate> {
    let stds: Vec<f64> = frames
        .iter()
        .filter(|f| f.confident)
        .filter_map(|f| f.tip_std_mm)
        .collect();
    step_gate_of(&confident_steps(frames), &stds)
}

/// The step gate from tip steps between confident frames and those frames' `tip_std_mm`
/// (module docs); `None` with fewer than [`MIN_STEPS`] steps.
#[must_use]
pub fn step_gate_of(steps: &[f64], tip_std_mm: &[f64]) -> Option<Gate> {
    let scale = robust_scale(steps).filter(|s| s.count >= MIN_STEPS)?;
    let raw = scale.median + K * scale.sigma;
    let floor = NOISE_FLOOR * median(tip_std_mm).unwrap_or(0.0);
    let measured = format!(
        "median {:.3} + {K}·σ̂ {:.3} of {} tip steps between ok frames = {raw:.3}",
        scale.median, scale.sigma, scale.count
    );
    Some(if raw < floor {
        Gate {
            value: floor,
            reason: format!(
                "{measured}, raised to the floor {floor:.3} mm: {NOISE_FLOOR} times the median tip_std_mm"
            ),
        }
    } else {
        Gate {
            value: raw,
            reason: measured,
        }
    })
}

/// The frames of `frames` in ghost segments at step gate `g` millimetres per frame (module
/// docs), each with its tip's distance from the path between the tips around its segment.
#[must_use]
pub fn ghosts(frames: &[TipFrame], g: f64) -> Vec<(usize, f64)> {
    let posed: Vec<(usize, Point3)> = frames
        .iter()
        .enumerate()
        .filter_map(|(i, f)| Some((i, f.tip_in_world?)))
        .collect();
    // Segments: runs of posed frames whose tips move at most g per frame.
    let mut segments: Vec<&[(usize, Point3)]> = Vec::new();
    let mut start = 0;
    for k in 1..=posed.len() {
        let cut = k == posed.len() || {
            let (i, a) = posed[k - 1];
            let (j, b) = posed[k];
            (b - a).norm() > g * (j - i) as f64
        };
        if cut {
            segments.push(&posed[start..k]);
            start = k;
        }
    }
    let mut outliers = Vec::new();
    for w in segments.windows(3) {
        let (before, ghost, after) = (w[0], w[1], w[2]);
        if ghost.len() >= before.len() || ghost.len() >= after.len() {
            continue;
        }
        let (Some(&(i, a)), Some(&(j, b))) = (before.last(), after.first()) else {
            continue;
        };
        if (b - a).norm() > g * (j - i) as f64 {
            continue;
        }
        for &(k, tip) in ghost {
            let t = (k - i) as f64 / (j - i) as f64;
            let deviation = (tip - (a + (b - a) * t)).norm();
            if deviation > g {
                outliers.push((k, deviation));
            }
        }
    }
    outliers
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(x: f64) -> TipFrame {
        TipFrame {
            tip_in_world: Some(Point3::new(x, 0.0, 0.0)),
            confident: true,
            tip_std_mm: Some(0.05),
        }
    }

    #[test]
    fn a_short_jump_out_and_back_is_flagged_a_fast_stretch_is_not() {
        // 1 mm per frame with a burst at 30 mm per frame over frames 40–44, and a ghost
        // 500 mm off at 20–21.
        let mut x = 0.0;
        let mut frames = Vec::new();
        for i in 0..100 {
            x += if (40..45).contains(&i) { 30.0 } else { 1.0 };
            frames.push(frame(x));
        }
        for f in &mut frames[20..22] {
            f.tip_in_world = f
                .tip_in_world
                .map(|p| p + nalgebra::Vector3::new(0.0, 500.0, 0.0));
            f.confident = false;
        }
        let check = temporal_outliers(&frames);
        let flagged: Vec<usize> = check.outliers.iter().map(|o| o.0).collect();
        assert_eq!(flagged, vec![20, 21], "{check:?}");
        assert!(check.outliers.iter().all(|o| (o.1 - 500.0).abs() < 1.0));
    }
}
