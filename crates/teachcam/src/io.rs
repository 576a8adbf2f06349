//! File formats of the user-facing contract (`CONTRACT.md`): rig and tool JSON, recording
//! folders, detections and trajectory CSV. Every reader checks what it reads and names the file and the field
//! (or line) it refuses; every writer writes a whole file or nothing (a temporary file in the
//! same folder, renamed over the target once complete), and a command's several files all or
//! none ([`output`]).

pub mod camera_file;
pub mod decimal;
pub mod detections;
pub mod gray_png;
pub mod output;
pub mod plausible;
pub mod recording;
pub mod recording_writer;
pub mod rig;
pub mod robot;
pub mod tool;
pub mod wand;
pub mod wand_points;
pub mod tracking;
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

/// A thread's spare byte buffers of one kind (frame files, decoded pixels): memory given back
/// after a frame ([`give_spare`]) and taken again for the next ([`take_spare`]), so that a
/// frame's megabytes are not freed and faulted in anew each time (two frames of a pair freed
/// together made the allocator hand the memory back to the system: a third of `track`'s
/// time went to page faults).
pub(crate) type Spares = std::thread::LocalKey<std::cell::RefCell<Vec<Vec<u8>>>>;

/// An empty buffer: a spare of at least `capacity` bytes when the thread has one.
pub(crate) fn take_spare(spares: &'static Spares, capacity: usize) -> Vec<u8> {
    let spare = spares.try_with(|spares| {
        let mut spares = spares.try_borrow_mut().ok()?;
        let at = spares.iter().position(|b| b.capacity() >= capacity)?;
        Some(spares.swap_remove(at))
    });
    match spare.ok().flatten() {
        Some(mut buffer) => {
            buffer.clear();
            buffer
        }
        None => Vec::with_capacity(capacity),
    }
}

/// Keeps `buffer` as a spare of the thread, when it has fewer than `keep`.
pub(crate) fn give_spare(spares: &'static Spares, buffer: Vec<u8>, keep: usize) {
    let _ = spares.try_with(|spares| {
        if let Ok(mut spares) = spares.try_borrow_mut()
            && spares.len() < keep
        {
            spares.push(buffer);
        }
    });
}

/// Bytes read at a time by [`read_line_chunks`].
const READ_CHUNK_BYTES: usize = 1 << 20;

/// Reads a text file in pieces of whole lines of about [`READ_CHUNK_BYTES`] (a longer line is
/// read whole), handing each piece to `each` with the 1-based number of its first line; `each`
/// returns how many lines the piece held. The file is never held whole, so a large table costs
/// one buffer, not its size.
///
/// # Errors
/// [`FileError::Read`]; [`FileError::Invalid`] at the first byte that is not UTF-8 (the byte
/// offset in the file, as [`read_text`] gives it); what `each` returns.
pub(crate) fn read_line_chunks(
    path: &Path,
    mut each: impl FnMut(usize, &str) -> Result<usize, FileError>,
) -> Result<(), FileError> {
    use std::io::Read as _;
    let read_error = |source| FileError::Read {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(read_error)?;
    let mut buffer = vec![0u8; READ_CHUNK_BYTES];
    let (mut filled, mut offset, mut line) = (0, 0, 1);
    loop {
        if filled == buffer.len() {
            buffer.resize(2 * buffer.len(), 0);
        }
        let read = match file.read(&mut buffer[filled..]) {
            Ok(read) => read,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(read_error(e)),
        };
        filled += read;
        // Up to the last line break (a break is one byte, never inside a UTF-8 character), or
        // everything at the end of the file.
        let end = match buffer[..filled].iter().rposition(|&b| b == b'\n') {
            _ if read == 0 => filled,
            Some(last_break) => last_break + 1,
            None => continue,
        };
        let text = std::str::from_utf8(&buffer[..end]).map_err(|e| {
            FileError::invalid(
                path,
                format!("not UTF-8 text (byte {})", offset + e.valid_up_to()),
            )
        })?;
        line += each(line, text)?;
        buffer.copy_within(end..filled, 0);
        filled -= end;
        offset += end;
        if read == 0 {
            return Ok(());
        }
    }
}

/// Writes `contents` to `path` whole or not at all: an [`OutputSet`] of one file (a temporary
/// beside it, flushed and synced, then renamed over `path`). A failure leaves any previous file
/// untouched.
///
/// # Errors
/// [`FileError::Write`] naming `path`.
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<(), FileError> {
    write_atomically_with(path, |file| std::io::Write::write_all(file, contents))
}

/// As [`write_atomically`], the contents written by `write` into the temporary (an unbuffered
/// file: write it in large pieces), so that a large file need not be held in memory whole.
///
/// # Errors
/// [`FileError::Write`] naming `path`, with what `write` returned.
pub fn write_atomically_with(
    path: &Path,
    write: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>,
) -> Result<(), FileError> {
    let set = OutputSet::new();
    set.add_written(path, write)?;
    set.commit().map(|_| ())
}

/// Parses JSON into `T`, naming the file and serde's line/column on failure (an unknown key
/// is named with the keys expected). Every file read through it is one JSON object: a file
/// that is valid JSON of another shape at the top level (`[1000]`, `30`, `"rig"`) is refused
/// saying so, rather than with the name of a Rust type.
pub(crate) fn parse_json<T: serde::de::DeserializeOwned>(
    path: &Path,
    text: &str,
) -> Result<T, FileError> {
    serde_json::from_str(text).map_err(|e| {
        let other_shape = serde_json::from_str::<serde_json::Value>(text)
            .ok()
            .filter(|v| !v.is_object());
        match other_shape {
            Some(value) => FileError::invalid(
                path,
                format!(
                    "expected a JSON object ({{\"key\": value, ...}}) at the top level, got {}",
                    json_kind(&value)
                ),
            ),
            None => FileError::invalid(path, format!("{e}")),
        }
    })
}

/// What a JSON value is, as a message names it.
pub(crate) fn json_kind(value: &serde_json::Value) -> &'static str {
    match value {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Array(_) => "an array",
        serde_json::Value::Object(_) => "an object",
    }
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
