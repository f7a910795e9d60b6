//! The run folder of a sharded campaign (`pmon evaluate`, `pmon reproduce --scheduler ...`; docs/campaigns.md):
//! the plan (`tasks.json`) and one result file per finished task (`results/ID.json`), written as each task
//! finishes, so that a rerun runs only what is missing. Also the hand-over of a run folder to the Python
//! package (`python -m pmon.campaign run RUN --scheduler S`) and the progress display of local runs.

use std::fs;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::output::write_atomic;

/// The schedulers besides `local`, handed to the Python package.
pub const SCHEDULERS: &str = "local, dask://HOST:PORT, dask-local:N, ray, ray://HOST:PORT or ray-local:N";

/// Refuses a scheduler string the Python side would not know (before anything is planned or run).
pub fn check_scheduler(scheduler: &str) -> Result<()> {
    let known = ["dask://", "dask-local:", "ray://", "ray-local:"];
    if scheduler == "local" || scheduler == "ray" || known.iter().any(|k| scheduler.starts_with(k)) {
        Ok(())
    } else {
        bail!("--scheduler {scheduler}: expected {SCHEDULERS}")
    }
}

/// The run folder: the plan, and the results found in it.
pub struct RunDir {
    /// The folder.
    pub dir: PathBuf,
}

impl RunDir {
    fn results_dir(&self) -> PathBuf {
        self.dir.join("results")
    }

    /// Where the result of task `id` is written.
    pub fn result_path(&self, id: &str) -> PathBuf {
        self.results_dir().join(format!("{id}.json"))
    }

    /// Creates the folder and writes the plan, or checks that the plan in it is this one. `force` starts a
    /// folder holding another plan afresh; `command` names the command in the messages.
    pub fn prepare<T: Serialize>(dir: &Path, tasks: &[T], force: bool, command: &str) -> Result<Self> {
        let plan = serde_json::to_string_pretty(tasks).context("cannot serialise the plan")? + "\n";
        let plan_path = dir.join("tasks.json");
        if plan_path.exists() {
            let old = fs::read_to_string(&plan_path).with_context(|| format!("cannot read {}", plan_path.display()))?;
            if old != plan {
                if !force {
                    bail!(
                        "{} holds another plan (other source, logs, seed, parameters or scale): nothing run; pass \
                         --force to start it afresh, or choose another --run-dir",
                        dir.display()
                    );
                }
                // the other plan's results, and its nuScenes table slices (`pmon evaluate`)
                for sub in ["results", "tables"] {
                    let old = dir.join(sub);
                    if old.exists() {
                        fs::remove_dir_all(&old).with_context(|| format!("cannot remove {}", old.display()))?;
                    }
                }
            }
        } else if dir.exists() && fs::read_dir(dir).map(|mut d| d.next().is_some()).unwrap_or(true) {
            bail!("{} is not empty and holds no tasks.json: not a run folder of {command}", dir.display());
        }
        fs::create_dir_all(dir.join("results")).with_context(|| format!("cannot create {}", dir.display()))?;
        write_atomic(&plan_path, &plan)?;
        Ok(Self { dir: dir.to_path_buf() })
    }

    /// The result of a task, when its file exists and parses.
    pub fn result<R: DeserializeOwned>(&self, id: &str) -> Option<R> {
        let text = fs::read_to_string(self.result_path(id)).ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// The Python interpreter: `--python`, else `$PMON_PYTHON`, else `python3`.
pub fn python(explicit: Option<&Path>) -> PathBuf {
    explicit
        .map(Path::to_path_buf)
        .or_else(|| std::env::var_os("PMON_PYTHON").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// Runs the unfinished tasks of the run folder on `scheduler` through the Python package
/// (`python -m pmon.campaign run RUN --scheduler S [--quiet]`), which writes each result as it arrives.
pub fn run_python(python: &Path, run: &RunDir, scheduler: &str, quiet: bool) -> Result<()> {
    let mut cmd = Command::new(python);
    cmd.args(["-m", "pmon.campaign", "run"]).arg(&run.dir).args(["--scheduler", scheduler]);
    if quiet {
        cmd.arg("--quiet");
    }
    let status =
        cmd.status().with_context(|| format!("cannot run {} (give --python or PMON_PYTHON)", python.display()))?;
    if !status.success() {
        bail!(
            "{} -m pmon.campaign run {} --scheduler {scheduler} failed ({status}); the finished tasks are kept, rerun \
             to resume",
            python.display(),
            run.dir.display(),
        );
    }
    Ok(())
}

/// Progress of the tasks of a local run: a bar (done / total, failures, ETA) on a terminal, a line per task
/// otherwise (a log), nothing with `--quiet`.
pub struct TaskProgress {
    bar: Option<ProgressBar>,
    lines: bool,
}

impl TaskProgress {
    /// For `total` tasks.
    pub fn new(total: usize, what: &str, quiet: bool) -> Self {
        let tty = std::io::stderr().is_terminal();
        let bar = (!quiet && tty).then(|| {
            let pb = ProgressBar::new(total as u64);
            if let Ok(style) =
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} tasks, {msg}{elapsed} elapsed, ETA {eta}")
            {
                pb.set_style(style.progress_chars("=> "));
            }
            pb.set_prefix(what.to_string());
            pb.set_message("0 failed, ");
            pb.enable_steady_tick(Duration::from_millis(500));
            pb
        });
        Self { bar, lines: !quiet && !tty }
    }

    /// One task finished (`done` of `total`, `failed` so far); `line` is what a log shows for it.
    pub fn finished(&self, done: usize, total: usize, failed: usize, line: &str, failure: Option<&str>) {
        if let Some(pb) = &self.bar {
            pb.set_position(done as u64);
            pb.set_message(format!("{failed} failed, "));
            if let Some(f) = failure {
                pb.println(format!("FAILED {f}"));
            }
        } else if self.lines {
            eprintln!("[{done}/{total}] {line}");
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(pb) = &self.bar {
            pb.finish_and_clear();
        }
    }
}
