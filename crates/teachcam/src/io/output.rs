//! Output sets written all or nothing, and the checks of an output path made before any work.
//!
//! A command that writes several files (a trajectory, its markers and diagnostics; a KRL `.src`
//! and its `.dat`) stages them in one [`OutputSet`]:
//! ```text
//! add(target, bytes)  → `.NAME.teachcam-tmp-PID` beside the target, written, flushed, synced
//! commit()            → every temporary renamed over its target (rename(2) in one folder is atomic)
//! dropped uncommitted → every temporary removed; no target changed
//! ```
//! A failure before the renames (a missing folder, a full disk, a target that is a folder)
//! leaves every target as it was. A rename that fails part way (only possible when the folder
//! changes under the command) puts back the targets already replaced, from hard links made
//! before the first rename.
//!
//! Interrupts: the library handles no signals. Every temporary is listed, from just before it is
//! created until it is renamed or removed, in a process-wide registry; the binary's SIGINT/SIGTERM
//! handler calls [`remove_live_temporaries`]. The renames of a commit hold the registry, so an
//! interrupt lands before or after them, never between two of them. SIGKILL cannot be caught:
//! its temporaries stay, named `.NAME.teachcam-tmp-PID`, and the next output set that writes
//! into the same folder removes those whose process is gone (Linux, through `/proc/PID`; other
//! systems keep them).

use std::ffi::OsString;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

use super::FileError;

/// What a temporary's name holds between the target's name and the process id.
const TEMPORARY_MARK: &str = ".teachcam-tmp-";

/// Temporaries of this process not yet renamed or removed (see the module docs).
static LIVE_TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_temporaries() -> MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while the list was held leaves it valid: paths are pushed and removed
    // whole.
    LIVE_TEMPORARIES
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
}

/// Removes every temporary this process has not yet renamed or removed; returns how many
/// existed. For the binary's interrupt handler; safe to call from any thread at any time.
pub fn remove_live_temporaries() -> usize {
    live_temporaries()
        .drain(..)
        .filter(|t| remove_path(t).is_ok())
        .count()
}

/// Removes a file, or a folder with everything in it.
fn remove_path(path: &Path) -> std::io::Result<()> {
    if path.is_dir() {
        std::fs::remove_dir_all(path)
    } else {
        std::fs::remove_file(path)
    }
}

/// `.NAME.teachcam-tmp-PID` beside `target`.
fn temporary_beside(target: &Path, file_name: &std::ffi::OsStr) -> PathBuf {
    let mut temporary_name = OsString::from(".");
    temporary_name.push(file_name);
    temporary_name.push(format!("{TEMPORARY_MARK}{}", std::process::id()));
    folder_of(target).join(temporary_name)
}

/// One staged file: the temporary holding the complete contents, and where it goes.
#[derive(Debug)]
struct Staged {
    target: PathBuf,
    temporary: PathBuf,
}

/// Files written together: all of them or none (see the module docs). Safe to fill from
/// several threads; dropping it without [`OutputSet::commit`] removes its temporaries.
#[derive(Debug, Default)]
pub struct OutputSet {
    staged: Mutex<Vec<Staged>>,
    /// Folders already swept for stale temporaries.
    swept: Mutex<Vec<PathBuf>>,
}

/// The folder a path's file is in (`.` for a bare file name).
#[must_use]
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn write_error(path: &Path, source: std::io::Error) -> FileError {
    FileError::Write {
        path: path.to_path_buf(),
        source,
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

impl OutputSet {
    /// An empty set.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `contents` whole to a temporary beside `target`; the target itself is replaced
    /// only by [`OutputSet::commit`].
    ///
    /// # Errors
    /// [`FileError::Write`] naming `target`: its folder is missing or not writable, it is a
    /// folder, the set already holds it, or the disk refused the bytes.
    pub fn add(&self, target: &Path, contents: &[u8]) -> Result<(), FileError> {
        self.add_written(target, |file| file.write_all(contents))
    }

    /// As [`OutputSet::add`], the contents written by `write` into the temporary (an
    /// unbuffered file: write it in large pieces); an error from `write` leaves no temporary.
    ///
    /// # Errors
    /// As [`OutputSet::add`], and what `write` returns.
    pub fn add_written(
        &self,
        target: &Path,
        write: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>,
    ) -> Result<(), FileError> {
        let err = |source| write_error(target, source);
        let file_name = target
            .file_name()
            .ok_or_else(|| err(std::io::Error::other("no file name")))?;
        if target.is_dir() {
            return Err(err(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "it is a folder",
            )));
        }
        let folder = folder_of(target);
        if lock(&self.staged).iter().any(|s| s.target == target) {
            return Err(err(std::io::Error::other(
                "written twice by one command (give the outputs different names)",
            )));
        }
        self.sweep_stale(&folder);
        let temporary = temporary_beside(target, file_name);
        // Listed before it exists, so that an interrupt from here on removes it.
        live_temporaries().push(temporary.clone());
        let written = (|| {
            let mut file = std::fs::File::create(&temporary)?;
            write(&mut file)?;
            file.sync_all()
        })();
        if let Err(source) = written {
            forget_temporary(&temporary);
            // Best effort: the temporary does not exist when its creation failed.
            let _ = std::fs::remove_file(&temporary);
            return Err(err(source));
        }
        lock(&self.staged).push(Staged {
            target: target.to_path_buf(),
            temporary,
        });
        Ok(())
    }

    /// The targets staged so far, in the order they were added.
    #[must_use]
    pub fn targets(&self) -> Vec<PathBuf> {
        lock(&self.staged)
            .iter()
            .map(|s| s.target.clone())
            .collect()
    }

    /// Renames every temporary over its target; returns the targets written, in the order they
    /// were added.
    ///
    /// # Errors
    /// [`FileError::Write`] naming the target whose rename failed; the targets replaced before it
    /// are put back and every temporary is removed.
    pub fn commit(self) -> Result<Vec<PathBuf>, FileError> {
        let staged = std::mem::take(&mut *lock(&self.staged));
        // Held through the renames: an interrupt waits for them (see the module docs).
        let mut live = live_temporaries();
        let backups: Vec<Option<PathBuf>> = staged
            .iter()
            .map(|s| {
                let mut name = s.temporary.clone().into_os_string();
                name.push(".old");
                let backup = PathBuf::from(name);
                std::fs::hard_link(&s.target, &backup).ok().map(|()| backup)
            })
            .collect();
        let mut failure = None;
        for (done, s) in staged.iter().enumerate() {
            if let Err(source) = std::fs::rename(&s.temporary, &s.target) {
                failure = Some((done, write_error(&s.target, source)));
                break;
            }
        }
        if let Some((done, _)) = &failure {
            for (s, backup) in staged.iter().zip(&backups).take(*done) {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, &s.target);
                    }
                    // There was no previous file: the set leaves none.
                    None => {
                        let _ = std::fs::remove_file(&s.target);
                    }
                }
            }
            for s in &staged[*done..] {
                let _ = std::fs::remove_file(&s.temporary);
            }
        }
        for backup in backups.iter().flatten() {
            let _ = std::fs::remove_file(backup);
        }
        live.retain(|t| !staged.iter().any(|s| &s.temporary == t));
        drop(live);
        match failure {
            Some((_, error)) => Err(error),
            None => Ok(staged.into_iter().map(|s| s.target).collect()),
        }
    }

    /// Removes, once per folder, temporaries left in `folder` by a process that no longer runs.
    fn sweep_stale(&self, folder: &Path) {
        {
            let mut swept = lock(&self.swept);
            if swept.iter().any(|f| f == folder) {
                return;
            }
            swept.push(folder.to_path_buf());
        }
        sweep_stale(folder);
    }
}

/// Removes the temporaries (files or staged folders) left in `folder` by a process that no
/// longer runs.
fn sweep_stale(folder: &Path) {
    // Without /proc a process's end cannot be told: keep every temporary.
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name();
        let Some(pid) = stale_owner(&name.to_string_lossy()) else {
            continue;
        };
        if pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = remove_path(&entry.path());
        }
    }
}

/// The process id in a temporary's name `.NAME.teachcam-tmp-PID` (or its backup `...PID.old`).
fn stale_owner(name: &str) -> Option<u32> {
    if !name.starts_with('.') {
        return None;
    }
    let (_, rest) = name.rsplit_once(TEMPORARY_MARK)?;
    rest.strip_suffix(".old").unwrap_or(rest).parse().ok()
}

fn forget_temporary(temporary: &Path) {
    live_temporaries().retain(|t| t != temporary);
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        let staged = std::mem::take(&mut *lock(&self.staged));
        let mut live = live_temporaries();
        for s in &staged {
            let _ = std::fs::remove_file(&s.temporary);
        }
        live.retain(|t| !staged.iter().any(|s| &s.temporary == t));
    }
}

/// A folder of outputs written all or nothing (a simulated recording: thousands of frames and
/// their truth). Everything is written into a staging folder `.NAME.teachcam-tmp-PID` beside the
/// target; [`StagedFolder::commit`] renames it to the target or, when the target folder exists,
/// renames each staged entry over its namesake there (the old ones kept until every rename has
/// succeeded, then removed; put back if one fails). Dropped uncommitted, or interrupted, the
/// staging folder is removed and the target is as it was: never a mix of old and new frames.
#[derive(Debug)]
pub struct StagedFolder {
    target: PathBuf,
    staging: PathBuf,
    committed: bool,
}

impl StagedFolder {
    /// Creates the staging folder beside `target` (and `target`'s missing parent folders).
    ///
    /// # Errors
    /// [`FileError::Write`] naming `target`: it is a file, or its folder cannot be written.
    pub fn new(target: &Path) -> Result<Self, FileError> {
        let err = |source| write_error(target, source);
        let file_name = target
            .file_name()
            .ok_or_else(|| err(std::io::Error::other("no folder name")))?;
        if target.exists() && !target.is_dir() {
            return Err(err(std::io::Error::new(
                std::io::ErrorKind::NotADirectory,
                "it is a file, not a folder",
            )));
        }
        let parent = folder_of(target);
        std::fs::create_dir_all(&parent).map_err(err)?;
        sweep_stale(&parent);
        let staging = temporary_beside(target, file_name);
        live_temporaries().push(staging.clone());
        if staging.exists() {
            // This process's own leftover (a staging folder of an earlier set in this run).
            let _ = std::fs::remove_dir_all(&staging);
        }
        if let Err(source) = std::fs::create_dir(&staging) {
            forget_temporary(&staging);
            return Err(err(source));
        }
        Ok(Self {
            target: target.to_path_buf(),
            staging,
            committed: false,
        })
    }

    /// Where to write the outputs.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Puts the staged outputs in place (see the type's docs); returns the target.
    ///
    /// # Errors
    /// [`FileError::Write`] naming what could not be renamed; the target is then as it was.
    pub fn commit(mut self) -> Result<PathBuf, FileError> {
        // Held through the renames: an interrupt waits for them (see the module docs).
        let mut live = live_temporaries();
        let result = if self.target.is_dir() {
            self.merge_into_target()
        } else {
            std::fs::rename(&self.staging, &self.target)
                .map_err(|source| write_error(&self.target, source))
        };
        if result.is_ok() {
            self.committed = true;
            live.retain(|t| t != &self.staging);
        }
        drop(live);
        result.map(|()| self.target.clone())
    }

    /// Renames every staged entry over its namesake in the existing target folder.
    fn merge_into_target(&self) -> Result<(), FileError> {
        let entries: Vec<std::ffi::OsString> = std::fs::read_dir(&self.staging)
            .map_err(|source| write_error(&self.staging, source))?
            .filter_map(Result::ok)
            .map(|e| e.file_name())
            .collect();
        // (destination, backup of what it held)
        let mut done: Vec<(PathBuf, Option<PathBuf>)> = Vec::new();
        let mut failure = None;
        for name in &entries {
            let destination = self.target.join(name);
            let backup = if destination.exists() {
                let mut b = temporary_beside(&destination, name).into_os_string();
                b.push(".old");
                let b = PathBuf::from(b);
                if let Err(source) = std::fs::rename(&destination, &b) {
                    failure = Some(write_error(&destination, source));
                    break;
                }
                Some(b)
            } else {
                None
            };
            if let Err(source) = std::fs::rename(self.staging.join(name), &destination) {
                if let Some(b) = &backup {
                    let _ = std::fs::rename(b, &destination);
                }
                failure = Some(write_error(&destination, source));
                break;
            }
            done.push((destination, backup));
        }
        if let Some(error) = failure {
            for (destination, backup) in done.iter().rev() {
                let _ = std::fs::rename(
                    destination,
                    self.staging
                        .join(destination.file_name().unwrap_or_default()),
                );
                if let Some(b) = backup {
                    let _ = std::fs::rename(b, destination);
                }
            }
            return Err(error);
        }
        for (_, backup) in &done {
            if let Some(b) = backup {
                let _ = remove_path(b);
            }
        }
        let _ = std::fs::remove_dir_all(&self.staging);
        Ok(())
    }
}

impl Drop for StagedFolder {
    fn drop(&mut self) {
        if !self.committed {
            let mut live = live_temporaries();
            let _ = std::fs::remove_dir_all(&self.staging);
            live.retain(|t| t != &self.staging);
        }
    }
}

/// Why an output path is refused before any work.
#[derive(Debug, thiserror::Error)]
pub enum OutputPathError {
    /// The output's folder does not exist or is not a folder.
    #[error("cannot write {}: the folder {} does not exist", path.display(), folder.display())]
    MissingFolder {
        /// The output.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
    },
    /// The output is an existing folder.
    #[error("cannot write {}: it is a folder", path.display())]
    IsFolder {
        /// The output.
        path: PathBuf,
    },
    /// The output is one of the command's inputs.
    #[error("{}: the output is also an input (writing it would destroy the input); choose another name", path.display())]
    IsAnInput {
        /// The output.
        path: PathBuf,
    },
    /// Two outputs of one command are the same file.
    #[error("{}: given as two different outputs", path.display())]
    Repeated {
        /// The output.
        path: PathBuf,
    },
    /// The output's extension names another format than the one written.
    #[error("{}: .{extension} names another format; this writes {format} ({expected})", path.display())]
    WrongExtension {
        /// The output.
        path: PathBuf,
        /// Its extension.
        extension: String,
        /// What is written.
        format: String,
        /// The extensions accepted, `.a or .b`.
        expected: String,
    },
}

/// Extensions of formats users meet around teachcam; an output ending in one of these that
/// is not its own format's is refused (an unknown or missing extension is the user's choice).
const KNOWN_EXTENSIONS: [&str; 20] = [
    "csv", "tsv", "txt", "json", "yaml", "yml", "png", "jpg", "jpeg", "svg", "pdf", "html", "htm",
    "mod", "modx", "prg", "src", "dat", "script", "c3d",
];

/// One output of a command: where, and which format it is.
#[derive(Debug, Clone, Copy)]
pub struct Output<'a> {
    /// Where it goes.
    pub path: &'a Path,
    /// What it is, for the message (`"trajectory CSV"`).
    pub format: &'a str,
    /// Its format's extensions, lowercase without the dot (`["csv"]`); empty accepts any.
    pub extensions: &'a [&'a str],
}

impl<'a> Output<'a> {
    /// A CSV table.
    #[must_use]
    pub fn csv(path: &'a Path) -> Self {
        Self {
            path,
            format: "CSV",
            extensions: &["csv"],
        }
    }
}

/// Checks a command's outputs before any work: each one's folder exists, none is a folder, none
/// is one of `inputs` (the same file under any name), no two are the same, and none ends in the
/// extension of another format than its own.
///
/// # Errors
/// [`OutputPathError`] for the first output refused.
pub fn check_outputs(outputs: &[Output<'_>], inputs: &[&Path]) -> Result<(), OutputPathError> {
    let inputs: Vec<PathBuf> = inputs
        .iter()
        .filter_map(|p| std::fs::canonicalize(p).ok())
        .collect();
    let mut seen: Vec<PathBuf> = Vec::new();
    for output in outputs {
        let path = output.path;
        if path.is_dir() {
            return Err(OutputPathError::IsFolder {
                path: path.to_path_buf(),
            });
        }
        let folder = folder_of(path);
        if !folder.is_dir() {
            return Err(OutputPathError::MissingFolder {
                path: path.to_path_buf(),
                folder,
            });
        }
        if let Some(extension) = path.extension().map(|e| e.to_string_lossy().to_lowercase())
            && !output.extensions.is_empty()
            && !output.extensions.contains(&extension.as_str())
            && KNOWN_EXTENSIONS.contains(&extension.as_str())
        {
            let expected: Vec<String> = output.extensions.iter().map(|e| format!(".{e}")).collect();
            return Err(OutputPathError::WrongExtension {
                path: path.to_path_buf(),
                extension,
                format: output.format.to_string(),
                expected: expected.join(" or "),
            });
        }
        // The same file under any spelling: the folder resolved, the name kept.
        let resolved = std::fs::canonicalize(&folder)
            .map(|f| f.join(path.file_name().unwrap_or_default()))
            .unwrap_or_else(|_| path.to_path_buf());
        let resolved = std::fs::canonicalize(&resolved).unwrap_or(resolved);
        if inputs.contains(&resolved) {
            return Err(OutputPathError::IsAnInput {
                path: path.to_path_buf(),
            });
        }
        if seen.contains(&resolved) {
            return Err(OutputPathError::Repeated {
                path: path.to_path_buf(),
            });
        }
        seen.push(resolved);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(folder: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_staged_folder_appears_whole_on_commit_and_not_at_all_when_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        let staged = StagedFolder::new(&target).unwrap();
        std::fs::create_dir(staged.path().join("cam0")).unwrap();
        std::fs::write(staged.path().join("cam0/000000.png"), "frame").unwrap();
        assert!(!target.exists(), "the target exists before commit");
        assert_eq!(staged.commit().unwrap(), target);
        assert_eq!(names(dir.path()), ["rec"]);
        assert_eq!(names(&target.join("cam0")), ["000000.png"]);

        let other = dir.path().join("other");
        let staged = StagedFolder::new(&other).unwrap();
        std::fs::write(staged.path().join("truth.csv"), "half").unwrap();
        drop(staged);
        assert_eq!(
            names(dir.path()),
            ["rec"],
            "a dropped folder left something"
        );
    }

    #[test]
    fn a_staged_folder_replaces_an_existing_folders_entries_and_keeps_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        std::fs::create_dir_all(target.join("cam0")).unwrap();
        for frame in ["000000.png", "000001.png", "000002.png"] {
            std::fs::write(target.join("cam0").join(frame), "old").unwrap();
        }
        std::fs::write(target.join("rig.json"), "old rig").unwrap();
        std::fs::write(target.join("notes.txt"), "the user's").unwrap();
        let staged = StagedFolder::new(&target).unwrap();
        std::fs::create_dir(staged.path().join("cam0")).unwrap();
        std::fs::write(staged.path().join("cam0/000000.png"), "new").unwrap();
        std::fs::write(staged.path().join("rig.json"), "new rig").unwrap();
        assert_eq!(std::fs::read(target.join("rig.json")).unwrap(), b"old rig");
        staged.commit().unwrap();
        // One new frame, not the new one beside two old ones.
        assert_eq!(names(&target.join("cam0")), ["000000.png"]);
        assert_eq!(
            std::fs::read(target.join("cam0/000000.png")).unwrap(),
            b"new"
        );
        assert_eq!(std::fs::read(target.join("rig.json")).unwrap(), b"new rig");
        assert_eq!(names(&target), ["cam0", "notes.txt", "rig.json"]);
        assert_eq!(names(dir.path()), ["rec"], "the staging folder is left");
    }

    #[test]
    fn a_staged_folder_refuses_a_file_as_its_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("rec");
        std::fs::write(&target, "a file").unwrap();
        let error = StagedFolder::new(&target).unwrap_err().to_string();
        assert!(error.contains("rec"), "{error}");
        assert_eq!(names(dir.path()), ["rec"]);
    }

    #[test]
    fn a_set_replaces_every_target_on_commit_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
        std::fs::write(&a, "old a").unwrap();
        let set = OutputSet::new();
        set.add(&a, b"new a").unwrap();
        set.add(&b, b"new b").unwrap();
        assert_eq!(
            std::fs::read(&a).unwrap(),
            b"old a",
            "replaced before commit"
        );
        assert_eq!(set.commit().unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(std::fs::read(&a).unwrap(), b"new a");
        assert_eq!(std::fs::read(&b).unwrap(), b"new b");
        assert_eq!(names(dir.path()), ["a.csv", "b.csv"]);
    }

    #[test]
    fn a_failed_add_leaves_every_target_as_it_was_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        std::fs::write(&a, "old a").unwrap();
        let missing = dir.path().join("nodir").join("diag.csv");
        let set = OutputSet::new();
        set.add(&a, b"new a").unwrap();
        let message = set.add(&missing, b"x").unwrap_err().to_string();
        assert!(message.contains("diag.csv"), "{message}");
        drop(set);
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert_eq!(names(dir.path()), ["a.csv"]);
    }

    #[test]
    fn a_target_that_is_a_folder_is_refused_before_anything_is_renamed() {
        let dir = tempfile::tempdir().unwrap();
        let src = dir.path().join("q.src");
        std::fs::create_dir(&src).unwrap();
        let set = OutputSet::new();
        set.add(&dir.path().join("q.dat"), b"dat").unwrap();
        assert!(set.add(&src, b"src").is_err());
        drop(set);
        assert_eq!(names(dir.path()), ["q.src"]);
    }

    #[test]
    fn a_failed_rename_puts_back_the_targets_already_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
        std::fs::write(&a, "old a").unwrap();
        let set = OutputSet::new();
        set.add(&a, b"new a").unwrap();
        set.add(&b, b"new b").unwrap();
        // The folder changes under the command: b becomes a non-empty folder.
        std::fs::create_dir(&b).unwrap();
        std::fs::write(b.join("x"), "x").unwrap();
        let message = set.commit().unwrap_err().to_string();
        assert!(message.contains("b.csv"), "{message}");
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert_eq!(names(dir.path()), ["a.csv", "b.csv"]);
    }

    #[test]
    fn stale_owner_reads_the_pid_of_temporaries_and_backups_only() {
        assert_eq!(stale_owner(".raw.csv.teachcam-tmp-42"), Some(42));
        assert_eq!(stale_owner(".raw.csv.teachcam-tmp-42.old"), Some(42));
        assert_eq!(stale_owner("raw.csv.teachcam-tmp-42"), None);
        assert_eq!(stale_owner(".raw.csv"), None);
    }

    #[test]
    fn outputs_are_checked_before_any_work() {
        let dir = tempfile::tempdir().unwrap();
        let raw = dir.path().join("raw.csv");
        std::fs::write(&raw, "x").unwrap();
        let csv = |path| Output {
            path,
            format: "trajectory CSV",
            extensions: &["csv"],
        };
        let same = dir.path().join(".").join("raw.csv");
        let e = check_outputs(&[csv(&same)], &[&raw]).unwrap_err();
        assert!(matches!(e, OutputPathError::IsAnInput { .. }), "{e}");
        let svg = dir.path().join("x.svg");
        let e = check_outputs(&[csv(&svg)], &[&raw]).unwrap_err();
        assert!(e.to_string().contains(".svg names another format"), "{e}");
        let missing = dir.path().join("nodir").join("x.csv");
        let e = check_outputs(&[csv(&missing)], &[]).unwrap_err();
        assert!(matches!(e, OutputPathError::MissingFolder { .. }), "{e}");
        let e = check_outputs(&[csv(dir.path())], &[]).unwrap_err();
        assert!(matches!(e, OutputPathError::IsFolder { .. }), "{e}");
        let out = dir.path().join("out.csv");
        let e = check_outputs(&[csv(&out), csv(&out)], &[]).unwrap_err();
        assert!(matches!(e, OutputPathError::Repeated { .. }), "{e}");
        let unknown = dir.path().join("out.trajectory");
        check_outputs(&[csv(&out), csv(&unknown)], &[&raw]).unwrap();
    }
}
