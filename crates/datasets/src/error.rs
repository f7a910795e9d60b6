//! The readers' error type.

use std::io;
use std::path::{Path, PathBuf};

/// A reading error, naming the file and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The file or directory could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The file is malformed, truncated or inconsistent with the others.
    #[error("{}: {message}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong (with a `line N:` prefix for line-based formats).
        message: String,
    },
    /// The spec string given to [`crate::open`] is not understood.
    #[error("dataset spec `{spec}`: {message}")]
    Spec {
        /// The spec string.
        spec: String,
        /// What is wrong.
        message: String,
    },
}

impl DatasetError {
    pub(crate) fn io(path: &Path, source: io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), source }
    }

    pub(crate) fn malformed(path: &Path, message: impl Into<String>) -> Self {
        Self::Malformed { path: path.to_path_buf(), message: message.into() }
    }

    /// The file the error is about (`None` for a spec error).
    #[must_use]
    pub fn path(&self) -> Option<&Path> {
        match self {
            Self::Io { path, .. } | Self::Malformed { path, .. } => Some(path),
            Self::Spec { .. } => None,
        }
    }
}
