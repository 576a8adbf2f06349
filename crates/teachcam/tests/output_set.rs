//! `io::OutputSet`'s process-wide registry of live temporaries, alone in its test binary:
//! [`remove_live_temporaries`] removes every temporary of the process, which would race with
//! other tests writing files in the same process.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails on the first unexpected error"
)]

use std::path::Path;

use teachcam::io::OutputSet;
use teachcam::io::output::remove_live_temporaries;

fn names(folder: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn live_temporaries_are_removed_on_request_and_stale_ones_by_the_next_set() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("raw.csv");
    let set = OutputSet::new();
    set.add(&target, b"x").unwrap();
    let own = format!(".raw.csv.teachcam-tmp-{}", std::process::id());
    assert_eq!(names(dir.path()), [own]);
    assert_eq!(remove_live_temporaries(), 1);
    assert!(names(dir.path()).is_empty());
    drop(set);
    // A temporary left by a process that is gone (pid 0 names no user process) and its backup.
    std::fs::write(
        dir.path().join(".raw.csv.teachcam-tmp-0"),
        "left by SIGKILL",
    )
    .unwrap();
    std::fs::write(dir.path().join(".raw.csv.teachcam-tmp-0.old"), "old").unwrap();
    // Another file whose name only looks alike is kept.
    std::fs::write(dir.path().join("notes.teachcam-tmp-0"), "user's").unwrap();
    let set = OutputSet::new();
    set.add(&target, b"y").unwrap();
    set.commit().unwrap();
    assert_eq!(names(dir.path()), ["notes.teachcam-tmp-0", "raw.csv"]);
    assert_eq!(std::fs::read(&target).unwrap(), b"y");
}
