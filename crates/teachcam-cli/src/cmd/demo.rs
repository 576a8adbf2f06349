//! `teachcam demo`: the paper's setup, simulated, through the whole pipeline.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use teachcam::io::trajectory::{read_trajectory, write_trajectory};
use teachcam::metrology::{first_order, monte_carlo};
use teachcam::pipeline::batch::{TrackFiles, TrackInput, TrackOptions, track};
use teachcam::sim::{Scenario, build_scene, write_scene};
use teachcam::smooth::{SmoothConfig, smooth};
use teachcam::track::TrackConfig;
use teachcam::trajectory::Trajectory;

use super::check::CellArgs;
use crate::progress::Progress;

/// Where the demo places the work object in the IRB 120's base frame: 350 mm in front of the
/// robot, 100 mm above its base (RAPID's `uframe`).
const DEMO_WOBJ: &str = "350,0,100,1,0,0,0";
/// How the brush is mounted: the tip 200 mm out along the flange's z axis, the brush turned
/// half a turn about x so that its handle points back to the flange (RAPID's `tframe`).
const DEMO_TCP: &str = "0,0,200,0,1,0,0";
/// The paper's camera repeatability (§IV-A), pixels.
const PAPER_PIXEL_NOISE: f64 = 0.15;
/// The paper's Monte Carlo result for its rig (§V-C), millimetres.
const PAPER_TIP_UNCERTAINTY_MM: f64 = 0.26;

/// Run the whole pipeline on a simulation of the paper's setup.
///
/// Simulates a painter's stroke seen by the paper's three-camera rig (1280x1024, 12 mm lenses,
/// 1 m away, a four-sphere brush, 4 s at 30 Hz), then run the whole pipeline on the rendered
/// images: detection, tracking, smoothing (low-pass 10 Hz, the paper's choice), the Monte Carlo
/// uncertainty study, the IRB 120 check and the RAPID export. Prints the accuracy against the
/// simulator's ground truth and the time of each stage; writes every file and an HTML report
/// into the output folder.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam demo"#)]
pub struct Args {
    /// Folder for the recording, trajectories, robot program and report (created).
    #[arg(long, default_value = "teachcam-demo")]
    pub out: PathBuf,
    /// Seed of the simulated image noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the summary as JSON on stdout instead of text (also with the global `--quiet`).
    #[arg(long)]
    pub json: bool,
}

/// The demo's numbers.
#[derive(Debug, Serialize)]
struct Summary {
    frames: usize,
    cameras: usize,
    frames_tracked: usize,
    raw_tip_error_rms_mm: f64,
    raw_tip_error_max_mm: f64,
    /// RMS over the tracked frames of each frame's own predicted tip uncertainty.
    predicted_tip_std_rms_mm: f64,
    smoothed_tip_error_rms_mm: Option<f64>,
    monte_carlo_tip_rms_mm: f64,
    first_order_tip_rms_mm: f64,
    paper_tip_uncertainty_mm: f64,
    pixel_noise_px: f64,
    robot_check_passed: bool,
    robot_peak_speed_fraction: f64,
    rapid_moves: usize,
    stage_seconds: Vec<(String, f64)>,
    files: Vec<String>,
}

/// RMS and largest tip distance between two trajectories, over frames where both have a pose.
fn tip_errors(truth: &Trajectory, measured: &Trajectory) -> (f64, f64, usize) {
    let errors: Vec<f64> = truth
        .samples
        .iter()
        .zip(&measured.samples)
        .filter_map(|(t, m)| Some((t.pose?.tip_in_world - m.pose?.tip_in_world).norm()))
        .collect();
    (
        teachcam::stats::rms(&errors),
        errors.iter().copied().fold(0.0, f64::max),
        errors.len(),
    )
}

/// Run the demo.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let out = &args.out;
    let mut stages: Vec<(String, f64)> = Vec::new();
    let mut timed =
        |name: &str, start: Instant| stages.push((name.to_string(), start.elapsed().as_secs_f64()));

    // 1. Simulate the paper's setup.
    let start = Instant::now();
    let scene = build_scene(Scenario::Paper, args.seed);
    let recording = out.join("recording");
    let progress = Progress::new("simulate", scene.truth.len() as u64);
    write_scene(&scene, &recording, args.seed, &|| progress.tick())
        .with_context(|| format!("writing {}", recording.display()))?;
    progress.finish();
    timed("simulate", start);

    // 2. Detect and track on the images.
    let start = Instant::now();
    let raw_path = out.join("raw.csv");
    // Tracked from the files written, as `track` would be.
    let rig = crate::load::rig(&recording.join("rig.json"))?;
    let tool = crate::load::tool(&recording.join("tool.json"))?;
    let run = track(
        TrackInput::Recording(&recording),
        &rig,
        &tool,
        &TrackOptions::default(),
        &|| {},
    )
    .map_err(|e| crate::recording::pipeline_error(e, &recording.join("tool.json")))?;
    run.write(
        &rig,
        &TrackFiles {
            trajectory: &raw_path,
            markers: Some(&out.join("markers.csv")),
            diagnostics: Some(&out.join("diagnostics.csv")),
            gates: Some(&out.join("diagnostics.gates.json")),
            time_offsets: None,
        },
    )?;
    timed("detect + track", start);
    let raw = read_trajectory(&raw_path)?;
    let (raw_rms, raw_max, tracked) = tip_errors(&scene.truth, &raw);
    let predicted: Vec<f64> = raw.samples.iter().filter_map(|s| s.tip_std_mm).collect();
    let predicted_rms = teachcam::stats::rms(&predicted);

    // 3. Smooth: zero-phase low-pass at 10 Hz, the paper's choice for painting.
    let start = Instant::now();
    let smoothed = smooth(&raw, &SmoothConfig::default())?;
    let smoothed_path = out.join("smoothed.csv");
    write_trajectory(&smoothed_path, &smoothed)?;
    let (smoothed_rms, _, _) = tip_errors(&scene.truth, &smoothed);
    timed("smooth (low-pass 10 Hz)", start);

    // 4. Uncertainty at the paper's pixel noise, at the middle of the stroke.
    let start = Instant::now();
    let middle = scene.truth.samples[scene.truth.len() / 2]
        .pose
        .map(|p| p.world_from_tool)
        .context("the simulated stroke has a pose in its middle frame")?;
    let mc = monte_carlo(
        &scene.rig,
        &scene.tool,
        &middle,
        PAPER_PIXEL_NOISE,
        10_000,
        args.seed,
        &TrackConfig::default(),
    )?;
    let fo = first_order(&scene.rig, &scene.tool, &middle, PAPER_PIXEL_NOISE)?;
    timed("uncertainty (10,000 trials)", start);

    // 5. Robot: check on the IRB 120, then the RAPID program of the smoothed trajectory.
    let start = Instant::now();
    let cell = CellArgs {
        robot: Some("irb120".into()),
        wobj: DEMO_WOBJ.into(),
        tcp: DEMO_TCP.into(),
        tool: None,
        speed_fraction: teachcam::robot::check::DEFAULT_SPEED_FRACTION,
        max_acceleration_deg_s2: None,
        time_scale: teachcam::robot::check::TimeScale::Auto,
        keep_outliers: false,
        free_tool_axis: false,
    };
    let rapid_path = out.join("stroke.mod");
    let written = super::export::write_program(&super::export::Args {
        dialect: super::export::Dialect::Rapid,
        trajectory: smoothed_path.clone(),
        cell,
        gaps: super::check::GapArgs {
            bridge_gaps: false,
            max_gap_s: None,
        },
        strokes: super::check::StrokeArgs::default(),
        output: rapid_path.clone(),
        tolerance_mm: 0.5,
        tolerance_deg: 0.5,
        approach: 50.0,
        home: None,
        name: Some("teachcam_demo".into()),
        tool_mass: None,
        tool_cog: None,
        force: false,
        rig: None,
        frame_id: None,
    })?;
    timed("robot check + RAPID", start);

    let summary = Summary {
        frames: scene.truth.len(),
        cameras: scene.rig.len(),
        frames_tracked: tracked,
        raw_tip_error_rms_mm: raw_rms,
        raw_tip_error_max_mm: raw_max,
        predicted_tip_std_rms_mm: predicted_rms,
        smoothed_tip_error_rms_mm: Some(smoothed_rms),
        monte_carlo_tip_rms_mm: mc.uncertainty.tip_rms_mm,
        first_order_tip_rms_mm: fo.tip_rms_mm,
        paper_tip_uncertainty_mm: PAPER_TIP_UNCERTAINTY_MM,
        pixel_noise_px: PAPER_PIXEL_NOISE,
        robot_check_passed: written.report.passes(),
        robot_peak_speed_fraction: written.report.peak_speed_ratio,
        rapid_moves: written.moves,
        stage_seconds: stages,
        files: [
            &recording,
            &raw_path,
            &out.join("markers.csv"),
            &out.join("diagnostics.csv"),
            &out.join("diagnostics.gates.json"),
            &smoothed_path,
            &rapid_path,
            &out.join("run.json"),
            &out.join("report.html"),
        ]
        .iter()
        .map(|p| p.display().to_string())
        .collect(),
    };
    let run_json = serde_json::json!({ "robot": "irb120", "wobj": DEMO_WOBJ, "tcp": DEMO_TCP, "summary": summary });
    teachcam::io::write_atomically(
        &out.join("run.json"),
        serde_json::to_string_pretty(&run_json)?.as_bytes(),
    )?;

    // 6. The report.
    let start = Instant::now();
    super::report::write_report(&super::report::Args::of(out.clone()))?;
    let mut summary = summary;
    summary
        .stage_seconds
        .push(("report".into(), start.elapsed().as_secs_f64()));
    print_summary(&summary, args)?;
    Ok(())
}

#[expect(clippy::print_stdout, reason = "the summary is the command's output")]
fn print_summary(s: &Summary, args: &Args) -> anyhow::Result<()> {
    if args.json {
        println!("{}", serde_json::to_string_pretty(s)?);
        return Ok(());
    }
    if crate::announce::quiet() {
        return Ok(());
    }
    println!(
        "teachcam demo: the paper's rig ({} cameras, 1280x1024, 12 mm lenses, 1 m) filming a painter's stroke",
        s.cameras
    );
    println!(
        "  tracked       {} of {} frames from the rendered images",
        s.frames_tracked, s.frames
    );
    println!(
        "  tip error     raw {:.3} mm RMS, {:.3} mm max (against the simulator's truth)",
        s.raw_tip_error_rms_mm, s.raw_tip_error_max_mm
    );
    if let Some(smoothed) = s.smoothed_tip_error_rms_mm {
        println!("                low-pass 10 Hz {smoothed:.3} mm RMS");
    }
    println!(
        "                each frame's own tip_std_mm predicted {:.3} mm RMS",
        s.predicted_tip_std_rms_mm
    );
    println!(
        "  uncertainty   tip {:.3} mm RMS at {} px (Monte Carlo, 10,000 trials; first order {:.3} mm); the paper: {} mm",
        s.monte_carlo_tip_rms_mm,
        s.pixel_noise_px,
        s.first_order_tip_rms_mm,
        s.paper_tip_uncertainty_mm
    );
    println!(
        "  robot         IRB 120 check {} (peak joint speed {:.0} % of the limit); RAPID: {} moves",
        if s.robot_check_passed {
            "passed"
        } else {
            "FAILED"
        },
        100.0 * s.robot_peak_speed_fraction,
        s.rapid_moves
    );
    for (stage, seconds) in &s.stage_seconds {
        println!("  time          {stage:<28} {seconds:>6.2} s");
    }
    for file in &s.files {
        println!("  wrote         {file}");
    }
    Ok(())
}
