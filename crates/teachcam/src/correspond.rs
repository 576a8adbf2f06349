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
//!   tell apart points sharing an epipolar plane (the paper's reason for a third camera);
//! - the blobs left over form groups in which several pairings are possible (two markers near
//!   one epipolar line of a two-camera rig): [`correspond_all`] keeps every maximal pairing of
//!   each group as an [`Ambiguity`], for identification to choose by the tool's distances
//!   ([`crate::track`]), instead of deciding alone.
//!
//! The tolerance is per camera pair ([`CorrespondConfig::pair_tolerance_px`]): the gates
//! measured from a recording ([`crate::track::gates`]) give each pair what its calibration
//! leaves.
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
#[derive(Debug, Clone, PartialEq)]
pub struct CorrespondConfig {
    /// Largest distance of a blob from an epipolar line, ideal pixels, for camera pairs not in
    /// `pair_tolerance_px`. 1 px is about 20× the simulated detection noise (0.05 px) and
    /// leaves room for a real rig's calibration error (0.1–0.3 px RMS), while a 1280-px image
    /// still holds hundreds of separate lines.
    pub epipolar_tolerance_px: f64,
    /// The tolerance of particular camera pairs, keyed `(lower id, higher id)`. Default empty.
    pub pair_tolerance_px: BTreeMap<(CameraId, CameraId), f64>,
    /// Fewest views that make a correspondence (2: triangulation needs two rays).
    pub min_views: usize,
}

impl Default for CorrespondConfig {
    fn default() -> Self {
        Self {
            epipolar_tolerance_px: 1.0,
            pair_tolerance_px: BTreeMap::new(),
            min_views: 2,
        }
    }
}

impl CorrespondConfig {
    /// The tolerance between cameras `a` and `b`, ideal pixels.
    #[must_use]
    pub fn tolerance_px(&self, a: CameraId, b: CameraId) -> f64 {
        self.pair_tolerance_px
            .get(&(a.min(b), a.max(b)))
            .copied()
            .unwrap_or(self.epipolar_tolerance_px)
    }
}

/// Blobs that several pairings explain: each alternative is one maximal set of disjoint
/// two-view correspondences among the group's blobs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ambiguity {
    /// The possible pairings, at least two.
    pub alternatives: Vec<Vec<Correspondence>>,
}

/// Everything correspondence found in one frame.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Correspondences {
    /// Correspondences the epipolar geometry decides alone (the paper's loop).
    pub unique: Vec<Correspondence>,
    /// Groups of left-over blobs with several possible pairings.
    pub ambiguous: Vec<Ambiguity>,
}

/// Most pairings kept for one ambiguous group: three markers on one epipolar line of a
/// two-camera rig have 6; a crowded group beyond this is left unpaired.
pub const MAX_PAIRINGS: usize = 64;

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

    /// The epipolar residual of a match, ideal pixels: the larger of the distance of `b`'s
    /// pixel from the line of `a`'s and the reverse.
    #[must_use]
    pub fn residual_px(
        &self,
        a: CameraId,
        ideal_a: &Pixel,
        b: CameraId,
        ideal_b: &Pixel,
    ) -> Option<f64> {
        let forward = self.line(a, ideal_a, b)?.distance(ideal_b);
        let backward = self.line(b, ideal_b, a)?.distance(ideal_a);
        Some(forward.max(backward))
    }
}

/// A blob as the search sees it.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    ideal: Pixel,
    used: bool,
}

/// Finds the correspondences the epipolar geometry decides alone among the blobs of one frame
/// (the paper's loop; [`correspond_all`] also keeps the ambiguous groups). Blobs that cannot
/// be undistorted are left out. The result is deterministic: cameras by id, blobs by index.
#[must_use]
pub fn correspond(
    rig: &Rig,
    geometry: &EpipolarGeometry,
    views: &Views,
    config: &CorrespondConfig,
) -> Vec<Correspondence> {
    correspond_all(rig, geometry, views, config).unique
}

/// [`correspond`], and the groups of left-over blobs that more than one pairing explains,
/// with every maximal pairing of each (at most [`MAX_PAIRINGS`]).
#[must_use]
pub fn correspond_all(
    rig: &Rig,
    geometry: &EpipolarGeometry,
    views: &Views,
    config: &CorrespondConfig,
) -> Correspondences {
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
    let ambiguous = ambiguous_groups(geometry, &blobs, config);
    Correspondences {
        unique: found,
        ambiguous,
    }
}

/// A blob by camera and index.
type Node = (CameraId, usize);

/// Whether two blobs of different cameras lie on each other's epipolar lines.
fn consistent(
    geometry: &EpipolarGeometry,
    blobs: &BTreeMap<CameraId, Vec<Option<Candidate>>>,
    config: &CorrespondConfig,
    a: Node,
    b: Node,
) -> bool {
    let ideal = |n: Node| {
        blobs
            .get(&n.0)?
            .get(n.1)
            .copied()
            .flatten()
            .map(|c| c.ideal)
    };
    let (Some(pa), Some(pb)) = (ideal(a), ideal(b)) else {
        return false;
    };
    geometry
        .residual_px(a.0, &pa, b.0, &pb)
        .is_some_and(|r| r <= config.tolerance_px(a.0, b.0))
}

/// The unused blobs joined by epipolar consistency, split into connected groups; each group
/// with more than one possible pair becomes an [`Ambiguity`] listing its maximal pairings.
fn ambiguous_groups(
    geometry: &EpipolarGeometry,
    blobs: &BTreeMap<CameraId, Vec<Option<Candidate>>>,
    config: &CorrespondConfig,
) -> Vec<Ambiguity> {
    let nodes: Vec<Node> = blobs
        .iter()
        .flat_map(|(camera, list)| {
            list.iter()
                .enumerate()
                .filter(|(_, c)| c.is_some_and(|c| !c.used))
                .map(|(i, _)| (*camera, i))
        })
        .collect();
    let mut edges: Vec<(usize, usize)> = Vec::new();
    for (i, a) in nodes.iter().enumerate() {
        for (j, b) in nodes.iter().enumerate().skip(i + 1) {
            if a.0 != b.0 && consistent(geometry, blobs, config, *a, *b) {
                edges.push((i, j));
            }
        }
    }
    // Connected groups of edges (union-find over the nodes).
    let mut parent: Vec<usize> = (0..nodes.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for &(a, b) in &edges {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra.max(rb)] = ra.min(rb);
    }
    let mut groups: BTreeMap<usize, Vec<(usize, usize)>> = BTreeMap::new();
    for &(a, b) in &edges {
        let r = root(&mut parent, a);
        groups.entry(r).or_default().push((a, b));
    }
    groups
        .into_values()
        .filter(|group| group.len() > 1)
        .filter_map(|group| {
            let mut pairings = Vec::new();
            maximal_matchings(&group, 0, &mut Vec::new(), &mut pairings);
            if pairings.len() < 2 || pairings.len() > MAX_PAIRINGS {
                return None;
            }
            let alternatives = pairings
                .into_iter()
                .map(|pairing| {
                    pairing
                        .into_iter()
                        .map(|(a, b)| Correspondence {
                            blobs: [nodes[a], nodes[b]].into_iter().collect(),
                        })
                        .collect()
                })
                .collect();
            Some(Ambiguity { alternatives })
        })
        .collect()
}

/// Every maximal set of disjoint edges of `edges` (no edge can be added), by include/exclude
/// recursion; stops collecting past [`MAX_PAIRINGS`].
fn maximal_matchings(
    edges: &[(usize, usize)],
    next: usize,
    chosen: &mut Vec<(usize, usize)>,
    out: &mut Vec<Vec<(usize, usize)>>,
) {
    if out.len() > MAX_PAIRINGS {
        return;
    }
    let free = |e: &(usize, usize), chosen: &[(usize, usize)]| {
        chosen
            .iter()
            .all(|c| c.0 != e.0 && c.0 != e.1 && c.1 != e.0 && c.1 != e.1)
    };
    let Some(edge) = edges.get(next) else {
        if edges.iter().all(|e| chosen.contains(e) || !free(e, chosen)) {
            out.push(chosen.clone());
        }
        return;
    };
    if free(edge, chosen) {
        chosen.push(*edge);
        maximal_matchings(edges, next + 1, chosen, out);
        chosen.pop();
    }
    maximal_matchings(edges, next + 1, chosen, out);
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

    /// Largest distance of `ideal` in `camera` from the epipolar lines of the chosen views, as
    /// a fraction of each pair's tolerance (≤ 1: consistent with every view).
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
            let tolerance = self.config.tolerance_px(*chosen_camera, camera);
            worst = worst.max(line.distance(ideal) / tolerance);
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
                (worst <= 1.0).then(|| (last_line.distance(&c.ideal), i))
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
