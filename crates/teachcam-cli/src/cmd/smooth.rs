//! `teachcam smooth`: one of the paper's four smoothers over a trajectory CSV.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use teachcam::io::trajectory::{read_trajectory, write_trajectory};
use teachcam::io::{Output, check_outputs};
use teachcam::smooth::spline::SplineEnds;
use teachcam::smooth::{
    CutoffConvention, Method, ShortRuns, SmoothConfig, smooth_owned, suggest_cutoff,
};
use teachcam::trajectory::PoseSource;

use crate::Rejected;

/// Smooth a trajectory: low-pass, spline, Bezier or NURBS, rotations on SO(3).
///
/// Zero-phase Butterworth low-pass (the paper's choice), cubic spline, Bezier or NURBS
/// (least-squares B-spline). Rotations are smoothed on SO(3), the tip is
/// recomputed from the smoothed pose, gaps up to --max-gap frames are filled (column `filled`)
/// and longer gaps stay gaps.
///
/// For positions, `--method lowpass --cutoff HZ --order N` gives the numbers of
/// `scipy.signal.sosfiltfilt(scipy.signal.butter(N, HZ, fs=fs, output="sos"), x)`, which are
/// those of `filtfilt(*butter(N, HZ, fs=fs), x)` wherever that form is stable; HZ is the
/// cut-off of one pass, as in scipy (the zero-phase result is at -6 dB there). A cut-off whose
/// step response outlasts the record, or that double precision cannot hold, is refused.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam smooth raw.csv --method lowpass --cutoff 10 -o smooth.csv
  teachcam smooth raw.csv --method spline -o spline.csv"#)]
pub struct Args {
    /// Trajectory CSV to smooth (as written by `teachcam track`).
    pub input: PathBuf,
    /// Smoothing method.
    #[arg(long, value_enum, default_value_t = MethodName::Lowpass)]
    pub method: MethodName,
    /// Low-pass cut-off in Hz, or `auto`: residual analysis of x, y, z picks the cut-off of least
    /// estimated error against the motion (printed on stderr).
    #[arg(long, default_value = "10", value_parser = crate::flags::cutoff)]
    pub cutoff: String,
    /// Low-pass order (of each of the two passes).
    #[arg(long, default_value_t = 2, value_parser = crate::flags::count)]
    pub order: usize,
    /// What the cut-off means: `single-pass` (scipy's) or `winter` (the two-pass -3 dB point).
    #[arg(long, value_enum, default_value_t = Convention::SinglePass)]
    pub cutoff_convention: Convention,
    /// Spline end conditions.
    #[arg(long, value_enum, default_value_t = Ends::NotAKnot)]
    pub ends: Ends,
    /// NURBS degree.
    #[arg(long, default_value_t = 3, value_parser = crate::flags::count)]
    pub degree: usize,
    /// NURBS knot spacing, seconds.
    #[arg(long, default_value_t = 0.1, value_parser = crate::flags::positive)]
    pub knot_spacing: f64,
    /// Largest Bezier run, samples (the cost grows as its cube).
    #[arg(long, default_value_t = 2000, value_parser = crate::flags::count)]
    pub max_bezier_points: usize,
    /// Fill gaps of at most this many frames; longer gaps stay gaps.
    #[arg(long, default_value_t = 10)]
    pub max_gap: usize,
    /// Runs too short for the method (the low-pass's padding is 3·(order+1) samples, and its
    /// step response must settle within 1 % inside the run): `reject` the file, or make them
    /// `gap`s (empty rows).
    #[arg(long, value_enum, default_value_t = Short::Reject)]
    pub short_runs: Short,
    /// Tool file giving the tip; without it the tip is recovered from the trajectory.
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Smooth through the poses `track` flagged `outlier` (default: they are gaps, filled like
    /// any other when short).
    #[arg(long)]
    pub keep_outliers: bool,
    /// Output trajectory CSV (written whole or not at all).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
}

/// The four methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodName {
    /// Zero-phase Butterworth low-pass.
    Lowpass,
    /// Cubic spline interpolation (fills gaps, removes no noise).
    Spline,
    /// Bezier curve with the samples as control points (flattens the motion).
    Bezier,
    /// Least-squares B-spline at the original times.
    Nurbs,
}

/// Policies for runs too short for the method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Short {
    /// Refuse the file, naming the run's frames.
    Reject,
    /// Make the run a gap.
    Gap,
}

/// Cut-off conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Convention {
    /// scipy's: the cut-off of one pass.
    SinglePass,
    /// Winter's correction: the zero-phase result is at -3 dB at the cut-off.
    Winter,
}

/// Spline ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Ends {
    /// Zero second derivative at the ends.
    Natural,
    /// Continuous third derivative at the second and second-to-last knots (scipy's default).
    NotAKnot,
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let mut inputs = vec![args.input.as_path()];
    inputs.extend(args.tool.as_deref());
    check_outputs(&[Output::csv(&args.output)], &inputs)?;
    let mut trajectory = read_trajectory(&args.input).rejected()?;
    if !args.keep_outliers {
        trajectory.drop_outliers();
    }
    let mut config = SmoothConfig {
        max_gap_frames: args.max_gap,
        short_runs: match args.short_runs {
            Short::Reject => ShortRuns::Reject,
            Short::Gap => ShortRuns::Gap,
        },
        ..SmoothConfig::default()
    };
    if let Some(path) = &args.tool {
        config.tip_in_tool = Some(crate::load::tool(path)?.tip_in_tool());
    }
    config.method = match args.method {
        MethodName::Lowpass => {
            let cutoff_hz = if args.cutoff == "auto" {
                let suggestion =
                    suggest_cutoff(&trajectory, args.order, config.time_step_tolerance)
                        .with_context(|| format!("{}: residual analysis", args.input.display()))
                        .rejected()?;
                eprintln!(
                    "residual analysis suggests a cut-off of {:.2} Hz (x {:.2}, y {:.2}, z {:.2})",
                    suggestion.cutoff_hz,
                    suggestion.per_axis[0].suggested_cutoff_hz,
                    suggestion.per_axis[1].suggested_cutoff_hz,
                    suggestion.per_axis[2].suggested_cutoff_hz
                );
                suggestion.cutoff_hz
            } else {
                match args.cutoff.parse::<f64>() {
                    Ok(v) => v,
                    Err(_) => bail!("--cutoff {}: not a number of Hz nor `auto`", args.cutoff),
                }
            };
            Method::Lowpass {
                cutoff_hz,
                order: args.order,
                convention: match args.cutoff_convention {
                    Convention::SinglePass => CutoffConvention::SinglePass,
                    Convention::Winter => CutoffConvention::WinterTwoPass,
                },
            }
        }
        MethodName::Spline => Method::Spline {
            ends: match args.ends {
                Ends::Natural => SplineEnds::Natural,
                Ends::NotAKnot => SplineEnds::NotAKnot,
            },
        },
        MethodName::Bezier => Method::Bezier {
            max_control_points: args.max_bezier_points,
        },
        MethodName::Nurbs => Method::Nurbs {
            degree: args.degree,
            knot_spacing_s: args.knot_spacing,
        },
    };
    let smoothed = smooth_owned(trajectory, &config)
        .with_context(|| format!("{}", args.input.display()))
        .rejected()?;
    write_trajectory(&args.output, &smoothed)?;
    let poses = smoothed.samples.iter().filter(|s| s.pose.is_some()).count();
    let filled = smoothed
        .samples
        .iter()
        .filter(|s| s.pose.is_some() && s.source == PoseSource::Filled)
        .count();
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!(
            "{} frames, {poses} with a pose ({filled} filled), {} gaps",
            smoothed.len(),
            smoothed.len() - poses
        ),
    );
    Ok(())
}
