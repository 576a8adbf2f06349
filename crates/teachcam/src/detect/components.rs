//! Connected components of the pixels above a threshold, in one pass, as runs.
//!
//! Each row is scanned once; a stretch of `CHUNK` (128) pixels whose maximum is at or below the
//! threshold is skipped whole (the compiler turns that maximum into SIMD), so a dark frame
//! costs about one memory read. The runs of foreground pixels are joined to the runs of the
//! row above that touch them, 8-connected (a run `[a, b]` touches `[c, d]` when
//! `c ≤ b + 1` and `a ≤ d + 1`), with a union–find (path halving). Rosenfeld & Pfaltz, 1966,
//! on runs as in He et al., *Fast connected-component labeling*, Pattern Recognition 2009.

use super::{GrayView, Intensity};

/// Pixels examined at once when skipping dark stretches.
const CHUNK: usize = 128;

/// A horizontal run of foreground pixels: columns `x_start..=x_end` of row `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Row.
    pub y: u32,
    /// First column.
    pub x_start: u32,
    /// Last column (inclusive).
    pub x_end: u32,
}

impl Run {
    /// Pixels in the run.
    #[must_use]
    pub fn len(&self) -> usize {
        (self.x_end - self.x_start + 1) as usize
    }

    /// Never true: a run holds at least one pixel.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }
}

/// One 8-connected region above the threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Its runs, in raster order.
    pub runs: Vec<Run>,
    /// Pixels.
    pub area: usize,
    /// Inclusive bounds: leftmost, top, rightmost, bottom.
    pub bounds: super::PixelBox,
}

impl Region {
    /// True when the region reaches the first or last row or column of the image.
    #[must_use]
    pub fn touches_border(&self, width: usize, height: usize) -> bool {
        self.bounds.x_min == 0
            || self.bounds.y_min == 0
            || self.bounds.x_max as usize + 1 >= width
            || self.bounds.y_max as usize + 1 >= height
    }
}

/// The 8-connected regions of pixels strictly above `threshold`, ordered by their first pixel
/// in raster order; `None` when there are more than `max_regions`.
#[must_use]
pub fn label<P: Intensity>(
    image: GrayView<'_, P>,
    threshold: u32,
    max_regions: usize,
) -> Option<Vec<Region>> {
    let runs = find_runs(image, threshold);
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    join_touching_runs(&runs, &mut parent);

    // Label each root in order of its first run (runs are in raster order).
    let mut label_of_run = vec![u32::MAX; runs.len()];
    let mut regions: Vec<Region> = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        let root = find(&mut parent, i as u32) as usize;
        let label = if label_of_run[root] == u32::MAX {
            if regions.len() == max_regions {
                return None;
            }
            label_of_run[root] = regions.len() as u32;
            regions.push(Region {
                runs: Vec::new(),
                area: 0,
                bounds: super::PixelBox {
                    x_min: run.x_start,
                    y_min: run.y,
                    x_max: run.x_end,
                    y_max: run.y,
                },
            });
            label_of_run[root]
        } else {
            label_of_run[root]
        };
        let region = &mut regions[label as usize];
        region.runs.push(*run);
        region.area += run.len();
        let b = &mut region.bounds;
        b.x_min = b.x_min.min(run.x_start);
        b.x_max = b.x_max.max(run.x_end);
        b.y_max = run.y;
    }
    Some(regions)
}

/// Every run of pixels above `threshold`, in raster order.
fn find_runs<P: Intensity>(image: GrayView<'_, P>, threshold: u32) -> Vec<Run> {
    let mut runs = Vec::new();
    // `threshold < FULL_SCALE` here (the caller returns early otherwise), so it fits in `P`.
    let Some(t) = P::from(threshold) else {
        return runs;
    };
    for y in 0..image.height {
        let row = image.row(y);
        let w = row.len();
        let mut x = 0;
        while x < w {
            if row[x] <= t {
                if x % CHUNK == 0 && x + CHUNK <= w && !any_above(&row[x..x + CHUNK], t) {
                    x += CHUNK;
                } else {
                    x += 1;
                }
                continue;
            }
            let start = x;
            while x < w && row[x] > t {
                x += 1;
            }
            runs.push(Run {
                y: y as u32,
                x_start: start as u32,
                x_end: (x - 1) as u32,
            });
        }
    }
    runs
}

/// True when some value of the chunk is above `t`: the chunk's maximum, without an early
/// exit, so that it vectorises (`pmaxub` for 8-bit on any x86-64).
#[inline]
fn any_above<P: Intensity>(chunk: &[P], t: P) -> bool {
    chunk.iter().fold(P::zero(), |m, &v| m.max(v)) > t
}

/// Unites each run with the runs of the previous row it touches (8-connectivity).
fn join_touching_runs(runs: &[Run], parent: &mut [u32]) {
    let mut previous_row = 0..0;
    let mut i = 0;
    while i < runs.len() {
        let y = runs[i].y;
        let row_start = i;
        while i < runs.len() && runs[i].y == y {
            i += 1;
        }
        let current_row = row_start..i;
        let above_is_adjacent = previous_row
            .clone()
            .next()
            .is_some_and(|p| runs[p].y + 1 == y);
        if above_is_adjacent {
            // Both rows are sorted by column: sweep them together.
            let mut p = previous_row.start;
            for c in current_row.clone() {
                let cur = runs[c];
                while p < previous_row.end && runs[p].x_end + 1 < cur.x_start {
                    p += 1;
                }
                let mut q = p;
                while q < previous_row.end && runs[q].x_start <= cur.x_end + 1 {
                    union(parent, c as u32, q as u32);
                    q += 1;
                }
            }
        }
        previous_row = current_row;
    }
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let grand = parent[parent[i as usize] as usize];
        parent[i as usize] = grand;
        i = grand;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let ra = find(parent, a);
    let rb = find(parent, b);
    // The older run (smaller index) stays the root, so a region's root is its first run.
    if ra < rb {
        parent[rb as usize] = ra;
    } else if rb < ra {
        parent[ra as usize] = rb;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regions_of(rows: &[&str]) -> Vec<Region> {
        let width = rows[0].len();
        let pixels: Vec<u8> = rows
            .iter()
            .flat_map(|r| r.bytes().map(|b| if b == b'#' { 200 } else { 0 }))
            .collect();
        let view = GrayView {
            width,
            height: rows.len(),
            pixels: &pixels,
        };
        label(view, 100, 100).unwrap()
    }

    #[test]
    fn diagonal_neighbours_join_and_gaps_separate() {
        let regions = regions_of(&[
            "#...#....", //
            ".#..#..##", //
            "..#.#....", //
            ".........", //
            "#.#.#.#.#", //
        ]);
        let areas: Vec<usize> = regions.iter().map(|r| r.area).collect();
        assert_eq!(areas, vec![3, 3, 2, 1, 1, 1, 1, 1]);
    }

    #[test]
    fn a_u_shape_is_one_region_labelled_at_its_first_pixel() {
        let regions = regions_of(&[
            "......", //
            ".#..#.", //
            ".#..#.", //
            ".####.", //
        ]);
        assert_eq!(regions.len(), 1);
        assert_eq!(regions[0].area, 8);
        assert_eq!(
            regions[0].bounds,
            crate::detect::PixelBox {
                x_min: 1,
                y_min: 1,
                x_max: 4,
                y_max: 3
            }
        );
    }

    #[test]
    fn long_rows_cross_chunk_boundaries() {
        let width = 3 * CHUNK + 5;
        let mut pixels = vec![0u8; width * 3];
        for x in CHUNK - 2..CHUNK + 3 {
            pixels[width + x] = 255;
        }
        pixels[2 * width + width - 1] = 255;
        let view = GrayView {
            width,
            height: 3,
            pixels: &pixels,
        };
        let regions = label(view, 0, 10).unwrap();
        assert_eq!(regions.len(), 2);
        assert_eq!(regions[0].runs[0].x_start as usize, CHUNK - 2);
        assert_eq!(regions[0].runs[0].x_end as usize, CHUNK + 2);
        assert_eq!(regions[1].runs[0].x_start as usize, width - 1);
    }

    #[test]
    fn region_cap_is_reported() {
        let regions = regions_of(&["#.#.#"]);
        assert_eq!(regions.len(), 3);
        let pixels = [200u8, 0, 200, 0, 200];
        let view = GrayView {
            width: 5,
            height: 1,
            pixels: &pixels,
        };
        assert!(label(view, 100, 2).is_none());
    }
}
