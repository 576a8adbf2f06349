//! 2-D blob tracks in one camera and their interpolation between frames.
//!
//! Linking: a track's next blob is the one nearest to its constant-velocity prediction
//! `p̂ₖ₊₁ = pₖ + (pₖ − pₖ₋₁)`, accepted only when the two choose each other (mutual nearest)
//! and the runner-up lies clearly farther (`link_ratio`); otherwise the track ends. A marker
//! hidden for a frame therefore ends one track and starts another: nothing is bridged.
//!
//! Interpolation: the Lagrange polynomial through the `n` samples around the point (`n` even,
//! 8 by default: degree 7, error `O(h⁸ p⁽⁸⁾)`; on a 30 Hz recording of motion up to 5 Hz,
//! `ωh ≤ 1`, each two more points divide the error by about five), the window centred on the
//! interval where the track allows and shifted inside it near its ends (so a track's end is
//! still interpolated, not extrapolated, at a few times the centred error); fewer points on
//! shorter tracks, down to 4; nothing on tracks shorter than that, whose motion cannot be
//! followed. Each sample also carries the value of the polynomial through the same window
//! without its node farthest from the point, one order lower: their difference estimates that
//! lower order's error and bounds the chosen one's (de Boor, *A Practical Guide to Splines*,
//! ch. I–II). The estimate feeds the time offset's systematic uncertainty and the resampled
//! frames' "uncertain" report.

use crate::geometry::Pixel;

/// One blob followed through consecutive frames of one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct BlobTrack {
    /// The frame of the first sample.
    pub first_frame: usize,
    /// The blob index in each frame's list, from `first_frame` on, one per frame.
    pub blobs: Vec<usize>,
    /// The blob positions, one per frame (whatever pixel space the caller linked in).
    pub positions: Vec<Pixel>,
}

/// How a track sample was interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stencil {
    /// At a sample itself: no interpolation.
    Exact,
    /// A polynomial through `points` samples (an even number, at least 4), centred on the
    /// interval or not.
    Polynomial {
        /// Samples used.
        points: usize,
        /// True when the window is centred on the interval (the most accurate choice).
        centred: bool,
    },
}

/// A point of a track between frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSample {
    /// The interpolated position.
    pub position: Pixel,
    /// The value one order lower (the sample itself when exact).
    pub lower_order: Pixel,
    /// How `position` was found.
    pub stencil: Stencil,
}

impl TrackSample {
    /// The interpolation error estimate: the distance between the two orders, pixels (an
    /// upper estimate of the chosen order's error).
    #[must_use]
    pub fn error_px(&self) -> f64 {
        self.position.distance(&self.lower_order)
    }
}

impl BlobTrack {
    /// The frame of the last sample.
    #[must_use]
    pub fn last_frame(&self) -> usize {
        self.first_frame + self.positions.len().saturating_sub(1)
    }

    /// True when the track has a sample at or on both sides of the fractional frame `at`.
    #[must_use]
    pub fn spans(&self, at: f64) -> bool {
        at >= self.first_frame as f64 && at <= self.last_frame() as f64
    }

    /// The track at the fractional frame index `at`, interpolated through at most
    /// `max_points` samples (even, ≥ 4; fewer where the track is shorter); `None` outside the
    /// frames it spans and between the samples of a track shorter than four.
    #[must_use]
    pub fn sample(&self, at: f64, max_points: usize) -> Option<TrackSample> {
        if !at.is_finite() || !self.spans(at) {
            return None;
        }
        let p = &self.positions;
        let n = p.len();
        let local = at - self.first_frame as f64;
        let k = (local.floor() as usize).min(n - 1);
        let u = local - k as f64;
        if k + 1 >= n || u == 0.0 {
            return Some(TrackSample {
                position: p[k],
                lower_order: p[k],
                stencil: Stencil::Exact,
            });
        }
        let points = (4..=max_points.max(4)).rev().step_by(2).find(|&m| n >= m)?;
        // The window [start, start + points) centred on [k, k + 1], shifted to fit the track.
        let centred_start = k as isize - (points as isize / 2 - 1);
        let start = centred_start.clamp(0, (n - points) as isize) as usize;
        let window = &p[start..start + points];
        let nodes: Vec<f64> = (0..points).map(|j| (start + j) as f64).collect();
        let position = lagrange(window, &nodes, local);
        let farthest = if (local - nodes[0]).abs() > (nodes[points - 1] - local).abs() {
            0
        } else {
            points - 1
        };
        let (lower_window, lower_nodes): (Vec<Pixel>, Vec<f64>) = window
            .iter()
            .zip(&nodes)
            .enumerate()
            .filter(|(j, _)| *j != farthest)
            .map(|(_, (p, x))| (*p, *x))
            .unzip();
        Some(TrackSample {
            position,
            lower_order: lagrange(&lower_window, &lower_nodes, local),
            stencil: Stencil::Polynomial {
                points,
                centred: start as isize == centred_start,
            },
        })
    }
}

/// The polynomial through the samples `p` at `nodes`, evaluated at `x`.
fn lagrange(p: &[Pixel], nodes: &[f64], x: f64) -> Pixel {
    let mut value = Pixel::new(0.0, 0.0);
    for (j, (pj, xj)) in p.iter().zip(nodes).enumerate() {
        let w: f64 = nodes
            .iter()
            .enumerate()
            .filter(|(m, _)| *m != j)
            .map(|(_, xm)| (x - xm) / (xj - xm))
            .product();
        value.x += w * pj.x;
        value.y += w * pj.y;
    }
    value
}

/// Links one camera's blobs, `frames[f]` being its blob positions in frame `f`, into tracks.
/// Every blob belongs to exactly one track (a blob that links to nothing is a track of one
/// sample). `link_ratio` ∈ (0, 1): a link needs the runner-up at least `1 / link_ratio` times
/// worse than the chosen blob, seen from the track and from the blob alike.
///
/// A track of two or more samples predicts its next position (constant acceleration from
/// three samples, constant velocity from two) and links to the blob nearest that prediction.
/// A track of one sample has no velocity yet: each candidate blob implies one, and the
/// candidate whose implied next position lands nearest to a blob of the frame after wins, so
/// that a marker moving farther per frame than it is from its neighbours is still followed.
#[must_use]
pub fn link_tracks(frames: &[Vec<Pixel>], link_ratio: f64) -> Vec<BlobTrack> {
    let mut done = Vec::new();
    let mut active: Vec<BlobTrack> = Vec::new();
    for (frame, blobs) in frames.iter().enumerate() {
        let mut links: Vec<Option<usize>> = vec![None; active.len()];
        let mut taken = vec![false; blobs.len()];
        let moving: Vec<usize> = (0..active.len())
            .filter(|&t| active[t].positions.len() >= 2)
            .collect();
        let costs: Vec<Vec<f64>> = moving
            .iter()
            .map(|&t| {
                let prediction = predict(&active[t]);
                blobs.iter().map(|b| prediction.distance(b)).collect()
            })
            .collect();
        for (row, blob) in mutual_best(&costs, link_ratio).into_iter().enumerate() {
            if let Some(blob) = blob {
                links[moving[row]] = Some(blob);
                taken[blob] = true;
            }
        }
        let fresh: Vec<usize> = (0..active.len())
            .filter(|&t| active[t].positions.len() == 1)
            .collect();
        let next = frames.get(frame + 1).filter(|n| !n.is_empty());
        let costs: Vec<Vec<f64>> = fresh
            .iter()
            .map(|&t| {
                let p = active[t].positions[0];
                blobs
                    .iter()
                    .zip(&taken)
                    .map(|(b, &used)| match (used, next) {
                        (true, _) => f64::INFINITY,
                        (false, Some(next)) => {
                            let ahead = Pixel::new(2.0 * b.x - p.x, 2.0 * b.y - p.y);
                            next.iter()
                                .map(|n| ahead.distance(n))
                                .fold(f64::INFINITY, f64::min)
                        }
                        (false, None) => p.distance(b),
                    })
                    .collect()
            })
            .collect();
        for (row, blob) in mutual_best(&costs, link_ratio).into_iter().enumerate() {
            if let Some(blob) = blob {
                links[fresh[row]] = Some(blob);
                taken[blob] = true;
            }
        }
        let mut next_active = Vec::new();
        for (mut track, link) in active.into_iter().zip(links) {
            match link {
                Some(blob) => {
                    track.blobs.push(blob);
                    track.positions.push(blobs[blob]);
                    next_active.push(track);
                }
                None => done.push(track),
            }
        }
        for (blob, position) in blobs.iter().enumerate() {
            if !taken[blob] {
                next_active.push(BlobTrack {
                    first_frame: frame,
                    blobs: vec![blob],
                    positions: vec![*position],
                });
            }
        }
        active = next_active;
    }
    done.extend(active);
    done.sort_by_key(|t| (t.first_frame, t.blobs.first().copied()));
    done
}

/// Where a track's next sample should be: constant acceleration from its last three samples,
/// constant velocity from two.
fn predict(track: &BlobTrack) -> Pixel {
    match track.positions.as_slice() {
        [.., a, b, c] => Pixel::new(3.0 * c.x - 3.0 * b.x + a.x, 3.0 * c.y - 3.0 * b.y + a.y),
        [.., b, c] => Pixel::new(2.0 * c.x - b.x, 2.0 * c.y - b.y),
        [c] => *c,
        [] => Pixel::new(f64::NAN, f64::NAN),
    }
}

/// For each row of a cost matrix (tracks × blobs), the column it links to: each other's
/// least cost, with the runner-up at least `1 / ratio` times costlier along the row and the
/// column alike.
fn mutual_best(costs: &[Vec<f64>], ratio: f64) -> Vec<Option<usize>> {
    let columns = costs.first().map_or(0, Vec::len);
    let column_best: Vec<Option<(usize, f64, f64)>> = (0..columns)
        .map(|j| nearest_two(costs.iter().map(|row| row[j])))
        .collect();
    costs
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let (j, cost, second) = nearest_two(row.iter().copied())?;
            let (back, _, back_second) = column_best[j]?;
            (back == i && cost <= ratio * second && cost <= ratio * back_second).then_some(j)
        })
        .collect()
}

/// Index of the least finite value, the value, and the runner-up (∞ when alone).
pub(super) fn nearest_two(values: impl Iterator<Item = f64>) -> Option<(usize, f64, f64)> {
    let mut best: Option<(usize, f64)> = None;
    let mut second = f64::INFINITY;
    for (i, v) in values.enumerate() {
        match best {
            _ if !v.is_finite() => {}
            Some((_, b)) if v >= b => second = second.min(v),
            _ => {
                second = best.map_or(second, |(_, b)| b);
                best = Some((i, v));
            }
        }
    }
    best.map(|(i, v)| (i, v, second))
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        reason = "a test fails loudly on a broken fixture"
    )]

    use super::*;

    fn track_of(points: &[(f64, f64)]) -> BlobTrack {
        BlobTrack {
            first_frame: 3,
            blobs: vec![0; points.len()],
            positions: points.iter().map(|&(x, y)| Pixel::new(x, y)).collect(),
        }
    }

    const CENTRED_QUINTIC: Stencil = Stencil::Polynomial {
        points: 6,
        centred: true,
    };

    #[test]
    fn the_quintic_is_exact_on_quintic_motion_centred_or_not() {
        let motion = |t: f64| (2.0 + 3.0 * t - 0.7 * t.powi(5) / 50.0, -1.0 + 0.25 * t * t);
        let points: Vec<(f64, f64)> = (0..8).map(|k| motion(k as f64)).collect();
        let track = track_of(&points);
        for at in [3.5, 4.5, 5.3, 5.5, 6.9, 7.25, 9.5] {
            let s = track.sample(at, 6).unwrap();
            let (x, y) = motion(at - 3.0);
            assert!((s.position.x - x).abs() < 1e-9, "x at {at}");
            assert!((s.position.y - y).abs() < 1e-9, "y at {at}");
            // One order lower misses the fifth-order term: the estimate sees it.
            assert!(s.error_px() > 1e-4, "at {at}");
        }
        assert_eq!(track.sample(5.5, 6).unwrap().stencil, CENTRED_QUINTIC);
        assert_eq!(
            track.sample(3.5, 6).unwrap().stencil,
            Stencil::Polynomial {
                points: 6,
                centred: false
            }
        );
        let exact = track.sample(4.0, 6).unwrap();
        assert_eq!(exact.stencil, Stencil::Exact);
        assert_eq!(exact.position, track.positions[1]);
        assert_eq!(track.sample(10.0, 6).unwrap().position, track.positions[7]);
        assert!(track.sample(2.99, 6).is_none());
        assert!(track.sample(10.01, 6).is_none());
        // Three samples cannot be followed between frames, only at them.
        let short = track_of(&points[..3]);
        assert!(short.sample(3.5, 6).is_none());
        assert!(short.sample(4.0, 6).is_some());
    }

    #[test]
    fn the_error_estimate_is_the_lower_orders_true_error() {
        let motion = |t: f64| (t.powi(4), 0.0);
        let points: Vec<(f64, f64)> = (0..8).map(|k| motion(k as f64)).collect();
        let track = track_of(&points);
        let s = track.sample(6.5, 6).unwrap();
        let truth = motion(3.5).0;
        // The quintic and the quartic below it are exact on a quartic: no error to see.
        assert!((s.position.x - truth).abs() < 1e-9);
        assert!(s.error_px() < 1e-9);
        let motion = |t: f64| (t.powi(5), 0.0);
        let points: Vec<(f64, f64)> = (0..8).map(|k| motion(k as f64)).collect();
        let s = track_of(&points).sample(6.5, 6).unwrap();
        let truth = motion(3.5).0;
        assert!((s.position.x - truth).abs() < 1e-9);
        assert!((s.error_px() - (s.lower_order.x - truth).abs()).abs() < 1e-9);
        assert!(s.error_px() > 0.1);
    }

    #[test]
    fn linking_follows_crossing_free_motion_and_stops_at_ambiguity() {
        // Two blobs moving apart at 5 px per frame, then a third appears right next to one.
        let mut frames: Vec<Vec<Pixel>> = (0..5)
            .map(|f| {
                let f = f as f64;
                vec![
                    Pixel::new(100.0 + 5.0 * f, 50.0),
                    Pixel::new(300.0 - 5.0 * f, 80.0),
                ]
            })
            .collect();
        frames[4].reverse();
        let tracks = link_tracks(&frames, 0.5);
        assert_eq!(tracks.len(), 2);
        assert!(tracks.iter().all(|t| t.positions.len() == 5));
        let mut ambiguous = frames.clone();
        ambiguous.push(vec![
            Pixel::new(124.0, 50.0),
            Pixel::new(126.0, 50.0),
            Pixel::new(275.0, 80.0),
        ]);
        let tracks = link_tracks(&ambiguous, 0.5);
        let long: Vec<_> = tracks.iter().filter(|t| t.positions.len() == 6).collect();
        assert_eq!(
            long.len(),
            1,
            "only the unambiguous blob continues its track"
        );
        assert_eq!(tracks.len(), 4);
    }
}
