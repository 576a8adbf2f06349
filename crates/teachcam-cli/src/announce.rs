//! What a command says on stderr when it succeeds: one short block naming the files it wrote
//! and what they hold (frames, moves); `--quiet` silences it. Errors are printed by `main`
//! whatever `--quiet` says.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Set once by `main` from the global `--quiet` flag.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// One line on stderr unless `--quiet`.
#[expect(clippy::print_stderr, reason = "the command's success message")]
pub fn say(line: &str) {
    if !quiet() {
        eprintln!("{line}");
    }
}

/// `warning: what` on stderr, whatever `--quiet` says: a value that is likely wrong, like an
/// error, must be seen.
#[expect(clippy::print_stderr, reason = "the warning is the command's output")]
pub fn warn(what: &str) {
    eprintln!("warning: {what}");
}

/// `wrote A, B, C: what` on stderr unless `--quiet`.
pub fn wrote(paths: &[PathBuf], what: &str) {
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    if what.is_empty() {
        say(&format!("wrote {}", names.join(", ")));
    } else {
        say(&format!("wrote {}: {what}", names.join(", ")));
    }
}
