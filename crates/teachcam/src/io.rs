//! File formats of the user-facing contract (`CONTRACT.md`): rig and tool JSON, recording
//! folders, detections and trajectory CSV. Every reader checks what it reads and names the file and the field
//! (or line) it refuses; every writer writes a whole file or nothing (a temporary file in the
//! same folder, renamed over the target once complete), and a command's several files all or
//! none ([`output`]).

pub mod camera_file;
pub mod detections;
pub mod output;
pub mod plausible;
pub mod recording;
pub mod recording_writer;
pub mod rig;
pub mod robot;
pub mod tool;
pub mod wand;
pub mod trajectory;

use std::path::{Path, PathBuf};

pub use output::{Output, OutputPathError, OutputSet, StagedFolder, check_outputs};

/// Why a file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The operating system refused to read the file.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The operating system refused to write the file.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file's content is not what the format asks for.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong and where (field, camera, marker), lowercase.
        message: String,
    },
    /// A line of a text table is not what the format asks for.
    #[error("{}:{line}: {message}", path.display())]
    InvalidLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number (the header is line 1).
        line: usize,
        /// What is wrong, lowercase.
        message: String,
    },
}

impl FileError {
    pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> Self {
        Self::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn invalid_line(path: &Path, line: usize, message: impl Into<String>) -> Self {
        Self::InvalidLine {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}

/// Creates a folder and its parents (nothing to do when it exists).
///
/// # Errors
/// [`FileError::Write`] naming the folder.
pub fn create_folder(path: &Path) -> Result<(), FileError> {
    std::fs::create_dir_all(path).map_err(|source| FileError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a whole file as text.
///
/// # Errors
/// [`FileError::Read`], or [`FileError::Invalid`] when it is not UTF-8.
pub fn read_text(path: &Path) -> Result<String, FileError> {
    let bytes = std::fs::read(path).map_err(|source| FileError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|e| {
        FileError::invalid(
            path,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })
}

/// Writes `contents` to `path` whole or not at all: an [`OutputSet`] of one file (a temporary
/// beside it, flushed and synced, then renamed over `path`). A failure leaves any previous file
/// untouched.
///
/// # Errors
/// [`FileError::Write`] naming `path`.
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<(), FileError> {
    let set = OutputSet::new();
    set.add(path, contents)?;
    set.commit().map(|_| ())
}

/// Parses JSON into `T`, naming the file and serde's line/column on failure.
pub(crate) fn parse_json<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, FileError> {
    serde_json::from_str(text).map_err(|e| FileError::invalid(path, format!("{e}")))
}

/// `value` as pretty JSON with a final newline; `path` names the file it is for in errors.
pub(crate) fn json_text<T: serde::Serialize>(path: &Path, value: &T) -> Result<String, FileError> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| FileError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    text.push('\n');
    Ok(text)
}

/// Serialises `value` as pretty JSON with a final newline and writes it atomically.
pub(crate) fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), FileError> {
    write_atomically(path, json_text(path, value)?.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_whole_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn atomic_write_into_missing_folder_fails_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing").join("out.txt");
        let message = write_atomically(&path, b"x").unwrap_err().to_string();
        assert!(message.contains("out.txt"), "{message}");
    }
}
