//! The one error type of this crate.

use std::path::PathBuf;

/// Why a figure, a CSV file or an HTML report could not be produced.
///
/// Every variant names what it was writing (a file path, or `(in memory)` for the `*_string`/`*_bytes` renderers).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// Writing a file failed (missing folder, no permission, disk full, ...).
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The file that could not be written.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The plotting library failed while drawing.
    #[error("cannot draw figure {target}: {message}")]
    Draw {
        /// The output file, or `(in memory)`.
        target: String,
        /// What the plotting library said.
        message: String,
    },
    /// Encoding the rendered pixels as PNG failed.
    #[error("cannot encode PNG {target}: {message}")]
    Encode {
        /// The output file, or `(in memory)`.
        target: String,
        /// What the PNG encoder said.
        message: String,
    },
    /// A PNG size of zero or larger than [`crate::MAX_PNG_SIDE_PX`] was asked for.
    #[error("invalid PNG size {width_px}x{height_px} px for {target}: each side must be in 1..={max}", max = crate::MAX_PNG_SIDE_PX)]
    InvalidSize {
        /// The output file, or `(in memory)`.
        target: String,
        /// Requested width in pixels.
        width_px: u32,
        /// Requested height in pixels.
        height_px: u32,
    },
    /// The embedded DejaVu Sans font could not be parsed (should never happen: it is compiled in).
    #[error("cannot register the embedded DejaVu Sans font with plotters")]
    Font,
    /// Writing a CSV file failed (I/O, or a row whose length differs from the header's).
    #[error("cannot write CSV {}: {source}", path.display())]
    Csv {
        /// The CSV file.
        path: PathBuf,
        /// The underlying CSV error.
        #[source]
        source: csv::Error,
    },
}

/// The `target` text used for renderers that return bytes instead of writing a file.
pub(crate) const IN_MEMORY: &str = "(in memory)";
