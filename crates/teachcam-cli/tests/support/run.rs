//! Running the built `teachcam` binary from the CLI tests: one helper for every test file
//! (`#[path = "support/run.rs"] mod run;`).

use std::process::{Command, Output};

/// Runs `teachcam` with `args` in the current folder and returns what it printed and its status.
pub fn teachcam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(args)
        .output()
        .unwrap()
}
