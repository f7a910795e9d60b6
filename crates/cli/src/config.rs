//! Monitor parameters from TOML files.

use std::path::Path;

use anyhow::{Context, Result};
use pmon_monitor::MonitorParams;

/// Loads parameters: the defaults (Table I) with a TOML file's values on top. Unknown keys are errors.
pub fn load_params(path: Option<&Path>) -> Result<MonitorParams> {
    let Some(path) = path else { return Ok(MonitorParams::default()) };
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read parameter file {}", path.display()))?;
    let params: MonitorParams =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {}", path.display(), e.to_string().trim_end()))?;
    params.validate().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(params)
}

/// `pmon params`.
pub fn print_params(path: Option<&Path>) -> Result<()> {
    let params = load_params(path)?;
    let text = toml::to_string_pretty(&params).context("cannot serialise parameters")?;
    println!("# pmon monitor parameters (defaults: the paper's Table I). Units are in the names.");
    println!("# Load with --params FILE; keys left out keep these values; unknown keys are rejected.");
    print!("{text}");
    Ok(())
}
