//! Parameters as JSON text: the Python `Params` dataclass is built from [`default_params_json`] and every set
//! of values goes through [`validate_params_json`], so unknown keys and values out of range give the Rust
//! messages (serde's for keys and types, [`MonitorParams::validate`]'s for ranges) as `ValueError`s.

use pmon_monitor::MonitorParams;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::Value;

/// The defaults (the paper's Table I) as JSON.
#[pyfunction]
pub fn default_params_json() -> PyResult<String> {
    to_json(&MonitorParams::default())
}

/// `over` (a JSON object with any subset of the keys, nested tables too) laid over `base` (a full set, JSON),
/// parsed and validated; the full set back as JSON. The same layering as `pmon check --params`: keys left out
/// keep `base`'s values, unknown keys are errors.
#[pyfunction]
#[pyo3(signature = (over, base=None))]
pub fn validate_params_json(over: &str, base: Option<&str>) -> PyResult<String> {
    let over: Value = serde_json::from_str(over).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    let params = params_over(base, over)?;
    to_json(&params)
}

/// A TOML parameter file (as written by `pmon params`) over `base` (JSON, the defaults when `None`), validated;
/// errors name the file, as `pmon check --params FILE` does. `profile:NAME` is one of the profiles pmon ships
/// (`pmon_session::profiles`), as with `--params profile:NAME`.
#[pyfunction]
#[pyo3(signature = (path, base=None))]
pub fn params_json_from_toml_file(path: std::path::PathBuf, base: Option<&str>) -> PyResult<String> {
    if let Some(name) = path.to_str().and_then(pmon_session::profiles::profile_name) {
        return profile_params_json(name, base);
    }
    let text = std::fs::read_to_string(&path)
        .map_err(|e| PyValueError::new_err(format!("cannot read parameter file {}: {e}", path.display())))?;
    toml_over_json(&text, base, &path.display().to_string())
}

/// TOML text (any subset of the keys) over `base` (JSON, the defaults when `None`), validated; the full set back as
/// JSON. Errors begin with `what` (the file, or the profile).
fn toml_over_json(text: &str, base: Option<&str>, what: &str) -> PyResult<String> {
    let table: toml::Table =
        toml::from_str(text).map_err(|e| PyValueError::new_err(format!("{what}: {}", e.to_string().trim_end())))?;
    let over = serde_json::to_value(table).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    let params = params_over(base, over).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?;
    to_json(&params)
}

/// The profile `name` (one of [`profile_names`]) over `base` (JSON, the defaults when `None`), validated.
#[pyfunction]
#[pyo3(signature = (name, base=None))]
pub fn profile_params_json(name: &str, base: Option<&str>) -> PyResult<String> {
    let text = pmon_session::profiles::profile_toml(name).map_err(PyValueError::new_err)?;
    toml_over_json(text, base, &format!("profile:{name}"))
}

/// The names of the parameter profiles pmon ships (`Params.profile(NAME)`).
#[pyfunction]
pub fn profile_names() -> Vec<&'static str> {
    pmon_session::profiles::profile_names().collect()
}

/// The TOML text of the profile `name`, with its comments (what it buys and costs).
#[pyfunction]
pub fn profile_toml(name: &str) -> PyResult<&'static str> {
    pmon_session::profiles::profile_toml(name).map_err(PyValueError::new_err)
}

/// A full set of parameters (JSON) as the TOML `pmon params` writes, for `Params.to_toml`.
#[pyfunction]
pub fn params_toml_from_json(json: &str) -> PyResult<String> {
    let p: MonitorParams = serde_json::from_str(json).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    toml::to_string_pretty(&p).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))
}

/// Parses a full set of parameters (JSON text, as [`validate_params_json`] returns it), validated.
pub fn params_from_json(json: &str) -> PyResult<MonitorParams> {
    let p: MonitorParams = serde_json::from_str(json).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    p.validate().map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    Ok(p)
}

fn params_over(base: Option<&str>, over: Value) -> PyResult<MonitorParams> {
    let mut merged = match base {
        Some(b) => serde_json::from_str(b).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?,
        None => serde_json::to_value(MonitorParams::default())
            .map_err(|e| PyValueError::new_err(format!("internal: cannot serialise parameters: {e}")))?,
    };
    if !over.is_object() {
        return Err(PyValueError::new_err("parameters: expected a table of keys and values"));
    }
    merge(&mut merged, over);
    let p: MonitorParams =
        serde_json::from_value(merged).map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    p.validate().map_err(|e| PyValueError::new_err(format!("parameters: {e}")))?;
    Ok(p)
}

/// Deep merge: objects merge key by key, every other value replaces (as `pmon check --params` layers files).
fn merge(base: &mut Value, over: Value) {
    match (base, over) {
        (Value::Object(b), Value::Object(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot @ Value::Object(_)) if v.is_object() => merge(slot, v),
                    _ => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

fn to_json(p: &MonitorParams) -> PyResult<String> {
    serde_json::to_string(p).map_err(|e| PyValueError::new_err(format!("internal: cannot serialise parameters: {e}")))
}
