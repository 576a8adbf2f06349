//! `teachcam calibrate refine`: a rig's extrinsics refined from any recording of a tool, the
//! tool's marker geometry fixing the scale ([`teachcam::calib::refine`]).

use std::path::PathBuf;

use anyhow::{Context, anyhow};
use rayon::prelude::*;
use teachcam::calib::refine::{RefineConfig, Refinement, confident_views, refine_rig};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::io::rig::{CameraStdFile, write_rig_with_std};
use teachcam::io::{Output, check_outputs};
use teachcam::track::gates::{GateOverrides, measure_gates, sample_frames};
use teachcam::track::{FrameTrack, Tracker};

use crate::Rejected;
use crate::flags::detection::{DetectFlags, GateFlags};
use teachcam::pipeline::recording::{GATE_SAMPLE_FRAMES, detect_for_tracking};

/// Refine the rig's extrinsics from a recording of a tool (a bumped camera mended from the
/// footage itself).
///
/// Tracks the recording through the rig with the gates measured through it (in the first round,
/// when that leaves too few frames, again with the epipolar and triangulation gates widened to
/// 3x their ceilings: a camera bumped further loses most frames at the measured gates), takes the frames whose identification is confident (every marker identified in two
/// or more cameras, no rival labelling), and adjusts every camera's
/// extrinsics and every such frame's tool pose together, the tool's marker geometry exact
/// (it fixes the scale), intrinsics held as given; then tracks again through the moved rig, a
/// few rounds. The world stays where the rig has it: one camera is held fixed, the one that
/// agrees best with the others (or `--hold`); with two cameras, which one moved cannot be told
/// from the footage, and the first is held. Prints per camera what moved (centre mm, rotation
/// degrees) with its σ, and each camera pair's median epipolar distance before and after.
/// Writes the rig with each camera's σ (`centre_std_mm`, `rotation_std_deg`).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate refine rec --rig rec/rig.json --tool rec/tool.json -o refined.json"#)]
pub struct RefineArgs {
    /// The recording folder (as for `track`).
    pub recording: PathBuf,
    /// The rig to refine.
    #[arg(long)]
    pub rig: PathBuf,
    /// The tool seen in the recording.
    #[arg(long)]
    pub tool: PathBuf,
    /// Output rig file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Hold this camera fixed (default: the one that agrees best with the others).
    #[arg(long)]
    pub hold: Option<String>,
    /// Refine the extrinsics only (intrinsics held as given, the tool's shape exact).
    #[arg(long)]
    pub extrinsics_only: bool,
    /// Also write the tool with its marker geometry as refined (the input's scale).
    #[arg(long)]
    pub tool_out: Option<PathBuf>,
    /// Rounds of track → adjust at most (they stop earlier when nothing moves).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub rounds: u32,
    #[command(flatten)]
    pub detect: DetectFlags,
    #[command(flatten)]
    pub gates: GateFlags,
}

/// The first round's epipolar tolerance, pixels: 3x the measured gate's 5 px ceiling (a 0.4°
/// tilt moves image points ~4 px off the epipolar lines of a 650 px focal length, ~12 px at
/// 1800 px).
const WIDE_EPIPOLAR_PX: f64 = 15.0;

/// The first round's triangulation residual gate, pixels: 3x the measured gate's 4 px ceiling.
const WIDE_RESIDUAL_PX: f64 = 12.0;

/// Run `calibrate refine`.
pub fn run_refine(args: &RefineArgs) -> anyhow::Result<()> {
    let mut outputs = vec![Output {
        path: &args.output,
        format: "a rig file (JSON)",
        extensions: &["json"],
    }];
    if let Some(tool_out) = &args.tool_out {
        outputs.push(Output {
            path: tool_out,
            format: "a tool file (JSON)",
            extensions: &["json"],
        });
    }
    check_outputs(&outputs, &[&args.rig, &args.tool])?;
    let rig = crate::load::rig(&args.rig)?;
    let tool = crate::load::tool(&args.tool)?;
    if rig.len() < 2 {
        return Err(anyhow!(
            "{}: {} camera; refinement needs at least 2",
            args.rig.display(),
            rig.len()
        ))
        .rejected();
    }
    let hold = match &args.hold {
        None => None,
        Some(name) => Some(rig.id_of(name).ok_or_else(|| {
            anyhow!(
                "--hold {name}: no camera of that name in {} (cameras: {})",
                args.rig.display(),
                rig.cameras
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?),
    };
    let overrides = args.gates.overrides();
    let progress = crate::progress::Progress::new("detect", 0);
    let detected = detect_for_tracking(
        &args.recording,
        &rig,
        &tool,
        &args.detect.options(),
        overrides.min_roundness,
        &|| progress.tick(),
    )
    .map_err(|e| crate::recording::pipeline_error(e, &args.tool))?;
    progress.finish();
    let views: Vec<Views> = detected
        .recording
        .inputs(&rig)
        .into_iter()
        .map(|f| f.views)
        .collect();
    let sampled: Vec<Views> = sample_frames(views.len(), GATE_SAMPLE_FRAMES)
        .into_iter()
        .map(|f| views[f].clone())
        .collect();
    let config = RefineConfig {
        hold,
        max_rounds: args.rounds as usize,
        intrinsics: if args.extrinsics_only {
            Vec::new()
        } else {
            RefineConfig::default().intrinsics
        },
        ..RefineConfig::default()
    };
    let rounds = Rounds {
        tool: &tool,
        views: &views,
        sampled: &sampled,
        min_roundness: &detected.min_roundness,
        overrides,
        min_frames: config.min_frames,
    };
    let track = |through: &Rig, round: usize| rounds.track(through, round);
    let result = refine_rig(&rig, &tool, &views, &config, track)
        .with_context(|| format!("{}: refine", args.recording.display()))
        .rejected()?;
    print_result(&result);
    let std: Vec<CameraStdFile> = result
        .cameras
        .iter()
        .map(|c| CameraStdFile {
            centre_std_mm: c.centre_std_mm,
            rotation_std_deg: c.rotation_std_deg,
        })
        .collect();
    let mut written = vec![args.output.clone()];
    let refined_tool = args.tool_out.as_ref().map(|path| {
        let mut refined = tool.clone();
        refined.markers_in_tool.clone_from(&result.markers_in_tool);
        (path, refined)
    });
    if let Some((path, refined)) = &refined_tool {
        // Render the tool first so that an invalid one leaves no rig behind either.
        let text = teachcam::io::tool::tool_json(path, refined)?;
        write_rig_with_std(&args.output, &result.rig, &std)?;
        std::fs::write(path, text).with_context(|| format!("{}: write", path.display()))?;
        written.push((*path).clone());
    } else {
        write_rig_with_std(&args.output, &result.rig, &std)?;
    }
    crate::announce::wrote(&written, &format!("{} cameras", result.rig.cameras.len()));
    Ok(())
}

/// What every round tracks: the detected recording and the gates' inputs.
struct Rounds<'a> {
    tool: &'a teachcam::tool::Tool,
    views: &'a [Views],
    sampled: &'a [Views],
    min_roundness: &'a teachcam::track::gates::Gate,
    overrides: GateOverrides,
    min_frames: usize,
}

impl Rounds<'_> {
    /// Every frame tracked through `rig` with the gates measured from `sampled` through it;
    /// in round 0, when that leaves fewer than `min_frames` confident frames (a camera bumped
    /// beyond what the measured gates' ceilings absorb), again with the epipolar and
    /// triangulation gates widened (unless the user set them), keeping the pass with more
    /// confident frames.
    fn track(&self, rig: &Rig, round: usize) -> Vec<FrameTrack> {
        let pass = |overrides: &GateOverrides| -> Vec<FrameTrack> {
            let gates = measure_gates(
                rig,
                self.tool,
                self.sampled,
                &[],
                self.min_roundness.clone(),
                overrides,
            );
            let tracker = Tracker::new(rig, self.tool, gates.track_config());
            self.views
                .par_iter()
                .map(|v| tracker.track_frame(v))
                .collect()
        };
        let measured = pass(&self.overrides);
        let confident = |tracks: &[FrameTrack]| confident_views(self.tool, tracks).len();
        if round > 0 || confident(&measured) >= self.min_frames {
            return measured;
        }
        let mut wide = self.overrides;
        wide.epipolar_tolerance_px = wide.epipolar_tolerance_px.or(Some(WIDE_EPIPOLAR_PX));
        wide.max_residual_px = wide.max_residual_px.or(Some(WIDE_RESIDUAL_PX));
        let widened = pass(&wide);
        if confident(&widened) > confident(&measured) {
            widened
        } else {
            measured
        }
    }
}

/// What moved, σ, epipolar distances before and after.
fn print_result(result: &Refinement) {
    let rounds: Vec<String> = result
        .confident_per_round
        .iter()
        .enumerate()
        .map(|(r, n)| format!("round {}: {n}", r + 1))
        .collect();
    println!("confident frames per round: {}", rounds.join(", "));
    println!(
        "frames used {}, rejected {} (residual gate {:.3} px); held fixed: {}",
        result.frames_used,
        result.frames_rejected,
        result.residual_gate_px,
        result.rig.cameras[result.held.0].name
    );
    for c in &result.cameras {
        println!(
            "{}: moved {:.3} mm, turned {:.4}°; {} frames ({} dropped), rms {:.3} px, centre ± {:.4} mm, rotation ± {:.5}°",
            c.name,
            c.moved_mm,
            c.turned_deg,
            c.frames,
            c.dropped,
            c.rms_px,
            c.centre_std_mm,
            c.rotation_std_deg
        );
    }
    for p in &result.pairs {
        println!(
            "epipolar {}-{}: median {:.3} px before, {:.3} px after ({} marker images)",
            p.a, p.b, p.before_px, p.after_px, p.count
        );
    }
    for (camera, fit) in result.rig.cameras.iter().zip(&result.intrinsics) {
        let free: Vec<String> = fit
            .free
            .iter()
            .map(|(p, value, std)| format!("{} {value:.4} ± {std:.4}", p.name()))
            .collect();
        let held: Vec<String> = fit
            .held
            .iter()
            .map(|(p, effect)| format!("{} (1σ would move the image {effect:.2} px)", p.name()))
            .collect();
        println!(
            "{}: intrinsics refined: {}; held as given, not determined by this footage: {}",
            camera.name,
            if free.is_empty() {
                "none".to_owned()
            } else {
                free.join(", ")
            },
            if held.is_empty() {
                "none".to_owned()
            } else {
                held.join(", ")
            }
        );
    }
    let judged: Vec<String> = result
        .held_out
        .iter()
        .map(|(name, rigidity)| match rigidity {
            Some(mm) => format!("{name} {mm:.3} mm"),
            None => format!("{name} not measurable"),
        })
        .collect();
    let input = result
        .input_rigidity_mm
        .map_or_else(|| "not measurable".to_owned(), |mm| format!("{mm:.3} mm"));
    println!(
        "held-out frames ({}): tool rigidity (std of the marker distances) through the input rig {input}; {}",
        result.held_out_frames,
        judged.join(", ")
    );
    if result.kept_input {
        println!(
            "note: no refinement made the tool more rigid on the held-out frames than the input rig ({} was best): the input rig is written unchanged",
            result.chosen
        );
    } else {
        println!(
            "written: {} (the most rigid tool on the held-out frames)",
            result.chosen
        );
    }
    if !result.converged {
        println!("warning: the bundle adjustment stopped at its iteration limit, not at a minimum");
    }
}
