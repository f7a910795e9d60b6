//! Monitor parameters from TOML files.
//!
//! Parameters come in layers: the defaults (the paper's Table I), then what the input itself needs (a dataset's
//! ground height and ego footprint, or a converted recording's `params.toml`), then the user's `--params` file.
//! A file may give any subset of keys, also inside nested tables (`[motion_limits]` with only `accel_max_mps2`):
//! every key it leaves out keeps the value of the layer below. Unknown keys are errors.

use std::path::Path;

use anyhow::{Context, Result};
use pmon_monitor::MonitorParams;
use serde::Deserialize;

/// Loads parameters: the defaults (Table I) with a TOML file's values on top. Unknown keys are errors.
pub fn load_params(path: Option<&Path>) -> Result<MonitorParams> {
    load_params_over(MonitorParams::default(), path)
}

/// The profile a `--params` value names (`profile:NAME`, one of the profiles pmon ships in
/// `crates/session/profiles`, shared with the C API and the Python package; README, "The recall profile"), if it
/// names one: its name and text, or an error that lists the profiles there are. `None` for a file path (a file
/// whose name begins with `profile:` is given as `./profile:...`).
fn profile_of(path: &Path) -> Option<Result<(&str, &'static str)>> {
    let name = pmon_session::profiles::profile_name(path.to_str()?)?;
    Some(pmon_session::profiles::profile_toml(name).map(|text| (name, text)).map_err(|e| anyhow::anyhow!("{e}")))
}

/// Loads a TOML file's values over `base` (keys left out keep `base`'s values, nested tables too), validated.
/// `profile:NAME` loads one of the profiles pmon ships the same way.
pub fn load_params_over(base: MonitorParams, path: Option<&Path>) -> Result<MonitorParams> {
    let Some(path) = path else {
        base.validate().map_err(|e| anyhow::anyhow!("parameters: {e}"))?;
        return Ok(base);
    };
    if let Some(profile) = profile_of(path) {
        let (name, text) = profile?;
        let params = params_from_str_over(base, text).map_err(|e| anyhow::anyhow!("profile:{name}: {e}"))?;
        params.validate().map_err(|e| anyhow::anyhow!("profile:{name}: {e}"))?;
        return Ok(params);
    }
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read parameter file {}", path.display()))?;
    let yaml = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("yaml") || e.eq_ignore_ascii_case("yml"));
    let params = if yaml { params_from_yaml_over(base, &text) } else { params_from_str_over(base, &text) }
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    params.validate().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(params)
}

/// Parses TOML parameters over `base` (not validated).
///
/// # Errors
/// TOML syntax, wrong types, unknown keys.
pub fn params_from_str_over(base: MonitorParams, text: &str) -> Result<MonitorParams, String> {
    let file: toml::Table = toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())?;
    let mut merged = toml::Table::try_from(base).map_err(|e| format!("internal: cannot serialise parameters: {e}"))?;
    merge(&mut merged, file);
    MonitorParams::deserialize(toml::Value::Table(merged)).map_err(|e| e.to_string().trim_end().to_string())
}

/// Parses YAML parameters over `base` (not validated): a ROS 2 parameter file in Autoware's style, one node
/// entry (`/**:` or the node's name) holding `ros__parameters:`, or a plain mapping of the same keys as the TOML
/// file. Keys, nesting (`motion_limits:`), merging and errors are those of the TOML file.
///
/// # Errors
/// YAML syntax (with line and column), a layout that is neither of the two, wrong types, unknown keys.
pub fn params_from_yaml_over(base: MonitorParams, text: &str) -> Result<MonitorParams, String> {
    let doc: yaml_serde::Value = yaml_serde::from_str(text).map_err(|e| e.to_string())?;
    let yaml_serde::Value::Mapping(top) = doc else {
        return Err("a parameter file must be a mapping (`/**:` / `ros__parameters:` or `key: value` lines)".into());
    };
    let ros = yaml_serde::Value::String("ros__parameters".into());
    let params = if let Some(p) = top.get(&ros) {
        p.clone()
    } else if top.len() == 1 && top.values().next().is_some_and(|v| v.get("ros__parameters").is_some()) {
        let node = top.values().next().and_then(|v| v.get("ros__parameters")).cloned();
        node.unwrap_or(yaml_serde::Value::Null)
    } else {
        yaml_serde::Value::Mapping(top)
    };
    if params.is_null() {
        return Ok(base);
    }
    let table = toml::Table::try_from(&params).map_err(|e| format!("cannot use the parameters: {e}"))?;
    let mut merged = toml::Table::try_from(base).map_err(|e| format!("internal: cannot serialise parameters: {e}"))?;
    merge(&mut merged, table);
    MonitorParams::deserialize(toml::Value::Table(merged)).map_err(|e| e.to_string().trim_end().to_string())
}

/// Deep merge: tables merge key by key, every other value replaces.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// The parameters `--params PATH` gives (the file or profile over the defaults) and what they are, in words: the
/// source and the keys it changes from the defaults (`cell_size_m` and `grid_size_m` left out), for `pmon bench`'s
/// notes (each case keeps its own cell and grid size) and the `params` key of `pmon ros2`'s `/diagnostics`.
pub fn described_params(path: Option<&Path>) -> Result<(MonitorParams, String)> {
    let Some(path) = path else {
        return Ok((load_params(None)?, "the defaults (Table I)".to_string()));
    };
    let params = load_params(Some(path))?;
    let to_map = |p: &MonitorParams| match serde_json::to_value(p) {
        Ok(serde_json::Value::Object(m)) => Ok(m),
        _ => Err(anyhow::anyhow!("cannot serialise parameters")),
    };
    let (d, p) = (to_map(&MonitorParams::default())?, to_map(&params)?);
    let changed: Vec<String> = p
        .iter()
        .filter(|(k, v)| !matches!(k.as_str(), "cell_size_m" | "grid_size_m") && d.get(*k) != Some(*v))
        .map(|(k, v)| format!("{k} = {v}"))
        .collect();
    let keys = if changed.is_empty() { "no key changed".to_string() } else { changed.join(", ") };
    Ok((params, format!("the defaults with --params {} over them: {keys}", path.display())))
}

/// `pmon params`.
pub fn print_params(path: Option<&Path>) -> Result<()> {
    let params = load_params(path)?;
    let text = toml::to_string_pretty(&params).context("cannot serialise parameters")?;
    println!("# pmon monitor parameters (defaults: the paper's Table I). Units are in the names.");
    if let Some(Ok((name, _))) = path.and_then(profile_of) {
        println!("# The profile `{name}` over them (crates/session/profiles/{name}.toml: what it buys and costs).");
    }
    println!("# Load with --params FILE; keys left out keep these values; unknown keys are rejected.");
    print!("{text}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaml_in_autowares_style_equals_the_same_toml() {
        let toml = "tau_tp = 0.9\n[motion_limits]\naccel_max_mps2 = 5.0\n";
        let want = params_from_str_over(MonitorParams::default(), toml).unwrap();
        for yaml in [
            "/**:\n  ros__parameters:\n    tau_tp: 0.9\n    motion_limits:\n      accel_max_mps2: 5.0\n",
            "pmon:\n  ros__parameters:\n    tau_tp: 0.9\n    motion_limits:\n      accel_max_mps2: 5.0\n",
            "tau_tp: 0.9\nmotion_limits:\n  accel_max_mps2: 5.0\n",
        ] {
            assert_eq!(params_from_yaml_over(MonitorParams::default(), yaml).unwrap(), want, "{yaml}");
        }
        // An empty ros__parameters keeps the defaults.
        let empty = params_from_yaml_over(MonitorParams::default(), "/**:\n  ros__parameters:\n").unwrap();
        assert_eq!(empty, MonitorParams::default());
    }

    #[test]
    fn yaml_errors_name_the_key_or_the_line() {
        let e = params_from_yaml_over(MonitorParams::default(), "/**:\n  ros__parameters:\n    tau_tpp: 0.9\n")
            .unwrap_err();
        assert!(e.contains("tau_tpp"), "{e}");
        let e = params_from_yaml_over(MonitorParams::default(), "tau_tp: 0.9\n  bad: [\n").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        let e = params_from_yaml_over(MonitorParams::default(), "- 1\n- 2\n").unwrap_err();
        assert!(e.contains("must be a mapping"), "{e}");
        let e = params_from_yaml_over(MonitorParams::default(), "tau_tp: yes please\n").unwrap_err();
        assert!(e.contains("tau_tp") || e.contains("invalid type"), "{e}");
    }

    #[test]
    fn issue_10_partial_file_keeps_the_other_defaults() {
        let p = params_from_str_over(MonitorParams::default(), "tau_tp = 0.9\n").unwrap();
        assert_eq!(p, MonitorParams { tau_tp: 0.9, ..MonitorParams::default() });
    }

    #[test]
    fn issue_10_partial_nested_table_keeps_its_other_keys() {
        let p = params_from_str_over(MonitorParams::default(), "[motion_limits]\naccel_max_mps2 = 5.0\n").unwrap();
        let d = MonitorParams::default();
        assert_eq!(p.motion_limits.accel_max_mps2, 5.0);
        assert_eq!(p.motion_limits.brake_max_mps2, d.motion_limits.brake_max_mps2);
        assert_eq!(p.motion_limits.turn_rate_max_radps, d.motion_limits.turn_rate_max_radps);
        let p = params_from_str_over(d, "[default_uncertainty]\nx_m = 0.3\n").unwrap();
        assert_eq!(p.default_uncertainty.x_m, 0.3);
        assert_eq!(p.default_uncertainty.heading_rad, d.default_uncertainty.heading_rad);
    }

    #[test]
    fn issue_10_partial_file_keeps_the_dataset_settings_below_it() {
        let dataset =
            MonitorParams { ground_z_m: -1.73, ego_footprint_m: [-1.0, -1.0, 3.0, 1.0], ..Default::default() };
        let p = params_from_str_over(dataset, "tau_fn = 0.9\n").unwrap();
        assert_eq!(p.ground_z_m, -1.73);
        assert_eq!(p.ego_footprint_m, [-1.0, -1.0, 3.0, 1.0]);
        assert_eq!(p.tau_fn, 0.9);
        // A key the file gives wins over the dataset's.
        let p = params_from_str_over(dataset, "ground_z_m = 0.0\n").unwrap();
        assert_eq!(p.ground_z_m, 0.0);
    }

    /// Every shipped profile loads and validates, and changes the defaults (a profile that changed nothing
    /// would be a stub); `recall` turns on exactly its three rules. An unknown name is an error that lists the
    /// profiles; a path that does not begin with `profile:` is still a file.
    #[test]
    fn profiles_load_over_the_defaults() {
        let d = MonitorParams::default();
        for (name, _) in pmon_session::profiles::PROFILES {
            let p = load_params(Some(Path::new(&format!("profile:{name}")))).unwrap();
            assert_ne!(p, d, "profile {name} changes nothing");
        }
        let p = load_params(Some(Path::new("profile:recall"))).unwrap();
        assert_eq!(p, MonitorParams { returns_beyond_cells: 1, face_in_front: true, seen_over: true, ..d });
        let e = load_params(Some(Path::new("profile:fast"))).unwrap_err().to_string();
        assert!(e.contains("unknown parameter profile `fast`") && e.contains("profile:recall"), "{e}");
        let e = load_params(Some(Path::new("./profile:recall"))).unwrap_err().to_string();
        assert!(e.contains("cannot read parameter file ./profile:recall"), "{e}");
    }

    #[test]
    fn unknown_keys_are_still_errors_also_nested() {
        let e = params_from_str_over(MonitorParams::default(), "tau_tpp = 0.9\n").unwrap_err();
        assert!(e.contains("tau_tpp"), "{e}");
        let e = params_from_str_over(MonitorParams::default(), "[motion_limits]\naccel = 5.0\n").unwrap_err();
        assert!(e.contains("accel"), "{e}");
    }
}
