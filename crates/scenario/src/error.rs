//! [`ScenarioError`]: everything that can go wrong loading a scenario or writing a simulated recording.

use std::io;
use std::path::PathBuf;

use pmon_recording::RecordingError;

/// A scenario or output error. Each variant names the file (or scenario) and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The scenario text is not valid TOML or does not match the schema (unknown key, wrong type, ...).
    #[error("{source_name}: {message}")]
    Parse {
        /// The file (or `<string>`, or the built-in's name) the text came from.
        source_name: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A key has a value out of its range.
    #[error("{source_name}: `{key}` {reason}")]
    Invalid {
        /// The file or scenario.
        source_name: String,
        /// The key, dotted as in the TOML file (`lidar.beams`).
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// Writing the recording failed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

impl ScenarioError {
    pub(crate) fn invalid(source_name: &str, key: &str, reason: impl Into<String>) -> Self {
        Self::Invalid { source_name: source_name.to_string(), key: key.to_string(), reason: reason.into() }
    }

    /// Replaces the source name of parse and validation errors (used when the text came from a file).
    pub(crate) fn with_source(self, name: &str) -> Self {
        match self {
            Self::Parse { message, .. } => Self::Parse { source_name: name.to_string(), message },
            Self::Invalid { key, reason, .. } => Self::Invalid { source_name: name.to_string(), key, reason },
            other => other,
        }
    }
}
