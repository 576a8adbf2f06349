//! `teachcam export`: a robot program for the trajectory of the TCP.

use std::path::PathBuf;

use teachcam::io::{Output, OutputSet, check_outputs};
use teachcam::robot::check::{CheckReport, check_path};
use teachcam::robot::krl::krl_program;
use teachcam::robot::program::build_program;
use teachcam::robot::rapid::{RapidConfig, rapid_module};
use teachcam::robot::simplify::SimplifyConfig;
use teachcam::robot::table::poses_csv;
use teachcam::robot::urscript::{UrScriptConfig, urscript_program};

use super::check::{CellArgs, resolve, summary};
use crate::Rejected;

/// The program dialects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Dialect {
    /// ABB RAPID module (.mod): tooldata, wobjdata, robtargets with confdata, MoveL.
    Rapid,
    /// KUKA KRL: FILE.src (LIN, $VEL.CP) and FILE.dat (E6POS points) beside it.
    Krl,
    /// Universal Robots URScript (.script): movel with p[...] in metres and rotation vectors.
    Urscript,
    /// CSV of every frame's TCP pose in the work object and the checked joints.
    Csv,
}

/// Write a robot program (RAPID, KRL, URScript or CSV) for a trajectory.
///
/// The trajectory is checked on the robot first
/// (as `teachcam check`); a program that would fail is not written unless `--force` is given.
/// Targets are simplified within the path tolerance; each move's speed reproduces the recorded
/// timing.
///
/// Example: `teachcam export rapid smooth.csv --wobj "350,0,150,1,0,0,0" --tcp
/// "0,0,150,1,0,0,0" -o stroke.mod`
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Program dialect.
    #[arg(value_enum)]
    pub dialect: Dialect,
    /// Trajectory CSV (from `track` or `smooth`).
    pub trajectory: PathBuf,
    #[command(flatten)]
    pub cell: CellArgs,
    /// Output file (for krl, the .src; the .dat is written beside it).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Path tolerance for dropping targets, millimetres.
    #[arg(long, default_value_t = 0.5, value_parser = crate::flags::positive)]
    pub tolerance_mm: f64,
    /// Orientation tolerance for dropping targets, degrees.
    #[arg(long, default_value_t = 0.5, value_parser = crate::flags::positive)]
    pub tolerance_deg: f64,
    /// Program name (default: the output file's name).
    #[arg(long)]
    pub name: Option<String>,
    /// Write the program even when the check fails.
    #[arg(long)]
    pub force: bool,
}

/// What [`write_program`] wrote.
#[derive(Debug)]
pub struct Written {
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Moves in the program (after simplification).
    pub moves: usize,
    /// The robot check of every frame.
    pub report: CheckReport,
}

/// Checks the trajectory on the robot and writes the program; prints the check's summary only
/// when the check fails.
#[expect(
    clippy::print_stdout,
    reason = "a failing check's summary is part of the output"
)]
pub fn write_program(args: &Args) -> anyhow::Result<Written> {
    if !(args.tolerance_mm > 0.0 && args.tolerance_deg > 0.0) {
        anyhow::bail!("--tolerance-mm and --tolerance-deg must be positive");
    }
    let dat = args.output.with_extension("dat");
    let program = |extensions| Output {
        path: &args.output,
        format: args.dialect.format(),
        extensions,
    };
    let mut outputs = vec![program(args.dialect.extensions())];
    if args.dialect == Dialect::Krl {
        outputs.push(Output {
            path: &dat,
            format: "KRL data",
            extensions: &["dat"],
        });
    }
    let mut inputs = vec![args.trajectory.as_path()];
    inputs.extend(args.cell.tool.as_deref());
    check_outputs(&outputs, &inputs)?;
    let resolved = resolve(&args.trajectory, &args.cell)?;
    let report = check_path(
        &resolved.model,
        &resolved.cell,
        &resolved.targets,
        &resolved.config,
    );
    if !report.passes() {
        print!("{}", summary(&report, resolved.gaps, &resolved.model.name));
        if !args.force {
            return Err(anyhow::anyhow!(
                "{}: {} of {} frames fail on the {}; no program written (--force writes it anyway)",
                args.trajectory.display(),
                report.failing().count(),
                report.frames.len(),
                resolved.model.name
            ))
            .rejected();
        }
    }
    let name = args.name.clone().unwrap_or_else(|| {
        args.output
            .file_stem()
            .map_or_else(|| "teachcam".into(), |s| s.to_string_lossy().into_owned())
    });
    let tolerance = SimplifyConfig {
        position_tolerance: args.tolerance_mm,
        orientation_tolerance: args.tolerance_deg.to_radians(),
    };
    let program = build_program(&name, &resolved.cell, &report, &tolerance);
    let outputs = OutputSet::new();
    match args.dialect {
        Dialect::Rapid => outputs.add(
            &args.output,
            rapid_module(&program, &RapidConfig::default()).as_bytes(),
        )?,
        Dialect::Krl => {
            let krl = krl_program(&program);
            outputs.add(&args.output, krl.src.as_bytes())?;
            outputs.add(&dat, krl.dat.as_bytes())?;
        }
        Dialect::Urscript => outputs.add(
            &args.output,
            urscript_program(&program, &UrScriptConfig::default()).as_bytes(),
        )?,
        Dialect::Csv => outputs.add(&args.output, poses_csv(&report).as_bytes())?,
    }
    Ok(Written {
        files: outputs.commit()?,
        moves: program.moves.len(),
        report,
    })
}

impl Dialect {
    /// What the dialect's program file is, for messages.
    fn format(self) -> &'static str {
        match self {
            Self::Rapid => "an ABB RAPID module",
            Self::Krl => "a KUKA KRL program",
            Self::Urscript => "a URScript program",
            Self::Csv => "CSV",
        }
    }

    /// The extensions of the dialect's program file (RAPID: module, program module, old
    /// program).
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Self::Rapid => &["mod", "modx", "prg"],
            Self::Krl => &["src"],
            Self::Urscript => &["script"],
            Self::Csv => &["csv"],
        }
    }
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let Written {
        files,
        moves,
        report,
    } = write_program(args)?;
    let what = if args.dialect == Dialect::Csv {
        format!("{} frames", report.frames.len())
    } else {
        format!("{moves} moves from {} frames", report.frames.len())
    };
    crate::announce::wrote(&files, &what);
    Ok(())
}
