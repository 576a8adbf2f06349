//! The `teachcam` command: a thin layer over the `teachcam` library.
//!
//! Each subcommand lives in `cmd/<name>.rs` as an `Args` struct (its doc comments are the help
//! text) and a `run` function: parse → resolve files → call the library → write outputs whole.
//! Exit status: 0 success, 1 input data rejected, 2 usage or internal error.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod progress;

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
    /// Write a simulated recording with its ground truth.
    Simulate(cmd::simulate::Args),
    /// Check a trajectory on a robot: reach, joint limits, speeds, singularities.
    Check(cmd::check::Args),
    /// Write a robot program (RAPID, KRL, URScript or CSV) for a trajectory.
    Export(cmd::export::Args),
    /// Align the vision frame with the robot's base from points known in both.
    Align(cmd::align::Args),
    /// Pivot calibration of the tool centre point.
    Pivot(cmd::pivot::Args),
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
        Command::Simulate(args) => cmd::simulate::run(&args),
        Command::Check(args) => cmd::check::run(&args),
        Command::Export(args) => cmd::export::run(&args),
        Command::Align(args) => cmd::align::run(&args),
        Command::Pivot(args) => cmd::pivot::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            // `chain()` yields context layers as anyhow's wrapper type, so a `DataRejected`
            // given as context is found by `downcast_ref`, not by `is`.
            if error.downcast_ref::<DataRejected>().is_some()
                || error.chain().any(|cause| cause.is::<DataRejected>())
            {
                ExitCode::from(1)
            } else {
                ExitCode::from(2)
            }
        }
    }
}
