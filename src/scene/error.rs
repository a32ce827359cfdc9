//! Why a scene does not load: [`SceneError`], one line naming the file; [`cut_token`] for quoting
//! input in it.

use std::path::PathBuf;

/// Errors that stop a scene from loading. Each displays as one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The OBJ file cannot be opened or read. The cause is part of the message (not also a
    /// `source()`, so a chain prints it once).
    #[error("{path}: cannot read: {error}")]
    Io {
        /// The OBJ file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The path is a directory, FIFO, device or socket: refused before it is opened, since
    /// reading it could block or never end.
    #[error("{path}: not a regular file ({kind}); give the path of an OBJ file")]
    NotRegularFile {
        /// The path given.
        path: PathBuf,
        /// What it is instead, e.g. "a FIFO" or "a directory".
        kind: &'static str,
    },
    /// The OBJ file is larger than [`MAX_OBJ_BYTES`](super::MAX_OBJ_BYTES) (refused before it is read).
    #[error("{path}: larger than the {limit_mib} MiB limit for {what}")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What it was read as ("an OBJ file").
        what: &'static str,
        /// The limit, in MiB.
        limit_mib: u64,
    },
    /// A statement that does not parse: a number that is not one, a face corner with more than
    /// three parts, a `vt` without numbers, too few numbers for `v` or `vn`.
    #[error("{path}:{line}: malformed line: {message}")]
    Malformed {
        /// The OBJ file.
        path: PathBuf,
        /// The 1-based line the statement starts on (`\` continuations join later lines to it).
        line: usize,
        /// What is wrong, quoting the token (cut by [`cut_token`]).
        message: String,
    },
    /// A face index that is 0, or points past the elements defined before its line (OBJ indices
    /// refer backwards only).
    #[error("{path}:{line}: {kind} index {index} out of range ({count} defined so far)")]
    IndexOutOfRange {
        /// The OBJ file.
        path: PathBuf,
        /// The face's line.
        line: usize,
        /// "vertex", "normal" or "texture coordinate".
        kind: String,
        /// The index as written: 1-based, or negative (relative to the last defined).
        index: i64,
        /// How many elements of that kind precede the line.
        count: usize,
    },
    /// A `v` or `vn` coordinate that parses but is infinite or NaN.
    #[error("{path}:{line}: coordinate {value:?} is not a finite number")]
    NonFinite {
        /// The OBJ file.
        path: PathBuf,
        /// The statement's line.
        line: usize,
        /// The token, quoted and cut by [`cut_token`].
        value: String,
    },
    /// Nothing to render: the file has no faces, or every triangle is degenerate.
    #[error("{path}: no triangles to render{detail}")]
    Empty {
        /// The OBJ file.
        path: PathBuf,
        /// Which of the two, with the count: " (8 vertices, no faces)" or
        /// " (all 12 faces are degenerate)".
        detail: String,
    },
    /// The file holds a NUL byte: binary data or UTF-16 text, not an OBJ.
    #[error("{path}: binary data (NUL bytes), not an OBJ text file")]
    NotText {
        /// The file.
        path: PathBuf,
    },
}

/// A token from an input file as shown in a message: at most 40 characters, and when cut, its
/// length in bytes (a 10 MB token must not become a 10 MB error line).
pub fn cut_token(s: &str) -> String {
    const KEEP: usize = 40;
    match s.char_indices().nth(KEEP) {
        None => format!("{s:?}"),
        Some((end, _)) => format!("{:?}... ({} bytes)", &s[..end], s.len()),
    }
}
