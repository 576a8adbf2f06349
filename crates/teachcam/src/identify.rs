//! Identification: which measured 3-D point is which marker of the tool.
//!
//! The paper's distance-matrix voting (§II-B): the distance `d_ij` between measured points `i`
//! and `j` is matched to the model distance `d̂_kl` it equals (within a tolerance); the indices
//! `k, l` are written into the table `ind_i`; the index that occurs most in `ind_i` is the
//! marker that point `i` is, and a row with no match at all is a point with no marker (an
//! occluded marker's place, or a stray). The paper's worked example (five markers, one
//! occluded, the others shuffled) is a test of this module.
//!
//! Made robust here: the tolerance comes from the noise of triangulated points; instead of
//! taking each point's most frequent index on its own, the labels are the largest set in which
//! every labelled pair is at its markers' model distance, each point trying its voted markers
//! most votes first (so a stray that matched one distance by chance, and tied a vote, cannot
//! take a label); a point still unlabelled takes the one free marker whose distances it
//! reproduces. A tool whose own distances could be mistaken
//! for one another is refused before tracking starts ([`check_identifiable`]).
//!
//! Refusing what is not there: when another labelling as large as the chosen one is also
//! consistent, the points do not say which is right; [`Identification::rival`] holds it, and
//! the tracker makes such a frame a gap instead of guessing.

use std::collections::BTreeMap;

use crate::geometry::{MarkerId, Point3};
use crate::tool::Tool;

/// Options of identification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyConfig {
    /// Largest difference between a measured and a model distance, millimetres. Triangulated
    /// points of the paper's rig scatter by ≈ 0.03 mm, so distances by ≈ 0.05 mm: 0.3 mm is
    /// six of those, and leaves room for a tool model measured to 0.1 mm.
    pub distance_tolerance_mm: f64,
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self {
            distance_tolerance_mm: 0.3,
        }
    }
}

/// Why a tool model cannot be identified reliably.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// Two of the tool's marker distances are too close to be told apart.
    #[error(
        "tool '{tool}' is ambiguous: distance {a:?}-{b:?} ({distance_ab_mm:.2} mm) and {c:?}-{d:?} ({distance_cd_mm:.2} mm) differ by less than twice the {tolerance_mm} mm tolerance; move a marker"
    )]
    Ambiguous {
        /// Tool name.
        tool: String,
        /// First pair, first marker.
        a: usize,
        /// First pair, second marker.
        b: usize,
        /// First pair's distance.
        distance_ab_mm: f64,
        /// Second pair, first marker.
        c: usize,
        /// Second pair, second marker.
        d: usize,
        /// Second pair's distance.
        distance_cd_mm: f64,
        /// The tolerance.
        tolerance_mm: f64,
    },
}

/// A model pair of markers with their distance.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ModelPair {
    a: MarkerId,
    b: MarkerId,
    distance_mm: f64,
}

/// The error for two marker pairs whose distances cannot be told apart.
fn ambiguity(tool: String, p: &ModelPair, q: &ModelPair, config: &IdentifyConfig) -> IdentifyError {
    IdentifyError::Ambiguous {
        tool,
        a: p.a.0,
        b: p.b.0,
        distance_ab_mm: p.distance_mm,
        c: q.a.0,
        d: q.b.0,
        distance_cd_mm: q.distance_mm,
        tolerance_mm: config.distance_tolerance_mm,
    }
}

fn model_pairs(markers: &[Point3]) -> Vec<ModelPair> {
    let mut pairs = Vec::new();
    for i in 0..markers.len() {
        for j in i + 1..markers.len() {
            pairs.push(ModelPair {
                a: MarkerId(i),
                b: MarkerId(j),
                distance_mm: (markers[i] - markers[j]).norm(),
            });
        }
    }
    pairs
}

/// Refuses a tool whose marker distances could be mistaken for one another at this tolerance:
/// any two of them closer than twice the tolerance.
///
/// # Errors
/// [`IdentifyError::Ambiguous`] naming the two pairs.
pub fn check_identifiable(tool: &Tool, config: &IdentifyConfig) -> Result<(), IdentifyError> {
    let pairs = model_pairs(&tool.markers_in_tool);
    for (i, p) in pairs.iter().enumerate() {
        for q in &pairs[i + 1..] {
            if (p.distance_mm - q.distance_mm).abs() < 2.0 * config.distance_tolerance_mm {
                return Err(ambiguity(tool.name.clone(), p, q, config));
            }
        }
    }
    Ok(())
}

/// The paper's `ind_i` tables: for each measured point `i` and each other point `j`, the model
/// pair whose distance `d_ij` matches (the nearest within tolerance), or `None`.
#[must_use]
pub fn index_tables(
    model: &[Point3],
    points: &[Point3],
    config: &IdentifyConfig,
) -> Vec<Vec<Option<(MarkerId, MarkerId)>>> {
    let pairs = model_pairs(model);
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            points
                .iter()
                .enumerate()
                .map(|(j, q)| {
                    if i == j {
                        return None;
                    }
                    let d = (p - q).norm();
                    pairs
                        .iter()
                        .map(|m| ((m.distance_mm - d).abs(), m))
                        .filter(|(error, _)| *error <= config.distance_tolerance_mm)
                        .min_by(|x, y| x.0.total_cmp(&y.0))
                        .map(|(_, m)| (m.a, m.b))
                })
                .collect()
        })
        .collect()
}

/// The outcome of identification for one tool.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Identification {
    /// For each identified marker, the index of its measured point.
    pub labels: BTreeMap<MarkerId, usize>,
    /// Measured points that are no marker of this tool.
    pub unassigned: Vec<usize>,
    /// Another labelling with as many markers, also consistent: the points cannot tell the
    /// two apart (`None` when the choice has a margin).
    pub rival: Option<BTreeMap<MarkerId, usize>>,
}

/// Labels measured points with the tool's markers by the paper's voting, then keeps only a
/// mutually consistent set (every labelled pair at the model's distance within tolerance).
#[must_use]
pub fn identify(model: &[Point3], points: &[Point3], config: &IdentifyConfig) -> Identification {
    let tables = index_tables(model, points, config);
    // Votes: how often each marker's index occurs in ind_i (the paper's count).
    let votes: Vec<Vec<usize>> = tables
        .iter()
        .map(|table| {
            let mut votes = vec![0_usize; model.len()];
            for (a, b) in table.iter().flatten() {
                votes[a.0] += 1;
                votes[b.0] += 1;
            }
            votes
        })
        .collect();
    let (mut labels, rival) = consistent_labels(model, points, &votes, config);
    complete(model, points, config, &mut labels);
    let unassigned = (0..points.len())
        .filter(|i| !labels.values().any(|p| p == i))
        .collect();
    Identification {
        labels,
        unassigned,
        rival,
    }
}

/// Search nodes [`consistent_labels`] may visit: far more than a tool of up to ten markers among
/// a dozen points needs, and a bound on the time a crowded frame can take.
const SEARCH_BUDGET: usize = 200_000;

/// Equally large consistent sets [`consistent_labels`] keeps to look for a rival among.
const MAX_TIES: usize = 1024;

/// The paper's choice made robust: the largest set of labels in which every pair of labelled
/// points is at its markers' model distance. Each point tries the markers it voted for, most
/// votes first (the paper's "the first tries are the more probable"), and then no label;
/// among equally large sets the one with more votes wins. A stray that matched one distance by
/// chance can tie a vote, but cannot join a consistent set. Fewer than two labels carry no
/// evidence, so they give none. The second result is an equally large consistent set that
/// labels some point differently, when there is one (a set that only leaves out other markers
/// of the same labelling is none).
type Labels = BTreeMap<MarkerId, usize>;

fn consistent_labels(
    model: &[Point3],
    points: &[Point3],
    votes: &[Vec<usize>],
    config: &IdentifyConfig,
) -> (Labels, Option<Labels>) {
    let best_vote = |i: usize| votes[i].iter().copied().max().unwrap_or(0);
    let mut order: Vec<usize> = (0..points.len()).filter(|i| best_vote(*i) > 0).collect();
    order.sort_by_key(|i| (std::cmp::Reverse(best_vote(*i)), *i));
    let candidates: Vec<Vec<usize>> = votes
        .iter()
        .map(|v| {
            let mut markers: Vec<usize> = (0..model.len()).filter(|m| v[*m] > 0).collect();
            markers.sort_by_key(|m| (std::cmp::Reverse(v[*m]), *m));
            markers
        })
        .collect();
    struct Search<'a> {
        model: &'a [Point3],
        points: &'a [Point3],
        votes: &'a [Vec<usize>],
        candidates: &'a [Vec<usize>],
        order: &'a [usize],
        tolerance: f64,
        best: Vec<(usize, usize)>,
        best_votes: usize,
        /// Every consistent set as large as the best so far (at most [`MAX_TIES`]).
        ties: Vec<Vec<(usize, usize)>>,
        ties_overflowed: bool,
        nodes: usize,
    }
    impl Search<'_> {
        fn fits(&self, point: usize, marker: usize, current: &[(usize, usize)]) -> bool {
            current.iter().all(|&(q, n)| {
                n != marker
                    && ((self.points[point] - self.points[q]).norm()
                        - (self.model[marker] - self.model[n]).norm())
                    .abs()
                        <= self.tolerance
            })
        }

        fn visit(&mut self, depth: usize, current: &mut Vec<(usize, usize)>, votes: usize) {
            self.nodes += 1;
            if self.nodes > SEARCH_BUDGET
                || current.len() + (self.order.len() - depth) < self.best.len()
            {
                return;
            }
            let Some(&point) = self.order.get(depth) else {
                if current.len() > self.best.len() {
                    self.ties.clear();
                    self.ties_overflowed = false;
                }
                if current.len() >= self.best.len() {
                    if self.ties.len() < MAX_TIES {
                        self.ties.push(current.clone());
                    } else {
                        self.ties_overflowed = true;
                    }
                }
                if (current.len(), votes) > (self.best.len(), self.best_votes) {
                    self.best = current.clone();
                    self.best_votes = votes;
                }
                return;
            };
            for k in 0..self.candidates[point].len() {
                let marker = self.candidates[point][k];
                if self.fits(point, marker, current) {
                    current.push((point, marker));
                    self.visit(depth + 1, current, votes + self.votes[point][marker]);
                    current.pop();
                }
            }
            self.visit(depth + 1, current, votes);
        }
    }
    let mut search = Search {
        model,
        points,
        votes,
        candidates: &candidates,
        order: &order,
        tolerance: config.distance_tolerance_mm,
        best: Vec::new(),
        best_votes: 0,
        ties: Vec::new(),
        ties_overflowed: false,
        nodes: 0,
    };
    search.visit(0, &mut Vec::new(), 0);
    if search.best.len() < 2 {
        return (BTreeMap::new(), None);
    }
    let labels = |set: &[(usize, usize)]| -> Labels {
        set.iter()
            .map(|&(point, marker)| (MarkerId(marker), point))
            .collect()
    };
    // A tie that agrees with the best wherever both label (another subset of the same
    // labelling, as when one noisy distance leaves out a different marker) is no rival; one
    // that puts a point on another marker, or a marker on another point, is. Too many ties to
    // have kept them all count as a rival: the points did not decide.
    let conflicts = |tie: &[(usize, usize)]| {
        tie.iter()
            .any(|&(p, m)| search.best.iter().any(|&(q, n)| (p == q) != (m == n)))
    };
    let rival = search
        .ties
        .iter()
        .find(|tie| conflicts(tie))
        .or(search.ties_overflowed.then_some(&search.best))
        .map(|tie| labels(tie));
    (labels(&search.best), rival)
}

/// Identifies several tools in one cloud of points: each tool's markers by
/// [`identify`], then a point claimed by more than one tool is taken from every tool that
/// claimed it (the tools' distance signatures must differ for this to be rare; see
/// [`check_tools_distinct`]). Results are in the order of `models`.
#[must_use]
pub fn identify_tools(
    models: &[&[Point3]],
    points: &[Point3],
    config: &IdentifyConfig,
) -> Vec<Identification> {
    let mut found: Vec<Identification> =
        models.iter().map(|m| identify(m, points, config)).collect();
    let claimed = |point: usize, found: &[Identification]| {
        found
            .iter()
            .filter(|f| f.labels.values().any(|p| *p == point))
            .count()
    };
    let contested: Vec<usize> = (0..points.len())
        .filter(|p| claimed(*p, &found) > 1)
        .collect();
    for f in &mut found {
        f.labels.retain(|_, p| !contested.contains(p));
        f.unassigned = (0..points.len())
            .filter(|i| !f.labels.values().any(|p| p == i))
            .collect();
    }
    found
}

/// Refuses a set of tools that could be mistaken for one another: a tool's distance that
/// another tool also has (within twice the tolerance) lets a point of one vote for the other.
///
/// # Errors
/// [`IdentifyError::Ambiguous`] naming the tools' pairs (the first tool's in `a`-`b`, the
/// second's in `c`-`d`, with `tool` naming both).
pub fn check_tools_distinct(tools: &[&Tool], config: &IdentifyConfig) -> Result<(), IdentifyError> {
    for tool in tools {
        check_identifiable(tool, config)?;
    }
    for (i, first) in tools.iter().enumerate() {
        for second in &tools[i + 1..] {
            for p in model_pairs(&first.markers_in_tool) {
                for q in model_pairs(&second.markers_in_tool) {
                    if (p.distance_mm - q.distance_mm).abs() < 2.0 * config.distance_tolerance_mm {
                        let tools = format!("{}' and '{}", first.name, second.name);
                        return Err(ambiguity(tools, &p, &q, config));
                    }
                }
            }
        }
    }
    Ok(())
}

/// Completion: a point left without a label (its votes tied, e.g. because a stray matched one
/// of its distances by chance) takes the one free marker whose model distances to at least two
/// labelled markers it reproduces, when no other point could take it.
fn complete(
    model: &[Point3],
    points: &[Point3],
    config: &IdentifyConfig,
    labels: &mut BTreeMap<MarkerId, usize>,
) {
    loop {
        if labels.len() < 2 {
            return;
        }
        let fits = |point: usize, marker: usize, labels: &BTreeMap<MarkerId, usize>| {
            labels.iter().all(|(m, q)| {
                ((points[point] - points[*q]).norm() - (model[marker] - model[m.0]).norm()).abs()
                    <= config.distance_tolerance_mm
            })
        };
        let free_points: Vec<usize> = (0..points.len())
            .filter(|i| !labels.values().any(|p| p == i))
            .collect();
        let free_markers: Vec<usize> = (0..model.len())
            .filter(|m| !labels.contains_key(&MarkerId(*m)))
            .collect();
        let mut added = None;
        for &point in &free_points {
            let markers: Vec<usize> = free_markers
                .iter()
                .copied()
                .filter(|&m| fits(point, m, labels))
                .collect();
            if let [marker] = markers[..] {
                let rivals = free_points
                    .iter()
                    .filter(|&&q| q != point && fits(q, marker, labels))
                    .count();
                if rivals == 0 {
                    added = Some((MarkerId(marker), point));
                    break;
                }
            }
        }
        match added {
            Some((marker, point)) => {
                labels.insert(marker, point);
            }
            None => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A five-marker model with well separated distances, for the paper's example.
    fn five_markers() -> Vec<Point3> {
        [
            [0.0, 0.0, 0.0],
            [71.0, 5.0, 0.0],
            [12.0, 48.0, 3.0],
            [-40.0, 25.0, 30.0],
            [30.0, -35.0, 22.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect()
    }

    #[test]
    fn the_papers_worked_example() {
        // §II-B, equation 3: five markers expected, the 4th not reconstructed, the others
        // acquired in the order (1, 3, 5, 2) (1-based model indices).
        let model = five_markers();
        let config = IdentifyConfig::default();
        check_identifiable(
            &Tool::new(
                "five".into(),
                10.0,
                model.clone(),
                crate::geometry::Pose::identity(),
            )
            .unwrap(),
            &config,
        )
        .unwrap();
        let acquired = [0, 2, 4, 1];
        let points: Vec<Point3> = acquired.iter().map(|&k| model[k]).collect();
        let tables = index_tables(&model, &points, &config);
        // ind_1 = (0 1 1 1 / 0 3 5 2), ind_2 = (3 0 3 3 / 1 0 5 2),
        // ind_3 = (5 5 0 5 / 1 3 0 2), ind_4 = (2 2 2 0 / 1 3 5 0): as unordered 0-based pairs.
        let paper: [[Option<(usize, usize)>; 4]; 4] = [
            [None, Some((0, 2)), Some((0, 4)), Some((0, 1))],
            [Some((2, 0)), None, Some((2, 4)), Some((2, 1))],
            [Some((4, 0)), Some((4, 2)), None, Some((4, 1))],
            [Some((1, 0)), Some((1, 2)), Some((1, 4)), None],
        ];
        for (i, row) in paper.iter().enumerate() {
            for (j, expected) in row.iter().enumerate() {
                let found = tables[i][j].map(|(a, b)| (a.0.min(b.0), a.0.max(b.0)));
                assert_eq!(
                    found,
                    expected.map(|(a, b)| (a.min(b), a.max(b))),
                    "ind_{} column {}",
                    i + 1,
                    j + 1
                );
            }
        }
        let id = identify(&model, &points, &config);
        // "the 1st marker corresponds to the 1st one, the 2nd to the 3rd, the 3rd to the 5th,
        // the 4th to the 2nd; a marker is missing (the 4th)".
        let expected: BTreeMap<MarkerId, usize> = [
            (MarkerId(0), 0),
            (MarkerId(2), 1),
            (MarkerId(4), 2),
            (MarkerId(1), 3),
        ]
        .into();
        assert_eq!(id.labels, expected);
        assert!(!id.labels.contains_key(&MarkerId(3)));
        assert!(id.unassigned.is_empty());
    }

    #[test]
    fn two_tools_in_one_cloud_are_told_apart() {
        let brush: Vec<Point3> = [
            [0.0, 0.0, 0.0],
            [53.0, 59.0, 26.0],
            [-47.0, 6.0, 34.0],
            [45.0, -8.0, 4.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
        let probe: Vec<Point3> = [
            [0.0, 0.0, 0.0],
            [120.0, 0.0, 0.0],
            [30.0, 95.0, 0.0],
            [-20.0, 40.0, 60.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
        let config = IdentifyConfig::default();
        let tools: Vec<Tool> = [("brush", &brush), ("probe", &probe)]
            .iter()
            .map(|(n, m)| {
                Tool::new(
                    (*n).into(),
                    10.0,
                    (*m).clone(),
                    crate::geometry::Pose::identity(),
                )
                .unwrap()
            })
            .collect();
        check_tools_distinct(&[&tools[0], &tools[1]], &config).unwrap();
        // The probe 400 mm away, both clouds shuffled together, one brush marker hidden.
        let offset = nalgebra::Vector3::new(400.0, 0.0, 0.0);
        let points = vec![
            probe[3] + offset,
            brush[2],
            probe[0] + offset,
            brush[0],
            probe[1] + offset,
            brush[3],
            probe[2] + offset,
        ];
        let found = identify_tools(&[&brush, &probe], &points, &config);
        let brush_labels: BTreeMap<MarkerId, usize> =
            [(MarkerId(0), 3), (MarkerId(2), 1), (MarkerId(3), 5)].into();
        let probe_labels: BTreeMap<MarkerId, usize> = [
            (MarkerId(0), 2),
            (MarkerId(1), 4),
            (MarkerId(2), 6),
            (MarkerId(3), 0),
        ]
        .into();
        assert_eq!(found[0].labels, brush_labels);
        assert_eq!(found[1].labels, probe_labels);
        // A tool with one of the brush's distances is refused beside it.
        let twin = Tool::new(
            "twin".into(),
            10.0,
            vec![
                Point3::origin(),
                Point3::new(45.88, 0.0, 0.0),
                Point3::new(0.0, 90.0, 0.0),
            ],
            crate::geometry::Pose::identity(),
        )
        .unwrap();
        let message = check_tools_distinct(&[&tools[0], &twin], &config)
            .unwrap_err()
            .to_string();
        assert!(message.contains("brush' and 'twin"), "{message}");
    }

    #[test]
    fn an_ambiguous_tool_is_refused_naming_the_pairs() {
        // The contract's example brush: markers 0-2 (51.1 mm) and 2-3 (51.8 mm) are 0.7 mm apart.
        let markers = [
            [0.0, 0.0, 0.0],
            [62.0, 8.0, 0.0],
            [18.0, 47.0, 9.0],
            [-26.0, 71.0, 22.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect();
        let tool = Tool::new(
            "brush".into(),
            10.0,
            markers,
            crate::geometry::Pose::identity(),
        )
        .unwrap();
        let strict = IdentifyConfig {
            distance_tolerance_mm: 0.5,
        };
        let message = check_identifiable(&tool, &strict).unwrap_err().to_string();
        assert!(
            message.contains("0-2") && message.contains("2-3"),
            "{message}"
        );
        assert!(
            check_identifiable(
                &tool,
                &IdentifyConfig {
                    distance_tolerance_mm: 0.3
                }
            )
            .is_ok()
        );
    }

    #[test]
    fn one_noisy_distance_leaves_no_rival_but_a_mirror_triangle_is_one() {
        // Four markers seen; point 3 moved 0.35 mm along the 2-3 line
        // pulls that distance out of tolerance (0.3 mm) while its other two stay in.
        // {0,1,2} and {0,1,3} are then both consistent: two subsets of one labelling, no rival.
        let model = five_markers()[..4].to_vec();
        let config = IdentifyConfig::default();
        let mut points = model.clone();
        let away = (model[3] - model[2]).normalize();
        points[3] += away * 0.35;
        let d = |a: usize, b: usize| (points[a] - points[b]).norm() - (model[a] - model[b]).norm();
        assert!(d(2, 3).abs() > config.distance_tolerance_mm, "{}", d(2, 3));
        assert!(
            d(0, 3).abs() <= config.distance_tolerance_mm
                && d(1, 3).abs() <= config.distance_tolerance_mm
        );
        let id = identify(&model, &points, &config);
        assert_eq!(id.labels.len(), 3, "{:?}", id.labels);
        assert!(id.labels.iter().all(|(m, p)| m.0 == *p), "{:?}", id.labels);
        assert_eq!(id.rival, None);

        // Three markers of an isosceles triangle: its mirror labelling fits as well, a rival.
        let triangle = [[0.0, 0.0, 0.0], [60.0, 0.0, 0.0], [30.0, 40.0, 0.0]]
            .iter()
            .map(|p| Point3::new(p[0], p[1], p[2]))
            .collect::<Vec<_>>();
        let id = identify(&triangle, &triangle, &config);
        assert_eq!(id.labels.len(), 3);
        let rival = id.rival.expect("the mirror labelling");
        assert_ne!(rival, id.labels);
    }
}
