//! The figures made from trajectories alone: components with the residual, the spectrum,
//! per-frame quality, the smoothing comparison, the tip path to scale, the path on the robot
//! and the tip error.

use std::collections::BTreeMap;

use rand::SeedableRng;

use super::spectrum::{median_above, windowed_spectrum};
use super::{
    Axis, FigureBody, FigureId, FigureSlot, IRB120_REACH_MM, Mark, Panel, Role, Series, Shape,
    Style, Tick, short,
};
use crate::geometry::{Point3, Pose};
use crate::smooth::study::{StudyConfig, run_study};
use crate::smooth::{SmoothConfig, check_timing};
use crate::trajectory::{Sample, Status, ToolPose, Trajectory};

/// Heading of [`FigureId::Components`].
pub const COMPONENTS_TITLE: &str = "Trajectory components (paper Figs. 3 and 8)";
/// Heading of [`FigureId::Spectrum`].
pub const SPECTRUM_TITLE: &str = "Amplitude spectrum (paper Fig. 7)";
/// Heading of [`FigureId::Quality`].
pub const QUALITY_TITLE: &str = "Per-frame uncertainty and status";
/// Heading of [`FigureId::SmoothingStudy`].
pub const STUDY_TITLE: &str = "The paper's smoothing comparison (Figs. 4-6, 8)";
/// Heading of [`FigureId::Paths`].
pub const PATHS_TITLE: &str = "The tip's path, to scale";
/// Heading of [`FigureId::Robot`].
pub const ROBOT_TITLE: &str = "The stroke on the robot";
/// Heading of [`FigureId::TipError`].
pub const TIP_ERROR_TITLE: &str = "Tip error over time";

/// A component of a pose drawn over time.
struct Component {
    name: &'static str,
    unit: &'static str,
}

const COMPONENTS: [Component; 6] = [
    Component {
        name: "tip x",
        unit: "mm",
    },
    Component {
        name: "tip y",
        unit: "mm",
    },
    Component {
        name: "tip z",
        unit: "mm",
    },
    Component {
        name: "rotation x",
        unit: "deg",
    },
    Component {
        name: "rotation y",
        unit: "deg",
    },
    Component {
        name: "rotation z",
        unit: "deg",
    },
];

/// The six drawn components of a pose: the tip (mm), then the rotation from `reference` as a
/// rotation vector in the reference tool frame (deg): continuous through ±180° about any
/// axis, unlike Euler angles, for rotations within half a turn of the reference.
fn component_values(pose: &ToolPose, reference: &Pose) -> [f64; 6] {
    let v = (reference.rotation.inverse() * pose.world_from_tool.rotation).scaled_axis();
    let tip = pose.tip_in_world;
    [
        tip.x,
        tip.y,
        tip.z,
        v.x.to_degrees(),
        v.y.to_degrees(),
        v.z.to_degrees(),
    ]
}

/// The first pose of `raw`: the reference of the rotation components.
fn reference_pose(raw: &Trajectory) -> Option<(usize, Pose)> {
    raw.samples
        .iter()
        .find_map(|s| Some((s.frame.0, s.pose?.world_from_tool)))
}

/// `other`'s samples at `raw`'s frames (by frame number), `None` where it has none.
pub(crate) fn aligned<'a>(raw: &Trajectory, other: &'a Trajectory) -> Vec<Option<&'a Sample>> {
    let same = other.len() == raw.len()
        && other
            .samples
            .iter()
            .zip(&raw.samples)
            .all(|(a, b)| a.frame == b.frame);
    if same {
        return other.samples.iter().map(Some).collect();
    }
    let by_frame: BTreeMap<usize, &Sample> = other.samples.iter().map(|s| (s.frame.0, s)).collect();
    raw.samples
        .iter()
        .map(|s| by_frame.get(&s.frame.0).copied())
        .collect()
}

/// Times of `raw`'s frames: the shared abscissa of the time panels.
fn times(raw: &Trajectory) -> Vec<f64> {
    raw.samples.iter().map(|s| s.time_s).collect()
}

/// Root mean square of the present values, `None` when there are none.
pub(crate) fn rms(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values
        .into_iter()
        .fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (n > 0).then(|| (sum / n as f64).sqrt())
}

fn series(label: &str, role: Role, y: Vec<Option<f64>>, style: Style) -> Series {
    Series {
        label: label.to_string(),
        role,
        x: None,
        y,
        style,
    }
}

fn time_panel(
    title: String,
    y_axis: Axis,
    x: Vec<f64>,
    series: Vec<Series>,
    shape: Shape,
) -> Panel {
    Panel {
        title,
        x_axis: Axis::linear("time", "s"),
        y_axis,
        x,
        series,
        marks: Vec::new(),
        shape,
    }
}

/// Trajectory components raw / smoothed / truth, each over a panel of its residual
/// raw − smoothed (and smoothed − truth when the truth is known). `how` says how `smoothed`
/// was made.
#[must_use]
pub fn components(
    raw: &Trajectory,
    smoothed: &Trajectory,
    how: &str,
    truth: Option<&Trajectory>,
) -> FigureSlot {
    let Some((reference_frame, reference)) = reference_pose(raw) else {
        return FigureSlot::missing(
            FigureId::Components,
            COMPONENTS_TITLE,
            "the raw trajectory has no pose in any frame".into(),
        );
    };
    let values = |samples: &[Option<&Sample>]| -> Vec<Option<[f64; 6]>> {
        samples
            .iter()
            .map(|s| Some(component_values(s.as_ref()?.pose.as_ref()?, &reference)))
            .collect()
    };
    let raw_values = values(&raw.samples.iter().map(Some).collect::<Vec<_>>());
    let smoothed_values = values(&aligned(raw, smoothed));
    let truth_values = truth.map(|t| values(&aligned(raw, t)));
    let x = times(raw);
    let column = |v: &[Option<[f64; 6]>], c: usize| -> Vec<Option<f64>> {
        v.iter().map(|p| Some(p.as_ref()?[c])).collect()
    };
    let difference = |a: &[Option<f64>], b: &[Option<f64>]| -> Vec<Option<f64>> {
        a.iter().zip(b).map(|(a, b)| Some((*a)? - (*b)?)).collect()
    };
    let mut panels = Vec::new();
    let mut residual_tip_sq = Vec::new();
    for (c, component) in COMPONENTS.iter().enumerate() {
        let raw_c = column(&raw_values, c);
        let smoothed_c = column(&smoothed_values, c);
        let mut lines = Vec::new();
        if let Some(t) = &truth_values {
            lines.push(series("truth", Role::Truth, column(t, c), Style::Dashed));
        }
        lines.push(series("raw", Role::Raw, raw_c.clone(), Style::Points));
        lines.push(series(
            "smoothed",
            Role::Smoothed,
            smoothed_c.clone(),
            Style::Line,
        ));
        let what = if c < 3 {
            format!("{} (world frame)", component.name)
        } else {
            format!(
                "{} from frame {reference_frame}'s (tool frame)",
                component.name
            )
        };
        panels.push(time_panel(
            what,
            Axis::linear(component.name, component.unit),
            x.clone(),
            lines,
            Shape::Wide,
        ));
        let residual = difference(&raw_c, &smoothed_c);
        if c < 3 {
            residual_tip_sq.push(residual.clone());
        }
        let mut lines = vec![series(
            "raw − smoothed",
            Role::Residual,
            residual,
            Style::Line,
        )];
        if let Some(t) = &truth_values {
            lines.push(series(
                "smoothed − truth",
                Role::Truth,
                difference(&smoothed_c, &column(t, c)),
                Style::Dashed,
            ));
        }
        panels.push(time_panel(
            format!("residual of {}", component.name),
            Axis::linear("residual", component.unit),
            x.clone(),
            lines,
            Shape::Short,
        ));
    }
    let residual_rms = rms((0..x.len()).filter_map(|i| {
        let sq: Option<f64> = residual_tip_sq.iter().map(|r| r[i].map(|v| v * v)).sum();
        sq.map(f64::sqrt)
    }));
    let removed = residual_rms.map_or_else(
        || "no frame has both a raw and a smoothed pose".to_string(),
        |r| format!("the smoothing moved the tip by {r:.4} mm RMS"),
    );
    FigureSlot {
        id: FigureId::Components,
        title: COMPONENTS_TITLE.into(),
        caption: format!(
            "The tool tip's position and the tool's rotation over time: raw from tracking (points), {how} (line){}. Under each, the residual raw − smoothed, what the smoothing removed: {removed}. Drag to zoom, double-click to reset.",
            if truth.is_some() {
                ", and the simulator's truth (dashed); the second residual, smoothed − truth, is what is left of the error"
            } else {
                ""
            }
        ),
        body: FigureBody::Plots { panels },
    }
}

/// The tip (mm) and rotation (deg) columns of the samples `range` of `trajectory`, all posed.
fn segment_columns(samples: &[Option<&Sample>], reference: &Pose) -> Option<[Vec<f64>; 6]> {
    let mut columns: [Vec<f64>; 6] = Default::default();
    for s in samples {
        let v = component_values(s.as_ref()?.pose.as_ref()?, reference);
        for (c, column) in columns.iter_mut().enumerate() {
            column.push(v[c]);
        }
    }
    Some(columns)
}

/// The detrended, Hann-windowed amplitude spectrum of the raw trajectory's longest gap-free
/// segment, tip and rotation, with the cut-off marked; with the truth's over the same frames
/// when known, and a caption that says what the floor above the cut-off is, measured.
#[must_use]
pub fn spectrum(raw: &Trajectory, truth: Option<&Trajectory>, cutoff_hz: f64) -> FigureSlot {
    let missing = |reason: String| FigureSlot::missing(FigureId::Spectrum, SPECTRUM_TITLE, reason);
    let timing = match check_timing(raw, SmoothConfig::default().time_step_tolerance) {
        Ok(t) => t,
        Err(e) => return missing(format!("the raw trajectory has no spectrum: {e}")),
    };
    let Some(segment) = raw
        .segments()
        .into_iter()
        .max_by_key(|r| (r.len(), std::cmp::Reverse(r.start)))
    else {
        return missing("the raw trajectory has no pose in any frame".into());
    };
    if segment.len() < 8 {
        return missing(format!(
            "the longest run of frames with a pose has {} frames: a spectrum needs at least 8",
            segment.len()
        ));
    }
    let Some((_, reference)) = reference_pose(raw) else {
        return missing("the raw trajectory has no pose in any frame".into());
    };
    let fs = timing.sample_rate_hz;
    let raw_samples: Vec<Option<&Sample>> = raw.samples[segment.clone()].iter().map(Some).collect();
    let Some(raw_columns) = segment_columns(&raw_samples, &reference) else {
        return missing("the longest segment lost a pose".into());
    };
    let truth_columns = truth.and_then(|t| {
        let at = aligned(raw, t);
        segment_columns(&at[segment.clone()], &reference)
    });
    let spectra: Vec<_> = raw_columns
        .iter()
        .map(|c| windowed_spectrum(c, fs))
        .collect();
    let truth_spectra: Option<Vec<_>> = truth_columns
        .as_ref()
        .map(|t| t.iter().map(|c| windowed_spectrum(c, fs)).collect());
    // The DC bin holds what detrending left (nothing); a log axis cannot show zero.
    let frequency_hz: Vec<f64> = spectra[0].frequency_hz.iter().skip(1).copied().collect();
    let positive = |a: &[f64]| -> Vec<Option<f64>> {
        a.iter().skip(1).map(|v| (*v > 0.0).then_some(*v)).collect()
    };
    let names = ["x", "y", "z"];
    let first_frame = raw.samples[segment.start].frame.0;
    let last_frame = raw.samples[segment.end - 1].frame.0;
    let mut panels = Vec::new();
    for (group, (what, unit)) in [("tip position", "mm"), ("rotation", "deg")]
        .iter()
        .enumerate()
    {
        let mut lines = Vec::new();
        for (k, name) in names.iter().enumerate() {
            let c = 3 * group + k;
            lines.push(series(
                &format!("raw {name}"),
                Role::Component(k as u8),
                positive(&spectra[c].amplitude),
                Style::Line,
            ));
        }
        if let Some(t) = &truth_spectra {
            for (k, name) in names.iter().enumerate() {
                lines.push(series(
                    &format!("truth {name}"),
                    Role::Component(k as u8),
                    positive(&t[3 * group + k].amplitude),
                    Style::Dashed,
                ));
            }
        }
        panels.push(Panel {
            title: format!("{what}, frames {first_frame}..={last_frame}, detrended, Hann window"),
            x_axis: Axis::linear("frequency", "Hz"),
            y_axis: Axis::log("amplitude", unit),
            x: frequency_hz.clone(),
            series: lines,
            marks: vec![Mark::VerticalLine {
                x: cutoff_hz,
                label: format!("cut-off {} Hz", short(cutoff_hz)),
            }],
            shape: Shape::Wide,
        });
    }
    let floor = |s: &[crate::smooth::spectrum::Spectrum]| -> Option<f64> {
        s[..3]
            .iter()
            .filter_map(|s| median_above(&s.frequency_hz, &s.amplitude, cutoff_hz))
            .reduce(f64::max)
    };
    let mut caption = format!(
        "Single-sided amplitude of the tip position and rotation over the longest run of frames with a pose ({} frames at {} Hz), each component detrended (least-squares line removed) and Hann-windowed, so that the motion does not leak into every bin; the truth, when known, dashed. The motion lives in the first few hertz; the vertical line marks the low-pass cut-off.",
        segment.len(),
        short(fs)
    );
    if let Some(raw_floor) = floor(&spectra) {
        caption.push_str(&format!(
            " Above it the raw position spectrum's median is {raw_floor:.2e} mm (largest of x, y, z)"
        ));
        match (&truth_spectra, &truth_columns) {
            (Some(t), Some(columns)) => {
                let plain: Vec<_> = columns[..3]
                    .iter()
                    .map(|c| crate::smooth::spectrum::amplitude_spectrum(c, fs))
                    .collect();
                let plain_floor = plain
                    .iter()
                    .filter_map(|s| median_above(&s.frequency_hz, &s.amplitude, cutoff_hz))
                    .reduce(f64::max);
                let truth_floor = floor(t).unwrap_or(f64::NAN);
                caption.push_str(&format!(
                    "; the noise-free truth's, windowed the same way, is {truth_floor:.2e} mm{}.",
                    if truth_floor < 0.3 * raw_floor {
                        ", so the raw floor is measurement noise, what the low-pass removes"
                    } else {
                        ": as high, so above the cut-off this spectrum shows the motion's own leak as much as noise"
                    }
                ));
                if let Some(p) = plain_floor {
                    caption.push_str(&format!(
                        " Without detrending and the window the truth alone would show {p:.2e} mm there: the leak of its own motion."
                    ));
                }
            }
            _ => caption.push_str(
                ": a flat floor there is measurement noise (the simulator's truth, when given, is drawn for comparison).",
            ),
        }
    }
    FigureSlot {
        id: FigureId::Spectrum,
        title: SPECTRUM_TITLE.into(),
        caption,
        body: FigureBody::Plots { panels },
    }
}

/// Per-frame `tip_std_mm` and status.
#[must_use]
pub fn quality(raw: &Trajectory) -> FigureSlot {
    let x = times(raw);
    let tip_std: Vec<Option<f64>> = raw.samples.iter().map(|s| s.tip_std_mm).collect();
    let status: Vec<Option<f64>> = raw
        .samples
        .iter()
        .map(|s| {
            Status::ALL
                .iter()
                .position(|a| *a == s.status)
                .map(|i| i as f64)
        })
        .collect();
    let counts: Vec<String> = Status::ALL
        .iter()
        .map(|a| {
            format!(
                "{} {a}",
                raw.samples.iter().filter(|s| s.status == *a).count()
            )
        })
        .collect();
    let stds: Vec<f64> = tip_std.iter().flatten().copied().collect();
    let std_text = match (
        rms(stds.iter().copied()),
        stds.iter().copied().reduce(f64::max),
    ) {
        (Some(r), Some(m)) => format!("tip_std_mm is {r:.4} mm RMS, {m:.4} mm at most"),
        _ => "the file has no tip_std_mm values (`teachcam track` writes them)".to_string(),
    };
    let mut status_axis = Axis::linear("status", "");
    status_axis.ticks = Status::ALL
        .iter()
        .enumerate()
        .map(|(i, s)| Tick {
            value: i as f64,
            label: s.name().to_string(),
        })
        .collect();
    status_axis.range = Some([-0.5, 3.5]);
    let panels = vec![
        time_panel(
            "predicted tip uncertainty per frame".into(),
            Axis::linear("tip_std", "mm"),
            x.clone(),
            vec![series("tip_std_mm", Role::Predicted, tip_std, Style::Line)],
            Shape::Wide,
        ),
        time_panel(
            "status per frame".into(),
            status_axis,
            x,
            vec![series("status", Role::Raw, status, Style::Steps)],
            Shape::Short,
        ),
    ];
    FigureSlot {
        id: FigureId::Quality,
        title: QUALITY_TITLE.into(),
        caption: format!(
            "Each frame's predicted tip uncertainty (first order, from its blobs' centre noise) and its status (ok; degraded: a view dropped, a merged blob, fewer markers; outlier: residuals beyond the gate; lost: no pose). Frames: {}; {std_text}.",
            counts.join(", ")
        ),
        body: FigureBody::Plots { panels },
    }
}

/// The paper's comparison of smoothing methods on its own trajectory model, noise drawn with
/// `seed` (the numbers of `teachcam smoothing-study --seed SEED`).
#[must_use]
pub fn smoothing_study(seed: u64) -> FigureSlot {
    let config = StudyConfig::default();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let result = match run_study(&config, &mut rng) {
        Ok(r) => r,
        Err(e) => {
            return FigureSlot::missing(
                FigureId::SmoothingStudy,
                STUDY_TITLE,
                format!("the study did not run: {e}"),
            );
        }
    };
    let some = |v: &[f64]| -> Vec<Option<f64>> { v.iter().copied().map(Some).collect() };
    let mut panels = Vec::new();
    for m in &result.methods {
        panels.push(time_panel(
            format!(
                "{}: sinusoids + noise (RMS error {:.3} mm)",
                m.name, m.rms_error_mm
            ),
            Axis::linear("signal", "mm"),
            result.time_s.clone(),
            vec![
                series("noisy", Role::Raw, some(&result.noisy), Style::Points),
                series("clean", Role::Truth, some(&result.clean), Style::Dashed),
                series(&m.name, Role::Smoothed, some(&m.smoothed), Style::Line),
            ],
            Shape::Wide,
        ));
        panels.push(time_panel(
            format!("{}: white noise alone (kept {:.3})", m.name, m.noise_kept),
            Axis::linear("noise", "mm"),
            result.time_s.clone(),
            vec![
                series("noise", Role::Raw, some(&result.noise), Style::Points),
                series(
                    &m.name,
                    Role::Smoothed,
                    some(&m.smoothed_noise),
                    Style::Line,
                ),
            ],
            Shape::Short,
        ));
    }
    let numbers: Vec<String> = result
        .methods
        .iter()
        .map(|m| format!("{} {:.3} mm", m.name, m.rms_error_mm))
        .collect();
    FigureSlot {
        id: FigureId::SmoothingStudy,
        title: STUDY_TITLE.into(),
        caption: format!(
            "A sum of sinusoids ({}) plus white noise of {} mm at {} Hz, and the noise alone, through each method: the cubic spline keeps all the noise, the Bezier curve removes it but flattens the motion, the least-squares B-spline and the low-pass filter keep the motion and remove most of the noise. RMS error against the clean signal: raw {:.3} mm, {} (`teachcam smoothing-study --seed {seed}` gives the same numbers).",
            config
                .sinusoids
                .iter()
                .map(|s| format!("{} mm at {} Hz", s.amplitude_mm, s.frequency_hz))
                .collect::<Vec<_>>()
                .join(", "),
            config.noise_std_mm,
            config.sample_rate_hz,
            result.raw_rms_error_mm,
            numbers.join(", ")
        ),
        body: FigureBody::Plots { panels },
    }
}

/// Square ranges (equal spans) around every point of `series`, with a 5 % margin: the
/// ranges of an equal-aspect panel.
#[must_use]
pub fn equal_aspect_ranges(series: &[Series]) -> ([f64; 2], [f64; 2]) {
    let mut bounds = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for s in series {
        let Some(xs) = &s.x else { continue };
        for (x, y) in xs.iter().zip(&s.y) {
            if let Some(y) = y {
                bounds = [
                    bounds[0].min(*x),
                    bounds[1].max(*x),
                    bounds[2].min(*y),
                    bounds[3].max(*y),
                ];
            }
        }
    }
    if !bounds.iter().all(|b| b.is_finite()) {
        return ([-1.0, 1.0], [-1.0, 1.0]);
    }
    let half = 0.5 * (bounds[1] - bounds[0]).max(bounds[3] - bounds[2]).max(1e-3) * 1.05;
    let (cx, cy) = (0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]));
    ([cx - half, cx + half], [cy - half, cy + half])
}

/// A path series: its own `x` (the previous present value at a gap, so the front end sees
/// numbers) and `y` (`None` at a gap).
fn path_series(label: &str, role: Role, points: &[Option<(f64, f64)>], style: Style) -> Series {
    let mut last_x = 0.0;
    let x = points
        .iter()
        .map(|p| {
            if let Some((x, _)) = p {
                last_x = *x;
            }
            last_x
        })
        .collect();
    Series {
        label: label.to_string(),
        role,
        x: Some(x),
        y: points.iter().map(|p| p.map(|(_, y)| y)).collect(),
        style,
    }
}

fn xy_panel(title: String, x_axis: Axis, y_axis: Axis, series: Vec<Series>) -> Panel {
    let (x_range, y_range) = equal_aspect_ranges(&series);
    Panel {
        title,
        x_axis,
        y_axis,
        x: Vec::new(),
        series,
        marks: Vec::new(),
        shape: Shape::EqualAspect { x_range, y_range },
    }
}

fn tips(t: &Trajectory) -> Vec<Option<Point3>> {
    t.samples
        .iter()
        .map(|s| s.pose.map(|p| p.tip_in_world))
        .collect()
}

/// The tip path in the work-object frame seen from above, the front and the side, to scale.
#[must_use]
pub fn paths(raw: &Trajectory, smoothed: Option<&Trajectory>) -> FigureSlot {
    let views = [
        ("top view", 0, 1),
        ("front view", 0, 2),
        ("side view", 1, 2),
    ];
    let names = ["x", "y", "z"];
    let raw_tips = tips(raw);
    let smoothed_tips = smoothed.map(|s| {
        aligned(raw, s)
            .iter()
            .map(|s| s.and_then(|s| s.pose.map(|p| p.tip_in_world)))
            .collect::<Vec<_>>()
    });
    let mut span = [0.0; 3];
    let present: Vec<&Point3> = raw_tips.iter().flatten().collect();
    for (axis, s) in span.iter_mut().enumerate() {
        let (lo, hi) = present
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[axis]), hi.max(p[axis]))
            });
        *s = if hi >= lo { hi - lo } else { 0.0 };
    }
    if present.is_empty() {
        return FigureSlot::missing(
            FigureId::Paths,
            PATHS_TITLE,
            "the raw trajectory has no pose in any frame".into(),
        );
    }
    let panels = views
        .iter()
        .map(|(title, h, v)| {
            let project = |t: &[Option<Point3>]| -> Vec<Option<(f64, f64)>> {
                t.iter().map(|p| p.map(|p| (p[*h], p[*v]))).collect()
            };
            let mut lines = vec![path_series(
                "raw",
                Role::Raw,
                &project(&raw_tips),
                Style::Points,
            )];
            if let Some(s) = &smoothed_tips {
                lines.push(path_series(
                    "smoothed",
                    Role::Smoothed,
                    &project(s),
                    Style::Line,
                ));
            }
            xy_panel(
                format!(
                    "{title}: tip {} against {} (work-object frame)",
                    names[*v], names[*h]
                ),
                Axis::linear(names[*h], "mm"),
                Axis::linear(names[*v], "mm"),
                lines,
            )
        })
        .collect();
    FigureSlot {
        id: FigureId::Paths,
        title: PATHS_TITLE.into(),
        caption: format!(
            "The brush tip in the work-object frame seen from above, the front and the side, drawn to scale (a millimetre is as long across as up). The path spans {:.1} × {:.1} × {:.1} mm in x, y, z.",
            span[0], span[1], span[2]
        ),
        body: FigureBody::Plots { panels },
    }
}

/// `n + 1` points of a circle (closed).
fn circle(center: (f64, f64), radius: f64, n: usize) -> Vec<Option<(f64, f64)>> {
    (0..=n)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            Some((center.0 + radius * a.cos(), center.1 + radius * a.sin()))
        })
        .collect()
}

/// The path on the robot seen from above in its base frame, with the IRB 120's reach around
/// axis 1, to scale. `Err` says why it cannot be drawn.
///
/// # Errors
/// Without the work object's placement, or without a pose.
pub fn robot(
    raw: &Trajectory,
    smoothed: Option<&Trajectory>,
    base_from_wobj: Option<&Pose>,
) -> Result<FigureSlot, String> {
    let base_from_wobj =
        base_from_wobj.ok_or("the path on the robot needs the work object's placement")?;
    let path: Vec<Option<(f64, f64)>> = smoothed
        .unwrap_or(raw)
        .samples
        .iter()
        .map(|s| {
            s.pose.map(|p| {
                let in_base = base_from_wobj * p.tip_in_world;
                (in_base.x, in_base.y)
            })
        })
        .collect();
    let farthest = path
        .iter()
        .flatten()
        .map(|(x, y)| x.hypot(*y))
        .reduce(f64::max)
        .ok_or("the trajectory has no pose in any frame")?;
    let base = [
        Some((-20.0, 0.0)),
        Some((20.0, 0.0)),
        None,
        Some((0.0, -20.0)),
        Some((0.0, 20.0)),
    ];
    let panel = xy_panel(
        "top view in the IRB 120's base frame".into(),
        Axis::linear("x, base frame", "mm"),
        Axis::linear("y, base frame", "mm"),
        vec![
            path_series("tip path", Role::Smoothed, &path, Style::Line),
            path_series(
                &format!("reach of the wrist centre ({IRB120_REACH_MM} mm, data sheet)"),
                Role::Limit,
                &circle((0.0, 0.0), IRB120_REACH_MM, 180),
                Style::Dashed,
            ),
            path_series("robot base (axis 1)", Role::Reference, &base, Style::Line),
        ],
    );
    let t = base_from_wobj.translation.vector;
    Ok(FigureSlot {
        id: FigureId::Robot,
        title: ROBOT_TITLE.into(),
        caption: format!(
            "The {} tip path on the robot, seen from above in the IRB 120's base frame, to scale, with the reach of its wrist centre around axis 1. The work object is at ({:.0}, {:.0}, {:.0}) mm in the base frame; the tip comes within {farthest:.0} mm of axis 1 at most ({:.0} % of the reach; `teachcam check` tests every target, joint limits and speeds).",
            if smoothed.is_some() {
                "smoothed"
            } else {
                "raw"
            },
            t.x,
            t.y,
            t.z,
            100.0 * farthest / IRB120_REACH_MM
        ),
        body: FigureBody::Plots {
            panels: vec![panel],
        },
    })
}

/// The tip error against the simulator's truth over time, raw and smoothed, beside each
/// frame's predicted `tip_std_mm`.
#[must_use]
pub fn tip_error(
    truth: &Trajectory,
    raw: &Trajectory,
    smoothed: Option<&Trajectory>,
) -> FigureSlot {
    let truth_at = aligned(raw, truth);
    let errors = |m: &[Option<&Sample>]| -> Vec<Option<f64>> {
        truth_at
            .iter()
            .zip(m)
            .map(|(t, s)| {
                Some((t.as_ref()?.pose?.tip_in_world - s.as_ref()?.pose?.tip_in_world).norm())
            })
            .collect()
    };
    let raw_errors = errors(&raw.samples.iter().map(Some).collect::<Vec<_>>());
    let mut lines = vec![series("raw", Role::Raw, raw_errors.clone(), Style::Line)];
    let mut smoothed_rms = None;
    if let Some(s) = smoothed {
        let e = errors(&aligned(raw, s));
        smoothed_rms = rms(e.iter().flatten().copied());
        lines.push(series("smoothed", Role::Smoothed, e, Style::Line));
    }
    let predicted: Vec<Option<f64>> = raw.samples.iter().map(|s| s.tip_std_mm).collect();
    let predicted_rms = rms(predicted.iter().flatten().copied());
    lines.push(series(
        "predicted tip std (tip_std_mm)",
        Role::Predicted,
        predicted,
        Style::Dashed,
    ));
    let raw_rms = rms(raw_errors.iter().flatten().copied());
    let Some(raw_rms) = raw_rms else {
        return FigureSlot::missing(
            FigureId::TipError,
            TIP_ERROR_TITLE,
            "no frame has both a raw pose and a true pose".into(),
        );
    };
    let raw_max = raw_errors.iter().flatten().copied().fold(0.0, f64::max);
    let mut caption = format!(
        "Distance between the measured and the true tool tip in every frame, beside the per-frame first-order uncertainty that `track` writes (tip_std_mm, from the blobs' predicted centre noise). Raw: {raw_rms:.4} mm RMS, {raw_max:.4} mm at most"
    );
    if let Some(s) = smoothed_rms {
        caption.push_str(&format!("; smoothed: {s:.4} mm RMS"));
    }
    if let Some(p) = predicted_rms {
        caption.push_str(&format!(
            "; predicted: {p:.4} mm RMS ({:.2} of the raw error)",
            p / raw_rms
        ));
    }
    caption.push('.');
    FigureSlot {
        id: FigureId::TipError,
        title: TIP_ERROR_TITLE.into(),
        caption,
        body: FigureBody::Plots {
            panels: vec![time_panel(
                "tip error against the simulator's truth".into(),
                Axis::linear("tip error", "mm"),
                times(raw),
                lines,
                Shape::Wide,
            )],
        },
    }
}
