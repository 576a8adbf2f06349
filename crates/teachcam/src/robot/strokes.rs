//! Strokes of a take: the runs of frames where the brush paints, split where the tip leaves the
//! work surface or pauses; and trimming a take to a span of its time.
//!
//! Model: the work surface is the world's xy-plane, `z = 0` of the trajectory's frame, which is
//! the work object's frame (CONTRACT.md "Robot frames": `--wobj` places both in the robot's
//! base together, so it does not change a height). The tip is on the surface while
//! `|z| ≤ lift_mm` (either sign: a world whose z points into the table, as a chessboard lying
//! on it gives, has the brush at negative heights). A **stroke** is a run of consecutive targets
//! on the surface, cut at every **pause**: a run of targets whose speed stays under
//! `pause_speed_mm_s` for at least `pause_s`. The stroke before a pause ends on the pause's first
//! frame, the next begins on its last; runs of fewer than two targets are no stroke (nothing
//! to paint). Speeds are central differences over [`SPEED_WINDOW_S`]: the positions' noise
//! (σ ≈ 0.1 mm) then adds about `√2 σ / 0.2 s` ≈ 0.7 mm/s, well under the pause speed. Neither
//! a speed nor a pause spans lost frames: a gap in the data is judged by [`crate::robot::gaps`],
//! within its stroke.
//!
//! Defaults from the paper's stroke (the simulator's `painter_stroke`, measured at 300 Hz over
//! its 4 s): mean speed 178 mm/s, 5th percentile 61 mm/s, slowest 31 mm/s; acceleration up to
//! about 3000 mm/s²; height 1.1 to 8.0 mm above the surface. A pause is under 5 mm/s (a sixth
//! of the stroke's slowest moment: the stroke played six times slower still never pauses) for
//! 0.5 s (a reversal at the stroke's accelerations spends about `2 v / a` ≈ 0.01 s under
//! 5 mm/s); a lift is 10 mm (above the stroke's highest point, 8 mm, with the bristles'
//! deformation, and well under the 50 mm of an approach).

use std::ops::Range;

use crate::geometry::FrameIndex;
use crate::robot::TcpTarget;

/// Width of the central difference the speeds are measured over, seconds.
pub const SPEED_WINDOW_S: f64 = 0.2;

/// Options of [`find_strokes`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeConfig {
    /// Height above (or below) the work surface beyond which the tip has left it, millimetres.
    /// Default 10 mm: above the paper's stroke (at most 8 mm) and under an approach (50 mm).
    pub lift_mm: f64,
    /// Shortest pause that splits a stroke, seconds. Default 0.5 s: fifty times the time a
    /// reversal of the paper's stroke spends under the pause speed.
    pub pause_s: f64,
    /// Speed under which the tip pauses, mm/s. Default 5 mm/s: a sixth of the paper's stroke's
    /// slowest moment (31 mm/s), seven times the speed noise of a brush at rest.
    pub pause_speed_mm_s: f64,
}

impl Default for StrokeConfig {
    fn default() -> Self {
        Self {
            lift_mm: 10.0,
            pause_s: 0.5,
            pause_speed_mm_s: 5.0,
        }
    }
}

/// Why a stroke ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StrokeEnd {
    /// The tip leaves the surface after it.
    Lift,
    /// The tip pauses on the surface after it.
    Pause,
    /// The take (or its trimmed span) ends.
    TakeEnd,
}

impl StrokeEnd {
    /// A word for listings.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Lift => "lift",
            Self::Pause => "pause",
            Self::TakeEnd => "end",
        }
    }
}

/// One stroke of a take.
#[derive(Debug, Clone, PartialEq)]
pub struct Stroke {
    /// Its targets, as positions in the list given to [`find_strokes`].
    pub targets: Range<usize>,
    /// Its first frame.
    pub first: FrameIndex,
    /// Its last frame.
    pub last: FrameIndex,
    /// Time of the first frame, seconds of the take.
    pub start_s: f64,
    /// Time of the last frame, seconds of the take.
    pub end_s: f64,
    /// Path length of the tip, millimetres.
    pub length_mm: f64,
    /// Length over duration, mm/s.
    pub mean_speed_mm_s: f64,
    /// Why it ends.
    pub end: StrokeEnd,
}

impl std::fmt::Display for Stroke {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frames {}-{}, {:.3}-{:.3} s, {:.1} mm at {:.1} mm/s",
            self.first.0,
            self.last.0,
            self.start_s,
            self.end_s,
            self.length_mm,
            self.mean_speed_mm_s
        )
    }
}

/// The tip's height off the work surface at a target, `|z|`, millimetres.
fn height(target: &TcpTarget) -> f64 {
    target.wobj_from_tcp.translation.vector.z.abs()
}

/// The tip's lowest height off the work surface (`|z|`, mm) over the targets, `None` for
/// none: what a take without a stroke says.
#[must_use]
pub fn lowest_height_mm(targets: &[TcpTarget]) -> Option<f64> {
    targets.iter().map(height).min_by(f64::total_cmp)
}

/// True when targets `i` and `i + 1` of a run are consecutive frames (no frame lost between).
fn consecutive(run: &[TcpTarget], i: usize) -> bool {
    run[i + 1].frame.0 == run[i].frame.0 + 1
}

/// The tip's speed at each target of a run, mm/s: the central difference between the targets
/// [`SPEED_WINDOW_S`] / 2 before and after it (at least the neighbours), never across lost
/// frames (one-sided at a gap and at the run's ends; zero for a frame alone between gaps).
fn speeds(run: &[TcpTarget]) -> Vec<f64> {
    let half = SPEED_WINDOW_S / 2.0;
    (0..run.len())
        .map(|k| {
            let t = run[k].time_s;
            let mut a = k;
            while a > 0 && consecutive(run, a - 1) && (a == k || run[a - 1].time_s >= t - half) {
                a -= 1;
            }
            let mut b = k;
            while b + 1 < run.len()
                && consecutive(run, b)
                && (b == k || run[b + 1].time_s <= t + half)
            {
                b += 1;
            }
            let dt = run[b].time_s - run[a].time_s;
            let d = (run[b].wobj_from_tcp.translation.vector
                - run[a].wobj_from_tcp.translation.vector)
                .norm();
            if dt > 0.0 { d / dt } else { 0.0 }
        })
        .collect()
}

/// The strokes of a take's targets (in time order), in order ([`StrokeConfig`]).
#[must_use]
pub fn find_strokes(targets: &[TcpTarget], config: &StrokeConfig) -> Vec<Stroke> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < targets.len() {
        if height(&targets[start]) > config.lift_mm {
            start += 1;
            continue;
        }
        let mut end = start + 1;
        while end < targets.len() && height(&targets[end]) <= config.lift_mm {
            end += 1;
        }
        let run_end = if end < targets.len() {
            StrokeEnd::Lift
        } else {
            StrokeEnd::TakeEnd
        };
        split_at_pauses(targets, start..end, run_end, config, &mut out);
        start = end;
    }
    out
}

/// The strokes of one run on the surface, cut at its pauses.
fn split_at_pauses(
    targets: &[TcpTarget],
    run: Range<usize>,
    run_end: StrokeEnd,
    config: &StrokeConfig,
    out: &mut Vec<Stroke>,
) {
    let speed = speeds(&targets[run.clone()]);
    // Pauses as ranges of positions in the run.
    let mut pauses: Vec<Range<usize>> = Vec::new();
    let mut k = 0;
    while k < speed.len() {
        if speed[k] >= config.pause_speed_mm_s {
            k += 1;
            continue;
        }
        // A pause is measured: it never spans lost frames (a gap is judged as a gap).
        let mut e = k + 1;
        while e < speed.len()
            && speed[e] < config.pause_speed_mm_s
            && consecutive(&targets[run.clone()], e - 1)
        {
            e += 1;
        }
        let lasts = targets[run.start + e - 1].time_s - targets[run.start + k].time_s;
        if lasts >= config.pause_s {
            pauses.push(k..e);
        }
        k = e;
    }
    let mut from = 0;
    for pause in &pauses {
        push_stroke(
            targets,
            run.start + from..run.start + pause.start + 1,
            StrokeEnd::Pause,
            out,
        );
        from = pause.end - 1;
    }
    push_stroke(targets, run.start + from..run.end, run_end, out);
}

/// The whole list of targets as one stroke (what `check` and `export` use for a take that
/// never touches the surface), `None` for fewer than two targets.
#[must_use]
pub fn whole_take(targets: &[TcpTarget]) -> Option<Stroke> {
    let mut out = Vec::new();
    push_stroke(targets, 0..targets.len(), StrokeEnd::TakeEnd, &mut out);
    out.pop()
}

/// Adds the stroke over `range` when it has at least two targets.
fn push_stroke(targets: &[TcpTarget], range: Range<usize>, end: StrokeEnd, out: &mut Vec<Stroke>) {
    if range.len() < 2 {
        return;
    }
    let slice = &targets[range.clone()];
    let length_mm: f64 = slice
        .windows(2)
        .map(|w| {
            (w[1].wobj_from_tcp.translation.vector - w[0].wobj_from_tcp.translation.vector).norm()
        })
        .sum();
    let (first, last) = (&slice[0], &slice[slice.len() - 1]);
    let duration = last.time_s - first.time_s;
    out.push(Stroke {
        targets: range,
        first: first.frame,
        last: last.frame,
        start_s: first.time_s,
        end_s: last.time_s,
        length_mm,
        mean_speed_mm_s: if duration > 0.0 {
            length_mm / duration
        } else {
            0.0
        },
        end,
    });
}

/// Why a span of a take cannot be cut (`--from`, `--to`).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TrimError {
    /// The start is not before the end.
    #[error(
        "--from {from} --to {to}: --from must come before --to (the take runs {start_s:.3}-{end_s:.3} s)"
    )]
    Empty {
        /// `--from`, seconds.
        from: f64,
        /// `--to`, seconds.
        to: f64,
        /// The take's first time, seconds.
        start_s: f64,
        /// The take's last time, seconds.
        end_s: f64,
    },
    /// A bound outside the take.
    #[error("{flag} {value}: outside the take, which runs {start_s:.3}-{end_s:.3} s")]
    Outside {
        /// `--from` or `--to`.
        flag: &'static str,
        /// The value given, seconds.
        value: f64,
        /// The take's first time, seconds.
        start_s: f64,
        /// The take's last time, seconds.
        end_s: f64,
    },
}

/// A span of a take, seconds of its `time_s`, both ends included.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// First time kept.
    pub from_s: f64,
    /// Last time kept.
    pub to_s: f64,
}

impl Span {
    /// The span `from`..`to` of a take running `start_s`..`end_s` (a bound not given is the
    /// take's own).
    ///
    /// # Errors
    /// [`TrimError`]: a bound outside the take (or not finite), or `from ≥ to`.
    pub fn within(
        start_s: f64,
        end_s: f64,
        from: Option<f64>,
        to: Option<f64>,
    ) -> Result<Self, TrimError> {
        let outside = |flag, value: f64| {
            (!(value >= start_s && value <= end_s)).then_some(TrimError::Outside {
                flag,
                value,
                start_s,
                end_s,
            })
        };
        if let Some(e) = from.and_then(|v| outside("--from", v)) {
            return Err(e);
        }
        if let Some(e) = to.and_then(|v| outside("--to", v)) {
            return Err(e);
        }
        let span = Self {
            from_s: from.unwrap_or(start_s),
            to_s: to.unwrap_or(end_s),
        };
        if (from.is_some() || to.is_some()) && span.from_s >= span.to_s {
            return Err(TrimError::Empty {
                from: span.from_s,
                to: span.to_s,
                start_s,
                end_s,
            });
        }
        Ok(span)
    }

    /// The targets whose time lies in the span.
    #[must_use]
    pub fn trim(&self, targets: &[TcpTarget]) -> Vec<TcpTarget> {
        targets
            .iter()
            .filter(|t| t.time_s >= self.from_s && t.time_s <= self.to_s)
            .copied()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pose_from_parts;
    use nalgebra::{UnitQuaternion, Vector3};

    /// A target at frame `k` of a 30 Hz take at `(x, 0, z)`.
    fn at(k: usize, x: f64, z: f64) -> TcpTarget {
        TcpTarget {
            frame: FrameIndex(k),
            time_s: k as f64 / 30.0,
            wobj_from_tcp: pose_from_parts(Vector3::new(x, 0.0, z), UnitQuaternion::identity()),
        }
    }

    #[test]
    fn a_lift_splits_and_a_pause_splits() {
        // 0-29 painting at 100 mm/s, 30-44 lifted 30 mm, 45-74 painting, 75-104 resting
        // (1 s), 105-134 painting.
        let mut targets = Vec::new();
        for k in 0..135 {
            let (x, z) = match k {
                0..30 => (k as f64 * 100.0 / 30.0, 2.0),
                30..45 => (100.0, 30.0),
                45..75 => (100.0 - (k - 45) as f64 * 100.0 / 30.0, 2.0),
                75..105 => (0.0, 2.0),
                _ => ((k - 105) as f64 * 100.0 / 30.0, 2.0),
            };
            targets.push(at(k, x, z));
        }
        let strokes = find_strokes(&targets, &StrokeConfig::default());
        let spans: Vec<(usize, usize, StrokeEnd)> = strokes
            .iter()
            .map(|s| (s.first.0, s.last.0, s.end))
            .collect();
        // The pause: speeds under 5 mm/s from about frame 78 (the window reaches back 3
        // frames) to frame 101.
        assert_eq!(spans.len(), 3, "{spans:?}");
        assert_eq!(
            (spans[0].0, spans[0].1, spans[0].2),
            (0, 29, StrokeEnd::Lift)
        );
        assert_eq!(spans[1].0, 45);
        assert_eq!(spans[1].2, StrokeEnd::Pause);
        assert!((76..=79).contains(&spans[1].1), "{spans:?}");
        assert!((101..=105).contains(&spans[2].0), "{spans:?}");
        assert_eq!(spans[2].1, 134);
        assert!((strokes[0].mean_speed_mm_s - 100.0).abs() < 1.0);
        assert!((strokes[0].length_mm - 96.67).abs() < 0.01);
    }

    #[test]
    fn lost_frames_are_no_pause() {
        // Along x at 40 mm/s, frames 30-59 lost, during which the tip went back 4 frames'
        // worth: frame 60 is where frame 26 was. Measured straight across the gap, frames 29
        // and 60 would have no speed for 1 s (a pause). No speed is measured across a gap.
        let targets: Vec<TcpTarget> = (0..91)
            .filter(|k| !(30..60).contains(k))
            .map(|k| {
                let step = if k < 30 { k as f64 } else { k as f64 - 34.0 };
                at(k, 40.0 * step / 30.0, 2.0)
            })
            .collect();
        let strokes = find_strokes(&targets, &StrokeConfig::default());
        assert_eq!(strokes.len(), 1, "{strokes:?}");
    }

    #[test]
    fn no_stroke_when_the_tip_stays_up() {
        let targets: Vec<TcpTarget> = (0..30).map(|k| at(k, k as f64, 40.0 + k as f64)).collect();
        assert!(find_strokes(&targets, &StrokeConfig::default()).is_empty());
        assert_eq!(lowest_height_mm(&targets), Some(40.0));
    }

    #[test]
    fn spans_outside_the_take_or_empty_are_refused() {
        assert!(Span::within(0.0, 4.0, Some(1.0), Some(2.0)).is_ok());
        assert!(matches!(
            Span::within(0.0, 4.0, Some(2.0), Some(1.0)),
            Err(TrimError::Empty { .. })
        ));
        assert!(matches!(
            Span::within(0.0, 4.0, None, Some(5.0)),
            Err(TrimError::Outside { flag: "--to", .. })
        ));
        assert!(Span::within(0.0, 4.0, Some(f64::NAN), None).is_err());
        let span = Span::within(0.0, 4.0, Some(1.0), Some(2.0)).unwrap();
        let targets: Vec<TcpTarget> = (0..120).map(|k| at(k, 0.0, 0.0)).collect();
        let kept = span.trim(&targets);
        assert_eq!((kept[0].frame.0, kept[kept.len() - 1].frame.0), (30, 60));
    }
}
