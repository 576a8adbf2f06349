//! `teachcam simulate`: write a simulated recording with its ground truth.

use std::path::PathBuf;

use anyhow::Context;
use teachcam::sim::calibration::{
    IMAGES_PER_CAMERA_FOR_0_02_DEG, PlacementCount, calibration_scene_with, write_calibration,
};
use teachcam::sim::wand::{GROUND_FRAMES, WAND_FRAMES, write_wand_scenario};
use teachcam::sim::{Scenario, build_scene, write_scene};

use crate::progress::Progress;

/// Write a simulated recording with its ground truth.
///
/// Writes one folder per camera of 8-bit PNG frames, `recording.json`,
/// `rig.json`, `tool.json`, the true trajectory `truth.csv` and the exact projection of every
/// marker centre in every view `projections.csv`.
///
/// Scenarios: `paper` (the paper's three-camera rig and four-sphere brush, a 4 s painter's stroke
/// at 30 Hz), `static` (the brush at rest, 100 frames), `occluded` (markers hidden in some views,
/// glints, a glint touching a marker), `four-cameras`.
///
/// Real failure modes (issue 14): `stereo-ir` (a real stereo IR recording's twin: two 640x480
/// PS3 Eye cameras 2 m away, a hand-held 3-marker triangle at 50 Hz with motion blur, small
/// saturated blobs with bloom, JPEG quality 55, uneven light, glints, streaks, mirror images in a
/// steel plate, a hand partly hiding markers; 300 frames), `stereo-ir-miscal` (the same with
/// `rig.json` 0.4 deg off in cam1; the true rig in `rig_true.json`, the error in
/// `miscalibration.json`), `unsynced` (the paper's rig, cam1 +9.3 ms and cam2 -13.1 ms late, a
/// fast stroke; the offsets in `time_offsets.json`), `four-cameras-hard` (four cameras with
/// hidden and half-hidden markers, glints touching markers, streaks, the brush's mirror image
/// in the work object, markers whose images touch).
///
/// `calibration` and `four-cameras-calibration` write chessboard views for `teachcam calibrate
/// rig` instead: a 9x6 board with 50 mm squares lying on the work object (view `world`, the
/// world frame) and held in placements around the working volume (until every camera has
/// `--images-per-camera` images, or `--views` placements), as
/// `<camera>/<view>.png` (only views a camera sees whole), the true `rig.json`, `boards.json`
/// (each view's world_from_board), `corners.csv` (true corners) and `calibration.json`
/// (the world view, its offset from the simulator's world, the command to run).
///
/// `wand` writes a wand calibration: `wand/` (a 0/160/500 mm wand waved through the
/// four-camera rig, 400 frames at 60 Hz, 10 % of camera-frames with a marker hidden or a
/// glint), `ground/` (an L-frame lying still on the work object, 30 frames), `cameras.json`
/// (the true intrinsics, no extrinsics), `wand.json`, `lframe.json` and the true rig
/// `rig_true.json` (world = the L-frame's frame), for `teachcam calibrate wand`.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam simulate --scenario paper --out rec
  teachcam simulate --scenario static --frames 20 --out static
  teachcam simulate --scenario calibration --views 6 --out boards
  teachcam simulate --scenario wand --out dance"#)]
pub struct Args {
    /// Scenario name: paper, static, occluded, four-cameras, calibration,
    /// four-cameras-calibration, stereo-ir, stereo-ir-miscal, unsynced, four-cameras-hard or
    /// wand.
    #[arg(long, default_value = "paper")]
    pub scenario: String,
    /// Output folder (created; files in it are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the image noise and the random glints: the same seed gives the same files.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write only the first N frames of the scenario.
    #[arg(long, value_parser = crate::flags::count)]
    pub frames: Option<usize>,
    /// Calibration scenarios: board placements held around the working volume, besides the
    /// one on the work object (instead of `--images-per-camera`).
    #[arg(long, conflicts_with = "images_per_camera", value_parser = crate::flags::count)]
    pub views: Option<usize>,
    /// Calibration scenarios: hold the board until every camera has this many images. The
    /// default, 40, brings every camera's rotation σ to about 0.006° on the simulated rigs
    /// (3σ within 0.02°; about 63 placements for the paper's rig, 93 for four cameras).
    #[arg(long, default_value_t = IMAGES_PER_CAMERA_FOR_0_02_DEG, value_parser = crate::flags::count)]
    pub images_per_camera: usize,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let scenario = Scenario::from_name(&args.scenario).with_context(|| {
        let names: Vec<&str> = Scenario::ALL.iter().map(|s| s.name()).collect();
        format!(
            "unknown scenario '{}' (choose from {})",
            args.scenario,
            names.join(", ")
        )
    })?;
    if scenario == Scenario::Wand {
        let frames = args.frames.unwrap_or(WAND_FRAMES).min(WAND_FRAMES);
        if frames == 0 {
            anyhow::bail!("--frames must be at least 1");
        }
        let progress = Progress::new("simulate", (frames + GROUND_FRAMES) as u64);
        write_wand_scenario(&args.out, args.seed, Some(frames), &|| progress.tick())
            .with_context(|| format!("writing the simulation to {}", args.out.display()))?;
        progress.finish();
        eprintln!(
            "wrote a wand dance of {frames} frames and a ground frame of {GROUND_FRAMES} frames x 4 cameras to {} (wand/, ground/, cameras.json, wand.json, lframe.json, rig_true.json)",
            args.out.display()
        );
        return Ok(());
    }
    if scenario.is_calibration() {
        if args.frames.is_some() {
            anyhow::bail!(
                "--frames applies to recordings; scenario '{}' has --views",
                scenario.name()
            );
        }
        let count = args.views.map_or(
            PlacementCount::ImagesPerCamera(args.images_per_camera),
            PlacementCount::Held,
        );
        let scene = calibration_scene_with(scenario.rig(), count, args.seed);
        let progress = Progress::new("simulate", scene.placements.len() as u64);
        write_calibration(&scene, &args.out, args.seed, &|| progress.tick())
            .with_context(|| format!("writing the simulation to {}", args.out.display()))?;
        progress.finish();
        eprintln!(
            "wrote {} board views x {} cameras of scenario '{}' to {}",
            scene.placements.len(),
            scene.rig.len(),
            scenario.name(),
            args.out.display()
        );
        return Ok(());
    }
    let mut scene = build_scene(scenario, args.seed);
    if let Some(frames) = args.frames {
        if frames == 0 {
            anyhow::bail!("--frames must be at least 1");
        }
        scene.truth.samples.truncate(frames);
    }
    let progress = Progress::new("simulate", scene.truth.len() as u64);
    write_scene(&scene, &args.out, args.seed, &|| progress.tick())
        .with_context(|| format!("writing the simulation to {}", args.out.display()))?;
    progress.finish();
    eprintln!(
        "wrote {} frames x {} cameras of scenario '{}' to {}",
        scene.truth.len(),
        scene.rig.len(),
        scenario.name(),
        args.out.display()
    );
    Ok(())
}
