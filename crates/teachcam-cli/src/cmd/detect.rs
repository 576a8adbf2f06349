//! `teachcam detect`: marker blobs with sub-pixel centres in every frame of a recording.

use std::path::{Path, PathBuf};

use teachcam::io::{Output, check_outputs, write_atomically};
use teachcam::pipeline::recording::{DetectedRecording, LimitsGiven, detect_learned};
use teachcam::source::FrameSource;
use teachcam::source::folder::FolderSource;

use crate::Rejected;
use crate::flags::detection::{DetectorFlags, configs};
use crate::progress::Progress;

/// Find the marker blobs in every frame of a recording and write their sub-pixel centres.
///
/// The limits are measured from the recording first and printed in one line (each flag
/// overrides its limit): from 40 frames spread over it, each camera's threshold (a third of
/// the markers' contrast above each frame's background) and smallest blob (a quarter of the
/// smallest markers' area: specks are not markers), then the roundness floor from the blobs
/// of 60 frames. Each frame is thresholded, its 8-connected bright regions are measured, and
/// the regions that are too small, too large or cut by the image border are left out. A region that is not
/// round (markers whose images merged) is split when its markers come apart at half contrast
/// with 2 px between their edges, and left out otherwise. Frames run in parallel.
///
/// Output columns: `camera,frame,x_px,y_px,radius_px,area_px,roundness,center_std_px,peak`
/// (camera = the sub-folder's or video's name, frame = 0-based index, centre in OpenCV pixels, radius of
/// the equal-flux disc, predicted centre noise per axis), every number to the last bit so that
/// `teachcam track --detections` tracks these very blobs.
///
/// With `--rig` and a marker size (`--tool` or `--marker-diameter`), the size limits follow from
/// each camera's focal length and `--near`/`--far`, and the `refined` centre is moved from the
/// centre of the sphere's elliptical image to the projection of the sphere's centre.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam detect rec -o detections.csv --rig rec/rig.json --tool rec/tool.json"#)]
pub struct Args {
    /// Recording folder: one sub-folder of PNG frames or one video file per camera.
    pub recording: PathBuf,
    /// Output CSV file (written whole or not at all).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Detector options.
    #[command(flatten)]
    pub options: DetectorFlags,
}

/// The CSV text of the detections.
fn csv_text(recording: &DetectedRecording) -> String {
    teachcam::io::detections::detections_csv(
        recording
            .sets
            .iter()
            .flat_map(|s| s.cameras.iter().flatten()),
    )
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut inputs: Vec<&Path> = Vec::new();
    inputs.extend(args.options.rig.as_deref());
    inputs.extend(args.options.tool.as_deref());
    check_outputs(&[Output::csv(&args.output)], &inputs)?;
    let source = FolderSource::open(&args.recording, None).rejected()?;
    let setups = configs(&args.options, source.cameras())?;
    let len = source.len_hint().unwrap_or(0) as u64;
    drop(source);
    let given = LimitsGiven {
        min_area_px: args.options.min_area.is_some(),
        min_roundness: args.options.min_roundness,
    };
    let progress = Progress::new("detect", len);
    let (recording, limits) =
        detect_learned(&args.recording, None, setups, given, &|| progress.tick()).rejected()?;
    progress.finish();
    crate::announce::say(&limits.summary());
    write_atomically(&args.output, csv_text(&recording).as_bytes())?;
    let blobs: usize = recording
        .sets
        .iter()
        .flat_map(|s| s.cameras.iter().flatten())
        .map(|c| c.blobs.len())
        .sum();
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!(
            "{blobs} blobs in {} frames x {} cameras",
            recording.sets.len(),
            recording.cameras.len()
        ),
    );
    Ok(())
}
