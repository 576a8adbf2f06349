//! Where the tests find the real third-party data (`../shared/data` beside the clone: OpenCV's
//! chessboard photographs, Zhang's data, C3D files...) and the reproducers of past wrong
//! answers (`../shared/repro`). One function serves every test so that they all treat a
//! missing folder the same way: under CI (`CI` set) it is a failure, elsewhere the test says it
//! was skipped and why.

use std::path::PathBuf;

/// `../shared/data/<folder>` (or the data root for `""`), or `None` when it is missing and
/// `CI` is not set; the caller then returns early, its test skipped.
///
/// # Panics
/// When the folder is missing and `CI` is set: CI always has the data beside its clone.
#[must_use]
pub fn shared_data(folder: &str) -> Option<PathBuf> {
    shared("data", folder)
}

/// `../shared/repro/<folder>` (a reproducer: its input files and `README.txt`), or `None`
/// when it is missing and `CI` is not set, as [`shared_data`].
///
/// # Panics
/// When the folder is missing and `CI` is set.
#[must_use]
pub fn shared_repro(folder: &str) -> Option<PathBuf> {
    shared("repro", folder)
}

#[expect(clippy::print_stderr, reason = "a skipped test says why")]
fn shared(kind: &str, folder: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(kind)
        .join(folder);
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "test {kind} folder {} is missing (CI is set, so this is a failure)",
        dir.display()
    );
    eprintln!("skipped: test {kind} folder {} is missing", dir.display());
    None
}
