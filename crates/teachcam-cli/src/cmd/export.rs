//! `teachcam export`: a robot program for the trajectory of the TCP.

use std::path::PathBuf;

use teachcam::io::{Output, OutputSet, check_outputs};
use teachcam::robot::check::CheckReport;
use teachcam::robot::checked::{CheckedPath, stroke_ranges};
use teachcam::robot::kinematics::{Joints, Maker};
use teachcam::robot::krl::{krl_name_problem, krl_program};
use teachcam::robot::program::{ToolLoad, build_stroke_program, check_home, identifier};
use teachcam::robot::rapid::{RapidConfig, rapid_module, rapid_name_problem};
use teachcam::robot::simplify::SimplifyConfig;
use teachcam::robot::table::poses_csv;
use teachcam::robot::urscript::{UrScriptConfig, urscript_name_problem, urscript_program};

use super::check::{CellArgs, GapArgs, StrokeArgs, checked_path, resolve, strokes_line, summary};
use crate::Rejected;

/// The program dialects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Dialect {
    /// ABB RAPID module (.mod): tooldata with its load, wobjdata, robtargets with confdata,
    /// MoveJ to the first, then MoveL.
    Rapid,
    /// KUKA KRL: FILE.src ($TOOL, $BASE, $LOAD, a PTP to the first point with its S and T,
    /// then LIN with $VEL.CP) and FILE.dat (E6POS points) beside it; DEF is the file's name.
    Krl,
    /// Universal Robots URScript (.script): set_tcp, set_payload, movej to the first target's
    /// joints (radians), then movel with p[...] in metres and rotation vectors.
    Urscript,
    /// CSV of every frame's TCP pose in the work object and the checked joints.
    Csv,
    /// ROS 2 MCAP take (CDR, schemas embedded): /teachcam/tool, /tf, /teachcam/status per
    /// frame, /tf_static with --rig, /teachcam/joint_trajectory with --robot.
    Mcap,
}

/// Write a robot program (RAPID, KRL, URScript or CSV) or a ROS 2 take (MCAP) for a
/// trajectory.
///
/// The trajectory is checked on the robot first
/// (as `teachcam check`); a program that would fail is not written unless `--force` is given.
/// Targets are simplified within the path tolerance; each move's speed reproduces the recorded
/// timing. Each dialect drives its maker's robots (rapid: ABB, krl: KUKA, urscript: Universal
/// Robots; csv: any); another maker's robot is refused unless `--force`.
///
/// The tool's load (RAPID tload, KRL $LOAD, URScript set_payload) is `--tool-mass` kg at
/// `--tool-cog` in the flange frame; without them 0.2 kg (a brush and its holder) at half the
/// TCP offset is assumed, and the program's comment says so. A KRL program's DEF name is the
/// output file's name, which must then be a KRL name (letters, digits, underscores, starting
/// with a letter, at most 24 characters).
///
/// mcap: a ROS 2 bag (`ros2 bag play`, Foxglove) with the tool's pose on /teachcam/tool
/// (geometry_msgs/msg/PoseWithCovarianceStamped: the tip in metres, the tool's orientation,
/// the covariance from tip_std_mm), /tf (world -> teachcam_tool), /teachcam/status
/// (diagnostic_msgs/msg/DiagnosticArray) per frame, stamped with time_s; frames without a pose
/// have a status only. --rig adds the cameras on /tf_static; --robot adds the checked joint
/// path as one trajectory_msgs/msg/JointTrajectory (radians, time after time scaling).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam export rapid smooth.csv --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" -o stroke.mod
  teachcam export krl smooth.csv --robot kr6-r700 --wobj "350,0,100,1,0,0,0" --tcp "200,0,0,0.7071068,0,-0.7071068,0" -o stroke.src
  teachcam export urscript smooth.csv --robot ur5e --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" -o stroke.script
  teachcam export csv smooth.csv --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" -o targets.csv
  teachcam export mcap smooth.csv --rig rig.json --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" -o take.mcap"#)]
pub struct Args {
    /// Program dialect.
    #[arg(value_enum)]
    pub dialect: Dialect,
    /// Trajectory CSV (from `track` or `smooth`).
    pub trajectory: PathBuf,
    #[command(flatten)]
    pub cell: CellArgs,
    #[command(flatten)]
    pub gaps: GapArgs,
    #[command(flatten)]
    pub strokes: StrokeArgs,
    /// Output file (for krl, the .src; the .dat is written beside it).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Path tolerance for dropping targets, millimetres.
    #[arg(long, default_value_t = 0.5, value_parser = crate::flags::positive)]
    pub tolerance_mm: f64,
    /// Orientation tolerance for dropping targets, degrees.
    #[arg(long, default_value_t = 0.5, value_parser = crate::flags::positive)]
    pub tolerance_deg: f64,
    /// Approach and retract, millimetres back along the tool's axis (away from the work) from
    /// the first and last points: a joint move to the approach pose, a linear move onto the
    /// paint at 50 mm/s, the same off it at the end; 0 for none.
    #[arg(long, default_value_t = 50.0, value_parser = crate::flags::non_negative)]
    pub approach: f64,
    /// Home joints "j1,...,j6" (degrees, the maker's convention: ABB jointtarget, KUKA A1-A6,
    /// UR movej): a joint move there first and last (RAPID MoveAbsJ, KRL PTP {A1 ...}, URScript
    /// movej). Each must be inside the robot's range.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::joints)]
    pub home: Option<[f64; 6]>,
    /// Program name (default: the output file's name; KRL: must be the file's name).
    #[arg(long)]
    pub name: Option<String>,
    /// The tool's mass, kg (default: 0.2 kg assumed, said in the program).
    #[arg(long, value_parser = crate::flags::positive)]
    pub tool_mass: Option<f64>,
    /// The tool's centre of gravity in the maker's flange frame, "x,y,z" mm (default: half
    /// the TCP offset).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::point)]
    pub tool_cog: Option<[f64; 3]>,
    /// Write the program even when the check fails or the robot is another maker's (mcap:
    /// the joint path of the frames that have joints).
    #[arg(long)]
    pub force: bool,
    /// mcap: the rig whose cameras go on /tf_static (world -> camera_<name>).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// mcap: the world frame's name, every message's frame_id [default: world].
    #[arg(long)]
    pub frame_id: Option<String>,
}

/// The program's name: `--name`, else the output file's name, made an identifier. A reserved
/// word of the dialect (RAPID `MODULE`, URScript `def`, a KRL keyword) is refused with
/// `--name`; from a file name it is prefixed `tc_`, said on stderr (KRL: refused, its DEF must
/// be the file's name). The program file must have its dialect's extension.
fn program_name(args: &Args) -> anyhow::Result<String> {
    let stem = args
        .output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let extension = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let extensions = args.dialect.extensions();
    if args.dialect != Dialect::Csv && !extensions.contains(&extension.as_str()) {
        let expected: Vec<String> = extensions.iter().map(|e| format!(".{e}")).collect();
        anyhow::bail!(
            "-o {}: {} must end in {}",
            args.output.display(),
            args.dialect.format(),
            expected.join(" or ")
        );
    }
    if args.dialect == Dialect::Krl {
        let name = args.name.clone().unwrap_or_else(|| stem.clone());
        if name != stem {
            anyhow::bail!(
                "--name {name}: a KRL program's DEF must be its file's name '{stem}' (KSS refuses another)"
            );
        }
        if let Some(problem) = krl_name_problem(&name) {
            anyhow::bail!(
                "-o {}: {problem}, and KSS needs the DEF name to be the file's name",
                args.output.display()
            );
        }
        return Ok(name);
    }
    let name = identifier(args.name.as_deref().unwrap_or(&stem));
    let problem = match args.dialect {
        Dialect::Rapid => rapid_name_problem(&name),
        Dialect::Urscript => urscript_name_problem(&name),
        Dialect::Krl | Dialect::Csv | Dialect::Mcap => None,
    };
    match (problem, &args.name) {
        (None, _) => Ok(name),
        (Some(problem), Some(given)) => {
            anyhow::bail!("--name {given}: {problem}; choose another name")
        }
        (Some(problem), None) => {
            let prefixed = identifier(&format!("tc_{name}"));
            crate::announce::warn(&format!(
                "-o {}: {problem}; the program is named {prefixed}",
                args.output.display()
            ));
            Ok(prefixed)
        }
    }
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
    /// The take's strokes, one line.
    pub strokes: String,
}

/// Checks the trajectory on the robot and writes the program; prints the check's summary only
/// when the check fails.
#[expect(
    clippy::print_stdout,
    reason = "a failing check's summary and the gaps are part of the output"
)]
pub fn write_program(args: &Args) -> anyhow::Result<Written> {
    if args.dialect == Dialect::Mcap {
        anyhow::bail!("export mcap writes a take, not a program");
    }
    if args.rig.is_some() || args.frame_id.is_some() {
        anyhow::bail!("--rig and --frame-id are options of export mcap only");
    }
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
    let name = program_name(args)?;
    let robot = super::check::resolve_robot(args.cell.robot_name())?;
    if let Some(maker) = args.dialect.maker()
        && maker != robot.maker
        && !args.force
    {
        anyhow::bail!(
            "{} programs drive {} robots, and the {} is made by {} (--force writes it anyway)",
            args.dialect.label(),
            maker.label(),
            robot.name,
            robot.maker.label()
        );
    }
    if let Some(mass) = args.tool_mass {
        let cog = args.tool_cog.unwrap_or_default();
        if let Err(problem) = robot.load_problem(mass, cog) {
            return Err(anyhow::anyhow!("--tool-mass: {problem}")).rejected();
        }
    }
    let home = args.home.map(|h| Joints(h.map(f64::to_radians)));
    if let Some(home) = &home {
        check_home(&robot, home).map_err(|e| {
            anyhow::anyhow!(
                "--home {}: {e}",
                joints_text(&args.home.unwrap_or_default())
            )
        })?;
    }
    let resolved = resolve(&args.trajectory, &args.cell)?;
    let CheckedPath {
        targets,
        strokes,
        tool_axis,
        report,
        ..
    } = checked_path(&resolved, &args.strokes)?;
    if let Some(line) = &tool_axis {
        crate::announce::say(line);
    }
    let (gaps, gap_lines, gap_refusal) = args.gaps.judge(&targets, &strokes, args.tolerance_mm);
    print!("{gap_lines}");
    if let Some(refusal) = gap_refusal {
        return Err(anyhow::anyhow!(
            "{}: {refusal}; no program written",
            args.trajectory.display()
        ))
        .rejected();
    }
    let ranges = stroke_ranges(&strokes);
    if !report.passes() {
        print!("{}", summary(&report, resolved.gaps, &resolved.robot.name));
        if !args.force {
            return Err(anyhow::anyhow!(
                "{}: {}; no program written (--force writes it anyway)",
                args.trajectory.display(),
                super::check::failure_line(&report)
            ))
            .rejected();
        }
    }
    let tolerance = SimplifyConfig {
        position_tolerance: args.tolerance_mm,
        orientation_tolerance: args.tolerance_deg.to_radians(),
    };
    // The report's frames are the strokes' in order.
    let mut frame_ranges = Vec::with_capacity(ranges.len());
    let mut at = 0;
    for range in &ranges {
        frame_ranges.push(at..at + range.len());
        at += range.len();
    }
    let mut program =
        build_stroke_program(&name, &resolved.cell, &report, &tolerance, &frame_ranges);
    if args.dialect != Dialect::Csv {
        program
            .add_approach(args.approach, resolved.config.speed_fraction)
            .map_err(|e| anyhow::anyhow!("--approach {}: {e}", args.approach))
            .rejected()?;
    }
    program.home = home;
    program.tool_axis = tool_axis;
    program.gaps = gaps.into_iter().filter(|g| !g.bridgeable).collect();
    if args.tool_mass.is_some() || args.tool_cog.is_some() {
        let assumed = ToolLoad::assumed(&resolved.cell);
        let load = ToolLoad {
            mass_kg: args.tool_mass.unwrap_or(assumed.mass_kg),
            cog_in_flange: args
                .tool_cog
                .map_or(assumed.cog_in_flange, nalgebra::Vector3::from),
        };
        let cog: [f64; 3] = load.cog_in_flange.into();
        match resolved.robot.load_problem(load.mass_kg, cog) {
            Ok(None) => {}
            Ok(Some(note)) => crate::announce::warn(&note),
            Err(problem) => {
                return Err(anyhow::anyhow!("--tool-mass/--tool-cog: {problem}")).rejected();
            }
        }
        program.load = Some(load);
    }
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
        Dialect::Mcap => anyhow::bail!("export mcap writes a take, not a program"),
    }
    Ok(Written {
        files: outputs.commit()?,
        moves: program.moves.len(),
        report,
        strokes: strokes_line(&strokes, &args.strokes),
    })
}

/// "j1,...,j6" as given.
fn joints_text(joints: &[f64; 6]) -> String {
    joints
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

impl Dialect {
    /// The maker whose robots the dialect drives, `None` for CSV (any robot).
    fn maker(self) -> Option<Maker> {
        match self {
            Self::Rapid => Some(Maker::Abb),
            Self::Krl => Some(Maker::Kuka),
            Self::Urscript => Some(Maker::UniversalRobots),
            Self::Csv | Self::Mcap => None,
        }
    }

    /// The dialect's name, for messages.
    fn label(self) -> &'static str {
        match self {
            Self::Rapid => "RAPID",
            Self::Krl => "KRL",
            Self::Urscript => "URScript",
            Self::Csv => "CSV",
            Self::Mcap => "MCAP",
        }
    }

    /// What the dialect's program file is, for messages.
    fn format(self) -> &'static str {
        match self {
            Self::Rapid => "an ABB RAPID module",
            Self::Krl => "a KUKA KRL program",
            Self::Urscript => "a URScript program",
            Self::Csv => "CSV",
            Self::Mcap => "a ROS 2 MCAP file",
        }
    }

    /// The extensions of the dialect's program file (RAPID: module, program module, old
    /// program).
    fn extensions(self) -> &'static [&'static str] {
        match self {
            Self::Rapid => &["mod", "modx"],
            Self::Krl => &["src"],
            Self::Urscript => &["script"],
            Self::Csv => &["csv"],
            Self::Mcap => &["mcap"],
        }
    }
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if args.dialect == Dialect::Mcap {
        return super::export_mcap::run(args);
    }
    let Written {
        files,
        moves,
        report,
        strokes,
    } = write_program(args)?;
    let what = if args.dialect == Dialect::Csv {
        format!("{} frames", report.frames.len())
    } else {
        format!("{moves} moves from {} frames", report.frames.len())
    };
    crate::announce::wrote(&files, &what);
    if args.dialect != Dialect::Csv {
        crate::announce::say(&report.timing.describe(&report.robot.name));
        crate::announce::say(&strokes);
    }
    Ok(())
}
