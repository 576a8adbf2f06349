//! `teachcam check`: can the robot run this trajectory? Reach, joint limits, joint speeds,
//! configuration changes and the wrist singularity, frame by frame.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use nalgebra::UnitQuaternion;
use teachcam::geometry::Pose;
use teachcam::io::trajectory::read_trajectory;
use teachcam::robot::check::{CheckConfig, CheckReport, issue_ranges};
use teachcam::robot::checked::{CheckedPath, PathError, PathOptions, no_stroke_line};
use teachcam::robot::gaps::{Gap, GapConfig, find_gaps};
use teachcam::robot::kinematics::Robot;
use teachcam::robot::kinematics::models::KNOWN_ROBOTS;
use teachcam::robot::strokes::{Span, Stroke, StrokeConfig, find_strokes};
use teachcam::robot::table::joints_csv;
use teachcam::robot::{Cell, TcpTarget, tcp_targets};

use crate::Rejected;

/// Check a trajectory on a robot: reach, joint limits, joint speeds, singularities.
///
/// Every frame must be reachable with the joints inside their ranges and the joint
/// speeds within the data sheet's at the recorded timing, no configuration change; frames near
/// the wrist singularity are reported as warnings. Prints a summary, the failing frames as runs
/// ("frames 12-40: axis 1 too fast, up to 325°/s of 225°/s") and
/// suggestions (slow down by a factor, a verified `--wobj` to paste); exits with status 1 when the
/// program would fail on the robot.
///
/// Only the strokes are checked (as `teachcam strokes` lists them, within --from/--to): the
/// runs of frames where the tip is within --lift-mm of the work surface (the world's xy-plane),
/// cut where it pauses; each stroke on its own, all at one time scale. A take that never
/// touches the surface (a world whose xy-plane is not the work surface) is checked whole, with
/// a warning naming the tip's lowest height.
///
/// Frames (CONTRACT.md, "Robot frames"): the trajectory's world is the work object; `--wobj`
/// places it in the robot's base, `--tcp` places the brush's tip in the maker's flange frame:
/// ABB's tool0 and UR's tool flange have z out of the flange, KUKA's FLANGE has x out of it.
/// Joint angles are the maker's: ABB as in a RAPID jointtarget, KUKA A1-A6 as the pendant
/// shows them, UR as movej's (degrees in --joints-out).
///
/// Robots: irb120 (ABB IRB 120), kr6-r700 and kr6-r900 (KUKA KR 6 R700/R900 sixx), ur5e and
/// ur10e (Universal Robots), or a robot file: {"name": "...", "maker": "abb"|"kuka"|"ur",
/// "opw": {"a1_mm", "a2_mm", "b_mm" (0), "c1_mm", "c2_mm", "c3_mm", "c4_mm", "offsets_deg": [6],
/// "sign_corrections": [6]} for a spherical wrist (ROS-Industrial opw_kinematics parameters) or
/// "dh": {"d1_mm", "a2_mm", "a3_mm", "d4_mm", "d5_mm", "d6_mm"} for a UR-like arm, and
/// "joints": six {"min_deg", "max_deg", "max_speed_deg_s"}}.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam check smooth.csv --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" --joints-out joints.csv
  teachcam check smooth.csv --robot ur5e --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0"
  teachcam check smooth.csv --robot kr6-r700 --wobj "350,0,100,1,0,0,0" --tcp "200,0,0,0.7071068,0,-0.7071068,0""#)]
pub struct Args {
    /// Trajectory CSV (from `track` or `smooth`).
    pub trajectory: PathBuf,
    #[command(flatten)]
    pub cell: CellArgs,
    /// Path tolerance, millimetres (as export's): a gap in the data whose straight crossing
    /// would leave the smoothest path by more is named and fails the check.
    #[arg(long, default_value_t = 0.5, value_parser = crate::flags::positive)]
    pub tolerance_mm: f64,
    #[command(flatten)]
    pub gaps: GapArgs,
    #[command(flatten)]
    pub strokes: StrokeArgs,
    /// Write the chosen joint angles of every frame here (degrees, the maker's convention; then
    /// the maker's configuration: ABB cf1,cf4,cf6,cfx; KUKA s,t; UR configuration 0-7).
    #[arg(long)]
    pub joints_out: Option<PathBuf>,
}

/// The robot and the frames that place the trajectory on it (shared by `check` and `export`).
#[derive(Debug, clap::Args)]
pub struct CellArgs {
    /// Robot: irb120, kr6-r700, kr6-r900, ur5e, ur10e, or a robot file (.json, see above)
    /// [default: irb120; `export mcap` writes no joint path without it].
    #[arg(long)]
    pub robot: Option<String>,
    /// Work object in the robot's base frame, "x,y,z,qw,qx,qy,qz" (mm; RAPID's uframe).
    #[arg(long, allow_hyphen_values = true, default_value = "0,0,0,1,0,0,0", value_parser = crate::flags::pose)]
    pub wobj: String,
    /// Tool centre point in the maker's flange frame, "x,y,z,qw,qx,qy,qz" (mm): ABB tool0 and UR
    /// tool flange (z out of the flange; RAPID's tframe, set_tcp), KUKA FLANGE (x out; $TOOL).
    #[arg(long, allow_hyphen_values = true, default_value = "0,0,0,1,0,0,0", value_parser = crate::flags::pose)]
    pub tcp: String,
    /// Tool file whose `tip_rotation` turns the TCP frame (without it, the TCP has the tool's
    /// orientation); `export mcap` also draws its markers on `/teachcam/markers`.
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Fraction of each axis's maximum speed the path may use (0 < f <= 1): the time scale
    /// keeps every joint under this share of its data-sheet speed, a margin for the
    /// controller's blending and ramps.
    #[arg(long, default_value_t = teachcam::robot::check::DEFAULT_SPEED_FRACTION, value_parser = crate::flags::fraction)]
    pub speed_fraction: f64,
    /// How the demonstration's timing is played: auto slows the whole path by the smallest
    /// factor that keeps every joint within its limits (printed and written in the program);
    /// 1 keeps the recorded timing and fails naming the axis, frame and the factor that would
    /// fit; F slows it F times.
    #[arg(long, default_value = "auto", value_parser = crate::flags::time_scale)]
    pub time_scale: teachcam::robot::check::TimeScale,
    /// Largest joint acceleration allowed on every axis, deg/s^2 (the makers publish none; without
    /// this flag accelerations are reported, not judged).
    #[arg(long)]
    pub max_acceleration_deg_s2: Option<f64>,
    /// Use the poses `track` flagged `outlier` (default: treat them as gaps).
    #[arg(long)]
    pub keep_outliers: bool,
    /// The tool is symmetric about its axis (the TCP's z: a round brush, a nozzle): choose the
    /// rotation about it per frame, smoothly, to keep the wrist from its singularity and the
    /// joints in range and within their speeds (also `"axisymmetric": true` in --tool's file).
    /// The tip positions and the tool's axis are kept.
    #[arg(long)]
    pub free_tool_axis: bool,
}

/// Which part of the take is checked or exported, and how it splits into strokes (shared by
/// `check`, `export` and `strokes`).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct StrokeArgs {
    /// Start of the span used, seconds of the take's time_s [default: the take's start].
    #[arg(long, allow_hyphen_values = true)]
    pub from: Option<f64>,
    /// End of the span used, seconds of the take's time_s [default: the take's end].
    #[arg(long, allow_hyphen_values = true)]
    pub to: Option<f64>,
    /// A stroke ends where the tip rises more than this off the work surface (the world's
    /// xy-plane, z = 0, which is the work object's: |z| in the trajectory), millimetres.
    #[arg(long, default_value_t = StrokeConfig::default().lift_mm, value_parser = crate::flags::positive)]
    pub lift_mm: f64,
    /// A stroke ends where the tip pauses (slower than --pause-speed-mm-s) this long, seconds.
    #[arg(long, default_value_t = StrokeConfig::default().pause_s, value_parser = crate::flags::positive)]
    pub pause_s: f64,
    /// Speed under which the tip pauses, mm/s.
    #[arg(long, default_value_t = StrokeConfig::default().pause_speed_mm_s, value_parser = crate::flags::positive)]
    pub pause_speed_mm_s: f64,
}

impl Default for StrokeArgs {
    /// The whole take, [`StrokeConfig::default`].
    fn default() -> Self {
        let config = StrokeConfig::default();
        Self {
            from: None,
            to: None,
            lift_mm: config.lift_mm,
            pause_s: config.pause_s,
            pause_speed_mm_s: config.pause_speed_mm_s,
        }
    }
}

impl StrokeArgs {
    /// The library's [`PathOptions`] of these flags, the tool's axis free or not.
    pub fn options(&self, free_tool_axis: bool) -> PathOptions {
        PathOptions {
            from_s: self.from,
            to_s: self.to,
            strokes: self.config(),
            free_tool_axis,
        }
    }

    /// The options of [`find_strokes`].
    pub fn config(&self) -> StrokeConfig {
        StrokeConfig {
            lift_mm: self.lift_mm,
            pause_s: self.pause_s,
            pause_speed_mm_s: self.pause_speed_mm_s,
        }
    }

    /// The targets within `--from`/`--to` of a take running `take_s` (usage error, exit 2,
    /// naming the take's span, for a span outside it or empty) and their strokes (none: exit
    /// 1 naming the tip's lowest height).
    pub fn strokes(
        &self,
        targets: &[TcpTarget],
        take_s: (f64, f64),
    ) -> anyhow::Result<(Vec<TcpTarget>, Vec<Stroke>)> {
        let (trimmed, strokes) = self.split(targets, take_s)?;
        match strokes {
            Ok(strokes) => Ok((trimmed, strokes)),
            Err(none) => Err(anyhow::anyhow!("{none}")).rejected(),
        }
    }

    /// The trimmed targets and their strokes, or the line saying there is none.
    fn split(&self, targets: &[TcpTarget], take_s: (f64, f64)) -> anyhow::Result<Split> {
        let span = Span::within(take_s.0, take_s.1, self.from, self.to)?;
        let trimmed = span.trim(targets);
        let strokes = find_strokes(&trimmed, &self.config());
        if !strokes.is_empty() {
            return Ok((trimmed, Ok(strokes)));
        }
        let none = no_stroke_line(&span, &trimmed, self.lift_mm);
        Ok((trimmed, Err(none)))
    }
}

/// The targets of a span and their strokes, or the line saying it has none.
type Split = (Vec<TcpTarget>, Result<Vec<Stroke>, String>);

/// One line naming the strokes of a take, for `check` and `export`.
pub fn strokes_line(strokes: &[Stroke], args: &StrokeArgs) -> String {
    let spans: Vec<String> = strokes
        .iter()
        .map(|s| format!("{}-{}", s.first.0, s.last.0))
        .collect();
    format!(
        "{} stroke{} (frames {}; split where the tip rises over {} mm off the work surface or pauses under {} mm/s for {} s)",
        strokes.len(),
        if strokes.len() == 1 { "" } else { "s" },
        spans.join(", "),
        args.lift_mm,
        args.pause_speed_mm_s,
        args.pause_s
    )
}

/// How `check` and `export` treat gaps in the data (frames lost, or outliers dropped).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct GapArgs {
    /// Cross gaps too long for the path tolerance with straight moves anyway (export names
    /// each in the program where it is); without it, such a gap fails check and export.
    #[arg(long)]
    pub bridge_gaps: bool,
    /// Bridge every gap up to this long, seconds, whatever its shape (default: a gap is
    /// bridged when the smoothest path across it, from the speeds on either side, stays
    /// within the path tolerance of a straight move).
    #[arg(long, value_parser = crate::flags::non_negative)]
    pub max_gap_s: Option<f64>,
}

impl GapArgs {
    /// The gaps within the strokes of the targets, judged at `tolerance_mm`; the lines naming those too long to
    /// bridge (as warnings when `--bridge-gaps`); `Err` with one line when such a gap is not
    /// to be bridged.
    pub fn judge(
        &self,
        targets: &[TcpTarget],
        strokes: &[Stroke],
        tolerance_mm: f64,
    ) -> (Vec<Gap>, String, Option<String>) {
        use std::fmt::Write as _;
        let config = GapConfig {
            tolerance_mm,
            max_gap_s: self.max_gap_s,
        };
        // Within each stroke: between strokes the program lifts the brush.
        let gaps: Vec<Gap> = strokes
            .iter()
            .flat_map(|s| find_gaps(&targets[s.targets.clone()], &config))
            .collect();
        let too_long: Vec<&Gap> = gaps.iter().filter(|g| !g.bridgeable).collect();
        let criterion = match self.max_gap_s {
            Some(s) => format!("longer than --max-gap-s {s}"),
            None => format!("beyond the path tolerance of {tolerance_mm} mm"),
        };
        let mut lines = String::new();
        let what = if self.bridge_gaps {
            "warning: gap bridged by a straight move"
        } else {
            "  gap"
        };
        for gap in &too_long {
            let _ = writeln!(lines, "{what}: {gap}");
        }
        let refusal = (!too_long.is_empty() && !self.bridge_gaps).then(|| {
            format!(
                "{} gap{} in the data {criterion} (first: frames {}-{}); a straight move across would not follow the demonstration (--bridge-gaps crosses them anyway, or --max-gap-s S)",
                too_long.len(),
                if too_long.len() == 1 { "" } else { "s" },
                too_long[0].after.0 + 1,
                too_long[0].before.0 - 1
            )
        });
        (gaps, lines, refusal)
    }
}

impl Default for CellArgs {
    /// `check`'s defaults: the IRB 120, work object and TCP at identity, automatic time scale.
    fn default() -> Self {
        Self {
            robot: None,
            wobj: "0,0,0,1,0,0,0".into(),
            tcp: "0,0,0,1,0,0,0".into(),
            tool: None,
            speed_fraction: teachcam::robot::check::DEFAULT_SPEED_FRACTION,
            time_scale: teachcam::robot::check::TimeScale::Auto,
            max_acceleration_deg_s2: None,
            keep_outliers: false,
            free_tool_axis: false,
        }
    }
}

impl CellArgs {
    /// The robot asked for, `irb120` when none was.
    pub fn robot_name(&self) -> &str {
        self.robot.as_deref().unwrap_or("irb120")
    }
}

/// Everything `check` and `export` need, resolved from the arguments and files.
pub struct Resolved {
    /// The robot.
    pub robot: Robot,
    /// The cell.
    pub cell: Cell,
    /// Targets of the frames with a pose.
    pub targets: Vec<TcpTarget>,
    /// Frames without a pose.
    pub gaps: usize,
    /// The take's first and last times, seconds (every frame's, with a pose or not).
    pub take_s: (f64, f64),
    /// Check options.
    pub config: CheckConfig,
    /// True when the rotation about the tool's axis is free (`--free-tool-axis`, or the tool
    /// file's `"axisymmetric": true`).
    pub free_tool_axis: bool,
}

/// Parses "x,y,z,qw,qx,qy,qz" into a pose, naming the flag on failure.
pub fn parse_pose(text: &str, flag: &str) -> anyhow::Result<Pose> {
    teachcam::geometry::parse_pose(text).with_context(|| flag.to_string())
}

/// Reads the trajectory and the tool, and parses the frames.
pub fn resolve(trajectory: &Path, args: &CellArgs) -> anyhow::Result<Resolved> {
    let trajectory = read_trajectory(trajectory).rejected()?;
    resolve_trajectory(trajectory, args)
}

/// [`resolve`] of a trajectory already read (the report's smoothed one).
pub fn resolve_trajectory(
    mut trajectory: teachcam::trajectory::Trajectory,
    args: &CellArgs,
) -> anyhow::Result<Resolved> {
    let robot = resolve_robot(args.robot_name())?;
    let cell = Cell {
        base_from_wobj: parse_pose(&args.wobj, "--wobj")?,
        flange_from_tcp: parse_pose(&args.tcp, "--tcp")?,
    };
    crate::load::check_tcp(&cell.flange_from_tcp);
    if let Some(warning) = teachcam::robot::tcp_convention_warning(&robot, &cell.flange_from_tcp) {
        crate::announce::warn(&warning);
    }
    if !(args.speed_fraction > 0.0 && args.speed_fraction <= 1.0) {
        bail!(
            "--speed-fraction {}: must be in (0, 1]",
            args.speed_fraction
        );
    }
    let tip_rotation = match &args.tool {
        Some(path) => crate::load::tool(path)?.tool_from_tcp.rotation,
        None => UnitQuaternion::identity(),
    };
    let free_tool_axis = args.free_tool_axis
        || match &args.tool {
            Some(path) => teachcam::io::tool::read_axisymmetric(path).rejected()?,
            None => false,
        };
    if !args.keep_outliers {
        trajectory.drop_outliers();
    }
    let targets = tcp_targets(&trajectory, &tip_rotation);
    if targets.is_empty() {
        return Err(anyhow::anyhow!(
            "{}: no frame has a pose",
            args_path(trajectory.len())
        ))
        .rejected();
    }
    if let Some(a) = args.max_acceleration_deg_s2
        && !(a.is_finite() && a > 0.0)
    {
        bail!("--max-acceleration-deg-s2 {a}: must be a positive number");
    }
    let config = CheckConfig {
        speed_fraction: args.speed_fraction,
        max_acceleration: args.max_acceleration_deg_s2.map(|a| [a.to_radians(); 6]),
        time_scale: args.time_scale,
        ..CheckConfig::default()
    };
    let take_s = (
        trajectory.samples.first().map_or(0.0, |s| s.time_s),
        trajectory.samples.last().map_or(0.0, |s| s.time_s),
    );
    Ok(Resolved {
        robot,
        cell,
        take_s,
        gaps: trajectory.len() - targets.len(),
        targets,
        config,
        free_tool_axis,
    })
}

/// A robot by name, else from a robot file; an unknown name that is no file is a usage error.
pub fn resolve_robot(text: &str) -> anyhow::Result<Robot> {
    if let Some(robot) = Robot::by_name(text) {
        return Ok(robot);
    }
    let path = Path::new(text);
    let looks_like_file = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        || text.contains(std::path::MAIN_SEPARATOR);
    if looks_like_file {
        return teachcam::io::robot::read_robot(path).rejected();
    }
    bail!(
        "--robot {text}: unknown robot (known: {}; or a robot file ending in .json)",
        KNOWN_ROBOTS.join(", ")
    )
}

fn args_path(frames: usize) -> String {
    format!("trajectory of {frames} frames")
}

/// The summary lines of a check: counts, the issues as runs of frames, suggestions.
pub fn summary(report: &CheckReport, gaps: usize, robot: &str) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let failing: Vec<_> = report.failing().collect();
    let _ = writeln!(
        out,
        "{robot}: {} frames checked ({gaps} without a pose), {} unreachable, {} failing, {} near the wrist singularity; peak joint speed {:.0}% of the limit",
        report.frames.len(),
        report.unreachable_count(),
        failing.len(),
        report.near_singular_count(),
        100.0 * report.peak_speed_ratio
    );
    let _ = writeln!(out, "{}", report.timing.describe(robot));
    let speeds: Vec<String> = report
        .peak_joint_speed
        .iter()
        .map(|v| format!("{:.0}", v.to_degrees()))
        .collect();
    let accelerations: Vec<String> = report
        .peak_joint_acceleration
        .iter()
        .map(|v| format!("{:.0}", v.to_degrees()))
        .collect();
    let speeds_measured = report
        .frames
        .windows(2)
        .any(|pair| pair[0].joints.is_some() && pair[1].joints.is_some());
    if speeds_measured {
        let _ = writeln!(
            out,
            "peak joint speeds [{}] deg/s, accelerations [{}] deg/s^2 (axes 1-6)",
            speeds.join(", "),
            accelerations.join(", ")
        );
        for line in teachcam::report::joints::joint_lines(report) {
            let _ = writeln!(out, "  {line}");
        }
    } else {
        let _ = writeln!(
            out,
            "peak joint speeds: none measured (no two consecutive frames have joints)"
        );
    }
    // Runs of frames with the same issue, one line each (a long take out of reach is one
    // line, not one a frame); warnings first.
    let ranges = issue_ranges(report);
    for r in ranges.iter().filter(|r| !r.is_failure()) {
        let _ = writeln!(out, "warning: {r}");
    }
    for r in ranges.iter().filter(|r| r.is_failure()) {
        let _ = writeln!(out, "  {r}");
    }
    for s in &report.suggestions {
        let _ = writeln!(out, "suggestion: {s}");
    }
    out
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the report is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(path) = &args.joints_out {
        let mut inputs = vec![args.trajectory.as_path()];
        inputs.extend(args.cell.tool.as_deref());
        teachcam::io::check_outputs(&[teachcam::io::Output::csv(path)], &inputs)?;
    }
    let resolved = resolve(&args.trajectory, &args.cell)?;
    let CheckedPath {
        targets,
        strokes,
        tool_axis,
        report,
        ..
    } = checked_path(&resolved, &args.strokes)?;
    if let Some(path) = &args.joints_out {
        teachcam::io::write_atomically(path, joints_csv(&report).as_bytes())?;
        crate::announce::wrote(
            std::slice::from_ref(path),
            &format!("joints of {} frames", report.frames.len()),
        );
    }
    println!("{}", strokes_line(&strokes, &args.strokes));
    if let Some(line) = &tool_axis {
        println!("{line}");
    }
    print!("{}", summary(&report, resolved.gaps, &resolved.robot.name));
    let (_, gap_lines, gap_refusal) = args.gaps.judge(&targets, &strokes, args.tolerance_mm);
    print!("{gap_lines}");
    if let Some(refusal) = gap_refusal {
        return Err(anyhow::anyhow!("{}: {refusal}", args.trajectory.display())).rejected();
    }
    if report.passes() {
        println!("ok: the robot can run this trajectory");
        Ok(())
    } else {
        Err(anyhow::anyhow!(
            "{}: {}",
            args.trajectory.display(),
            failure_line(&report)
        ))
        .rejected()
    }
}

/// The targets of `resolved` within `--from`/`--to`, split into strokes, the roll about the
/// tool's axis chosen where it is free, and their check (the library's
/// [`teachcam::robot::checked::checked_path`]): what `check` prints and writes with
/// `--joints-out`, `export` programs, `export mcap` records and `report --robot` draws. A span
/// without a stroke is checked whole, with a warning saying so.
///
/// # Errors
/// A span outside the take (usage, exit 2); fewer than two poses in it (exit 1).
pub fn checked_path(resolved: &Resolved, strokes: &StrokeArgs) -> anyhow::Result<CheckedPath> {
    let path = teachcam::robot::checked::checked_path(
        &resolved.robot,
        &resolved.cell,
        &resolved.targets,
        resolved.take_s,
        &strokes.options(resolved.free_tool_axis),
        &resolved.config,
    )
    .map_err(|e| match e {
        PathError::Span(span) => anyhow::Error::new(span),
        e @ PathError::TooFewPoses => anyhow::Error::new(crate::DataRejected(e.into())),
    })?;
    if let Some(none) = &path.no_stroke {
        crate::announce::warn(&format!(
            "{none}: the whole span is taken as one stroke (is the world's xy-plane the work surface? --lift-mm)"
        ));
    }
    Ok(path)
}

/// Why a failing check fails, in one line: a given time scale too fast for the arm names the
/// axis, the frame and the factor that would fit; otherwise the count of failing frames.
pub fn failure_line(report: &CheckReport) -> String {
    report.time_scale_refusal().unwrap_or_else(|| {
        format!(
            "{} of {} frames fail on the {}",
            report.failing().count(),
            report.frames.len(),
            report.robot.name
        )
    })
}
