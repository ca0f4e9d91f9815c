//! The library's error, by kind: what a front end needs to tell a user
//! what went wrong and where — the survey's file, line and key, the input
//! or output file, the part, the interrupted run or the budget — and to
//! choose how to say it (the command line its exit status, Python its
//! exception class).

use std::io;
use std::path::{Path, PathBuf};

use crate::output::WriteError;
use crate::survey::SurveyError;

/// What went wrong, by kind.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The survey has problems, each at its file, line and key.
    #[error(transparent)]
    Survey(#[from] SurveyError),
    /// A file the run reads cannot be read, or is one the run would
    /// write over or remove.
    #[error(transparent)]
    Input(PathError),
    /// An output file could not be written.
    #[error(transparent)]
    Output(#[from] WriteError),
    /// The output directory is not one the run may write into (it holds
    /// files no run wrote, or is not a directory).
    #[error(transparent)]
    Directory(PathError),
    /// A part given to a merge does not make one run with the others, or
    /// a part number is out of range.
    #[error(transparent)]
    Part(PathError),
    /// The interrupted run in a directory cannot be resumed.
    #[error(transparent)]
    Resume(PathError),
    /// The run's output or memory would not fit the machine.
    #[error(transparent)]
    Budget(#[from] BudgetError),
}

/// A file or directory, and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct PathError {
    /// The file or directory.
    pub path: PathBuf,
    /// What is wrong, and what to do about it.
    pub reason: String,
    /// The system's error under it, if there is one.
    #[source]
    pub cause: Option<io::Error>,
}

impl PathError {
    /// `reason` at `path`.
    pub fn new(path: &Path, reason: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            reason: reason.into(),
            cause: None,
        }
    }

    /// The system error `e` at `path`, said as `what` (e.g. "cannot read
    /// it") followed by the system's words.
    pub fn io(path: &Path, what: &str, e: io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            reason: format!("{what}: {e}"),
            cause: Some(e),
        }
    }
}

/// A run refused before it starts because its output or its memory would
/// not fit.
#[derive(Debug, thiserror::Error)]
#[error(
    "{}: {}; run fewer pulses, or pass --no-space-check (no_space_check) to run anyway (for \
     example when most pulses miss the scene)",
    dir.display(),
    shortfalls.join("; ")
)]
pub struct BudgetError {
    /// The output directory.
    pub dir: PathBuf,
    /// Each shortfall, in words.
    pub shortfalls: Vec<String>,
}

impl Error {
    /// The file or directory the error is about, when it is about one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            Error::Survey(_) => None,
            Error::Input(e) | Error::Directory(e) | Error::Part(e) | Error::Resume(e) => {
                Some(&e.path)
            }
            Error::Output(e) => Some(&e.path),
            Error::Budget(e) => Some(&e.dir),
        }
    }
}
