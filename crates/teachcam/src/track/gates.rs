//! Gates measured from the recording: every limit of detect, correspond, triangulate, identify
//! and register, set from what this rig and these images give, not from constants tuned to the
//! simulator (DESIGN.md, "Gates are data").
//!
//! Model. A first pass over a sample of frames measures, with every gate at its ceiling:
//! - blob roundness (before detection proper: [`roundness_gate`]);
//! - for frames *confidently* tracked (every marker of the tool identified, no rival labelling,
//!   no dropped view): the epipolar residual of each pair of views of each marker, per camera
//!   pair; the triangulation residuals of the markers; the differences between measured and
//!   model marker distances; the registration residual.
//!
//! Each gate is then a robust bound on its sample, `median ± k σ̂` with `σ̂ = 1.4826 · MAD`
//! (the normal-consistent median absolute deviation; Rousseeuw & Croux 1993), clamped to a
//! floor and a ceiling, each with its reason:
//!
//! | gate | k | floor | ceiling |
//! |---|---|---|---|
//! | min roundness (`median − kσ̂`, σ̂ at least the lower tail's, [`roundness_gate`]) | 4 | 0.5: two touching equal discs | 0.75: the detector's default |
//! | epipolar tolerance per pair | 4 | 1 px | 5 px |
//! | triangulation residual | 4 | 0.1 px | 4 px |
//! | distance tolerance | 6 | 0.3 mm | 0.49 × the tool's closest pair of distances |
//! | registration residual | 4 | 0.02 mm | 5 mm |
//!
//! For a residual whose error is normal, `median + 4σ̂` is about 3σ (0.3 % of honest values
//! beyond it); the distance tolerance takes 6 (about 4σ) because each frame tests up to six
//! distances and a missed one loses a label. A gate with fewer than [`MIN_SAMPLES`] values
//! keeps the library's default. Every gate can be overridden ([`GateOverrides`]); an overridden
//! gate is also used in the first pass.
//!
//! Where the blobs' shapes are given, the confident markers' blobs also set when a blob is
//! *merged* ([`crate::track::merged`]): size ratio over its median, `median + 4σ̂` (floor 1.15: a blob's
//! radius scatters by a few percent with its sub-pixel phase; ceiling √2: two equal touching
//! discs' flux), roundness `median − 4σ̂` (floor 0.5, ceiling 0.9).
//!
//! The first pass also looks for a mirror (a shiny work object): frames where the tool's
//! rival labelling is its pure reflection through one plane ([`crate::track::reflections`]).
//! Its marker noise is the first pass's distance tolerance, the largest identification takes.

use std::collections::BTreeMap;
use std::fmt;

use crate::camera::Rig;
use crate::correspond::{CorrespondConfig, EpipolarGeometry, Views};
use crate::geometry::CameraId;
use crate::identify::IdentifyConfig;
use crate::tool::Tool;
use crate::track::merged::{MergedGate, Shapes, size_ratio};
use crate::track::reflections::{MirrorPlane, learn_mirror};
use crate::track::{FrameTrack, TrackConfig, Tracker};
use crate::triangulate::TriangulateConfig;

pub use crate::stats::{RobustScale, median, robust_scale};

/// Fewest values a gate is measured from; with fewer it keeps its default.
pub const MIN_SAMPLES: usize = 10;

/// One gate: its value and why it has it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Gate {
    /// The limit, in the gate's unit.
    pub value: f64,
    /// How it was set, for people.
    pub reason: String,
}

impl Gate {
    fn given(value: f64, flag: &str) -> Self {
        Self {
            value,
            reason: format!("given ({flag})"),
        }
    }

    fn default_value(value: f64, why: &str) -> Self {
        Self {
            value,
            reason: format!("default: {why}"),
        }
    }
}

/// The epipolar tolerance of one camera pair.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PairGate {
    /// The lower camera id.
    pub first: CameraId,
    /// The higher camera id.
    pub second: CameraId,
    /// The cameras' names, `first-second`.
    pub name: String,
    /// The tolerance, ideal pixels.
    pub gate: Gate,
}

/// Every gate of tracking, with the evidence they came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Gates {
    /// Smallest blob roundness kept by detection.
    pub min_roundness: Gate,
    /// Epipolar tolerance of pairs without a measured one, ideal pixels.
    pub epipolar_tolerance_px: Gate,
    /// Epipolar tolerance of each camera pair measured.
    pub pairs: Vec<PairGate>,
    /// Largest RMS triangulation residual of a point, pixels.
    pub max_residual_px: Gate,
    /// Identification's tolerance on marker distances, millimetres.
    pub distance_tolerance_mm: Gate,
    /// Largest registration RMS of an `ok` pose, millimetres.
    pub max_registration_rms_mm: Gate,
    /// Median triangulation residual of confidently identified markers, pixels.
    pub typical_residual_px: Option<f64>,
    /// Median registration residual of confidently tracked frames, millimetres.
    pub typical_registration_rms_mm: Option<f64>,
    /// Frames of the sample.
    pub sampled_frames: usize,
    /// Frames of the sample tracked confidently.
    pub confident_frames: usize,
    /// The mirror the sample shows, if any: points behind it are reflections.
    pub mirror: Option<MirrorPlane>,
    /// Why there is a mirror or none, for people.
    pub mirror_reason: String,
    /// When a marker's blob is merged with something touching it, if measured.
    pub merged: Option<MergedGate>,
    /// How the merged-blob gate was set, or why there is none, for people.
    pub merged_reason: String,
    /// Set when the confident frames look like chance alignments of other points rather
    /// than the tool ([`chance_alignments`]): the sample does not show the tool, and no
    /// frame tracked through these gates is to be trusted.
    pub chance: Option<String>,
}

/// Gates the user fixed; `None` is measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GateOverrides {
    /// `--min-roundness`.
    pub min_roundness: Option<f64>,
    /// `--epipolar-tolerance`, ideal pixels, for every pair.
    pub epipolar_tolerance_px: Option<f64>,
    /// `--max-residual-px`.
    pub max_residual_px: Option<f64>,
    /// `--distance-tolerance`, millimetres.
    pub distance_tolerance_mm: Option<f64>,
    /// `--max-registration-rms`, millimetres.
    pub max_registration_rms_mm: Option<f64>,
}

/// Which side of the sample a gate bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    /// `median + k σ̂`: a largest allowed value.
    Upper,
    /// `median − k σ̂`: a smallest allowed value.
    Lower,
}

/// How one gate is measured.
struct Rule<'a> {
    what: &'a str,
    unit: &'a str,
    side: Side,
    k: f64,
    floor: (f64, &'a str),
    ceiling: (f64, &'a str),
    default: (f64, &'a str),
}

impl Rule<'_> {
    fn measure(&self, values: &[f64]) -> Gate {
        self.measure_with(values, robust_scale(values))
    }

    fn measure_with(&self, values: &[f64], scale: Option<RobustScale>) -> Gate {
        let Some(scale) = scale.filter(|s| s.count >= MIN_SAMPLES) else {
            return Gate::default_value(
                self.default.0,
                &format!(
                    "{} {} of {} measured, {MIN_SAMPLES} needed; {}",
                    values.len(),
                    self.what,
                    MIN_SAMPLES,
                    self.default.1
                ),
            );
        };
        let (sign, op) = match self.side {
            Side::Upper => (1.0, '+'),
            Side::Lower => (-1.0, '-'),
        };
        let raw = scale.median + sign * self.k * scale.sigma;
        let measured = format!(
            "median {:.3} {op} {}·σ̂ {:.3} of {} {} = {raw:.3}",
            scale.median, self.k, scale.sigma, scale.count, self.what
        );
        let unit = self.unit;
        let (value, reason) = if raw < self.floor.0 {
            (
                self.floor.0,
                format!(
                    "{measured}, raised to the floor {} {unit}: {}",
                    self.floor.0, self.floor.1
                ),
            )
        } else if raw > self.ceiling.0 {
            (
                self.ceiling.0,
                format!(
                    "{measured}, cut to the ceiling {:.3} {unit}: {}",
                    self.ceiling.0, self.ceiling.1
                ),
            )
        } else {
            (raw, measured)
        };
        Gate { value, reason }
    }
}

const ROUNDNESS: Rule<'static> = Rule {
    what: "blobs",
    unit: "",
    side: Side::Lower,
    k: 4.0,
    floor: (0.5, "two touching equal discs score 0.5"),
    ceiling: (
        0.75,
        "the detector's default; rounder blobs need no stricter floor",
    ),
    default: (0.75, "the detector's default"),
};

const EPIPOLAR: Rule<'static> = Rule {
    what: "matches",
    unit: "px",
    side: Side::Upper,
    k: 4.0,
    floor: (
        1.0,
        "a good calibration leaves 0.1-0.3 px; tighter gains nothing",
    ),
    ceiling: (
        5.0,
        "beyond it the rig does not fit the images: recalibrate",
    ),
    default: (1.0, "the correspondence default"),
};

const RESIDUAL: Rule<'static> = Rule {
    what: "marker points",
    unit: "px",
    side: Side::Upper,
    k: 4.0,
    floor: (0.1, "below it leaving views out chases detector noise"),
    ceiling: (
        4.0,
        "beyond it views of different markers would pass as one",
    ),
    default: (1.0, "the triangulation default"),
};

const SIZE_RATIO: Rule<'static> = Rule {
    what: "marker blobs",
    unit: "",
    side: Side::Upper,
    k: 4.0,
    floor: (
        1.15,
        "a blob's radius scatters by a few percent with its sub-pixel phase",
    ),
    ceiling: (
        std::f64::consts::SQRT_2,
        "two equal touching discs have sqrt(2) the radius of one",
    ),
    default: (std::f64::consts::SQRT_2, "two equal touching discs"),
};

const MERGED_ROUNDNESS: Rule<'static> = Rule {
    what: "marker blobs",
    unit: "",
    side: Side::Lower,
    k: 4.0,
    floor: (0.5, "two touching equal discs score 0.5"),
    ceiling: (0.9, "compressed small discs score 0.9 and less"),
    default: (0.5, "two touching equal discs"),
};

const REGISTRATION: Rule<'static> = Rule {
    what: "confident frames",
    unit: "mm",
    side: Side::Upper,
    k: 4.0,
    floor: (
        0.02,
        "the best marker trackers' noise; tighter flags honest frames",
    ),
    ceiling: (
        5.0,
        "a marker 5 mm off its place is a wrong point or a bent tool",
    ),
    default: (0.5, "the registration default"),
};

/// The detector's roundness floor from the roundness of a sample of blobs detected with the
/// floor at its lowest (see the module docs), or `given`.
#[must_use]
pub fn roundness_gate(roundness: &[f64], given: Option<f64>) -> Gate {
    match given {
        Some(v) => Gate::given(v, "--min-roundness"),
        None => ROUNDNESS.measure_with(roundness, lower_tail_scale(roundness)),
    }
}

/// `Φ⁻¹(0.9)`: a normal sample's 10th percentile lies this many σ below its median.
const TENTH_PERCENTILE_SIGMAS: f64 = 1.281_551_565_545;

/// Median and the larger of the MAD's σ̂ and the lower tail's `(median − p10) / Φ⁻¹(0.9)`.
/// Roundness is bounded by 1 and skewed toward 0: block compression and motion blur give real
/// markers ragged edges now and then, a tail the MAD does not see (on the real PS3 Eye
/// recording, median 0.88, MAD σ̂ 0.043 but a 10th percentile of 0.75 and markers down to
/// 0.57), while clean discs keep both small.
fn lower_tail_scale(values: &[f64]) -> Option<RobustScale> {
    let scale = robust_scale(values)?;
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let p10 = v[(v.len() - 1) / 10];
    Some(RobustScale {
        sigma: scale
            .sigma
            .max((scale.median - p10) / TENTH_PERCENTILE_SIGMAS),
        ..scale
    })
}

/// The registration gate from the registration residuals of confidently tracked frames
/// (millimetres), or `given`.
#[must_use]
pub fn registration_gate(rms_mm: &[f64], given: Option<f64>) -> Gate {
    match given {
        Some(v) => Gate::given(v, "--max-registration-rms"),
        None => REGISTRATION.measure(rms_mm),
    }
}

/// The lowest roundness floor [`roundness_gate`] can give: detect the sample with it.
pub const ROUNDNESS_FLOOR: f64 = 0.5;

/// Evenly spaced frame indices, at most `at_most` of `count` (all when fewer).
#[must_use]
pub fn sample_frames(count: usize, at_most: usize) -> Vec<usize> {
    if count <= at_most {
        return (0..count).collect();
    }
    (0..at_most).map(|i| i * count / at_most).collect()
}

/// The largest distance tolerance that keeps the tool's marker distances apart: 0.49 of the
/// closest pair of its distances (identification refuses a tolerance of half of it).
#[must_use]
pub fn distance_tolerance_ceiling_mm(tool: &Tool) -> f64 {
    let m = &tool.markers_in_tool;
    let mut distances = Vec::new();
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            distances.push((m[i] - m[j]).norm());
        }
    }
    distances.sort_by(f64::total_cmp);
    let closest = distances
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    if closest.is_finite() {
        0.49 * closest
    } else {
        // Three or fewer markers with one distance: nothing to confuse.
        0.49 * distances.first().copied().unwrap_or(1.0)
    }
}

/// What the confident frames of the first pass show.
#[derive(Debug, Default)]
struct Evidence {
    epipolar_px: BTreeMap<(CameraId, CameraId), Vec<f64>>,
    residual_px: Vec<f64>,
    distance_error_mm: Vec<f64>,
    registration_mm: Vec<f64>,
    /// Size ratio and roundness of each confident marker's blob in each view.
    blobs: Vec<(f64, f64)>,
    confident: usize,
}

/// A frame every marker of which was identified, with no rival and no dropped view.
fn is_confident(track: &FrameTrack, tool: &Tool) -> bool {
    track.outcome.is_ok()
        && track.labels.len() == tool.markers_in_tool.len()
        && track
            .flags
            .iter()
            .all(|f| matches!(f, crate::track::Flag::RegistrationResidual { .. }))
}

fn gather(
    rig: &Rig,
    tool: &Tool,
    geometry: &EpipolarGeometry,
    tracks: &[FrameTrack],
    frames: &[Views],
    shapes: &[Shapes],
) -> Evidence {
    let mut evidence = Evidence::default();
    for (frame, track) in tracks.iter().enumerate() {
        if !is_confident(track, tool) {
            continue;
        }
        let Ok(pose) = &track.outcome else { continue };
        evidence.confident += 1;
        evidence.registration_mm.push(pose.rms_mm);
        for (marker, &p) in &track.labels {
            let point = &track.points[p];
            evidence.residual_px.push(point.residual_px);
            for (camera, pixel) in &point.views {
                // The blob is the one of its camera's list at this very centre.
                let shape = frames.get(frame).zip(shapes.get(frame)).and_then(|(v, s)| {
                    let i = v.get(camera)?.iter().position(|b| b == pixel)?;
                    s.get(camera)?.get(i)
                });
                if let Some(shape) = shape
                    && let Some(ratio) = size_ratio(
                        rig,
                        *camera,
                        shape,
                        &point.position,
                        tool.marker_diameter_mm,
                    )
                {
                    evidence.blobs.push((ratio, shape.roundness));
                }
            }
            let ideal: Vec<(CameraId, crate::geometry::Pixel)> = point
                .views
                .iter()
                .filter_map(|(c, px)| Some((*c, rig.camera(*c)?.ideal_pixel(px).ok()?)))
                .collect();
            for (i, (a, pa)) in ideal.iter().enumerate() {
                for (b, pb) in &ideal[i + 1..] {
                    if let Some(r) = geometry.residual_px(*a, pa, *b, pb) {
                        evidence.epipolar_px.entry((*a, *b)).or_default().push(r);
                    }
                }
            }
            for (other, &q) in track.labels.range(..*marker) {
                let measured = (track.points[q].position - point.position).norm();
                let model = (tool.markers_in_tool[marker.0] - tool.markers_in_tool[other.0]).norm();
                evidence.distance_error_mm.push((measured - model).abs());
            }
        }
    }
    evidence
}

/// Measures every tracking gate from a sample of frames' blob centres (`frames`, e.g. the
/// frames of [`sample_frames`] detected with the roundness gate) and their blobs' shapes
/// (`shapes`, one per frame, or none: no merged-blob gate), and returns them with
/// `min_roundness` (from [`roundness_gate`]) alongside. Overridden gates are used as given,
/// in the first pass too.
#[must_use]
pub fn measure_gates(
    rig: &Rig,
    tool: &Tool,
    frames: &[Views],
    shapes: &[Shapes],
    min_roundness: Gate,
    overrides: &GateOverrides,
) -> Gates {
    let distance_ceiling_mm = distance_tolerance_ceiling_mm(tool);
    let first_pass = TrackConfig {
        correspond: CorrespondConfig {
            epipolar_tolerance_px: overrides
                .epipolar_tolerance_px
                .unwrap_or(EPIPOLAR.ceiling.0),
            ..CorrespondConfig::default()
        },
        triangulate: TriangulateConfig {
            max_residual_px: overrides.max_residual_px.unwrap_or(RESIDUAL.ceiling.0),
            ..TriangulateConfig::default()
        },
        identify: IdentifyConfig {
            distance_tolerance_mm: overrides
                .distance_tolerance_mm
                .unwrap_or(distance_ceiling_mm),
        },
        max_registration_rms_mm: overrides
            .max_registration_rms_mm
            .unwrap_or(REGISTRATION.ceiling.0),
        mirror: None,
        merged: None,
    };
    let mirror_noise_mm = first_pass.identify.distance_tolerance_mm;
    let tracker = Tracker::new(rig, tool, first_pass);
    let tracks: Vec<FrameTrack> = {
        use rayon::prelude::*;
        frames.par_iter().map(|v| tracker.track_frame(v)).collect()
    };
    let geometry = EpipolarGeometry::new(rig);
    let evidence = gather(rig, tool, &geometry, &tracks, frames, shapes);

    let all_epipolar: Vec<f64> = evidence.epipolar_px.values().flatten().copied().collect();
    let epipolar_tolerance_px = match overrides.epipolar_tolerance_px {
        Some(v) => Gate::given(v, "--epipolar-tolerance"),
        None => EPIPOLAR.measure(&all_epipolar),
    };
    let pairs = if overrides.epipolar_tolerance_px.is_some() {
        Vec::new()
    } else {
        evidence
            .epipolar_px
            .iter()
            .filter(|(_, v)| v.len() >= MIN_SAMPLES)
            .map(|((a, b), values)| {
                let name = |c: &CameraId| {
                    rig.camera(*c)
                        .map_or_else(|| c.to_string(), |cam| cam.name.clone())
                };
                PairGate {
                    first: *a,
                    second: *b,
                    name: format!("{}-{}", name(a), name(b)),
                    gate: EPIPOLAR.measure(values),
                }
            })
            .collect()
    };
    let max_residual_px = match overrides.max_residual_px {
        Some(v) => Gate::given(v, "--max-residual-px"),
        None => RESIDUAL.measure(&evidence.residual_px),
    };
    let distance_rule = Rule {
        what: "marker distances",
        unit: "mm",
        side: Side::Upper,
        k: 6.0,
        floor: (0.3, "tool models are measured to about 0.1 mm"),
        ceiling: (
            distance_ceiling_mm,
            "0.49 of the tool's closest pair of distances, which must stay apart",
        ),
        default: (
            IdentifyConfig::default()
                .distance_tolerance_mm
                .min(distance_ceiling_mm),
            "the identification default",
        ),
    };
    let distance_tolerance_mm = match overrides.distance_tolerance_mm {
        Some(v) => Gate::given(v, "--distance-tolerance"),
        None => distance_rule.measure(&evidence.distance_error_mm),
    };
    let max_registration_rms_mm =
        registration_gate(&evidence.registration_mm, overrides.max_registration_rms_mm);
    let (mirror, mirror_reason) = match learn_mirror(rig, &tracks, mirror_noise_mm) {
        Ok(m) => {
            let reason = format!(
                "n = ({:.3}, {:.3}, {:.3}), offset {:.1} mm: the tool's mirror image in {} frames, {:.2} mm RMS from a pure reflection; points more than {:.2} mm behind it are left out",
                m.normal.x, m.normal.y, m.normal.z, m.offset_mm, m.frames, m.rms_mm, m.margin_mm
            );
            (Some(m), reason)
        }
        Err(why) => (None, format!("none: {why}")),
    };
    let (merged, merged_reason) = merged_gate(&evidence.blobs);
    let chance = chance_alignments(&evidence.distance_error_mm, mirror_noise_mm);
    Gates {
        min_roundness,
        epipolar_tolerance_px,
        pairs,
        max_residual_px,
        distance_tolerance_mm,
        max_registration_rms_mm,
        typical_residual_px: median(&evidence.residual_px),
        typical_registration_rms_mm: median(&evidence.registration_mm),
        sampled_frames: frames.len(),
        confident_frames: evidence.confident,
        mirror,
        mirror_reason,
        merged,
        merged_reason,
        chance,
    }
}

/// Why the confident frames' marker distances look like chance, `None` when they show a tool.
///
/// The first pass identifies markers within `tolerance_mm` of the tool's distances. Where the
/// tool is in view, the measured distances miss the model's by the calibration's and
/// detector's noise: a small fraction of the tolerance, which is the ceiling
/// ([`distance_tolerance_ceiling_mm`], half the gap between two of the tool's distances). Where
/// it is not, chance triples of other points (a cloud of markers, reflections) fit the
/// distances anywhere within the tolerance, spread evenly: their median error is half of it.
/// A median beyond a quarter of the tolerance is 2.7 standard errors from a uniform spread's
/// half with [`MIN_SAMPLES`] distances, and 12 % of the tool's closest gap: no rig that tracks
/// leaves it. Fewer than [`MIN_SAMPLES`] distances judge nothing.
#[must_use]
pub fn chance_alignments(distance_error_mm: &[f64], tolerance_mm: f64) -> Option<String> {
    if distance_error_mm.len() < MIN_SAMPLES {
        return None;
    }
    let typical = median(distance_error_mm)?;
    (typical > 0.25 * tolerance_mm).then(|| {
        format!(
            "the confidently tracked frames' marker distances miss the tool's by a median {typical:.2} mm of the {tolerance_mm:.2} mm the first pass allows ({} distances): chance alignments of other points spread evenly up to the tolerance, a tool in view stays near zero; the tool is not in view, or the rig does not measure it",
            distance_error_mm.len()
        )
    })
}

/// The merged-blob gate from the confident markers' blobs (size ratio, roundness), with its
/// reason; none with fewer than [`MIN_SAMPLES`].
fn merged_gate(blobs: &[(f64, f64)]) -> (Option<MergedGate>, String) {
    let ratios: Vec<f64> = blobs.iter().map(|b| b.0).collect();
    let roundness: Vec<f64> = blobs.iter().map(|b| b.1).collect();
    let Some(typical) = median(&ratios).filter(|_| blobs.len() >= MIN_SAMPLES) else {
        return (
            None,
            format!(
                "none: {} marker blobs with shapes measured, {MIN_SAMPLES} needed",
                blobs.len()
            ),
        );
    };
    // Relative to the typical ratio: blur and bloom scale every marker's blob alike.
    let relative: Vec<f64> = ratios.iter().map(|r| r / typical).collect();
    let size = SIZE_RATIO.measure(&relative);
    let round = MERGED_ROUNDNESS.measure(&roundness);
    let gate = MergedGate {
        max_size_ratio: size.value * typical,
        typical_size_ratio: typical,
        min_roundness: round.value,
    };
    let reason = format!(
        "radius over the sphere's predicted one above {:.3} × the typical {typical:.3} ({}), or roundness under {:.3} ({}) above halfway between the two sizes",
        size.value, size.reason, round.value, round.reason
    );
    (Some(gate), reason)
}

impl Gates {
    /// The library's defaults as gates, for callers that measure nothing.
    #[must_use]
    pub fn defaults() -> Self {
        let config = TrackConfig::default();
        Self {
            min_roundness: Gate::default_value(ROUNDNESS.default.0, ROUNDNESS.default.1),
            epipolar_tolerance_px: Gate::default_value(
                config.correspond.epipolar_tolerance_px,
                EPIPOLAR.default.1,
            ),
            pairs: Vec::new(),
            max_residual_px: Gate::default_value(
                config.triangulate.max_residual_px,
                RESIDUAL.default.1,
            ),
            distance_tolerance_mm: Gate::default_value(
                config.identify.distance_tolerance_mm,
                "the identification default",
            ),
            max_registration_rms_mm: Gate::default_value(
                config.max_registration_rms_mm,
                REGISTRATION.default.1,
            ),
            typical_residual_px: None,
            typical_registration_rms_mm: None,
            sampled_frames: 0,
            confident_frames: 0,
            mirror: None,
            mirror_reason: "none: nothing measured".into(),
            merged: None,
            merged_reason: "none: nothing measured".into(),
            chance: None,
        }
    }

    /// The tracking options these gates set.
    #[must_use]
    pub fn track_config(&self) -> TrackConfig {
        TrackConfig {
            correspond: CorrespondConfig {
                epipolar_tolerance_px: self.epipolar_tolerance_px.value,
                pair_tolerance_px: self
                    .pairs
                    .iter()
                    .map(|p| ((p.first, p.second), p.gate.value))
                    .collect(),
                ..CorrespondConfig::default()
            },
            triangulate: TriangulateConfig {
                max_residual_px: self.max_residual_px.value,
                ..TriangulateConfig::default()
            },
            identify: IdentifyConfig {
                distance_tolerance_mm: self.distance_tolerance_mm.value,
            },
            max_registration_rms_mm: self.max_registration_rms_mm.value,
            mirror: self.mirror.clone(),
            merged: self.merged,
        }
    }
}

impl Gates {
    /// The gates in one line, for a run that does not print the table ([`Gates`]'s `Display`):
    /// the values without the reasons.
    pub fn summary(&self) -> String {
        format!(
            "gates from {} of {} sampled frames: roundness {:.2}, epipolar {:.2} px, residual {:.2} px, distances {:.2} mm, registration {:.2} mm; {}",
            self.confident_frames,
            self.sampled_frames,
            self.min_roundness.value,
            self.epipolar_tolerance_px.value,
            self.max_residual_px.value,
            self.distance_tolerance_mm.value,
            self.max_registration_rms_mm.value,
            if self.mirror.is_some() {
                "a mirror"
            } else {
                "no mirror"
            },
        )
    }
}

impl fmt::Display for Gates {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "gates ({} of {} sampled frames tracked confidently):",
            self.confident_frames, self.sampled_frames
        )?;
        let mut line = |name: &str, gate: &Gate, unit: &str| {
            writeln!(
                f,
                "  {name:<24} {:>8.3} {unit:<3} {}",
                gate.value, gate.reason
            )
        };
        line("min roundness", &self.min_roundness, "")?;
        line("epipolar tolerance", &self.epipolar_tolerance_px, "px")?;
        for pair in &self.pairs {
            line(&format!("  epipolar {}", pair.name), &pair.gate, "px")?;
        }
        line("triangulation residual", &self.max_residual_px, "px")?;
        line("distance tolerance", &self.distance_tolerance_mm, "mm")?;
        line("registration residual", &self.max_registration_rms_mm, "mm")?;
        writeln!(f, "  {:<24} {}", "mirror", self.mirror_reason)?;
        if let Some(chance) = &self.chance {
            writeln!(f, "  {:<24} {chance}", "tool not shown")?;
        }
        writeln!(f, "  {:<24} {}", "merged blob", self.merged_reason)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_scale_of_a_known_sample() {
        let s = robust_scale(&[1.0, 2.0, 3.0, 4.0, 100.0, f64::NAN]).unwrap();
        assert_eq!(s.median, 3.0);
        // |x − 3| = 2, 1, 0, 1, 97: median 1.
        assert!((s.sigma - 1.4826).abs() < 1e-12);
        assert_eq!(s.count, 5);
        assert_eq!(median(&[]), None);
    }

    #[test]
    fn a_gate_is_clamped_and_says_why() {
        let tight: Vec<f64> = (0..50).map(|i| 0.01 + 0.0001 * f64::from(i)).collect();
        let g = RESIDUAL.measure(&tight);
        assert_eq!(g.value, 0.1);
        assert!(g.reason.contains("raised to the floor"), "{}", g.reason);
        let wide: Vec<f64> = (0..50).map(|i| 3.0 + 0.1 * f64::from(i)).collect();
        let g = RESIDUAL.measure(&wide);
        assert_eq!(g.value, 4.0);
        assert!(g.reason.contains("ceiling"), "{}", g.reason);
        let g = RESIDUAL.measure(&[0.5; 3]);
        assert_eq!(g.value, 1.0);
        assert!(
            g.reason.contains("3 marker points of 10 measured"),
            "{}",
            g.reason
        );
    }

    #[test]
    fn roundness_of_compressed_small_blobs_lowers_the_floor() {
        // The real blobs: 0.57–0.9, spread evenly.
        let real: Vec<f64> = (0..200)
            .map(|i| 0.57 + 0.33 * f64::from(i) / 199.0)
            .collect();
        let g = roundness_gate(&real, None);
        assert!(g.value <= 0.57, "{g:?}");
        assert!(g.value >= 0.5);
        // Simulated discs: 0.95–1; the floor stays the detector's.
        let clean: Vec<f64> = (0..200)
            .map(|i| 0.95 + 0.05 * f64::from(i) / 199.0)
            .collect();
        assert_eq!(roundness_gate(&clean, None).value, 0.75);
        assert_eq!(roundness_gate(&clean, Some(0.3)).value, 0.3);
    }

    #[test]
    fn sample_frames_are_spread_and_bounded() {
        assert_eq!(sample_frames(5, 10), vec![0, 1, 2, 3, 4]);
        let s = sample_frames(1000, 4);
        assert_eq!(s, vec![0, 250, 500, 750]);
    }
}
