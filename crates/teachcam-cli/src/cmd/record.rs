//! `teachcam record`: a recording folder from cameras, the simulator or another recording.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use rayon::prelude::*;
use teachcam::io::recording_writer::RecordingWriter;
use teachcam::io::{rig::write_rig, tool::write_tool};
use teachcam::source::{FrameSource, SourceSpec, open_source};

use crate::Rejected;
use crate::capture::{CameraFlags, parse_source, stop_requested};

/// Record a source's frames into a recording folder that every command reads.
///
/// Writes `<camera>/000000.png ...` (8- or 16-bit gray, as the camera gives), `timestamps.csv`
/// (`camera,frame,time_s`: each frame's exposure time, seconds from the start) and
/// `recording.json` (the rate). From the simulator it also writes the scenario's `rig.json` and
/// `tool.json`, so that `teachcam track OUT --rig OUT/rig.json --tool OUT/tool.json` runs at
/// once. Frames of different cameras are paired by trigger sequence where the cameras are
/// triggered (the simulator, a recording) and by time otherwise (nearest within half a period);
/// a set missing a camera is not written, so every camera keeps the same number of frames.
///
/// Ends at `--seconds` / `--frames`, at the end of a finite source, or on Ctrl-C: the set in hand
/// is finished, every frame file is whole, the folder is valid, and a summary gives frames per
/// camera, sets dropped (the writer fell behind the cameras) and the pairing mismatch.
///
/// Sources: `sim:paper` (the simulator's scenario, at `--fps`, 60 by default),
/// `v4l2:/dev/video0,/dev/video2` (live cameras, named cam0, cam1, ...), `folder:REC` or a
/// folder path (a recording; videos are decoded to PNG frames).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam record --source sim:paper --seconds 2 --out recorded
  teachcam record --source v4l2:/dev/video0,/dev/video2 --seconds 10 --out cameras"#)]
pub struct Args {
    /// Where frames come from: sim:SCENARIO, v4l2:DEVICE[,DEVICE...], folder:REC or a folder.
    #[arg(long, default_value = "sim:paper", value_parser = parse_source)]
    pub source: SourceSpec,
    /// Output recording folder (created; must be empty if it exists).
    #[arg(long)]
    pub out: PathBuf,
    /// Stop after this many seconds.
    #[arg(long, value_parser = crate::flags::positive)]
    pub seconds: Option<f64>,
    /// Stop after writing this many frame sets.
    #[arg(long, value_parser = crate::flags::count)]
    pub frames: Option<usize>,
    #[command(flatten)]
    pub camera: CameraFlags,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if args.out.exists() {
        let empty = std::fs::read_dir(&args.out)
            .with_context(|| format!("cannot read {}", args.out.display()))?
            .next()
            .is_none();
        anyhow::ensure!(
            empty,
            "{}: the output folder exists and is not empty (record writes a new recording)",
            args.out.display()
        );
    }
    // `--frames` counts sets written, so the source is not capped by it: a set dropped
    // because the writer fell behind does not count.
    let config = args.camera.source_config(&args.source, args.seconds, None);
    let mut source = open_source(&args.source, &config).rejected()?;
    let names: Vec<String> = source.cameras().iter().map(|c| c.name.clone()).collect();
    let mut writer = RecordingWriter::create(&args.out, &names)?;
    if let SourceSpec::Sim(scenario) = &args.source {
        let scene = teachcam::source::sim::scene(*scenario, &config.sim);
        write_rig(&writer.staging().join("rig.json"), &scene.rig)?;
        write_tool(&writer.staging().join("tool.json"), &scene.tool)?;
    }
    let summary = record(source.as_mut(), &names, &mut writer, args)?;
    writer.finish(source.fps())?;
    crate::announce::wrote(std::slice::from_ref(&args.out), &summary);
    Ok(())
}

/// Writes sets until the source ends, a limit is reached or a stop is asked. Returns the
/// summary line.
fn record(
    source: &mut dyn FrameSource,
    names: &[String],
    writer: &mut RecordingWriter,
    args: &Args,
) -> anyhow::Result<String> {
    let started = Instant::now();
    let mut incomplete = 0usize;
    while !stop_requested() {
        if args
            .seconds
            .is_some_and(|s| started.elapsed().as_secs_f64() >= s)
        {
            break;
        }
        if args.frames.is_some_and(|f| writer.sets() >= f) {
            break;
        }
        let Some(set) = source.next_set() else { break };
        let set = set.rejected()?;
        let Some(cameras) = set
            .cameras
            .iter()
            .map(Option::as_ref)
            .collect::<Option<Vec<_>>>()
        else {
            incomplete += 1;
            continue;
        };
        let images = cameras
            .par_iter()
            .zip(names)
            .map(|(camera, name)| camera.decode(name, None).rejected())
            .collect::<anyhow::Result<Vec<_>>>()?;
        let frames: Vec<_> = images
            .iter()
            .zip(&cameras)
            .map(|(image, camera)| (image.as_ref(), camera.time_s))
            .collect();
        writer.push(&frames)?;
    }
    let written = writer.sets();
    let fps = source.fps();
    let stats = source.stats();
    let per_camera: Vec<String> = names.iter().map(|n| format!("{n} {written}")).collect();
    let unpaired: usize = stats.unpaired_frames.iter().sum();
    Ok(format!(
        "{written} frames per camera ({}) at {fps} Hz; dropped: {} sets (writer behind), {} incomplete sets skipped, {unpaired} frames unpaired; largest time spread within a set {:.3} ms{}",
        per_camera.join(", "),
        stats.dropped_sets,
        incomplete,
        1e3 * stats.max_pair_spread_s,
        if stop_requested() {
            " (stopped by signal)"
        } else {
            ""
        }
    ))
}
