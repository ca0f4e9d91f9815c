//! Why an output file could not be written, and which file: the error of
//! every writer and of [`super::PointSink`], kept as a type all the way up
//! to whoever reports it (never flattened into an `io::Error` and
//! downcast back).

use std::io;
use std::path::{Path, PathBuf};

/// A failure to write, continue or join an output file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {cause}", path.display())]
pub struct WriteError {
    /// The file (or directory).
    pub path: PathBuf,
    /// What went wrong.
    #[source]
    pub cause: WriteCause,
}

/// What went wrong writing a file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteCause {
    /// The system failed an operation on the file.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// A coordinate the LAS file's scale and offset cannot store.
    #[error("coordinate {value} m cannot be stored with offset {offset} m and scale {scale} m")]
    Coordinate {
        /// The coordinate, m.
        value: f64,
        /// The file's offset on that axis, m.
        offset: f64,
        /// The file's scale, m.
        scale: f64,
    },
    /// A file to continue or to join that is not one this writer would
    /// have written (`action`: "continue", "append").
    #[error("cannot {action} this file: {reason}")]
    Mismatch {
        /// What was asked of the file.
        action: &'static str,
        /// How it differs.
        reason: String,
    },
    /// A part's bytes that could not be appended to the file they join
    /// (the error names the part; `into` is the joined file).
    #[error("cannot append it to '{}': {cause}", into.display())]
    Join {
        /// The joined file being written.
        into: PathBuf,
        /// The failure, reading the one or writing the other.
        cause: io::Error,
    },
    /// A file or directory that is not this program's to replace or
    /// write into, and what to do about it.
    #[error("{0}")]
    Refused(String),
    /// Settings or data the format cannot hold.
    #[error("{0}")]
    Unsupported(String),
}

impl WriteError {
    /// A system error on `path`.
    pub fn io(path: &Path, e: io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            cause: WriteCause::Io(e),
        }
    }

    /// An error of `cause` on `path`.
    pub fn new(path: &Path, cause: WriteCause) -> Self {
        Self {
            path: path.to_path_buf(),
            cause,
        }
    }

    /// The kind of the system error under it, if it is one.
    pub fn io_kind(&self) -> Option<io::ErrorKind> {
        match &self.cause {
            WriteCause::Io(e) | WriteCause::Join { cause: e, .. } => Some(e.kind()),
            _ => None,
        }
    }

    /// A file that is not one this writer would `action` ("continue",
    /// "append"), for `reason`.
    pub fn mismatch(path: &Path, action: &'static str, reason: impl Into<String>) -> Self {
        Self::new(
            path,
            WriteCause::Mismatch {
                action,
                reason: reason.into(),
            },
        )
    }
}

/// `io::Result`s made [`WriteError`]s naming a file.
pub trait AtFile<T> {
    /// The error, if any, as one on `path`.
    fn at(self, path: &Path) -> Result<T, WriteError>;
}

impl<T> AtFile<T> for io::Result<T> {
    fn at(self, path: &Path) -> Result<T, WriteError> {
        self.map_err(|e| WriteError::io(path, e))
    }
}
