//! `teachcam report`: one self-contained HTML page of a run's figures.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use base64::Engine as _;
use image::{Rgb, RgbImage};
use teachcam::camera::Rig;
use teachcam::detect::{DetectConfig, detect};
use teachcam::geometry::{Point3, Pose, parse_pose};
use teachcam::io::recording::GrayFrame;
use teachcam::io::rig::read_rig;
use teachcam::io::tool::read_tool;
use teachcam::io::trajectory::read_trajectory;
use teachcam::metrology::uncertainty_map;
use teachcam::smooth::{SmoothConfig, trajectory_spectrum};
use teachcam::source::FrameSource;
use teachcam::source::folder::FolderSource;
use teachcam::tool::Tool;
use teachcam::trajectory::Trajectory;

use crate::Rejected;
use crate::plot::{Panel, Series, YScale, png_bytes};

/// Reach of the IRB 120 from axis 1 to the wrist centre, millimetres (ABB data sheet).
const IRB120_REACH_MM: f64 = 580.0;

/// Write an HTML report of a run: one self-contained page of figures.
///
/// Reads from RUN_DIR what is there: `raw.csv` (required), `smoothed.csv`,
/// `recording/` (with `rig.json`, `tool.json`, `truth.csv`) and `run.json` (the demo's summary
/// and work-object placement). Figures: every trajectory component raw vs smoothed vs truth
/// (paper Figs. 3 and 8), the amplitude spectrum (Fig. 7), the smoothing comparison (Figs. 4-6),
/// the tip path in three views with the robot's reach, the tip error over time, the uncertainty
/// map, and each camera's first frame with the detected blobs.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam report teachcam-demo"#)]
pub struct Args {
    /// The run's folder (as written by `teachcam demo`).
    pub run_dir: PathBuf,
    /// Output HTML file (default RUN_DIR/report.html).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Work object in the robot's base frame, for the reach drawing (default: from run.json).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub wobj: Option<String>,
}

/// A labelled line of a panel: its legend text and its (x, y) values.
type Line = (String, (Vec<f64>, Vec<f64>));

/// The panel series of labelled lines.
fn series(lines: &[Line]) -> Vec<Series<'_>> {
    lines
        .iter()
        .map(|(label, (x, y))| Series {
            label: label.clone(),
            x,
            y,
        })
        .collect()
}

/// A figure of the page: a caption and PNG bytes.
struct Figure {
    title: String,
    caption: String,
    png: Vec<u8>,
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let output = write_report(args)?;
    crate::announce::wrote(&[output], "");
    Ok(())
}

/// Writes the report; returns where.
pub fn write_report(args: &Args) -> Result<PathBuf> {
    let dir = &args.run_dir;
    if let Some(output) = &args.output {
        let output = teachcam::io::Output {
            path: output,
            format: "an HTML page",
            extensions: &["html", "htm"],
        };
        teachcam::io::check_outputs(&[output], &[])?;
    }
    let raw = read_trajectory(&dir.join("raw.csv")).rejected()?;
    let smoothed = optional(&dir.join("smoothed.csv"), read_trajectory)?;
    let recording = dir.join("recording");
    let truth = optional(&recording.join("truth.csv"), read_trajectory)?;
    let rig = optional(&recording.join("rig.json"), read_rig)?;
    let tool = optional(&recording.join("tool.json"), read_tool)?;
    let run_json: Option<serde_json::Value> = optional(&dir.join("run.json"), |p| {
        let text = teachcam::io::read_text(p)?;
        serde_json::from_str(&text).map_err(|e| teachcam::io::FileError::Invalid {
            path: p.to_path_buf(),
            message: e.to_string(),
        })
    })?;
    let wobj_text = args.wobj.clone().or_else(|| {
        run_json
            .as_ref()
            .and_then(|j| j["wobj"].as_str().map(str::to_string))
    });
    let base_from_wobj = wobj_text
        .as_deref()
        .map(parse_pose)
        .transpose()
        .context("--wobj")
        .rejected()?;

    let mut figures = vec![components(&raw, smoothed.as_ref(), truth.as_ref())?];
    if let Ok(spectra) = trajectory_spectrum(&raw, SmoothConfig::default().time_step_tolerance) {
        figures.push(Figure {
            title: "Amplitude spectrum (paper Fig. 7)".into(),
            caption: "Single-sided amplitude of each component of the raw trajectory, over its longest stretch without gaps. The motion lives in the first few hertz; above it, the flat floor is the measurement noise that the low-pass filter removes.".into(),
            png: png_bytes(&super::spectrum::spectrum_panels(&spectra))?,
        });
    }
    let study = super::smoothing_study::Args {
        out: dir.join("smoothing-study"),
        seed: 1,
        noise_mm: 1.0,
    };
    super::smoothing_study::write_study(&study)?;
    figures.push(Figure {
        title: "The paper's smoothing comparison (Figs. 4-6, 8)".into(),
        caption: "A sum of sinusoids plus white noise, and the noise alone, through each method: the cubic spline keeps all the noise, the Bezier curve removes it but flattens the motion, the least-squares B-spline and the low-pass filter keep the motion and remove most of the noise. Numbers in smoothing-study/study.csv.".into(),
        png: std::fs::read(study.out.join("study.png")).context("reading the smoothing study's figure")?,
    });
    figures.push(paths(&raw, smoothed.as_ref(), base_from_wobj.as_ref())?);
    if let Some(truth) = &truth {
        figures.push(tip_errors(truth, &raw, smoothed.as_ref())?);
    }
    if let (Some(rig), Some(tool)) = (&rig, &tool) {
        if let Some(figure) = uncertainty(rig, tool, &raw)? {
            figures.push(figure);
        }
        if let Some(figure) = camera_views(&recording, rig, tool)? {
            figures.push(figure);
        }
    }
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| dir.join("report.html"));
    teachcam::io::write_atomically(&output, html(&figures, run_json.as_ref()).as_bytes())?;
    Ok(output)
}

/// Reads a file when it exists; a file that exists but is wrong is an error.
fn optional<T, E: Into<anyhow::Error>>(
    path: &Path,
    read: impl Fn(&Path) -> Result<T, E>,
) -> Result<Option<T>> {
    if path.exists() {
        read(path).map(Some).rejected()
    } else {
        Ok(None)
    }
}

/// Times and values of one component over the frames that have a pose.
fn series_of(
    trajectory: &Trajectory,
    value: impl Fn(&teachcam::trajectory::ToolPose) -> f64,
) -> (Vec<f64>, Vec<f64>) {
    trajectory
        .samples
        .iter()
        .filter_map(|s| Some((s.time_s, value(s.pose.as_ref()?))))
        .unzip()
}

fn components(
    raw: &Trajectory,
    smoothed: Option<&Trajectory>,
    truth: Option<&Trajectory>,
) -> Result<Figure> {
    type Component = (
        &'static str,
        &'static str,
        fn(&teachcam::trajectory::ToolPose) -> f64,
    );
    let list: [Component; 6] = [
        ("tip x", "mm", |p| p.tip_in_world.x),
        ("tip y", "mm", |p| p.tip_in_world.y),
        ("tip z", "mm", |p| p.tip_in_world.z),
        ("roll (about world x)", "deg", |p| {
            p.world_from_tool.rotation.euler_angles().0.to_degrees()
        }),
        ("pitch (about world y)", "deg", |p| {
            p.world_from_tool.rotation.euler_angles().1.to_degrees()
        }),
        ("yaw (about world z)", "deg", |p| {
            p.world_from_tool.rotation.euler_angles().2.to_degrees()
        }),
    ];
    let data: Vec<Vec<Line>> = list
        .iter()
        .map(|(_, _, f)| {
            let mut lines = vec![("raw".to_string(), series_of(raw, f))];
            if let Some(s) = smoothed {
                lines.push(("smoothed".into(), series_of(s, f)));
            }
            if let Some(t) = truth {
                lines.push(("truth".into(), series_of(t, f)));
            }
            lines
        })
        .collect();
    let panels: Vec<Panel> = list
        .iter()
        .zip(&data)
        .map(|((name, unit, _), lines)| Panel {
            title: (*name).to_string(),
            x_label: "time (s)".into(),
            y_label: format!("{name} ({unit})"),
            y_scale: YScale::Linear,
            series: series(lines),
        })
        .collect();
    Ok(Figure {
        title: "Trajectory components (paper Figs. 3 and 8)".into(),
        caption: "The tool tip's position and the tool's orientation (XYZ Euler angles) over time: raw from tracking, after smoothing, and the simulator's truth.".into(),
        png: png_bytes(&panels)?,
    })
}

fn circle(center_x: f64, center_y: f64, radius: f64) -> (Vec<f64>, Vec<f64>) {
    (0..=180)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 180.0;
            (center_x + radius * a.cos(), center_y + radius * a.sin())
        })
        .unzip()
}

fn paths(
    raw: &Trajectory,
    smoothed: Option<&Trajectory>,
    base_from_wobj: Option<&Pose>,
) -> Result<Figure> {
    let tip = |t: &Trajectory, axis: usize| -> Vec<f64> {
        t.samples
            .iter()
            .filter_map(|s| s.pose.map(|p| p.tip_in_world[axis]))
            .collect()
    };
    let views = [
        ("top view", 0, 1),
        ("front view", 0, 2),
        ("side view", 1, 2),
    ];
    let names = ["x", "y", "z"];
    let axes: Vec<[Vec<f64>; 3]> = std::iter::once(raw)
        .chain(smoothed)
        .map(|t| [tip(t, 0), tip(t, 1), tip(t, 2)])
        .collect();
    let labels = ["raw tip path", "smoothed tip path"];
    let mut panels: Vec<Panel> = views
        .iter()
        .map(|(title, h, v)| Panel {
            title: format!(
                "{title}: tip {} against {} (work-object frame)",
                names[*v], names[*h]
            ),
            x_label: format!("{} (mm)", names[*h]),
            y_label: format!("{} (mm)", names[*v]),
            y_scale: YScale::Linear,
            series: axes
                .iter()
                .zip(labels)
                .map(|(a, label)| Series {
                    label: label.into(),
                    x: &a[*h],
                    y: &a[*v],
                })
                .collect(),
        })
        .collect();
    // The path on the robot, seen from above in its base frame, with the reach of the wrist
    // centre around axis 1.
    let in_base: Option<(Vec<f64>, Vec<f64>)> = base_from_wobj.map(|b| {
        smoothed
            .unwrap_or(raw)
            .samples
            .iter()
            .filter_map(|s| s.pose.map(|p| b * p.tip_in_world))
            .map(|p| (p.x, p.y))
            .unzip()
    });
    let reach = circle(0.0, 0.0, IRB120_REACH_MM);
    let base = (
        vec![-20.0, 20.0, 0.0, 0.0, 0.0],
        vec![0.0, 0.0, 0.0, -20.0, 20.0],
    );
    if let Some((x, y)) = &in_base {
        panels.push(Panel {
            title: "the stroke on the robot: top view in the IRB 120's base frame".into(),
            x_label: "x, base frame (mm)".into(),
            y_label: "y, base frame (mm)".into(),
            y_scale: YScale::Linear,
            series: vec![
                Series {
                    label: "tip path".into(),
                    x,
                    y,
                },
                Series {
                    label: format!("reach of the wrist centre ({IRB120_REACH_MM} mm, data sheet)"),
                    x: &reach.0,
                    y: &reach.1,
                },
                Series {
                    label: "robot base (axis 1)".into(),
                    x: &base.0,
                    y: &base.1,
                },
            ],
        });
    }
    Ok(Figure {
        title: "The tip's path".into(),
        caption: "The brush tip in the work-object frame seen from above, the front and the side; then, where the work object's placement is known, the path on the robot seen from above with the IRB 120's reach.".into(),
        png: png_bytes(&panels)?,
    })
}

fn tip_errors(
    truth: &Trajectory,
    raw: &Trajectory,
    smoothed: Option<&Trajectory>,
) -> Result<Figure> {
    let errors = |m: &Trajectory| -> (Vec<f64>, Vec<f64>) {
        truth
            .samples
            .iter()
            .zip(&m.samples)
            .filter_map(|(t, s)| {
                Some((
                    t.time_s,
                    (t.pose?.tip_in_world - s.pose?.tip_in_world).norm(),
                ))
            })
            .unzip()
    };
    let mut lines = vec![("raw".to_string(), errors(raw))];
    if let Some(s) = smoothed {
        lines.push(("smoothed".into(), errors(s)));
    }
    let predicted: (Vec<f64>, Vec<f64>) = raw
        .samples
        .iter()
        .filter_map(|s| Some((s.time_s, s.tip_std_mm?)))
        .unzip();
    if !predicted.0.is_empty() {
        lines.push(("predicted tip std (tip_std_mm)".into(), predicted));
    }
    let panel = Panel {
        title: "tip error against the simulator's truth".into(),
        x_label: "time (s)".into(),
        y_label: "tip error (mm)".into(),
        y_scale: YScale::Linear,
        series: series(&lines),
    };
    Ok(Figure {
        title: "Tip error over time".into(),
        caption: "Distance between the measured and the true tool tip in every frame, and the per-frame first-order uncertainty that `track` writes (from the blobs' predicted centre noise).".into(),
        png: png_bytes(&[panel])?,
    })
}

fn uncertainty(rig: &Rig, tool: &Tool, raw: &Trajectory) -> Result<Option<Figure>> {
    let poses: Vec<Pose> = raw
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| p.world_from_tool))
        .collect();
    let Some(middle) = poses.get(poses.len() / 2) else {
        return Ok(None);
    };
    let noise_px = 0.15;
    let xs: Vec<f64> = (-12..=12).map(|i| f64::from(i) * 25.0).collect();
    let rows = [-200.0, -100.0, 0.0, 100.0, 200.0];
    let centre = middle.translation.vector;
    let mut lines: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    for dy in rows {
        let positions: Vec<Point3> = xs
            .iter()
            .map(|dx| Point3::new(centre.x + dx, centre.y + dy, centre.z))
            .collect();
        let cells = uncertainty_map(rig, tool, &middle.rotation, &positions, noise_px);
        let (x, y): (Vec<f64>, Vec<f64>) = cells
            .iter()
            .filter_map(|c| Some((c.position[0], c.tip_rms_mm?)))
            .unzip();
        lines.push((format!("all cameras, y = {:.0} mm", centre.y + dy), x, y));
        if dy == 0.0 {
            let (x, y): (Vec<f64>, Vec<f64>) = cells
                .iter()
                .filter_map(|c| Some((c.position[0], c.tip_rms_one_camera_dropped_mm?)))
                .unzip();
            lines.push((
                format!("worst camera dropped, y = {:.0} mm", centre.y),
                x,
                y,
            ));
        }
    }
    let panel = Panel {
        title: format!(
            "first-order tip RMS at {noise_px} px marker noise, tool at the stroke's middle orientation, z = {:.0} mm",
            centre.z
        ),
        x_label: "x of the tool origin (mm)".into(),
        y_label: "tip RMS uncertainty (mm)".into(),
        y_scale: YScale::Linear,
        series: lines
            .iter()
            .map(|(label, x, y)| Series {
                label: label.clone(),
                x,
                y,
            })
            .collect(),
    };
    Ok(Some(Figure {
        title: "Uncertainty over the working volume".into(),
        caption: "Where to work: the tip uncertainty the rig gives at the paper's 0.15 px across the working area, with all cameras and with the most useful camera missing (the paper asks that the rig work with one camera out). Lines end where the tool leaves the views.".into(),
        png: png_bytes(&[panel])?,
    }))
}

fn camera_views(recording: &Path, rig: &Rig, tool: &Tool) -> Result<Option<Figure>> {
    // The first frame of each camera, PNG or video; a folder that cannot be read has no figure.
    let Ok(mut source) = FolderSource::open(recording, None) else {
        return Ok(None);
    };
    let Some(first) = source.next_set().transpose().rejected()? else {
        return Ok(None);
    };
    const SCALE: u32 = 3;
    let mut tiles: Vec<RgbImage> = Vec::new();
    for camera in &rig.cameras {
        let Some(frame) = source
            .cameras()
            .iter()
            .position(|c| c.name == camera.name)
            .and_then(|c| first.cameras.get(c)?.as_ref())
        else {
            continue;
        };
        let decoded = frame.decode(&camera.name, None).rejected()?;
        let GrayFrame::Eight(image) = decoded.as_ref() else {
            continue;
        };
        let blobs = detect(
            image,
            &DetectConfig::for_marker(camera, tool.marker_diameter_mm, 300.0, 3000.0),
        )?;
        if blobs.is_empty() {
            continue;
        }
        let margin = 30.0;
        let x0 = (blobs
            .iter()
            .map(|b| b.center.x)
            .fold(f64::INFINITY, f64::min)
            - margin)
            .max(0.0) as u32;
        let y0 = (blobs
            .iter()
            .map(|b| b.center.y)
            .fold(f64::INFINITY, f64::min)
            - margin)
            .max(0.0) as u32;
        let x1 = (blobs.iter().map(|b| b.center.x).fold(0.0, f64::max) + margin)
            .min(f64::from(image.width() - 1)) as u32;
        let y1 = (blobs.iter().map(|b| b.center.y).fold(0.0, f64::max) + margin)
            .min(f64::from(image.height() - 1)) as u32;
        let mut tile = RgbImage::from_fn((x1 - x0 + 1) * SCALE, (y1 - y0 + 1) * SCALE, |x, y| {
            let v = image.get_pixel(x0 + x / SCALE, y0 + y / SCALE).0[0];
            Rgb([v, v, v])
        });
        for b in &blobs {
            let cx = (b.center.x - f64::from(x0) + 0.5) * f64::from(SCALE);
            let cy = (b.center.y - f64::from(y0) + 0.5) * f64::from(SCALE);
            let r = (b.radius_px + 2.0) * f64::from(SCALE);
            for k in 0..360 {
                let a = f64::from(k).to_radians();
                put(
                    &mut tile,
                    cx + r * a.cos(),
                    cy + r * a.sin(),
                    Rgb([255, 40, 40]),
                );
            }
            for d in -4..=4 {
                put(&mut tile, cx + f64::from(d), cy, Rgb([255, 40, 40]));
                put(&mut tile, cx, cy + f64::from(d), Rgb([255, 40, 40]));
            }
        }
        tiles.push(tile);
    }
    if tiles.is_empty() {
        return Ok(None);
    }
    let width = tiles.iter().map(RgbImage::width).sum::<u32>() + 10 * (tiles.len() as u32 - 1);
    let height = tiles.iter().map(RgbImage::height).max().unwrap_or(1);
    let mut sheet = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let mut x = 0;
    for tile in &tiles {
        image::imageops::replace(&mut sheet, tile, i64::from(x), 0);
        x += tile.width() + 10;
    }
    let mut png = std::io::Cursor::new(Vec::new());
    sheet.write_to(&mut png, image::ImageFormat::Png)?;
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    Ok(Some(Figure {
        title: "What the cameras see".into(),
        caption: format!(
            "The first frame of each camera ({}, left to right), cropped around the markers and enlarged {SCALE}x, with the detected blobs circled and their sub-pixel centres marked.",
            names.join(", ")
        ),
        png: png.into_inner(),
    }))
}

fn put(image: &mut RgbImage, x: f64, y: f64, color: Rgb<u8>) {
    if x >= 0.0 && y >= 0.0 && (x as u32) < image.width() && (y as u32) < image.height() {
        image.put_pixel(x as u32, y as u32, color);
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn html(figures: &[Figure], run: Option<&serde_json::Value>) -> String {
    let mut page = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>teachcam report</title>\n<style>body{font-family:sans-serif;max-width:1040px;margin:2em auto;color:#222}img{max-width:100%;border:1px solid #ddd}table{border-collapse:collapse}td,th{padding:2px 10px;border-bottom:1px solid #eee;text-align:left}figcaption{color:#555;margin:.4em 0 2em}</style></head><body>\n<h1>teachcam report</h1>\n",
    );
    if let Some(summary) = run
        .and_then(|r| r.get("summary"))
        .and_then(|s| s.as_object())
    {
        page.push_str("<h2>Summary</h2><table>\n");
        for (key, value) in summary {
            let shown = match value {
                serde_json::Value::Number(n) => n
                    .as_f64()
                    .map_or_else(|| n.to_string(), |v| format!("{v:.4}")),
                other => other.to_string(),
            };
            let _ = writeln!(
                page,
                "<tr><th>{}</th><td>{}</td></tr>",
                escape(&key.replace('_', " ")),
                escape(&shown)
            );
        }
        page.push_str("</table>\n");
    }
    let engine = base64::engine::general_purpose::STANDARD;
    for figure in figures {
        let _ = writeln!(
            page,
            "<h2>{}</h2>\n<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>",
            escape(&figure.title),
            escape(&figure.title),
            engine.encode(&figure.png),
            escape(&figure.caption)
        );
    }
    page.push_str("</body></html>\n");
    page
}
