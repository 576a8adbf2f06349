//! The `teachcam` command: a thin layer over the `teachcam` library.
//!
//! Each subcommand lives in `cmd/<name>.rs` as an `Args` struct (its doc comments are the help
//! text) and a `run` function: parse → resolve files → call the library → write outputs whole.
//! Exit status: 0 success, 1 input data rejected, 2 usage (flags and flag values, output paths)
//! or internal error, 3 the tool was not found in any frame (`track`, `import`), 130
//! interrupted by SIGINT, 143 by SIGTERM (the temporaries of unfinished outputs are removed
//! first; `signals`, ARCHITECTURE.md, "Outputs and exit codes").

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

mod announce;
mod capture;
mod cmd;
mod flags;
mod load;
mod plot;
mod progress;
mod recording;
mod ros2_live;
mod signals;

/// The whole path on simulated data, from an empty folder; every command's own examples
/// (`teachcam COMMAND --help`) run in the folder these leave behind.
const EXAMPLES: &str = r#"Examples:
  teachcam demo
  teachcam simulate --scenario paper --out rec
  teachcam track rec --rig rec/rig.json --tool rec/tool.json -o raw.csv --markers-out markers.csv
  teachcam smooth raw.csv --method lowpass --cutoff 10 -o smooth.csv
  teachcam check smooth.csv --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0"
  teachcam export rapid smooth.csv --robot irb120 --wobj "350,0,100,1,0,0,0" --tcp "0,0,200,0,1,0,0" -o stroke.mod

Every command's examples (`teachcam COMMAND --help`) run in the folder these leave behind."#;

/// Program an industrial robot by demonstration: marker tracking with calibrated cameras,
/// trajectory smoothing, robot checks and robot programs (ABB RAPID, KUKA KRL, UR URScript).
#[derive(Debug, Parser)]
#[command(name = "teachcam", version, about, long_about = None, after_help = EXAMPLES)]
struct Cli {
    /// Print nothing on success (errors are still printed).
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    Demo(cmd::demo::Args),
    Report(cmd::report::Args),
    Simulate(cmd::simulate::Args),
    Detect(cmd::detect::Args),
    Repeatability(cmd::repeatability::Args),
    Track(cmd::track::Args),
    Record(cmd::record::Args),
    Live(cmd::live::Args),
    Studio(cmd::studio::Args),
    Doctor(cmd::doctor::Args),
    Calibrate(cmd::calibrate::Args),
    Uncertainty(cmd::uncertainty::Args),
    UncertaintyMap(cmd::uncertainty_map::Args),
    ToolCheck(cmd::tool_check::Args),
    C3d(cmd::c3d::Args),
    Import(cmd::import::Args),
    Smooth(cmd::smooth::Args),
    Spectrum(cmd::spectrum::Args),
    SmoothingStudy(cmd::smoothing_study::Args),
    Check(cmd::check::Args),
    Export(cmd::export::Args),
    Replay(cmd::replay::Args),
    Strokes(cmd::strokes::Args),
    Align(cmd::align::Args),
    Pivot(cmd::pivot::Args),
}

/// An error whose cause is the user's data (exit status 1), as opposed to usage or internal
/// errors (exit status 2). Its message is the wrapped error's, on one line.
#[derive(Debug)]
pub struct DataRejected(pub anyhow::Error);

impl std::fmt::Display for DataRejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:#}", self.0)
    }
}

impl std::error::Error for DataRejected {}

/// The tool was not found in any frame (exit status 3).
#[derive(Debug)]
pub struct ToolNotFound(pub String);

impl std::fmt::Display for ToolNotFound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ToolNotFound {}

/// Marks a failure as the user's data being rejected (exit status 1).
pub trait Rejected<T> {
    /// The same result, its error marked as rejected data.
    fn rejected(self) -> anyhow::Result<T>;
}

impl<T, E: Into<anyhow::Error>> Rejected<T> for Result<T, E> {
    fn rejected(self) -> anyhow::Result<T> {
        self.map_err(|e| anyhow::Error::new(DataRejected(e.into())))
    }
}

/// Prints clap's error on one line (its tip kept, its usage block left to `--help`) and exits 2;
/// help and version print as clap does.
#[expect(
    clippy::print_stderr,
    reason = "the usage error is the command's output"
)]
fn usage_error(error: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        error.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        error.exit();
    }
    let text = error.render().to_string();
    let mut blocks = text.split("\n\n");
    let mut line: Vec<&str> = blocks
        .next()
        .unwrap_or_default()
        .lines()
        .map(str::trim)
        .collect();
    line.extend(
        blocks
            .flat_map(str::lines)
            .map(str::trim)
            .filter(|l| l.starts_with("tip:")),
    );
    eprintln!("{}", line.join(" "));
    ExitCode::from(2)
}

/// The message with control characters escaped (`\n`, `\u{1b}`), so that it stays one line
/// whatever a file's labels hold.
fn one_line(message: &str) -> String {
    message
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// Every flag that takes a value takes a negative number as that value (`--cutoff -3` reaches the
/// flag's own range message rather than clap's "unexpected argument '-3'").
fn negative_numbers(command: clap::Command) -> clap::Command {
    command
        .mut_args(|arg| {
            if arg.get_action().takes_values() {
                arg.allow_negative_numbers(true)
            } else {
                arg
            }
        })
        .mut_subcommands(negative_numbers)
}

fn main() -> ExitCode {
    let parsed = negative_numbers(Cli::command())
        .try_get_matches()
        .and_then(|matches| Cli::from_arg_matches(&matches));
    let cli = match parsed {
        Ok(cli) => cli,
        Err(error) => return usage_error(&error),
    };
    announce::set_quiet(cli.quiet);
    // `record`, `live` and `studio` end on Ctrl-C or SIGTERM by finishing the frame set in
    // hand; every other command removes the temporaries of unfinished outputs and exits 130
    // (SIGINT) or 143 (SIGTERM) with one line.
    let capture = matches!(
        cli.command,
        Command::Record(_) | Command::Live(_) | Command::Studio(_)
    );
    signals::handle(capture);
    let result = match cli.command {
        Command::Demo(args) => cmd::demo::run(&args),
        Command::Report(args) => cmd::report::run(&args),
        Command::Simulate(args) => cmd::simulate::run(&args),
        Command::Detect(args) => cmd::detect::run(&args),
        Command::Repeatability(args) => cmd::repeatability::run(&args),
        Command::Track(args) => cmd::track::run(&args),
        Command::Record(args) => cmd::record::run(&args),
        Command::Live(args) => cmd::live::run(&args),
        Command::Studio(args) => cmd::studio::run(&args),
        Command::Doctor(args) => cmd::doctor::run(&args),
        Command::Calibrate(args) => cmd::calibrate::run(&args),
        Command::Uncertainty(args) => cmd::uncertainty::run(&args),
        Command::UncertaintyMap(args) => cmd::uncertainty_map::run(&args),
        Command::ToolCheck(args) => cmd::tool_check::run(&args),
        Command::C3d(args) => cmd::c3d::run(&args),
        Command::Import(args) => cmd::import::run(&args),
        Command::Smooth(args) => cmd::smooth::run(&args),
        Command::Spectrum(args) => cmd::spectrum::run(&args),
        Command::SmoothingStudy(args) => cmd::smoothing_study::run(&args),
        Command::Check(args) => cmd::check::run(&args),
        Command::Export(args) => cmd::export::run(&args),
        Command::Replay(args) => cmd::replay::run(&args),
        Command::Strokes(args) => cmd::strokes::run(&args),
        Command::Align(args) => cmd::align::run(&args),
        Command::Pivot(args) => cmd::pivot::run(&args),
    };
    match result {
        Ok(()) if capture => signals::capture_exit(),
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", one_line(&format!("{error:#}")));
            if error
                .chain()
                .any(|cause| cause.downcast_ref::<ToolNotFound>().is_some())
            {
                ExitCode::from(3)
            } else if error
                .chain()
                .any(|cause| cause.downcast_ref::<DataRejected>().is_some())
            {
                ExitCode::from(1)
            } else {
                ExitCode::from(2)
            }
        }
    }
}
