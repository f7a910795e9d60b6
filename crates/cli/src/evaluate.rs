//! `pmon evaluate`: the real-data experiments of `pmon reproduce` over every log of a dataset, one task per log
//! and part, run here (`--scheduler local`) or on a Dask or Ray cluster through the Python package
//! (`python -m pmon.campaign run`), resumable from its run folder (docs/campaigns.md).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use pmon_campaign::real_data::evaluate::{self, Evaluation, LogTask, TaskResult};
use pmon_campaign::real_data::RealDataOptions;
use pmon_report::{HtmlReport, TableCell};
use rayon::prelude::*;

use crate::config::load_params;
use crate::output::{write_atomic, OutputDir};
use crate::reproduce::{claims_markdown, render_figure};
use crate::run_dir::{self, run_python, RunDir, TaskProgress};

/// Arguments of `pmon evaluate`.
#[derive(Args, Debug, Clone)]
pub struct EvaluateArgs {
    /// What to evaluate: `av2:DIR` (a folder of Argoverse 2 logs, e.g. `.../sensor/val`, or one log),
    /// `nuscenes:DATAROOT` (native v1.0 tables: one task per scene, the tables read once and cut into a slice per
    /// scene in the run folder; or the converted keyframe folder),
    /// `kitti:DIR`, `commonroad:DIR|FILE.xml`, or a folder of pmon recordings (`recordings:DIR` or DIR).
    pub source: String,
    /// nuScenes split (`val`, `train`, `mini_val`, ...): its scene names come from the nuScenes devkit
    /// (`pip install nuscenes-devkit`), asked through `--python`. Or give the names with `--scenes`.
    #[arg(long)]
    pub split: Option<String>,
    /// File of nuScenes scene names to evaluate, one per line (instead of `--split`).
    #[arg(long, value_name = "FILE", conflicts_with = "split")]
    pub scenes: Option<PathBuf>,
    /// Report folder (index.html, figures as SVG and PNG, CSV data, results.json).
    #[arg(long, short, default_value = "pmon-evaluate")]
    pub out: PathBuf,
    /// Run folder: the plan (`tasks.json`), nuScenes scene slices (`tables/`) and one result file per finished
    /// task (`results/ID.json`). A rerun
    /// with the same run folder runs only the tasks without a result (or whose result is an error).
    /// Default: OUT.run beside the report.
    #[arg(long)]
    pub run_dir: Option<PathBuf>,
    /// Campaign seed: each task's seed is derived from it and the task's identity.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Monitor parameters (TOML or YAML, or a profile pmon ships: `profile:recall`); defaults to the paper's
    /// Table I. Each dataset's ground height and ego footprint go over them.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Three position and two speed magnitudes, two seeds: checks the pipeline, no conclusions.
    #[arg(long)]
    pub smoke: bool,
    /// Where the tasks run: `local` (this process, `--threads` at a time), `dask://HOST:PORT` (a Dask
    /// scheduler), `dask-local:N` (a Dask LocalCluster of N workers), `ray` or `ray://HOST:PORT` (Ray),
    /// `ray-local:N`. All but `local` go through the Python package (`--python`).
    #[arg(long, default_value = "local")]
    pub scheduler: String,
    /// Tasks at a time with `--scheduler local` (default: all cores). Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// The Python interpreter with the `pmon` package (and dask or ray) installed. Default: `$PMON_PYTHON`,
    /// else `python3`.
    #[arg(long)]
    pub python: Option<PathBuf>,
    /// Write the run folder's plan (`tasks.json`) and stop: for running the tasks elsewhere
    /// (`python -m pmon.campaign run RUN_DIR --scheduler ...`) and merging them later.
    #[arg(long)]
    pub plan_only: bool,
    /// Start the run folder afresh when it holds another plan (other source, seed, parameters or scale).
    #[arg(long)]
    pub force: bool,
    /// No progress display (by default a bar on a terminal, a line per finished task otherwise).
    #[arg(long, short)]
    pub quiet: bool,
}

/// Scene names of a nuScenes split, from the devkit.
fn split_scenes(args: &EvaluateArgs, split: &str) -> Result<Vec<String>> {
    let py = run_dir::python(args.python.as_deref());
    let code = "import json, sys\nfrom nuscenes.utils.splits import create_splits_scenes\n\
                s = create_splits_scenes(verbose=False)\n\
                sys.exit(f'no split {sys.argv[1]!r}; known: {sorted(s)}') if sys.argv[1] not in s else print(json.dumps(s[sys.argv[1]]))";
    let out = Command::new(&py)
        .args(["-c", code, split])
        .output()
        .with_context(|| format!("cannot run {} for the nuScenes split", py.display()))?;
    if !out.status.success() {
        bail!(
            "the scene names of split `{split}` come from the nuScenes devkit (pip install nuscenes-devkit), asked \
             through {}; it failed: {}. Or give the scene names with --scenes FILE",
            py.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    serde_json::from_slice(&out.stdout).context("the devkit's split list is not a JSON list")
}

fn read_scenes(path: &Path) -> Result<Vec<String>> {
    let text = fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')).map(String::from).collect())
}

fn run_local(run: &RunDir, todo: &[&LogTask], threads: Option<usize>, quiet: bool) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let done = AtomicUsize::new(0);
    let failed = AtomicUsize::new(0);
    let first_error = Mutex::new(None);
    let total = todo.len();
    let progress = TaskProgress::new(total, "pmon evaluate", quiet);
    pool.install(|| {
        todo.par_iter().for_each(|t| {
            let started = Instant::now();
            let r = evaluate::run_task(&evaluate::with_scene_tables(t, &run.dir));
            let error = match &r.outcome {
                evaluate::Outcome::Ok(_) => None,
                evaluate::Outcome::Error(e) => Some(e.clone()),
            };
            let written = evaluate::result_json(&r)
                .map_err(|e| anyhow::anyhow!(e))
                .and_then(|text| write_atomic(&run.result_path(&t.id), &text));
            if let Err(e) = written {
                first_error.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get_or_insert(e);
            }
            let nfailed =
                failed.fetch_add(usize::from(error.is_some()), Ordering::SeqCst) + usize::from(error.is_some());
            let k = done.fetch_add(1, Ordering::SeqCst) + 1;
            let status = error.as_ref().map_or_else(|| "ok".to_string(), |e| format!("FAILED: {e}"));
            let line = format!("{} {:.1} s {status}", t.id, started.elapsed().as_secs_f64());
            progress.finished(k, total, nfailed, &line, error.as_ref().map(|e| format!("{}: {e}", t.id)).as_deref());
        });
    });
    progress.finish();
    match first_error.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn write_report(out: &Path, args: &EvaluateArgs, ev: &Evaluation) -> Result<()> {
    let real = &ev.real_data;
    for f in &real.figures {
        render_figure(out, f)?;
    }
    let json = serde_json::to_string_pretty(ev).context("cannot serialise the results")?;
    fs::write(out.join("results.json"), json + "\n").context("cannot write results.json")?;
    fs::write(out.join("claims.md"), claims_markdown(&real.claims)).context("cannot write claims.md")?;
    let mut html = HtmlReport::new("pmon evaluate: the real-data experiments over a dataset");
    html.paragraph(&format!(
        "The real-data experiments of pmon reproduce over every log of {} ({} tasks: one per log and part; {}). \
         Seed {}. Curves pool the counts of every log (95 % Wilson intervals of the sums); tables and claims are \
         per log.",
        args.source,
        ev.tasks.len(),
        if args.smoke { "smoke sweeps, no conclusions" } else { "the full sweeps" },
        args.seed
    ));
    if !ev.failed.is_empty() {
        html.heading("Failed tasks");
        let rows: Vec<Vec<TableCell>> = ev
            .failed
            .iter()
            .map(|f| {
                vec![TableCell::new(f.log.clone()), TableCell::new(f.part.name()), TableCell::miss(f.error.clone())]
            })
            .collect();
        html.table(&["log", "part", "error"], &rows);
    }
    html.heading("Figures");
    for f in &real.figures {
        html.figure_with_data(
            &format!("{}.png", f.spec.id),
            &format!("{} — {}", f.spec.title, f.spec.paper_ref),
            &format!("{}.csv", f.spec.id),
        );
        crate::causes::add_to_report(&mut html, f);
    }
    html.heading("Claims, per log");
    let rows: Vec<Vec<TableCell>> =
        real.claims.iter().map(|c| vec![TableCell::new(c.paper.clone()), TableCell::new(c.pmon.clone())]).collect();
    html.table(&["the paper", "pmon"], &rows);
    for (title, headers, rows) in &real.tables {
        html.subheading(title);
        let cells: Vec<Vec<TableCell>> =
            rows.iter().map(|r| r.iter().map(|c| TableCell::new(c.clone())).collect()).collect();
        html.table(headers, &cells);
    }
    for n in &real.notes {
        html.paragraph(n);
    }
    html.heading("Tasks");
    let rows: Vec<Vec<TableCell>> = ev
        .tasks
        .iter()
        .map(|t| {
            vec![
                TableCell::new(t.log.clone()),
                TableCell::new(t.part.name()),
                TableCell::num(t.frames.to_string()),
                if ev.failed.iter().any(|f| f.id == t.id) { TableCell::miss("failed") } else { TableCell::pass("ok") },
            ]
        })
        .collect();
    html.table(&["log", "part", "frames", ""], &rows);
    html.write(out.join("index.html"))?;
    Ok(())
}

/// `pmon evaluate`. Exit status 0 when every task ran, 1 when some failed (the report lists them), 2 on bad
/// input or usage.
pub fn run(args: &EvaluateArgs) -> Result<ExitCode> {
    let started = Instant::now();
    run_dir::check_scheduler(&args.scheduler)?;
    let params = load_params(args.params.as_deref())?;
    let scenes = match (&args.split, &args.scenes) {
        (Some(split), _) => Some(split_scenes(args, split)?),
        (None, Some(file)) => Some(read_scenes(file)?),
        (None, None) => None,
    };
    let options = if args.smoke { RealDataOptions::smoke() } else { RealDataOptions::full() };
    let plan = evaluate::plan(&args.source, scenes.as_deref(), args.seed, &options, &params)
        .map_err(|e| anyhow::anyhow!(e))?;
    for n in &plan.notes {
        eprintln!("pmon evaluate: note: {n}");
    }
    let run_dir = args.run_dir.clone().unwrap_or_else(|| {
        let mut name =
            args.out.file_name().map(std::ffi::OsStr::to_os_string).unwrap_or_else(|| "pmon-evaluate".into());
        name.push(".run");
        args.out.with_file_name(name)
    });
    let run = RunDir::prepare(&run_dir, &plan.tasks, args.force, "pmon evaluate")?;
    // The report folder is checked before anything runs (it is written under a temporary name at the end).
    let out_dir = OutputDir::prepare(&args.out, "evaluate", false)?;
    let todo: Vec<&LogTask> =
        plan.tasks.iter().filter(|t| !run.result::<TaskResult>(&t.id).is_some_and(|r| r.is_ok())).collect();
    // nuScenes v1.0 scenes: the tables read once and cut into a slice per scene, so a task reads its scene only
    // (every scene for `--plan-only`: the tasks run elsewhere; otherwise those still to run).
    let sliced_at = Instant::now();
    let sliced = if args.plan_only {
        evaluate::write_scene_tables(&plan.tasks, &run_dir)
    } else {
        evaluate::write_scene_tables(todo.iter().copied(), &run_dir)
    }
    .map_err(|e| anyhow::anyhow!(e))?;
    if sliced > 0 {
        eprintln!(
            "pmon evaluate: the nuScenes tables cut into {sliced} scene slices in {} ({:.1} s)",
            run_dir.join("tables").display(),
            sliced_at.elapsed().as_secs_f64()
        );
    }
    if args.plan_only {
        drop(out_dir);
        eprintln!("pmon evaluate: {} tasks planned in {}", plan.tasks.len(), run_dir.join("tasks.json").display());
        return Ok(ExitCode::SUCCESS);
    }
    eprintln!(
        "pmon evaluate: {} tasks ({} logs), {} finished in {}, {} to run ({})",
        plan.tasks.len(),
        plan.tasks.iter().map(|t| t.log.as_str()).collect::<std::collections::BTreeSet<_>>().len(),
        plan.tasks.len() - todo.len(),
        run_dir.display(),
        todo.len(),
        args.scheduler
    );
    if !todo.is_empty() {
        if args.scheduler == "local" {
            run_local(&run, &todo, args.threads, args.quiet)?;
        } else {
            run_python(&run_dir::python(args.python.as_deref()), &run, &args.scheduler, args.quiet)?;
        }
    }
    let mut results = BTreeMap::new();
    for t in &plan.tasks {
        if let Some(r) = run.result(&t.id) {
            results.insert(t.id.clone(), r);
        }
    }
    let mut ev = evaluate::merge(&plan.tasks, &results);
    for n in plan.notes.iter().rev() {
        ev.real_data.notes.insert(0, n.clone());
    }
    write_report(out_dir.path(), args, &ev)?;
    out_dir.commit()?;
    for f in &ev.failed {
        eprintln!("pmon evaluate: FAILED {} {}: {}", f.log, f.part.name(), f.error);
    }
    eprintln!(
        "pmon evaluate: {} of {} tasks ok, report in {} ({:.1} s)",
        ev.tasks.len() - ev.failed.len(),
        ev.tasks.len(),
        args.out.join("index.html").display(),
        started.elapsed().as_secs_f64()
    );
    Ok(if ev.failed.is_empty() { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
