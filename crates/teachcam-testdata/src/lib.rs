//! Where the tests find the real third-party data (`../shared/data` beside the clone: OpenCV's
//! chessboard photographs, Zhang's data, C3D files...), the reproducers of past wrong answers
//! (`../shared/repro`), and the independent checkers they run programs through
//! (`rapidchecker`). One function serves every test so that they all treat a missing folder or
//! checker the same way: under CI ([`under_ci`]: `CI` is `true`) it is a failure, elsewhere the
//! test says it was skipped and why ([`skipped`]).

pub mod browser;
pub mod cdr;

use std::path::PathBuf;

/// True under CI: the environment variable `CI` is `true` (as CI services set it, and as
/// `.ci/run` exports it). The one rule every skip guard follows.
#[must_use]
pub fn under_ci() -> bool {
    std::env::var("CI").as_deref() == Ok("true")
}

/// A test (or one check of it) that cannot run here because `why`: a failure under CI
/// ([`under_ci`]), elsewhere a line saying it was skipped.
///
/// # Panics
/// Under CI.
#[expect(clippy::print_stderr, reason = "a skipped test says why")]
pub fn skipped(test: &str, why: &str) {
    assert!(
        !under_ci(),
        "{test}: {why} (CI is true, so this is a failure)"
    );
    eprintln!("{test}: skipped: {why}");
}

/// True when `ffmpeg` and `ffprobe` run here; otherwise `test` is [`skipped`] (a failure under
/// CI: `.ci/run` installs them) and the caller returns early.
///
/// # Panics
/// When they are missing under CI.
#[must_use]
pub fn ffmpeg(test: &str) -> bool {
    let found = ["ffmpeg", "ffprobe"].iter().all(|program| {
        std::process::Command::new(program)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    if !found {
        skipped(
            test,
            "ffmpeg/ffprobe not installed (apt-get install ffmpeg; .ci/run installs it)",
        );
    }
    found
}

/// `../shared/data/<folder>` (or the data root for `""`), or `None` when it is missing and not
/// [`under_ci`]; the caller then returns early, its test skipped.
///
/// # Panics
/// When the folder is missing under CI: CI always has the data beside its clone.
#[must_use]
pub fn shared_data(folder: &str) -> Option<PathBuf> {
    shared("data", folder)
}

/// `../shared/repro/<folder>` (a reproducer: its input files and `README.txt`), or `None`
/// when it is missing and not [`under_ci`], as [`shared_data`].
///
/// # Panics
/// When the folder is missing under CI.
#[must_use]
pub fn shared_repro(folder: &str) -> Option<PathBuf> {
    shared("repro", folder)
}

fn shared(kind: &str, folder: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(kind)
        .join(folder);
    if dir.is_dir() {
        return Some(dir);
    }
    skipped(
        &format!("test {kind} folder"),
        &format!("{} is missing", dir.display()),
    );
    None
}

/// The Python that runs `rapidchecker` (PyPI, an independent RAPID parser): the one `.ci/run`
/// installs in a venv and names in `TEACHCAM_RAPIDCHECKER_PYTHON`, else `python3` when it has
/// the package.
fn rapidchecker_python() -> Option<PathBuf> {
    std::env::var_os("TEACHCAM_RAPIDCHECKER_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain([PathBuf::from("python3")])
        .find(|python| {
            std::process::Command::new(python)
                .args(["-m", "rapidchecker", "--help"])
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

/// RAPID modules through `rapidchecker`: `Some(Ok(()))` when it parses every file,
/// `Some(Err(what it printed))` when it refuses one, `None` when it is not installed (`test`
/// then says it skipped the check).
///
/// # Panics
/// When the checker is not installed and `CI` is `true` (`.ci/run` installs it).
#[must_use]
pub fn rapidchecker(test: &str, files: &[PathBuf]) -> Option<Result<(), String>> {
    let Some(python) = rapidchecker_python() else {
        skipped(
            &format!("{test}: RAPID parse"),
            "rapidchecker is not installed (pip install rapidchecker; .ci/run installs it)",
        );
        return None;
    };
    let mut command = std::process::Command::new(python);
    command.args(["-m", "rapidchecker"]).args(files);
    if let Some(dir) = files.first().and_then(|f| f.parent()) {
        command.current_dir(dir);
    }
    Some(match command.output() {
        Ok(out) if out.status.success() => Ok(()),
        Ok(out) => Err(format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )),
        Err(e) => Err(format!("rapidchecker does not run: {e}")),
    })
}

/// The Python with ROS 2's independent readers (PyPI `mcap`, `mcap-ros2-support`, and
/// `cyclonedds` for the DDS test): `TEACHCAM_ROS2_PYTHON` (`.ci/run` sets it), else the venv
/// `.ci/run` makes at `target/ros-venv`, when it imports `module`.
fn ros2_python(module: &str) -> Option<PathBuf> {
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/ros-venv/bin/python");
    std::env::var_os("TEACHCAM_ROS2_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain([venv])
        .find(|python| {
            std::process::Command::new(python)
                .args(["-c", &format!("import {module}")])
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

/// A command running `scripts/<script>` with the ROS 2 readers' Python (arguments and
/// environment left to the caller), or `None` when the readers are not installed (`test` then
/// says it skipped the check).
///
/// # Panics
/// When the readers are not installed and `CI` is `true` (`.ci/run` installs them).
#[must_use]
#[expect(clippy::print_stderr, reason = "a skipped check says why")]
pub fn ros2_command(test: &str, module: &str, script: &str) -> Option<std::process::Command> {
    let Some(python) = ros2_python(module) else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "{test}: the Python module {module} is not installed (.ci/run installs it in target/ros-venv)"
        );
        eprintln!(
            "{test}: skipped: {module} not installed (python3 -m venv target/ros-venv && target/ros-venv/bin/pip install mcap mcap-ros2-support cyclonedds)"
        );
        return None;
    };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scripts")
        .join(script);
    let mut command = std::process::Command::new(python);
    command.arg(path);
    Some(command)
}

/// Runs `scripts/<script>` with the ROS 2 readers' Python: `Some(Ok(stdout))` when it exits
/// 0, `Some(Err(what it printed))` otherwise, `None` when the readers are not installed
/// (`test` then says it skipped the check).
///
/// # Panics
/// When the readers are not installed and `CI` is `true` (`.ci/run` installs them).
#[must_use]
pub fn ros2_script(
    test: &str,
    module: &str,
    script: &str,
    args: &[std::ffi::OsString],
) -> Option<Result<String, String>> {
    let mut command = ros2_command(test, module, script)?;
    let output = command.args(args).output();
    Some(match output {
        Ok(out) if out.status.success() => Ok(String::from_utf8_lossy(&out.stdout).into_owned()),
        Ok(out) => Err(format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )),
        Err(e) => Err(format!("{script} does not run: {e}")),
    })
}
