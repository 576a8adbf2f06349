//! Correspondence: which blobs in different cameras are images of the same marker.
//!
//! The paper's trinocular loop (§II-A): take a point `P1,i` in camera 1; in camera 2 take the
//! point `P2,j` nearest to the epipolar line of `P1,i`; in camera 3 the point `P3,k` nearest to
//! the line of `P2,j`; the loop closes when `P1,i` is on the line of `P3,k` back in camera 1.
//! Otherwise the search backtracks to the next candidate, depth first, candidates sorted by
//! their distance to the line, so the first tries are the most probable.
//!
//! Generalised here to N ≥ 2 cameras, any of which may not see the marker:
//! - the chain visits the cameras after the start camera in order; at each camera the
//!   candidates are the unused blobs within `epipolar_tolerance_px` of the epipolar lines of
//!   *every* view chosen so far (with three views this is the paper's pair of secant lines
//!   plus its closing test), tried nearest-to-the-previous-view's-line first, and then the
//!   option "this camera does not see it";
//! - a chain of at least `min_views` views is a correspondence; the chain with more views wins
//!   because views are tried before skips;
//! - a two-view chain is accepted only when it is unambiguous (no other unused blob of either
//!   camera lies on the other's epipolar line within tolerance), since two views alone cannot
//!   tell apart points sharing an epipolar plane (the paper's reason for a third camera).
//!
//! Distances are measured in ideal (undistorted) pixels, where epipolar loci are straight.
//! Stray blobs seen in one camera never form a correspondence. Two strays that happen to lie on
//! each other's epipolar lines in two cameras are geometrically indistinguishable from a marker
//! seen twice; identification rejects the point they make.

use std::collections::BTreeMap;

use nalgebra::Matrix3;

use crate::camera::{EpipolarLine, Rig, epipolar_line};
use crate::geometry::{CameraId, Pixel};

/// Options of the correspondence search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrespondConfig {
    /// Largest distance of a blob from an epipolar line, ideal pixels. 1 px is about 20× the
    /// simulated detection noise (0.05 px) and leaves room for a real rig's calibration error
    /// (0.1–0.3 px RMS), while a 1280-px image still holds hundreds of separate lines.
    pub epipolar_tolerance_px: f64,
    /// Fewest views that make a correspondence (2: triangulation needs two rays).
    pub min_views: usize,
}

impl Default for CorrespondConfig {
    fn default() -> Self {
        Self {
            epipolar_tolerance_px: 1.0,
            min_views: 2,
        }
    }
}

/// The blobs one camera sees in one frame, by index, as distorted pixels.
pub type Views = BTreeMap<CameraId, Vec<Pixel>>;

/// One marker's images: for each camera that sees it, the index of its blob in that camera's
/// list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Correspondence {
    /// Blob index per camera.
    pub blobs: BTreeMap<CameraId, usize>,
}

/// Precomputed geometry of a rig for correspondence: fundamental matrices between every pair.
#[derive(Debug, Clone)]
pub struct EpipolarGeometry {
    fundamental: Vec<Vec<Matrix3<f64>>>,
}

impl EpipolarGeometry {
    /// The fundamental matrices of a rig.
    #[must_use]
    pub fn new(rig: &Rig) -> Self {
        Self {
            fundamental: rig.fundamental_matrices(),
        }
    }

    fn line(&self, from: CameraId, ideal: &Pixel, to: CameraId) -> Option<EpipolarLine> {
        epipolar_line(self.fundamental.get(from.0)?.get(to.0)?, ideal)
    }
}

/// A blob as the search sees it.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    ideal: Pixel,
    used: bool,
}

/// Finds the correspondences among the blobs of one frame. Blobs that cannot be undistorted
/// are left out. The result is deterministic: cameras by id, blobs by index.
#[must_use]
pub fn correspond(
    rig: &Rig,
    geometry: &EpipolarGeometry,
    views: &Views,
    config: &CorrespondConfig,
) -> Vec<Correspondence> {
    let mut blobs: BTreeMap<CameraId, Vec<Option<Candidate>>> = BTreeMap::new();
    for (camera_id, pixels) in views {
        let Some(camera) = rig.camera(*camera_id) else {
            continue;
        };
        let candidates = pixels
            .iter()
            .map(|px| {
                camera
                    .ideal_pixel(px)
                    .ok()
                    .map(|ideal| Candidate { ideal, used: false })
            })
            .collect();
        blobs.insert(*camera_id, candidates);
    }
    let cameras: Vec<CameraId> = blobs.keys().copied().collect();
    let mut found = Vec::new();
    for (start_position, start_camera) in cameras.iter().enumerate() {
        let start_count = blobs[start_camera].len();
        for start in 0..start_count {
            let Some(candidate) = blobs[start_camera][start] else {
                continue;
            };
            if candidate.used {
                continue;
            }
            let mut chain = vec![(*start_camera, start)];
            let search = Search {
                geometry,
                blobs: &blobs,
                cameras: &cameras[start_position + 1..],
                config,
            };
            if let Some(complete) = search.extend(&mut chain) {
                for (camera, index) in &complete {
                    if let Some(Some(c)) =
                        blobs.get_mut(camera).and_then(|list| list.get_mut(*index))
                    {
                        c.used = true;
                    }
                }
                found.push(Correspondence {
                    blobs: complete.into_iter().collect(),
                });
            }
        }
    }
    found
}

/// The depth-first search from one start blob.
#[derive(Clone, Copy)]
struct Search<'a> {
    geometry: &'a EpipolarGeometry,
    blobs: &'a BTreeMap<CameraId, Vec<Option<Candidate>>>,
    /// Cameras still to visit, in order.
    cameras: &'a [CameraId],
    config: &'a CorrespondConfig,
}

impl Search<'_> {
    fn ideal(&self, camera: CameraId, index: usize) -> Option<Pixel> {
        self.blobs.get(&camera)?.get(index)?.map(|c| c.ideal)
    }

    /// Largest distance of `ideal` in `camera` from the epipolar lines of the chosen views.
    fn worst_distance(
        &self,
        chain: &[(CameraId, usize)],
        camera: CameraId,
        ideal: &Pixel,
    ) -> Option<f64> {
        let mut worst = 0.0_f64;
        for (chosen_camera, chosen) in chain {
            let chosen_ideal = self.ideal(*chosen_camera, *chosen)?;
            let line = self.geometry.line(*chosen_camera, &chosen_ideal, camera)?;
            worst = worst.max(line.distance(ideal));
        }
        Some(worst)
    }

    /// Unused blobs of `camera` consistent with every view of the chain, nearest to the last
    /// view's epipolar line first.
    fn candidates(&self, chain: &[(CameraId, usize)], camera: CameraId) -> Vec<usize> {
        let Some(list) = self.blobs.get(&camera) else {
            return Vec::new();
        };
        let Some(&(last_camera, last)) = chain.last() else {
            return Vec::new();
        };
        let Some(last_line) = self
            .ideal(last_camera, last)
            .and_then(|p| self.geometry.line(last_camera, &p, camera))
        else {
            return Vec::new();
        };
        let mut ranked: Vec<(f64, usize)> = list
            .iter()
            .enumerate()
            .filter_map(|(i, c)| {
                let c = c.as_ref().filter(|c| !c.used)?;
                let worst = self.worst_distance(chain, camera, &c.ideal)?;
                (worst <= self.config.epipolar_tolerance_px)
                    .then(|| (last_line.distance(&c.ideal), i))
            })
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        ranked.into_iter().map(|(_, i)| i).collect()
    }

    /// Extends the chain over the remaining cameras, depth first: each consistent candidate in
    /// turn, then "not seen by this camera"; returns the first complete, acceptable chain.
    fn extend(&self, chain: &mut Vec<(CameraId, usize)>) -> Option<Vec<(CameraId, usize)>> {
        let Some((&camera, rest)) = self.cameras.split_first() else {
            return self.accept(chain);
        };
        let deeper = Search {
            cameras: rest,
            ..*self
        };
        for candidate in self.candidates(chain, camera) {
            chain.push((camera, candidate));
            if let Some(done) = deeper.extend(chain) {
                return Some(done);
            }
            chain.pop();
        }
        deeper.extend(chain)
    }

    /// A complete chain is a correspondence when it has enough views and, with only two, when
    /// neither view has a rival on the other's epipolar line.
    fn accept(&self, chain: &[(CameraId, usize)]) -> Option<Vec<(CameraId, usize)>> {
        if chain.len() < self.config.min_views.max(2) {
            return None;
        }
        if chain.len() == 2 {
            let (a, b) = (chain[0], chain[1]);
            let rivals_in_b = self.candidates(&[a], b.0).len();
            let rivals_in_a = self.candidates(&[b], a.0).len();
            if rivals_in_b > 1 || rivals_in_a > 1 {
                return None;
            }
        }
        Some(chain.to_vec())
    }
}
