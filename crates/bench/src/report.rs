//! What a benchmark run found: the timings ([`Timing`]: median, spread, p99, max), one [`CaseReport`] per kind of
//! frame, the paper's figures beside them and the goals ([`BenchReport`]). `goals.rs` judges the goals and
//! `table.rs` prints the report as text.

use serde::{Deserialize, Serialize};

use crate::Machine;

/// Median, spread and worst case of a duration over the iterations of a case, microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Median, microseconds.
    pub median_us: f64,
    /// 10th percentile, microseconds.
    pub p10_us: f64,
    /// 90th percentile, microseconds.
    pub p90_us: f64,
    /// 99th percentile (nearest rank), microseconds.
    #[serde(default)]
    pub p99_us: f64,
    /// The slowest iteration, microseconds.
    #[serde(default)]
    pub max_us: f64,
}

impl Timing {
    /// The p99 over the median (the worst-case goal's ratio; a zero median counts as 1e-9 us).
    #[must_use]
    pub fn p99_over_median(&self) -> f64 {
        self.p99_us / self.median_us.max(1e-9)
    }

    /// The worst-case goal's figures: "median M us, p99 P us (Rx), max X us".
    #[must_use]
    pub fn median_p99_max(&self) -> String {
        format!(
            "median {:.1} us, p99 {:.1} us ({:.2}x), max {:.1} us",
            self.median_us,
            self.p99_us,
            self.p99_over_median(),
            self.max_us
        )
    }

    /// Median and nearest-rank percentiles of samples in microseconds, rounded to nanoseconds (all zero for no
    /// sample).
    #[must_use]
    pub fn of(samples_us: &[f64]) -> Self {
        let mut s = samples_us.to_vec();
        s.sort_by(f64::total_cmp);
        let rank = |q: f64| -> f64 {
            if s.is_empty() {
                return 0.0;
            }
            let i = ((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1;
            s.get(i).copied().unwrap_or(0.0)
        };
        let median_us = match s.len() {
            0 => 0.0,
            n if n % 2 == 1 => s.get(n / 2).copied().unwrap_or(0.0),
            n => 0.5 * (s.get(n / 2 - 1).copied().unwrap_or(0.0) + s.get(n / 2).copied().unwrap_or(0.0)),
        };
        // Nanoseconds are the clock's resolution: round to them (short, readable JSON).
        let ns = |v: f64| (v * 1e3).round() / 1e3;
        Self {
            median_us: ns(median_us),
            p10_us: ns(rank(0.1)),
            p90_us: ns(rank(0.9)),
            p99_us: ns(rank(0.99)),
            max_us: ns(s.last().copied().unwrap_or(0.0)),
        }
    }
}

/// One stage's timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageTiming {
    /// The stage's name ([`Stage::name`](pmon_monitor::Stage::name)).
    pub stage: String,
    /// Its timing.
    pub timing: Timing,
}

/// The monitor's figures on one kind of frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseReport {
    /// Short name, e.g. `synthetic-64/0.5m`.
    pub name: String,
    /// What the frames are.
    pub description: String,
    /// Frames the case cycles through.
    pub frames: usize,
    /// Points per sweep (median over iterations); 0 without a cloud.
    pub points: u32,
    /// Points in the height band and the grid (median).
    pub points_in_band: u32,
    /// Objects per frame.
    pub objects: usize,
    /// Cell side, metres.
    pub cell_size_m: f32,
    /// Grid side, metres.
    pub grid_size_m: f32,
    /// Cells of the grid.
    pub grid_cells: u64,
    /// Cells with at least one hit (median): the cells the next frame resets.
    pub cells_hit: u32,
    /// Conflict clusters (median).
    pub clusters: u32,
    /// Timed iterations.
    pub samples: usize,
    /// Per stage, in the order of [`Stage::ALL`](pmon_monitor::Stage::ALL).
    pub stages: Vec<StageTiming>,
    /// The sensor checks: rasterize + regions + conflicts + verdicts (per iteration, then median).
    pub sensor_checks: Timing,
    /// The plausibility checks (the plausibility stage).
    pub plausibility: Timing,
    /// Object states the plausibility checks judged (verdict plausible or implausible) over the timed iterations.
    #[serde(default)]
    pub motion_states: u64,
    /// Of these, the states called implausible (alarms): about 15 % (paper rule) and 45 % (calibrated rule) in the
    /// `objects-N/no-cloud` cases, whose 6 frames jump back at every wrap; 0 in the steady traffic of
    /// `objects-30/steady`.
    #[serde(default)]
    pub motion_alarms: u64,
    /// The whole `check`.
    pub total: Timing,
    /// The floor: reading every point once ([`frames::coordinate_sum`](crate::frames::coordinate_sum)); `None` without a cloud.
    pub floor: Option<Timing>,
    /// Median sensor checks over median floor.
    pub sensor_over_floor: Option<f64>,
    /// The native floor: reading every point once at the speed of the processor's widest vector unit
    /// ([`native::native_sum`](crate::native::native_sum)); `None` without a cloud.
    #[serde(default)]
    pub native_floor: Option<Timing>,
    /// Median sensor checks over median native floor.
    #[serde(default)]
    pub sensor_over_native_floor: Option<f64>,
    /// The sensor checks of each frame of the cycle alone (frame `k` is every `frames`-th iteration): whether a
    /// p99 above the median is the heavier frames' content (their own medians differ) or jitter (one frame's own
    /// p99 above its median). Empty for a case of one frame.
    #[serde(default)]
    pub per_frame: Vec<FrameTiming>,
    /// The machine's own jitter ([`jitter::reference`](crate::jitter::reference)): a fixed work of the sensor checks' median length, timed
    /// as many times right after the case; `None` without a cloud.
    #[serde(default)]
    pub jitter_reference: Option<Timing>,
    /// The whole check (all five stages) in this thread's CPU time ([`cpu`](crate::cpu)): only the time the thread ran, so
    /// neither another task's time slice nor a hypervisor's steal time is in it; its p99 over its median is the
    /// monitor's own worst case (content and caches). `None` with `--split`, `--no-cpu-time` or without the clock.
    #[serde(default)]
    pub check_cpu: Option<Timing>,
    /// The machine's fixed work ([`Self::jitter_reference`]) in this thread's CPU time: what the machine still adds
    /// to a task of that length when lost time slices are left out (caches, interrupts).
    #[serde(default)]
    pub jitter_reference_cpu: Option<Timing>,
}

/// The sensor checks of one frame of a case's cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTiming {
    /// The frame's index in the cycle.
    pub frame: usize,
    /// Conflict clusters of the frame (the core's count, before `max_clusters`).
    pub clusters: u32,
    /// Timed iterations that checked it.
    pub samples: usize,
    /// Its sensor checks over those iterations.
    pub sensor_checks: Timing,
    /// Its whole checks in this thread's CPU time ([`CaseReport::check_cpu`]).
    #[serde(default)]
    pub check_cpu: Option<Timing>,
}

/// A figure of the paper's runtime evaluation (Section IV-G): averages, Python plausibility checks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperFigure {
    /// The machine.
    pub machine: String,
    /// Average latency of the sensor checks, 100 m x 100 m grid, 0.5 m cells, milliseconds.
    pub sensor_checks_ms: f64,
    /// Average latency of the plausibility checks for about 30 objects, milliseconds.
    pub plausibility_ms: f64,
}

/// The paper's figures.
#[must_use]
pub fn paper_figures() -> Vec<PaperFigure> {
    vec![
        PaperFigure {
            machine: "Intel Core i9-7900X @ 3.30GHz".to_string(),
            sensor_checks_ms: 12.0,
            plausibility_ms: 5.0,
        },
        PaperFigure {
            machine: "Intel Atom C3934 @ 2.00GHz".to_string(),
            sensor_checks_ms: 18.0,
            plausibility_ms: 13.0,
        },
    ]
}

/// A paper figure beside this machine's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperComparison {
    /// What is compared.
    pub what: String,
    /// The case measured here.
    pub case: String,
    /// This machine's median, microseconds.
    pub measured_us: f64,
    /// The paper's machine.
    pub paper_machine: String,
    /// The paper's average, microseconds.
    pub paper_us: f64,
    /// Paper over this machine (how many times faster here).
    pub ratio: f64,
}

/// A latency goal of the project and whether this run met it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoalResult {
    /// The goal.
    pub goal: String,
    /// What was measured, in words and numbers.
    pub measured: String,
    /// Met on this machine in this run.
    pub met: bool,
}

/// Everything one benchmark run found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// `pmon-bench` version.
    pub version: String,
    /// The machine.
    pub machine: Machine,
    /// Requested iterations per case.
    pub iterations: usize,
    /// One entry per case.
    pub cases: Vec<CaseReport>,
    /// The paper's figures beside this machine's (cases with the paper's grid).
    pub paper: Vec<PaperComparison>,
    /// The project's latency goals.
    pub goals: Vec<GoalResult>,
    /// What was skipped, and caveats.
    pub notes: Vec<String>,
}

/// Alarms of the plausibility checks per mille of the states they judged (`None` without a judged state).
#[must_use]
pub fn alarm_rate(c: &CaseReport) -> Option<f64> {
    (c.motion_states > 0).then(|| 1e3 * c.motion_alarms as f64 / c.motion_states as f64)
}
