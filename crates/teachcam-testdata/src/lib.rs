//! Where the tests find the real third-party data (`../shared/data` beside the clone: OpenCV's
//! chessboard photographs, Zhang's data, C3D files...). One function serves every test so that
//! they all treat a missing folder the same way: under CI (`CI` set) it is a failure, elsewhere
//! the test says it was skipped and why.

use std::path::PathBuf;

/// `../shared/data/<folder>` (or the data root for `""`), or `None` when it is missing and
/// `CI` is not set; the caller then returns early, its test skipped.
///
/// # Panics
/// When the folder is missing and `CI` is set: CI always has the data beside its clone.
#[must_use]
#[expect(clippy::print_stderr, reason = "a skipped test says why")]
pub fn shared_data(folder: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(folder);
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "test data folder {} is missing (CI is set, so this is a failure)",
        dir.display()
    );
    eprintln!("skipped: test data folder {} is missing", dir.display());
    None
}
