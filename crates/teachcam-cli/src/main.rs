//! The `teachcam` command: a thin layer over the `teachcam` library.
//!
//! Each subcommand lives in `cmd/<name>.rs` as an `Args` struct (its doc comments are the help
//! text) and a `run` function: parse → resolve files → call the library → write outputs whole.
//! Exit status: 0 success, 1 input data rejected, 2 usage or internal error.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod plot;

/// Program an industrial robot by demonstration: marker tracking with calibrated cameras,
/// trajectory smoothing, robot checks and robot programs (ABB RAPID, KUKA KRL, UR URScript).
#[derive(Debug, Parser)]
#[command(name = "teachcam", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate the paper's setup and run the whole pipeline on it.
    Demo(cmd::demo::Args),
    /// Smooth a trajectory (low-pass, spline, Bezier or NURBS), rotations on SO(3).
    Smooth(cmd::smooth::Args),
    /// Amplitude spectrum of each trajectory component, as CSV or PNG.
    Spectrum(cmd::spectrum::Args),
    /// Rerun the paper's comparison of smoothing methods on sinusoids plus noise.
    SmoothingStudy(cmd::smoothing_study::Args),
}

/// An error whose cause is the user's data (exit status 1), as opposed to usage or internal
/// errors (exit status 2).
#[derive(Debug)]
pub struct DataRejected;

impl std::fmt::Display for DataRejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("input rejected")
    }
}

impl std::error::Error for DataRejected {}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => cmd::demo::run(&args),
        Command::Smooth(args) => cmd::smooth::run(&args),
        Command::Spectrum(args) => cmd::spectrum::run(&args),
        Command::SmoothingStudy(args) => cmd::smoothing_study::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            if error.chain().any(|cause| cause.is::<DataRejected>()) {
                ExitCode::from(1)
            } else {
                ExitCode::from(2)
            }
        }
    }
}
