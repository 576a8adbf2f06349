//! `teachcam repeatability`: the paper's blob repeatability study (§IV-A, Fig. 10).

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::flags::detection::{DetectorFlags, configs};
use crate::recording::detect_folder;
use teachcam::detect::{MarkerSpread, RepeatabilityConfig, repeatability};
use teachcam::pipeline::recording::DetectedRecording;

/// Repeatability of blob centres of static markers (the paper's Fig. 10).
///
/// Every frame of a recording of markers at rest (e.g. `teachcam simulate --scenario static`)
/// is searched, each marker's centre is followed over the frames, and the standard deviation
/// of the centre is reported against the blob's area, per camera. The paper found 0.15 px with
/// its smallest-circle centre.
///
/// Output columns: `camera,x_px,y_px,area_px,frames,std_x_px,std_y_px,std_px,predicted_std_px`
/// (`std_px` per axis, `predicted_std_px` from the background noise and `--shot-noise`). `--plot` draws `std_px`
/// against `area_px` as SVG.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam repeatability static -o repeatability.csv --plot repeatability.svg
  teachcam repeatability static -o circle.csv --method smallest-circle"#)]
pub struct Args {
    /// Recording folder of static markers: one sub-folder of PNG frames per camera.
    pub recording: PathBuf,
    /// Output CSV file (written whole or not at all).
    #[arg(short, long)]
    pub output: PathBuf,
    /// SVG plot of the standard deviation against blob area.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// A blob belongs to a marker whose mean centre is at most this far, pixels.
    #[arg(long, default_value_t = 1.0, value_parser = crate::flags::positive)]
    pub match_radius: f64,
    /// Markers found in fewer frames are left out.
    #[arg(long, default_value_t = 10, value_parser = crate::flags::count)]
    pub min_frames: usize,
    /// Detector options.
    #[command(flatten)]
    pub options: DetectorFlags,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if !(args.match_radius.is_finite() && args.match_radius > 0.0) {
        return Err(anyhow::anyhow!(
            "--match-radius must be a positive number of pixels, got {}",
            args.match_radius
        ));
    }
    let mut outputs = vec![teachcam::io::Output::csv(&args.output)];
    if let Some(plot) = &args.plot {
        outputs.push(teachcam::io::Output {
            path: plot,
            format: "an SVG plot",
            extensions: &["svg"],
        });
    }
    teachcam::io::check_outputs(&outputs, &[])?;
    let recording: DetectedRecording = detect_folder(&args.recording, None, |cameras| {
        configs(&args.options, cameras)
    })?;
    let study = RepeatabilityConfig {
        match_radius_px: args.match_radius,
        min_frames: args.min_frames,
    };
    let per_camera: Vec<(String, Vec<MarkerSpread>)> = recording
        .cameras
        .iter()
        .enumerate()
        .map(|(c, camera)| {
            let blobs: Vec<Vec<_>> = recording
                .sets
                .iter()
                .filter_map(|set| set.cameras.get(c)?.as_ref())
                .map(|frame| frame.blobs.clone())
                .collect();
            (camera.clone(), repeatability(&blobs, &study))
        })
        .collect();
    let mut text =
        String::from("camera,x_px,y_px,area_px,frames,std_x_px,std_y_px,std_px,predicted_std_px\n");
    for (camera, spreads) in &per_camera {
        for s in spreads {
            let _ = writeln!(
                text,
                "{camera},{:.4},{:.4},{:.2},{},{:.5},{:.5},{:.5},{:.5}",
                s.mean_center.x,
                s.mean_center.y,
                s.mean_area_px,
                s.frames,
                s.std_x_px,
                s.std_y_px,
                s.std_px,
                s.predicted_std_px
            );
        }
    }
    let outputs = teachcam::io::OutputSet::new();
    outputs.add(&args.output, text.as_bytes())?;
    if let Some(plot) = &args.plot {
        outputs.add(plot, svg_plot(&per_camera, &args.options).as_bytes())?;
    }
    let written = outputs.commit()?;
    let markers: usize = per_camera.iter().map(|(_, s)| s.len()).sum();
    let all: Vec<f64> = per_camera
        .iter()
        .flat_map(|(_, s)| s.iter().map(|m| m.std_px))
        .collect();
    let rms = (all.iter().map(|v| v * v).sum::<f64>() / all.len().max(1) as f64).sqrt();
    crate::announce::wrote(
        &written,
        &format!(
            "{markers} static markers, centre std {rms:.4} px (rms over markers, method {})",
            args.options.method
        ),
    );
    Ok(())
}

/// A scatter plot of `std_px` (measured, filled; predicted, hollow) against `area_px`, one
/// colour per camera, as a standalone SVG.
fn svg_plot(per_camera: &[(String, Vec<MarkerSpread>)], options: &DetectorFlags) -> String {
    const W: f64 = 640.0;
    const H: f64 = 420.0;
    const LEFT: f64 = 70.0;
    const RIGHT: f64 = 150.0;
    const TOP: f64 = 40.0;
    const BOTTOM: f64 = 50.0;
    const COLOURS: [&str; 6] = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
    ];
    let points = per_camera.iter().flat_map(|(_, s)| s.iter());
    let (mut max_area, mut max_std) = (1.0f64, 1e-3f64);
    for s in points {
        max_area = max_area.max(s.mean_area_px);
        max_std = max_std.max(s.std_px).max(s.predicted_std_px);
    }
    let (area_top, area_step) = nice_axis(max_area);
    let (std_top, std_step) = nice_axis(max_std);
    let x = |a: f64| LEFT + (W - LEFT - RIGHT) * a / area_top;
    let y = |s: f64| H - BOTTOM - (H - TOP - BOTTOM) * s / std_top;
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">Blob centre repeatability ({} centre)</text>\n",
        (W - RIGHT + LEFT) / 2.0,
        options.method
    );
    // Axes, ticks and grid.
    let _ = writeln!(
        svg,
        "<path d=\"M{LEFT},{TOP} V{} H{}\" stroke=\"black\" fill=\"none\"/>",
        H - BOTTOM,
        W - RIGHT
    );
    let mut a = 0.0;
    while a <= area_top + 1e-9 {
        let _ = writeln!(
            svg,
            "<line x1=\"{0:.1}\" y1=\"{1}\" x2=\"{0:.1}\" y2=\"{2}\" stroke=\"#ddd\"/><text x=\"{0:.1}\" y=\"{3}\" text-anchor=\"middle\">{a}</text>",
            x(a),
            TOP,
            H - BOTTOM,
            H - BOTTOM + 16.0
        );
        a += area_step;
    }
    let mut s = 0.0;
    while s <= std_top + 1e-12 {
        let _ = writeln!(
            svg,
            "<line x1=\"{LEFT}\" y1=\"{0:.1}\" x2=\"{1}\" y2=\"{0:.1}\" stroke=\"#ddd\"/><text x=\"{2}\" y=\"{3:.1}\" text-anchor=\"end\">{s:.3}</text>",
            y(s),
            W - RIGHT,
            LEFT - 6.0,
            y(s) + 4.0
        );
        s += std_step;
    }
    let _ = writeln!(
        svg,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">blob area (pixels)</text>\n<text transform=\"translate(18,{}) rotate(-90)\" text-anchor=\"middle\">centre std per axis (px)</text>",
        (W - RIGHT + LEFT) / 2.0,
        H - 12.0,
        (H - BOTTOM + TOP) / 2.0
    );
    for (k, (camera, spreads)) in per_camera.iter().enumerate() {
        let colour = COLOURS[k % COLOURS.len()];
        for m in spreads {
            let _ = writeln!(
                svg,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"{colour}\"/><circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"none\" stroke=\"{colour}\"/>",
                x(m.mean_area_px),
                y(m.std_px),
                x(m.mean_area_px),
                y(m.predicted_std_px)
            );
        }
        let ly = TOP + 20.0 + 18.0 * k as f64;
        let _ = writeln!(
            svg,
            "<circle cx=\"{}\" cy=\"{ly}\" r=\"4\" fill=\"{colour}\"/><text x=\"{}\" y=\"{}\">{}</text>",
            W - RIGHT + 16.0,
            W - RIGHT + 26.0,
            ly + 4.0,
            xml_text(camera)
        );
    }
    let ly = TOP + 20.0 + 18.0 * per_camera.len() as f64;
    let _ = writeln!(
        svg,
        "<text x=\"{}\" y=\"{}\" font-size=\"10\">filled: measured</text><text x=\"{}\" y=\"{}\" font-size=\"10\">hollow: predicted</text>\n</svg>",
        W - RIGHT + 10.0,
        ly + 4.0,
        W - RIGHT + 10.0,
        ly + 18.0
    );
    svg
}

/// An axis end at or above `max` and a tick step, both 1, 2 or 5 times a power of ten.
fn nice_axis(max: f64) -> (f64, f64) {
    let raw = max / 5.0;
    let power = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power);
    ((max / step).ceil() * step, step)
}

/// Text escaped for XML.
fn xml_text(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
