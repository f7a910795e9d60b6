//! What the benchmark ran on.

use serde::{Deserialize, Serialize};

/// The machine and build a report was measured on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Machine {
    /// CPU model (`model name` of `/proc/cpuinfo`), or `unknown`.
    pub cpu_model: String,
    /// Logical cores available to this process.
    pub logical_cores: usize,
    /// One-minute load average (`/proc/loadavg`) when the run started: above about 0.5 on an idle-looking run,
    /// other work shared the cores and the figures are pessimistic. `None` where unavailable.
    pub load_average_1min: Option<f64>,
    /// Operating system and architecture, e.g. `linux x86_64`.
    pub platform: String,
    /// True for an optimised build (the figures of a debug build are not representative).
    pub optimized_build: bool,
    /// The rasterize loop measured and its instruction set on this processor: `blocked (avx2)`,
    /// `blocked (baseline)`, `baseline` or `scalar` (see `pmon_monitor::Rasterizer`).
    #[serde(default)]
    pub rasterizer: String,
}

impl Machine {
    /// Reads the machine's description (Linux `/proc` files where present).
    #[must_use]
    pub fn current(rasterizer: pmon_monitor::Rasterizer) -> Self {
        let cpu_model = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|text| cpu_model_of(&text))
            .unwrap_or_else(|| "unknown".to_string());
        let load_average_1min = std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|t| t.split_whitespace().next().and_then(|v| v.parse().ok()));
        Self {
            cpu_model,
            logical_cores: std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get),
            load_average_1min,
            platform: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
            optimized_build: !cfg!(debug_assertions),
            rasterizer: match rasterizer {
                pmon_monitor::Rasterizer::Blocked => format!("blocked ({})", rasterizer.instruction_set()),
                pmon_monitor::Rasterizer::BlockedBaseline => "baseline".to_string(),
                pmon_monitor::Rasterizer::Scalar => "scalar".to_string(),
            },
        }
    }
}

/// The first `model name` of a `/proc/cpuinfo` text.
#[must_use]
pub fn cpu_model_of(cpuinfo: &str) -> Option<String> {
    cpuinfo.lines().find_map(|line| {
        let (key, value) = line.split_once(':')?;
        (key.trim() == "model name").then(|| value.trim().to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_name_is_parsed() {
        let text = "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel name\t: Intel(R) Atom(TM) CPU C3934 @ 2.00GHz\n";
        assert_eq!(cpu_model_of(text).as_deref(), Some("Intel(R) Atom(TM) CPU C3934 @ 2.00GHz"));
        assert_eq!(cpu_model_of("processor : 0\n"), None);
    }
}
