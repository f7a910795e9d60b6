//! # pmon-python: the extension module `pmon._pmon`
//!
//! The Rust half of the Python package in `python/` (docs/python.md). It stays thin: numpy arrays in, the
//! monitor's verdicts out as numpy arrays, and the readers and the recording format lent as frames. Everything
//! per frame goes through [`pmon_session::Session`], the layer the C API uses as well, so Python, C and the
//! `pmon` command judge a frame by the same code. The Python side (`python/pmon/*.py`) checks types and shapes
//! with readable messages and builds the user-facing objects; this module checks again, so a call that slips
//! past the Python layer still gives a `ValueError`, never a crash.
//!
//! - `monitor`: `Monitor` (create, check a frame, the core's own time for the overhead measurement).
//! - `frames`: dataset readers, recording reader and writer, frames as dicts of numpy arrays.
//! - `campaign`: one campaign task (simulate, inject, check, score) as JSON in, counts out, for
//!   `pmon.campaign`; one task of `pmon evaluate` and of `pmon reproduce --scheduler ...`.
//! - `params`: parameters as JSON text (the Python `Params` dataclass is built from it), TOML files.

mod campaign;
mod frames;
mod monitor;
mod params;

use pyo3::prelude::*;

/// The extension module. Its content is private API: use the `pmon` package.
#[pymodule]
fn _pmon(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<monitor::Monitor>()?;
    m.add_class::<frames::DatasetFrames>()?;
    m.add_class::<frames::RecordingFrames>()?;
    m.add_class::<frames::RecordingWriter>()?;
    m.add_function(wrap_pyfunction!(params::default_params_json, m)?)?;
    m.add_function(wrap_pyfunction!(params::validate_params_json, m)?)?;
    m.add_function(wrap_pyfunction!(params::params_json_from_toml_file, m)?)?;
    m.add_function(wrap_pyfunction!(params::params_toml_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(params::profile_params_json, m)?)?;
    m.add_function(wrap_pyfunction!(params::profile_names, m)?)?;
    m.add_function(wrap_pyfunction!(params::profile_toml, m)?)?;
    m.add_function(wrap_pyfunction!(frames::class_names, m)?)?;
    m.add_function(wrap_pyfunction!(frames::dataset_schemes, m)?)?;
    m.add_function(wrap_pyfunction!(monitor::synthetic_frames, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::run_campaign_task, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::_cached_scenes, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::run_evaluation_task, m)?)?;
    m.add_function(wrap_pyfunction!(campaign::run_reproduce_task, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
